//! A transfer function with its method and the shader that draws it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::Instant;

use tet_bundle::Bundle;
use tet_preint::{BakeOptions, LutFile, Method, SegmentShader, TableDomain, TransferFunction};

use crate::EngineError;

/// Tables baked by this process ([`Look::bake`] of a tabulated method, and
/// GPU paths that bake their own table and say so through
/// [`count_table_bake`]).
static TABLES_BAKED: AtomicU32 = AtomicU32::new(0);

/// Counts one table bake made outside [`Look::bake`] (e.g. on the GPU).
pub fn count_table_bake() {
    TABLES_BAKED.fetch_add(1, Ordering::Relaxed);
}

/// Tables baked so far by this process.
pub fn tables_baked() -> u32 {
    TABLES_BAKED.load(Ordering::Relaxed)
}

/// What a frame is drawn with: the TF in scalar units, the method, and the
/// method's shader (its tables baked over the bundle's domain, or read
/// from a `.tetl`). Cloning shares the shader.
#[derive(Clone)]
pub struct Look {
    pub tf: TransferFunction,
    pub method: Method,
    pub shader: Arc<dyn SegmentShader>,
    /// The `.tetl` the shader was read from, if any.
    pub lut_path: Option<PathBuf>,
    /// Seconds spent baking or loading the shader.
    pub shader_seconds: f64,
}

impl std::fmt::Debug for Look {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Look")
            .field("method", &self.method)
            .field("lut_path", &self.lut_path)
            .field("shader_seconds", &self.shader_seconds)
            .finish_non_exhaustive()
    }
}

impl Look {
    /// Bakes `method`'s tables (none for untabulated methods) for `tf` over
    /// the (Sf, Sb, l) domain of `bundle`'s segments at tet_preint's default
    /// resolutions — what `tetlut bake --bundle` bakes.
    pub fn bake(bundle: &Bundle, method: Method, tf: TransferFunction) -> Result<Look, EngineError> {
        let t = Instant::now();
        let domain = TableDomain::from_bundle(bundle).map_err(EngineError::Domain)?;
        if method.is_tabulated() {
            count_table_bake();
        }
        let shader = tet_preint::make_shader(method, &tf, &domain, &BakeOptions::default())
            .map_err(|source| EngineError::Bake { method, source })?;
        Ok(Look { tf, method, shader: shader.into(), lut_path: None, shader_seconds: t.elapsed().as_secs_f64() })
    }

    /// The exact integrator of `tf` (no table): what the reference draws,
    /// and the slowest, most accurate CPU method.
    pub fn exact(tf: TransferFunction) -> Look {
        let shader = Arc::new(tet_preint::ExactShader::new(tf.clone()));
        Look { tf, method: Method::Exact, shader, lut_path: None, shader_seconds: 0.0 }
    }

    /// Reads a `.tetl` written by `tetlut bake`: its TF, method and tables.
    pub fn from_lut(path: &Path) -> Result<Look, EngineError> {
        let t = Instant::now();
        let lut = LutFile::read(path)?;
        Look::from_lut_file(&lut, path).map(|mut l| {
            l.shader_seconds = t.elapsed().as_secs_f64();
            l
        })
    }

    /// The TF and method a `.tetl` stores (`path` names it in errors), for
    /// paths that use the file's tables themselves (the GPU).
    pub fn lut_tf_and_method(lut: &LutFile, path: &Path) -> Result<(TransferFunction, Method), EngineError> {
        let tf = lut.transfer_function().map_err(|source| EngineError::LutTf { path: path.into(), source })?;
        let method = lut
            .header
            .method
            .parse::<Method>()
            .map_err(|source| EngineError::LutMethod { path: path.into(), source })?;
        Ok((tf, method))
    }

    /// A `.tetl` already read (`path` names it in errors).
    pub fn from_lut_file(lut: &LutFile, path: &Path) -> Result<Look, EngineError> {
        let t = Instant::now();
        let (tf, method) = Look::lut_tf_and_method(lut, path)?;
        let shader = tet_preint::load_shader(lut, path)?;
        Ok(Look {
            tf,
            method,
            shader: shader.into(),
            lut_path: Some(path.into()),
            shader_seconds: t.elapsed().as_secs_f64(),
        })
    }
}
