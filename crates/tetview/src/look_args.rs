//! The flags that choose what a frame is drawn with — a TF and a method, or
//! a baked `.tetl` — shared by `render` and `animate`, and the one place
//! they become a TF and a method.

use anyhow::Result;
use std::path::PathBuf;
use tet_bundle::Bundle;
use tet_engine::Look;
use tet_preint::{LutFile, Method, TransferFunction};

/// A TF and a method, or a baked table file.
#[derive(Debug, Clone, clap::Args)]
pub struct LookArgs {
    /// Transfer function: formats/tf.md JSON or a ParaView preset (as
    /// tetlut reads it); a normalized TF is mapped onto --range, or the
    /// bundle's scalar range (over every time step of a series). Without
    /// --tf and --lut: an automatic TF built from the bundle (opacity where
    /// its scalar × |∇s| histogram shows boundaries, colours from --colormap).
    #[arg(long)]
    pub tf: Option<PathBuf>,
    #[command(flatten)]
    pub tf_choice: crate::tf_choice::TfChoiceArgs,
    /// Method id: exact, pt-linear, table3d, atlas2d, poly1, poly2, poly4,
    /// partial, biv-exact, biv-approx (tables are baked now over the
    /// bundle's domain at tetlut's default resolutions). The default,
    /// table3d (128×128×256 f32, baked on the fly), meets the accuracy
    /// target against the reference; pt-linear is faster but misses it.
    #[arg(long, default_value = "table3d")]
    pub method: String,
    /// Pre-integration tables baked by `tetlut bake` (.tetl) instead of
    /// --tf/--method; the TF and method come from the file.
    #[arg(long, conflicts_with_all = ["tf", "colormap", "opacity_scale", "save_tf"])]
    pub lut: Option<PathBuf>,
    /// Scalar range LO,HI for a normalized transfer function.
    #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true)]
    pub range: Option<(f64, f64)>,
}

/// What [`LookArgs::resolve`] chose: the `.tetl` read (its TF travels in
/// the file), the TF in scalar units and the method.
pub struct Chosen {
    pub lut: Option<(LutFile, PathBuf)>,
    pub tf: TransferFunction,
    pub method: Method,
}

impl LookArgs {
    /// Reads `--lut`, or resolves `--tf` (or the automatic TF) for
    /// `bundle` by the engine's one TF policy, and parses `--method`.
    pub fn resolve(&self, bundle: &Bundle) -> Result<Chosen> {
        let lut = match &self.lut {
            Some(path) => Some((LutFile::read(path)?, path.clone())),
            None => None,
        };
        let (tf, method) = match &lut {
            Some((lut, path)) => Look::lut_tf_and_method(lut, path)?,
            None => {
                let method: Method = self.method.parse()?;
                (crate::tf_choice::resolve(self.tf.as_deref(), self.range, bundle, &self.tf_choice)?, method)
            }
        };
        Ok(Chosen { lut, tf, method })
    }
}

impl Chosen {
    /// The look for the CPU: the file's tables, or `method` baked for `tf`.
    pub fn look(self, bundle: &Bundle) -> Result<Look> {
        Ok(match &self.lut {
            Some((lut, path)) => Look::from_lut_file(lut, path)?,
            None => Look::bake(bundle, self.method, self.tf)?,
        })
    }
}
