//! Transfer functions and exact pre-integration of ray segments through
//! linear tetrahedra.
//!
//! * [`TransferFunction`] (module [`tf`]): piecewise-linear colour κ(s) and
//!   VTK-style opacity a(s), extinction ρ = a/u (spec: `formats/tf.md`), with
//!   ParaView preset import.
//! * [`integrate_segment`] (module [`exact`]): the f64 reference for one
//!   segment (Sf, Sb, l), returning premultiplied [`Rgba`].
//! * [`special`]: `erfcx` and `dawson` in f64.
//! * [`Method`], [`Segment`] and [`SegmentShader`] (module [`method`]): the
//!   method ids (`tet_preint::Method`) and the per-segment contract every method
//!   implements for the renderers ([`ExactShader`], [`PtLinearShader`], tables).
//! * [`PolyTable`] (module [`poly`]): `poly1`/`poly2`/`poly4`, Guthe et al.'s (2002)
//!   mean-extinction table, 16-bit α table and chromaticity polynomial in l.
//! * [`load_tf`] (module [`load`]): the one reader of transfer-function
//!   files every program and the viewer use — tetkit JSON or a ParaView
//!   preset, errors naming the file ([`TfError::Read`] when it cannot be
//!   read, [`TfError::File`] when its contents are not a TF).
//! * [`auto_tf`] (module [`auto_tf`]): a TF built from a bundle's scalar ×
//!   |∇s| histogram (Kindlmann and Durkin, 1998), coloured by a named
//!   [`Colormap`] (module [`colormap`]: viridis, inferno, magma, plasma,
//!   cool-to-warm, turbo, grayscale); [`choose_tf`] is what the CLIs call.
//! * [`Widget`] (module [`widget`]): 2D (scalar × |∇s|) widgets of Song et al. 2009;
//!   [`BivExact`], [`BivApprox`] and [`FbTable`] (module [`bivariate`]);
//!   [`GaussErfTable`] and [`BandTable`] (module [`biv_tables`]), Song
//!   et al.'s (2009) Gaussian, triangle- and sine-wave tables for the emission-only
//!   model ([`BivTables`]).
//!
//! ```
//! use tet_preint::{integrate_segment, TransferFunction};
//! let tf = TransferFunction::from_json(
//!     r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5]], "unit_distance": 1}"#,
//! )?;
//! // Constant extinction 0.5 over length 2: α = 1 − e^{−1}.
//! let px = integrate_segment(&tf, 0.3, 0.3, 2.0);
//! assert!((px.alpha - (1.0 - (-1.0f64).exp())).abs() < 1e-15);
//! assert!((px.color[0] - 0.7 * px.alpha).abs() < 1e-15);
//! # Ok::<(), tet_preint::TfError>(())
//! ```
//!
//! Pre-integration tables (each a [`SegmentShader`]), baked over a
//! [`TableDomain`] in a storage [`Precision`] and stored as `.tetl`
//! ([`LutFile`], spec `formats/lut.md`; [`bake`] and [`load_shader`] are
//! what `tetlut` calls):
//!
//! * [`Table3d`] (module [`table3d`]): T(Sf, Sb, l), slice-recurrence,
//!   Röttger & Ertl 2002 blend, incremental or exact build; banded storage.
//! * [`Atlas2d`] (module [`atlas2d`]): Röttger & Ertl's (2002) cylindrical planes, tiled.
//! * [`PsiTable`] + [`PartialShader`] (module [`partial`]): partial
//!   pre-integration.
//! * [`table_error`] (module [`error`]): RMS and max error against `exact`.
//! * [`make_shader`] and [`Baked`] (module [`factory`]): any method id to a
//!   ready shader, baking on the fly with [`BakeOptions`]' resolutions.
//!
//! Unsafe code: the crate denies it (`#![deny(unsafe_code)]`) except in one
//! private module, `simd_x86` (x86-64 only), the AVX2 + F16C kernel of
//! [`Table3d`]'s batched lookup, chosen at run time when the CPU has those
//! features; every `unsafe` block there states why its reads are in bounds.
//! It returns the portable lookup's values bit for bit; [`LookupKernel`]
//! (per table) or `TET_PREINT_LOOKUP=portable` (per process) force the
//! portable path.
//!
//! ```
//! use tet_preint::{table_error, uniform_triples, Table3d, Table3dParams, TableDomain, TransferFunction};
//! let tf = TransferFunction::from_json(
//!     r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 1}"#,
//! )?;
//! // Scalars in [0, 1], |Sf − Sb| ≤ 0.25 (the band), segments up to 2 long.
//! let domain = TableDomain::new(0.0, 1.0, 0.25, 2.0)?;
//! let table = Table3d::build(&tf, &domain, &Table3dParams { n_s: 32, n_l: 32, ..Default::default() })?;
//! assert!(table.memory_bytes() < table.full_memory_bytes());
//! let (rms, max) = table_error(&table, &tf, &uniform_triples(&domain, 1000, 7));
//! assert!(rms <= max && max < 0.02);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(unsafe_code)]

pub mod atlas2d;
pub mod auto_tf;
pub mod biv_tables;
pub mod bivariate;
pub mod certify;
pub mod colormap;
pub mod domain;
pub mod error;
pub mod exact;
pub mod factory;
pub mod load;
pub mod lut_file;
pub mod method;
pub mod partial;
pub mod poly;
pub mod precision;
mod simd;
// The crate's only unsafe code (the AVX2 table3d lookup); `deny`, not
// `forbid`, at the root so that this one module may allow it.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod simd_x86;
pub mod special;
pub mod table3d;
pub mod tf;
pub mod widget;

