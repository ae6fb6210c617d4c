//! The one transfer-function policy of every front end.

use std::path::PathBuf;

use tet_bundle::Bundle;
use tet_preint::{choose_tf, AutoTf, Colormap, TransferFunction};

use crate::EngineError;

/// Where the TF comes from.
#[derive(Debug, Clone, Default)]
pub enum TfSource {
    /// The bundle's automatic TF (opacity on its scalar × |∇s| boundaries,
    /// [`tet_preint::auto_tf`]).
    #[default]
    Auto,
    /// A file: formats/tf.md JSON or a ParaView preset
    /// ([`tet_preint::load_tf`]).
    File(PathBuf),
    /// A TF already in memory (normalized or in scalar units).
    Given(TransferFunction),
}

/// A TF and what to do to it before it meets the bundle.
#[derive(Debug, Clone)]
pub struct TfRequest {
    pub source: TfSource,
    /// Colour map of the automatic TF, or the colours that replace a given
    /// TF's over its nodes' span.
    pub colormap: Option<Colormap>,
    /// Multiplies every extinction (≥ 0; 1 leaves the TF as it is).
    pub opacity_scale: f64,
    /// Scalar range a normalized TF is mapped onto; `None`: the bundle's.
    pub range: Option<(f64, f64)>,
}

impl Default for TfRequest {
    fn default() -> TfRequest {
        TfRequest { source: TfSource::Auto, colormap: None, opacity_scale: 1.0, range: None }
    }
}

/// The TF a frame draws with, in scalar units, and how it was made.
#[derive(Debug, Clone)]
pub struct ResolvedTf {
    pub tf: TransferFunction,
    /// Set when the TF is the bundle's automatic one.
    pub auto: Option<AutoTf>,
    /// What a front end may tell the user (e.g. the automatic TF's histogram
    /// had to be computed now), one sentence each.
    pub notes: Vec<String>,
}

/// Reads or builds the TF of `req` for `bundle`: the colour map and opacity
/// scale applied, a normalized TF mapped onto `req.range` or the bundle's
/// scalar range (a constant scalar gets a unit-wide range around its value,
/// [`tet_preint::tf_for_bundle`]). A range for a TF in scalar units is an
/// error, not ignored.
pub fn resolve_tf(bundle: &Bundle, req: &TfRequest) -> Result<ResolvedTf, EngineError> {
    let given = match &req.source {
        TfSource::Auto => None,
        TfSource::File(path) => Some(tet_preint::load_tf(path)?),
        TfSource::Given(tf) => Some(tf.clone()),
    };
    let (mut tf, auto) = choose_tf(given, Some(bundle), req.colormap, req.opacity_scale)?;
    let mut notes = Vec::new();
    if let Some(note) = auto.as_ref().and_then(|a| a.source.note()) {
        notes.push(note.to_string());
    }
    match (tf.normalized(), req.range) {
        (true, Some((lo, hi))) => tf = tf.denormalize(lo, hi)?,
        (true, None) => tf = tet_preint::tf_for_bundle(&tf, bundle)?,
        (false, Some(_)) => return Err(EngineError::RangeForAbsoluteTf),
        (false, None) => {}
    }
    Ok(ResolvedTf { tf, auto, notes })
}
