//! One render engine for every front end: `tetview render`, `reference`,
//! `bench` and `animate`, the interactive viewer (tet_viewer's `Engine` is
//! a client: it picks looks and renderers, this crate draws), the Python
//! package and the examples ask it for frames instead of each wiring
//! bundle + TF → image.
//!
//! * [`TfRequest`] → [`resolve_tf`] → [`ResolvedTf`]: the one transfer
//!   function policy — a file (formats/tf.md JSON or a ParaView preset), a
//!   TF in memory, or the bundle's automatic TF; a colour map and opacity
//!   scale over it; a normalized TF mapped onto `range` or, by the one
//!   constant-scalar rule ([`tet_preint::tf_for_bundle`]), the bundle's
//!   scalar range.
//! * [`Look`]: a TF, its method and the shader that draws it — baked now
//!   over the bundle's (Sf, Sb, l) domain ([`Look::bake`]) or read from a
//!   `.tetl` ([`Look::from_lut`]), or at resolutions of the front end's
//!   choosing ([`Look::bake_with`]). A TF edit re-bakes the look
//!   ([`Look::rebake`]: a plain table3d in place, only the pairs the edit
//!   reaches). [`tables_baked`] counts this process's bakes, so a front
//!   end that bakes one table twice shows it.
//! * [`Certifier`]: the certified bake of a plain table3d look on a thread
//!   (one at a time, only the newest look queued), handed back as a look
//!   for the front end to swap in — an interactive front end draws the
//!   plain table at once and the certified one when it is done.
//! * [`FrameRequest`] (view, shading, culling, the CPU algorithm, early
//!   termination) and the [`FrameRenderer`] trait: [`CpuFrameRenderer`]
//!   (the face-adjacency walker or projected tetrahedra, keeping
//!   [`tet_render::Renderer`]'s per-view caches across frames) and
//!   [`ReferenceFrameRenderer`] (exact ray casting, the ground truth). A new
//!   renderer is one more implementation of the trait.
//! * [`Frame`]: the linear image with [`FrameStats`].
//!
//! Libraries here print nothing: what a front end may want to tell the user
//! (an automatic TF was built, gradients were computed) comes back as notes.
//!
//! ```
//! use tet_bundle::{Bundle, BundleMeta};
//! use tet_engine::{resolve_tf, Certifier, CpuFrameRenderer, FrameRenderer, FrameRequest, Look, TfRequest, TfSource};
//! use tet_preint::{Method, TransferFunction};
//!
//! // One tet with a linear scalar.
//! let mesh = tet_mesh::TetMesh {
//!     points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
//!     tets: vec![[0, 1, 2, 3]].into(),
//!     scalar_name: "s".into(),
//!     scalar: vec![0.0, 1.0, 2.0, 3.0],
//!     point_fields: vec![],
//! };
//! let adjacency = tet_mesh::build_adjacency(&mesh.points, &mesh.tets)?;
//! let bundle = Bundle::new(mesh, adjacency, BundleMeta::default());
//!
//! // A normalized TF is stretched over the bundle's scalar range [0, 3].
//! let tf = TransferFunction::from_json(r#"{"normalized": true, "color": [[0, 1, 0, 0], [1, 0, 0, 1]],
//!     "opacity": [[0, 0.5], [1, 2]], "unit_distance": 1}"#)?;
//! let resolved = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(tf), ..TfRequest::default() })?;
//! assert!(!resolved.tf.normalized());
//!
//! let look = Look::bake(&bundle, Method::Exact, resolved.tf.clone())?;
//! let mut renderer = CpuFrameRenderer::new(&bundle)?;
//! let view = tet_render::ViewSpec::framing([0.0; 3], [1.0; 3], [32, 32]);
//! let frame = renderer.render(&look, &FrameRequest::new(view.clone()), &|_, _| {})?;
//! assert!(frame.image.pixels().iter().any(|p| p[3] > 0.0));
//!
//! // An interactive front end: a plain table3d now, its certified bake on
//! // a thread, an edited TF re-baked in place.
//! let domain = tet_preint::TableDomain::from_bundle(&bundle)?;
//! let mut options = tet_preint::BakeOptions::default();
//! options.table3d.n_s = 16;
//! options.table3d.n_l = 32;
//! options.certify = tet_preint::CertifyOptions::off();
//! let plain = Look::bake_with(&domain, Method::Table3d, resolved.tf.clone(), &options, &[])?;
//! let mut certifier = Certifier::new(&bundle, domain, tet_preint::CertifyOptions::default())?;
//! certifier.certify(&plain)?;
//! certifier.wait();
//! let certified = certifier.certified(plain.key()).expect("done").map_err(|e| e.to_string())?;
//! renderer.render(certified, &FrameRequest::new(view), &|_, _| {})?;
//! let edited = TransferFunction::from_json(r#"{"color": [[0, 1, 0, 0], [3, 0, 0, 1]],
//!     "opacity": [[0, 0.5], [3, 1]], "unit_distance": 1}"#)?;
//! let plain = plain.rebake(&domain, edited, &options)?;
//! assert!(plain.rebake.is_some());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]

