//! A transfer function with its method and the shader that draws it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use tet_bundle::Bundle;
use tet_preint::{
    BakeOptions, Baked, CertifiedTable3d, LutFile, Method, RebakeStats, SegmentShader, TableDomain, TransferFunction,
};

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

/// The next look's key (see [`Look::key`]).
static NEXT_LOOK: AtomicU64 = AtomicU64::new(1);

fn next_key() -> u64 {
    NEXT_LOOK.fetch_add(1, Ordering::Relaxed)
}

/// What a frame is drawn with: the TF in scalar units, the method, and the
/// method baked (its tables over the bundle's domain, read from a `.tetl`,
/// or the integrating shader). Cloning shares the tables and keeps the
/// [`Look::key`].
#[derive(Clone)]
pub struct Look {
    pub tf: TransferFunction,
    pub method: Method,
    /// The baked method: what CPU renderers shade with ([`Look::shader`])
    /// and the GPU uploads. `None` for a look whose table the renderer
    /// bakes itself ([`Look::baked_by_renderer`]).
    pub baked: Option<Arc<Baked>>,
    /// The `.tetl` the tables were read from, if any.
    pub lut_path: Option<PathBuf>,
    /// Seconds spent baking or loading the tables.
    pub shader_seconds: f64,
    /// The (Sf, Sb, l) domain a renderer bakes over, for a look it bakes
    /// itself ([`Look::baked_by_renderer`]).
    pub domain: Option<TableDomain>,
    /// Set for a look re-baked in place from an earlier one
    /// ([`Look::rebake`]): the table's pairs and how many were baked again.
    pub rebake: Option<RebakeStats>,
    key: u64,
}

impl std::fmt::Debug for Look {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Look")
            .field("method", &self.method)
            .field("key", &self.key)
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
        let look = Look::bake_with(&domain, method, tf, &BakeOptions::default(), &[])?;
        Ok(Look { shader_seconds: t.elapsed().as_secs_f64(), ..look })
    }

    /// Bakes `method`'s tables for `tf` over `domain` with `options`' resolutions
    /// and table3d certification (`CertifyOptions::off()`: the table at its
    /// given resolution, plain lookups — what [`Look::rebake`] can update);
    /// `cells` are segments through the bundle's cells that the
    /// certification measures besides its own sets
    /// ([`tet_preint::certify::cell_triples`]; may be empty).
    pub fn bake_with(
        domain: &TableDomain,
        method: Method,
        tf: TransferFunction,
        options: &BakeOptions,
        cells: &[[f32; 3]],
    ) -> Result<Look, EngineError> {
        let t = Instant::now();
        if method.is_tabulated() {
            count_table_bake();
        }
        let baked = Baked::build_with_cells(method, &tf, domain, options, cells)
            .map_err(|source| EngineError::Bake { method, source })?;
        Ok(Look::new(tf, method, Some(baked), None, t.elapsed().as_secs_f64()))
    }

    /// This look's method baked for `tf` (an edit of this look's TF) over
    /// `domain` with `options`. A plain table3d (baked by [`Look::bake_with`]
    /// with certification off, at `options`' resolution, over `domain`) is
    /// re-baked in place, computing again only the (Sf, Sb) pairs the edit
    /// reaches ([`tet_preint::Table3d::rebake`]: the same bits as a fresh
    /// bake; the new look's `rebake` field says how many pairs); every other
    /// look is baked afresh. In place needs the tables to be this look's
    /// alone: while a renderer still holds them (see
    /// [`crate::CpuFrameRenderer::release_look`]) the re-bake works on a
    /// copy. The new look has a new [`Look::key`].
    pub fn rebake(
        self,
        domain: &TableDomain,
        tf: TransferFunction,
        options: &BakeOptions,
    ) -> Result<Look, EngineError> {
        let t = Instant::now();
        let method = self.method;
        let bake_err = |source| EngineError::Bake { method, source };
        let in_place = method == Method::Table3d
            && options.certify.max_error.is_none()
            && matches!(self.baked.as_deref(), Some(Baked::Table3d(held))
                if held.certificate().is_none()
                    && !held.splits_at_tf_nodes()
                    && held.exact_intervals().is_empty()
                    && *held.params() == options.table3d
                    && held.domain() == domain);
        if let (true, Some(baked)) = (in_place, self.baked) {
            // The table's TF and the new one as the bake takes them (data
            // units, checked as a fresh bake checks them).
            let old_tf = tet_preint::tf_for_domain(&self.tf, domain).map_err(bake_err)?;
            let new_tf = tet_preint::tf_for_bake(method, &tf, domain).map_err(bake_err)?;
            let Baked::Table3d(held) = Arc::try_unwrap(baked).unwrap_or_else(|shared| (*shared).clone()) else {
                unreachable!("checked to be a table3d above")
            };
            let mut table = held.into_table();
            count_table_bake();
            let stats = table.rebake(&old_tf, &new_tf).map_err(bake_err)?;
            let baked = Baked::Table3d(CertifiedTable3d::plain(table));
            let look = Look::new(tf, method, Some(baked), None, t.elapsed().as_secs_f64());
            return Ok(Look { rebake: Some(stats), ..look });
        }
        Look::bake_with(domain, method, tf, options, &[])
    }

    /// The exact integrator of `tf` (no table): what the reference draws,
    /// and the slowest, most accurate CPU method.
    pub fn exact(tf: TransferFunction) -> Look {
        let baked = Baked::Exact(tet_preint::ExactShader::new(tf.clone()));
        Look::new(tf, Method::Exact, Some(baked), None, 0.0)
    }

    /// `tf` drawn by `method` with tables the renderer bakes itself over
    /// `bundle`'s domain (the GPU renderer's on-device table3d bake); CPU
    /// renderers refuse it ([`EngineError::NotBaked`]).
    pub fn baked_by_renderer(bundle: &Bundle, tf: TransferFunction, method: Method) -> Result<Look, EngineError> {
        let domain = TableDomain::from_bundle(bundle).map_err(EngineError::Domain)?;
        Ok(Look { domain: Some(domain), ..Look::new(tf, method, None, None, 0.0) })
    }

    pub(crate) fn new(
        tf: TransferFunction,
        method: Method,
        baked: Option<Baked>,
        lut_path: Option<PathBuf>,
        shader_seconds: f64,
    ) -> Look {
        Look {
            tf,
            method,
            baked: baked.map(Arc::new),
            lut_path,
            shader_seconds,
            domain: None,
            rebake: None,
            key: next_key(),
        }
    }

    /// Identifies this look and its clones: renderers keep what they derived
    /// from a look (uploaded tables, cull masks) while the key is the same.
    pub fn key(&self) -> u64 {
        self.key
    }

    /// The baked method as the CPU renderers' shader.
    pub fn shader(&self) -> Result<Arc<dyn SegmentShader>, EngineError> {
        match &self.baked {
            Some(b) => Ok(b.clone() as Arc<dyn SegmentShader>),
            None => Err(EngineError::NotBaked { method: self.method }),
        }
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
        let baked = Baked::from_lut(lut, path)?;
        Ok(Look::new(tf, method, Some(baked), Some(path.into()), t.elapsed().as_secs_f64()))
    }
}