pub use atlas2d::{Atlas2d, Atlas2dParams};
pub use auto_tf::{
    auto_tf, auto_tf_from_histograms, choose_tf, constant_scalar_warning, normalized_tf_range, tf_for_bundle, AutoTf,
    AutoTfOptions, BoundarySource,
};
pub use biv_tables::{BandKind, BandTable, GaussErfTable};
pub use bivariate::{BivApprox, BivExact, BivTables, FbTable};
pub use certify::{Certificate, CertifiedTable3d, CertifyOptions};
pub use colormap::Colormap;
pub use domain::{ScalarQuantiles, TableDomain, TableError, QUANTILES};
pub use error::{lcg_unit, table_error, uniform_triples};
pub use exact::{integrate_segment, integrate_segment_with, optical_depth_with, Rgba};
pub use factory::{make_shader, tf_for_bake, tf_for_domain, Baked};
pub use load::{load_tf, load_tf_with, parse_tf, LoadOptions};
pub use lut_file::{
    bake, load_shader, BakeOptions, FbFileParams, LutError, LutFile, LutHeader, PolyFileParams, SectionInfo,
};
pub use method::{
    ExactShader, Method, PtLinearShader, Rgba32, Segment, SegmentBatch, SegmentShader, UnknownMethod, BATCH,
};
pub use partial::{PartialShader, PsiParams, PsiTable};
pub use poly::{AlphaTable, PolyError, PolyParams, PolyTable};
pub use precision::{Accumulation, Precision, Storage};
pub use table3d::{
    Build3d, ExtinctionPrefix, FullRebake, LookupKernel, RebakeStats, Reconstruction, ScalarAxis, Table3d,
    Table3dParams, RECONSTRUCTION_GAP,
};
pub use tf::{ColorNode, Emission, OpacityNode, TransferFunction};
pub use widget::{Shape, Widget};

/// A transfer function that cannot be used; each variant names the entry.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TfError {
    #[error("transfer function JSON: {0}")]
    Json(String),
    #[error("{list}[{index}]: expected {expected} numbers, found {found}")]
    Arity { list: &'static str, index: usize, expected: usize, found: usize },
    #[error("{list} has no control points")]
    Empty { list: &'static str },
    #[error("{list}[{index}]: value is NaN or infinite")]
    NonFinite { list: &'static str, index: usize },
    #[error("{list}[{index}]: negative value")]
    Negative { list: &'static str, index: usize },
    #[error("{list}[{index}]: {value:e} is above 3.4e38, the largest f32 (tables and images hold f32)")]
    TooLarge { list: &'static str, index: usize, value: f64 },
    #[error("{list}[{index}]: x = {x} repeats the previous control point")]
    Duplicate { list: &'static str, index: usize, x: f64 },
    #[error("{list}[{index}]: x = {x} is below the previous control point's {prev} (points must increase)")]
    Unsorted { list: &'static str, index: usize, x: f64, prev: f64 },
    #[error("unit_distance = {0}: must be positive and finite")]
    UnitDistance(f64),
    #[error("scalar range [{lo}, {hi}]: need finite lo < hi")]
    Range { lo: f64, hi: f64 },
    #[error("widgets[{index}].{field}: {reason}")]
    Widget { index: usize, field: &'static str, reason: String },
    #[error("unknown colour map {name:?}; known: {known}")]
    UnknownColormap { name: String, known: String },
    #[error("opacity scale {0}: must be finite and ≥ 0")]
    OpacityScale(f64),
    #[error("automatic transfer function: {0}")]
    AutoTf(String),
    #[error("ParaView preset: {0}")]
    Preset(String),
    /// A transfer-function file that cannot be read (missing, unreadable):
    /// the CLIs' "input unreadable" (exit 3). Written by [`load_tf`].
    #[error("cannot read transfer function: {source}: {}", path.display())]
    Read {
        #[source]
        source: IoFailure,
        path: std::path::PathBuf,
    },
    /// A transfer-function file that was read but whose contents are not a
    /// transfer function: `source` says why (for JSON syntax, with line and
    /// column). Written by [`load_tf`]; classified as `source` is.
    #[error("{source}: {}", path.display())]
    File {
        #[source]
        source: Box<TfError>,
        path: std::path::PathBuf,
    },
}

impl TfError {
    /// The error about the contents themselves: `source` of
    /// [`TfError::File`] (innermost), else `self`.
    pub fn contents(&self) -> &TfError {
        match self {
            TfError::File { source, .. } => source.contents(),
            e => e,
        }
    }
}

/// The `std::io::Error` of [`TfError::Read`], shared so that [`TfError`]
/// stays `Clone`; two are equal when their kind and text are.
#[derive(Debug, Clone)]
pub struct IoFailure(pub std::sync::Arc<std::io::Error>);

impl IoFailure {
    pub fn new(e: std::io::Error) -> IoFailure {
        IoFailure(std::sync::Arc::new(e))
    }

    /// The error as the operating system gave it.
    pub fn io(&self) -> &std::io::Error {
        &self.0
    }
}

impl PartialEq for IoFailure {
    fn eq(&self, other: &IoFailure) -> bool {
        self.0.kind() == other.0.kind() && self.0.to_string() == other.0.to_string()
    }
}

impl std::fmt::Display for IoFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for IoFailure {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}