mod certify;
mod frame;
#[cfg(feature = "gpu")]
mod gpu;
mod look;
mod tf;

#[cfg(feature = "gpu")]
pub use gpu::{GpuFrameOptions, GpuFrameRenderer, GpuFrameStats};

pub use certify::Certifier;
pub use frame::{
    check_adaptive, CpuFrameRenderer, Frame, FrameRenderer, FrameRequest, FrameStats, ReferenceFrameRenderer,
    GRADIENTS_NOTE,
};
pub use look::{count_table_bake, tables_baked, Look};
pub use tf::{resolve_tf, ResolvedTf, TfRequest, TfSource};

use std::path::PathBuf;

/// What can go wrong between a request and a frame. Errors of the crates
/// below pass through as their sources (a front end maps them to exit codes
/// by type); the variants with their own meaning say what to fix.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// Reading or checking the transfer function (`TfError::Read`: the file;
    /// other variants: its contents).
    #[error("{0}")]
    Tf(#[from] tet_preint::TfError),
    /// An adaptive-sampling tolerance outside [0, 1] or not finite, or
    /// asked of a renderer other than the walker ([`FrameRequest::adaptive`]).
    #[error("adaptive sampling {tol}: {why}")]
    Adaptive { tol: f32, why: &'static str },
    /// A range was given for a TF in absolute scalar units.
    #[error("a scalar range is only for normalized transfer functions (this one is in scalar units)")]
    RangeForAbsoluteTf,
    /// The method's table cannot be built for this TF and domain.
    #[error("method {method}: {source}")]
    Bake {
        method: tet_preint::Method,
        #[source]
        source: tet_preint::TableError,
    },
    /// The bundle gives no table domain (no scalar span or no cell size).
    #[error("{0}")]
    Domain(#[source] tet_preint::TableError),
    /// A `.tetl` that cannot be read or loaded.
    #[error("{0}")]
    Lut(#[from] tet_preint::LutError),
    /// A `.tetl` whose stored TF is invalid.
    #[error("the transfer function stored in {path}: {source}")]
    LutTf {
        path: PathBuf,
        #[source]
        source: tet_preint::TfError,
    },
    /// A `.tetl` naming a method this build does not know.
    #[error("the method stored in {path}: {source}")]
    LutMethod {
        path: PathBuf,
        #[source]
        source: tet_preint::UnknownMethod,
    },
    /// A look whose tables the renderer was to bake ([`Look::baked_by_renderer`])
    /// given to one that cannot.
    #[error(
        "method {method}: this look's tables are baked by the GPU renderer; bake them for the CPU with Look::bake"
    )]
    NotBaked { method: tet_preint::Method },
    /// A look given to a [`Certifier`] that is not a table3d with its
    /// tables baked.
    #[error("method {method}: only a baked table3d look can be certified")]
    NotCertifiable { method: tet_preint::Method },
    /// A certified bake's thread stopped without a result.
    #[error("the certified table3d bake stopped before it finished")]
    CertifyStopped,
    /// The GPU renderer (cargo feature `gpu`) failed; `kind` says whether
    /// the device is missing, the request is beyond it, or it failed.
    #[error("{source}")]
    Gpu {
        kind: GpuFailure,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// Scene, view or rasterization (see [`tet_render::RenderError`]).
    #[error("{0}")]
    Render(#[from] tet_render::RenderError),
}

/// What kind of GPU failure an [`EngineError::Gpu`] is (defined whether or
/// not the `gpu` feature is on, so front ends classify it either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GpuFailure {
    /// No usable adapter (none, lacking a feature, or the device refused).
    NoDevice,
    /// A method or option the GPU renderer does not have.
    Unsupported,
    /// The device failed (validation, memory limits, read-back).
    Failed,
}
