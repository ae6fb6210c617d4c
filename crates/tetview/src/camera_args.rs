//! The camera and display flags `tetview render` and `tetview reference`
//! share, and the one place each becomes a [`ViewSpec`] or a [`Display`]:
//! the two commands frame, size and tone-map a view the same way, so a
//! render and its reference are always the same picture.

use anyhow::{Context, Result};
use std::path::PathBuf;
use tet_cli::{ExitKind, KindExt};
use tet_render::{Display, Lighting, ToneMap, ViewSpec};

/// Where the camera is and how large the image.
#[derive(Debug, Clone, clap::Args)]
pub struct CameraArgs {
    /// View JSON (VTK camera fields; see `--save-view`); --size may resize it.
    #[arg(long, conflicts_with_all = ["azimuth", "elevation", "zoom", "view_up", "parallel"])]
    pub view: Option<PathBuf>,
    /// Degrees about the view-up, from the default view that frames the bounds.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub azimuth: f64,
    /// Degrees above the default view's horizon, after the azimuth.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub elevation: f64,
    /// Zoom after azimuth and elevation (2: twice as close).
    #[arg(long, default_value_t = 1.0)]
    pub zoom: f64,
    #[arg(long, value_parser = tet_cli::parse_direction, allow_hyphen_values = true, help = crate::cli::VIEW_UP_HELP)]
    pub view_up: Option<[f64; 3]>,
    /// Parallel projection for the default view (with the framing's parallel scale).
    #[arg(long)]
    pub parallel: bool,
    /// Image size WxH (default 512x512, or the view file's).
    #[arg(long, value_parser = tet_cli::parse_size)]
    pub size: Option<[u32; 2]>,
}

impl CameraArgs {
    /// The view: the `--view` file (resized by `--size`), or the default
    /// view framing `bounds` at `--size` (+z up when `z_up`, unless
    /// `--view-up`), orbited by azimuth, elevation and zoom. A view file that
    /// cannot be read or parsed is an input error (exit 3).
    pub fn resolve(&self, bounds: ([f64; 3], [f64; 3]), z_up: bool) -> Result<ViewSpec> {
        self.resolve_text(self.view_text()?.as_deref(), bounds, z_up)
    }

    /// The view as [`CameraArgs::resolve`] and the lighting as
    /// [`LightingArgs::lighting`], the view file read once for both.
    pub fn resolve_lit(
        &self,
        lighting: &LightingArgs,
        bounds: ([f64; 3], [f64; 3]),
        z_up: bool,
    ) -> Result<(ViewSpec, Option<Lighting>)> {
        let text = self.view_text()?;
        let view = self.resolve_text(text.as_deref(), bounds, z_up)?;
        Ok((view, lighting.lighting(self, text.as_deref())?))
    }

    /// The `--view` file's text, if one is given (unreadable: exit 3).
    fn view_text(&self) -> Result<Option<String>> {
        self.view
            .as_ref()
            .map(|p| {
                std::fs::read_to_string(p)
                    .with_context(|| format!("reading view {}", p.display()))
                    .kind(ExitKind::Input)
            })
            .transpose()
    }

    fn resolve_text(&self, text: Option<&str>, bounds: ([f64; 3], [f64; 3]), z_up: bool) -> Result<ViewSpec> {
        match (text, &self.view) {
            (Some(text), Some(p)) => {
                let mut v =
                    ViewSpec::from_json(text).with_context(|| format!("in {}", p.display())).kind(ExitKind::Input)?;
                if let Some(s) = self.size {
                    v.size = s;
                }
                Ok(v)
            }
            _ => {
                let (lo, hi) = bounds;
                let mut v = ViewSpec::default_for(lo, hi, self.size.unwrap_or([512, 512]), z_up, self.view_up)?;
                v.parallel = self.parallel;
                Ok(v.orbit(self.azimuth, self.elevation, self.zoom))
            }
        }
    }
}

/// How the volume is lit (`tetview render` and `tetview reference` alike,
/// so a lit render and its reference light the same way).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct LightingArgs {
    /// Blinn–Phong lighting with per-vertex gradients as normals (computed
    /// now when the bundle has none): the view file's "lighting" object
    /// when it has one (lights in world coordinates), else a headlight.
    #[arg(long)]
    pub light: bool,
    /// Light with one directional light travelling along DX,DY,DZ (world)
    /// instead of the headlight; implies --light.
    #[arg(long, value_parser = tet_cli::parse_direction, allow_hyphen_values = true)]
    pub light_dir: Option<[f64; 3]>,
    /// Volumetric shadows: every light but the headlight is dimmed by the
    /// volume's transmittance towards it; implies --light.
    #[arg(long)]
    pub shadows: bool,
}

impl LightingArgs {
    /// The lighting to render with, or `None` for none: the view file's
    /// "lighting" (`view_text`, the text of `camera`'s `--view`; a view
    /// file that has one turns lighting on), else --light-dir, else the
    /// headlight when --light or --shadows is given.
    fn lighting(&self, camera: &CameraArgs, view_text: Option<&str>) -> Result<Option<Lighting>> {
        let from_file = match (view_text, &camera.view) {
            (Some(text), Some(p)) => {
                Lighting::from_view_json(text).with_context(|| format!("in {}", p.display())).kind(ExitKind::Input)?
            }
            _ => None,
        };
        Lighting::choose(from_file, self.light, self.light_dir, self.shadows).map_err(|e| tet_cli::usage(e.to_string()))
    }
}

/// The view file text `--save-view` writes: the view and, when lit, its lighting.
pub fn view_json(view: &ViewSpec, lighting: Option<&Lighting>) -> String {
    let mut v = serde_json::to_value(view).expect("a view serializes");
    if let Some(l) = lighting {
        v["lighting"] = l.to_json_value();
    }
    serde_json::to_string_pretty(&v).expect("a value serializes")
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ToneMapArg {
    None,
    Reinhard,
}

impl ToneMapArg {
    /// The id as written on the command line and in `--json` output.
    pub fn id(self) -> &'static str {
        match self {
            ToneMapArg::None => "none",
            ToneMapArg::Reinhard => "reinhard",
        }
    }
}

/// How the PNG shows the linear image.
#[derive(Debug, Clone, clap::Args)]
pub struct DisplayArgs {
    /// Linear background colour r,g,b under the volume.
    #[arg(long, default_value = "0,0,0", value_parser = tet_cli::parse_rgb)]
    pub background: [f32; 3],
    /// none (linear colour, clamped) or reinhard (fitted to the covered pixels, colour kept).
    #[arg(long, value_enum, default_value = "reinhard")]
    pub tonemap: ToneMapArg,
    /// Exposure multiplier for Reinhard tone mapping.
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f32,
}

impl DisplayArgs {
    pub fn display(&self) -> Display {
        Display {
            background: self.background,
            tonemap: match self.tonemap {
                ToneMapArg::None => ToneMap::None,
                ToneMapArg::Reinhard => ToneMap::Reinhard { key: 0.18, exposure: self.exposure },
            },
        }
    }
}
