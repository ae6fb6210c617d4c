//! Exit codes: [`ExitKind`], tagging ([`Tagged`], [`KindExt`]) and the
//! classification of an error chain ([`exit_code`], [`classify`]).

use std::error::Error as StdError;
use std::fmt;

/// What went wrong, as the exit code every tetkit program returns for it.
///
/// One meaning per number in all three programs; `0` is success. clap's own
/// command-line errors exit 2 as well, so [`ExitKind::Usage`] covers both a
/// flag clap refuses and a value the program refuses after parsing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExitKind {
    /// 1: an unexpected failure (a bug; nothing the user did).
    Internal,
    /// 2: a bad command line: an unknown or conflicting flag, a bad value, an
    /// option the input needs that is missing (`--dims` for a raw volume, a
    /// `--scalar` the file lacks), or a transfer-function file whose
    /// contents are invalid (a typo, unsorted nodes, an unknown colour map).
    Usage,
    /// 3: an input cannot be read: missing or unreadable, malformed,
    /// truncated or corrupt, or of a format tetkit does not read.
    Input,
    /// 4: an input was read but its data is rejected: the mesh cannot be made
    /// valid (non-manifold faces, non-finite values, no cells left), or the
    /// data is degenerate (no volume, a constant scalar a table needs to span).
    Rejected,
    /// 5: an output cannot be written.
    Output,
    /// 6: the method cannot bake or certify its table with these inputs and
    /// limits (a TF with 2D widgets for a 1D method, a table over the size
    /// limit, a precision the method cannot store).
    Bake,
    /// 7: no usable GPU adapter (`tetview render --gpu`; without `--gpu`
    /// tetview renders on the CPU).
    NoGpu,
}

impl ExitKind {
    /// Every kind, in code order.
    pub const ALL: [ExitKind; 7] = [
        ExitKind::Internal,
        ExitKind::Usage,
        ExitKind::Input,
        ExitKind::Rejected,
        ExitKind::Output,
        ExitKind::Bake,
        ExitKind::NoGpu,
    ];

    /// The process exit code.
    pub fn code(self) -> u8 {
        match self {
            ExitKind::Internal => 1,
            ExitKind::Usage => 2,
            ExitKind::Input => 3,
            ExitKind::Rejected => 4,
            ExitKind::Output => 5,
            ExitKind::Bake => 6,
            ExitKind::NoGpu => 7,
        }
    }

    /// One line saying what the code means (the `--help` table's wording).
    pub fn meaning(self) -> &'static str {
        match self {
            ExitKind::Internal => "unexpected failure (a bug)",
            ExitKind::Usage => "bad command line: flag, value, missing option, invalid transfer-function contents",
            ExitKind::Input => "an input cannot be read: missing, malformed, truncated, corrupt or unsupported",
            ExitKind::Rejected => "input data rejected: the mesh cannot be made valid, degenerate data",
            ExitKind::Output => "an output cannot be written",
            ExitKind::Bake => "the method cannot bake or certify its table with these inputs and limits",
            ExitKind::NoGpu => "no usable GPU adapter (render --gpu)",
        }
    }

    /// The kind of an error chain (see [`exit_code`]).
    pub fn of(e: &anyhow::Error) -> ExitKind {
        e.chain().find_map(classify).unwrap_or(ExitKind::Internal)
    }
}

impl fmt::Display for ExitKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.code(), self.meaning())
    }
}

/// The exit-code table for each program's `--help` (`after_help`); a unit
/// test keeps it equal to [`ExitKind::ALL`]'s codes and meanings.
pub const EXIT_CODES_HELP: &str = "\
Exit codes (the same in tetprep, tetlut and tetview):
  0  success
  1  unexpected failure (a bug)
  2  bad command line: flag, value, missing option, invalid transfer-function contents
  3  an input cannot be read: missing, malformed, truncated, corrupt or unsupported
  4  input data rejected: the mesh cannot be made valid, degenerate data
  5  an output cannot be written
  6  the method cannot bake or certify its table with these inputs and limits
  7  no usable GPU adapter (render --gpu)";

/// An error tagged with the kind of failure it is; [`exit_code`] takes the
/// outermost tag of a chain. Displays as the wrapped error's whole chain
/// (see [`describe`]), so tagging loses no text; it has no `source`, so the
/// chain's text is not printed twice.
#[derive(Debug)]
pub struct Tagged {
    kind: ExitKind,
    inner: anyhow::Error,
}

impl Tagged {
    pub fn new(kind: ExitKind, inner: impl Into<anyhow::Error>) -> Tagged {
        Tagged { kind, inner: inner.into() }
    }

    pub fn kind(&self) -> ExitKind {
        self.kind
    }

    /// The tagged error, with its own chain.
    pub fn inner(&self) -> &anyhow::Error {
        &self.inner
    }
}

impl fmt::Display for Tagged {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&describe(&self.inner))
    }
}

impl StdError for Tagged {}

/// Tags a result's error with a kind: `std::fs::write(p, b).kind(ExitKind::Output)?`.
pub trait KindExt<T> {
    fn kind(self, kind: ExitKind) -> anyhow::Result<T>;
}

impl<T, E: Into<anyhow::Error>> KindExt<T> for Result<T, E> {
    fn kind(self, kind: ExitKind) -> anyhow::Result<T> {
        self.map_err(|e| anyhow::Error::new(Tagged::new(kind, e)))
    }
}

/// A new error of `kind` with the message `msg`.
pub fn fail(kind: ExitKind, msg: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(Tagged::new(kind, anyhow::Error::msg(msg.into())))
}

/// A usage error (exit code 2) with the message `msg`.
pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    fail(ExitKind::Usage, msg)
}

/// The exit code of an error: the outermost [`Tagged`] in its chain wins,
/// else the first cause [`classify`] knows, else 1 ([`ExitKind::Internal`]).
pub fn exit_code(e: &anyhow::Error) -> u8 {
    ExitKind::of(e).code()
}

/// A program's exit: success, or `e` described on stderr after `program`'s
/// name and its [`exit_code`] — what every tetkit program's `main` returns.
/// An error [`report_now`] printed already is not printed again.
pub fn exit_status(program: &str, result: anyhow::Result<()>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            if e.downcast_ref::<Reported>().is_none() {
                eprintln!("{program}: {}", describe(&e));
            }
            std::process::ExitCode::from(exit_code(&e))
        }
    }
}

/// An error already printed by [`report_now`]: it carries the exit code.
#[derive(Debug)]
pub struct Reported {
    kind: ExitKind,
    text: String,
}

impl fmt::Display for Reported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl StdError for Reported {}

/// Prints `e` now as [`exit_status`] would and returns an error with the
/// same exit code that `exit_status` does not print again: for a process
/// that must say why before it waits for others (an MPI rank: mpirun ends
/// the job at the first rank that exits with an error, cutting off ranks
/// that have not printed theirs).
pub fn report_now(program: &str, e: anyhow::Error) -> anyhow::Error {
    let text = describe(&e);
    // In one write: under mpirun every rank prints to one stderr, and
    // `eprintln!` writes a line in pieces another rank's could come between.
    let line = format!("{program}: {text}\n");
    let _ = std::io::Write::write_all(&mut std::io::stderr().lock(), line.as_bytes());
    anyhow::Error::new(Reported { kind: ExitKind::of(&e), text })
}

/// The chain of `e` joined by ": ", leaving out a cause whose text an outer
/// message already holds (library errors often quote their source). What
/// the programs print after their name.
pub fn describe(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let c = cause.to_string();
        if c.is_empty() || text.contains(&c) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&c);
    }
    text
}

/// The kind of one cause of a chain: a [`Tagged`] error's tag, or the kind
/// of a library error by its type and variant; `None` for anything else
/// (context messages, errors of crates this one does not know).
///
/// A bare `std::io::Error` counts as [`ExitKind::Output`]: the programs
/// tag every read of an input with [`ExitKind::Input`] where it happens,
/// and library errors carry the direction themselves (`BundleError::Io`'s
/// and `LutError::Io`'s `action`, `ReadError` always reads).
pub fn classify(cause: &(dyn StdError + 'static)) -> Option<ExitKind> {
    use ExitKind::*;
    if let Some(r) = cause.downcast_ref::<Reported>() {
        return Some(r.kind);
    }
    if let Some(t) = cause.downcast_ref::<Tagged>() {
        return Some(t.kind);
    }
    if let Some(e) = cause.downcast_ref::<tet_engine::EngineError>() {
        use tet_engine::EngineError as E;
        return match e {
            E::RangeForAbsoluteTf | E::Adaptive { .. } => Some(Usage),
            // Every failure of a method's bake, whatever the table error.
            E::Bake { .. } => Some(Bake),
            // A .tetl whose stored TF or method is unusable: the file's fault.
            E::LutTf { .. } | E::LutMethod { .. } => Some(Input),
            // A front end handed a renderer a look it cannot draw: our bug.
            E::NotBaked { .. } | E::NotCertifiable { .. } => Some(Internal),
            // A certified bake's thread that died (a panic): our bug.
            E::CertifyStopped => Some(Internal),
            E::Gpu { kind, .. } => match kind {
                tet_engine::GpuFailure::NoDevice => Some(NoGpu),
                tet_engine::GpuFailure::Unsupported => Some(Usage),
                tet_engine::GpuFailure::Failed => Some(Internal),
            },
            // The lower crates' errors decide (next in the chain).
            E::Tf(_) | E::Domain(_) | E::Lut(_) | E::Render(_) => None,
        };
    }
    if let Some(e) = cause.downcast_ref::<tet_convert::ConvertError>() {
        use tet_convert::ConvertError as C;
        return match e {
            // Point-cloud options for a mesh, a series of clouds: the request.
            C::CloudOptions { .. } | C::CloudSeries { .. } => Some(Usage),
            C::BadSteps { .. } => Some(Input),
            // The reader's, the triangulation's or the mesh's error decides.
            C::Read(_)
            | C::Steps { .. }
            | C::ReadStep { .. }
            | C::Cloud { .. }
            | C::Mesh { .. }
            | C::Invalid { .. }
            | C::Step { .. }
            | C::Write(_) => None,
        };
    }
    if let Some(e) = cause.downcast_ref::<tet_convert::partition::PartitionError>() {
        use tet_convert::partition::PartitionError as P;
        return match e {
            // A part count the mesh cannot have: the flag's value.
            P::NoParts | P::TooManyParts { .. } => Some(Usage),
            // Centroids that leave a piece empty: the data.
            P::EmptyPiece { .. } | P::TooLarge { .. } => Some(Rejected),
            // A point outside its box, steps that do not fit: our bug.
            P::OutsideBox { .. } | P::PieceSteps { .. } => Some(Internal),
            // An existing output directory without --force, a failed write.
            P::OutputExists { .. } | P::Write { .. } | P::WritePiece { .. } => Some(Output),
            P::Source { .. } | P::BadSource { .. } => Some(Input),
            // The conversion's or the analysis's error decides.
            P::Piece { .. } | P::Prepare { .. } | P::Analysis { .. } => None,
        };
    }
    if let Some(e) = cause.downcast_ref::<tet_bundle::ManifestError>() {
        return match e {
            // The bundle's own error decides (a piece that cannot be read).
            tet_bundle::ManifestError::PieceBundle { .. } => None,
            // A manifest or piece that is missing, malformed or fails its checks.
            _ => Some(Input),
        };
    }
    if let Some(e) = cause.downcast_ref::<tet_io::ReadError>() {
        return Some(match e {
            tet_io::ReadError::MissingOption { .. } => Usage,
            _ => Input,
        });
    }
    if let Some(e) = cause.downcast_ref::<tet_bundle::BundleError>() {
        return Some(match e {
            tet_bundle::BundleError::Io { action, .. } => read_or_write(action),
            _ => Input,
        });
    }
    if let Some(e) = cause.downcast_ref::<tet_preint::LutError>() {
        return Some(match e {
            tet_preint::LutError::Io { action, .. } => read_or_write(action),
            tet_preint::LutError::SectionName(_) => Internal,
            _ => Input,
        });
    }
    if cause.downcast_ref::<tet_container::ContainerError>().is_some() {
        return Some(Input);
    }
    if cause.downcast_ref::<tet_container::AtomicWriteError>().is_some() {
        return Some(Output);
    }
    if let Some(e) = cause.downcast_ref::<tet_mesh::MeshError>() {
        return Some(match e {
            // `--scalar NAME` names no field of the file: a bad value.
            tet_mesh::MeshError::UnknownScalar { .. } => Usage,
            // A series whose later step does not fit the first: the input's fault.
            tet_mesh::MeshError::StepMeshDiffers { .. } | tet_mesh::MeshError::NonFiniteInStep { .. } => Input,
            _ => Rejected,
        });
    }
    if let Some(e) = cause.downcast_ref::<tet_delaunay::DelaunayError>() {
        return Some(match e {
            tet_delaunay::DelaunayError::BadCircumradius(_) => Usage,
            _ => Rejected,
        });
    }
    if let Some(e) = cause.downcast_ref::<tet_analysis::AnalysisError>() {
        return Some(match e {
            tet_analysis::AnalysisError::BadAxis { .. } | tet_analysis::AnalysisError::BadTolerance(_) => Usage,
            _ => Rejected,
        });
    }
    if let Some(e) = cause.downcast_ref::<tet_preint::TfError>() {
        return Some(match e {
            // `tet_preint::load_tf` could not read the file.
            tet_preint::TfError::Read { .. } => Input,
            // A file's contents: as the reason they are rejected.
            tet_preint::TfError::File { .. } => tf_kind(e.contents()),
            e => tf_kind(e),
        });
    }
    if cause.downcast_ref::<tet_preint::UnknownMethod>().is_some() {
        return Some(Usage);
    }
    if let Some(e) = cause.downcast_ref::<tet_preint::TableError>() {
        return Some(match e {
            // A domain from a bundle with no scalar span or no cell size; a
            // domain from the command line is tagged Usage by the caller.
            tet_preint::TableError::Domain { .. } => Rejected,
            tet_preint::TableError::Resolution { .. } => Usage,
            tet_preint::TableError::TooLarge { .. } | tet_preint::TableError::Invalid(_) => Bake,
        });
    }
    if let Some(e) = cause.downcast_ref::<tet_preint::PolyError>() {
        return Some(match e {
            tet_preint::PolyError::Degree(_) | tet_preint::PolyError::Resolution(_) => Usage,
            _ => Bake,
        });
    }
    if let Some(e) = cause.downcast_ref::<tet_render::RenderError>() {
        use tet_render::RenderError as R;
        return Some(match e {
            // Camera values (a view file's or the flags') that make no view.
            R::View(_) => Usage,
            R::ImageSize { .. } | R::SizeMismatch { .. } | R::InvalidMesh { .. } | R::Scene(_) => Rejected,
            // Image files are mostly written; `tetview diff` tags its reads.
            R::Png(_) | R::Gif(_) | R::Npy { .. } | R::Io { .. } => Output,
            R::NormalizedTransferFunction | R::NotReady(_) => Internal,
        });
    }
    if cause.downcast_ref::<tet_plot::PlotError>().is_some() {
        return Some(Output);
    }
    if cause.downcast_ref::<std::io::Error>().is_some() {
        return Some(Output);
    }
    None
}

/// The kind of a transfer-function error that is not about reading a file:
/// contents that are not a valid TF are a usage error; the automatic TF
/// that this bundle's data cannot give is rejected data.
fn tf_kind(e: &tet_preint::TfError) -> ExitKind {
    match e {
        tet_preint::TfError::AutoTf(_) => ExitKind::Rejected,
        tet_preint::TfError::Read { .. } => ExitKind::Input,
        _ => ExitKind::Usage,
    }
}

/// The kind of a library's I/O failure by the action it names ("read",
/// "open"; anything else — create, write, sync, rename — is writing).
fn read_or_write(action: &str) -> ExitKind {
    match action {
        "read" | "open" => ExitKind::Input,
        _ => ExitKind::Output,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;
    use std::path::PathBuf;

    fn io(kind: std::io::ErrorKind) -> std::io::Error {
        std::io::Error::new(kind, "boom")
    }

    /// An error printed early keeps its exit code and text and is not
    /// printed twice.
    #[test]
    fn a_reported_error_keeps_its_code() {
        let e = report_now("test", usage("2 ranks for 3 pieces"));
        assert_eq!(exit_code(&e), ExitKind::Usage.code());
        assert_eq!(describe(&e), "2 ranks for 3 pieces");
        assert!(e.downcast_ref::<Reported>().is_some());
        assert_eq!(exit_status("test", Err(e)), std::process::ExitCode::from(ExitKind::Usage.code()));
    }

    #[test]
    fn codes_are_distinct_and_the_help_table_lists_each_one() {
        let codes: Vec<u8> = ExitKind::ALL.iter().map(|k| k.code()).collect();
        assert_eq!(codes, [1, 2, 3, 4, 5, 6, 7]);
        for k in ExitKind::ALL {
            let line = format!("  {}  {}", k.code(), k.meaning());
            assert!(EXIT_CODES_HELP.lines().any(|l| l == line), "help lacks {line:?}");
        }
        assert_eq!(EXIT_CODES_HELP.lines().count(), 1 + 1 + ExitKind::ALL.len());
    }

    #[test]
    fn the_outermost_tag_wins_over_inner_tags_and_library_errors() {
        let bundle = tet_bundle::BundleError::BadMagic { path: "b.tetb".into() };
        let e: anyhow::Result<()> = Err(bundle).kind(ExitKind::Rejected);
        let e = e.kind(ExitKind::Output).context("while saving").unwrap_err();
        assert_eq!(ExitKind::of(&e), ExitKind::Output);
        assert_eq!(exit_code(&e), 5);
        // Tagging keeps the text, printed once.
        assert_eq!(
            describe(&e),
            "while saving: not a tetkit bundle (the file does not start with the .tetb magic): b.tetb"
        );
    }

    #[test]
    fn untagged_errors_are_classified_by_type() {
        let cases: Vec<(anyhow::Error, ExitKind)> = vec![
            (
                tet_io::ReadError::Io { source: io(std::io::ErrorKind::NotFound), path: "m.vtu".into() }.into(),
                ExitKind::Input,
            ),
            (
                tet_io::ReadError::MissingOption {
                    format: tet_io::Format::Raw,
                    what: "--dims".into(),
                    path: "v.raw".into(),
                }
                .into(),
                ExitKind::Usage,
            ),
            (tet_bundle::BundleError::Damaged { what: "short".into(), path: "b".into() }.into(), ExitKind::Input),
            (
                tet_bundle::BundleError::Io {
                    action: "read",
                    source: io(std::io::ErrorKind::NotFound),
                    path: "b".into(),
                }
                .into(),
                ExitKind::Input,
            ),
            (
                tet_bundle::BundleError::Io {
                    action: "rename into place",
                    source: io(std::io::ErrorKind::PermissionDenied),
                    path: "b".into(),
                }
                .into(),
                ExitKind::Output,
            ),
            (tet_preint::LutError::BadMagic { path: "t.tetl".into() }.into(), ExitKind::Input),
            (
                tet_preint::LutError::Io { action: "write", source: io(std::io::ErrorKind::Other), path: "t".into() }
                    .into(),
                ExitKind::Output,
            ),
            (tet_mesh::MeshError::Empty { reason: "all NaN".into() }.into(), ExitKind::Rejected),
            (tet_convert::partition::PartitionError::NoParts.into(), ExitKind::Usage),
            (tet_convert::partition::PartitionError::TooManyParts { parts: 9, tets: 5 }.into(), ExitKind::Usage),
            (tet_convert::partition::PartitionError::EmptyPiece { piece: 1, parts: 3 }.into(), ExitKind::Rejected),
            (tet_convert::partition::PartitionError::OutputExists { path: "d".into() }.into(), ExitKind::Output),
            (
                tet_bundle::ManifestError::PieceChecksum { piece: 2, expected: 1, found: 2, path: "p".into() }.into(),
                ExitKind::Input,
            ),
            (tet_mesh::MeshError::UnknownScalar { name: "p".into(), available: "q".into() }.into(), ExitKind::Usage),
            (tet_delaunay::DelaunayError::NoPoints.into(), ExitKind::Rejected),
            (tet_delaunay::DelaunayError::BadCircumradius(-1.0).into(), ExitKind::Usage),
            (tet_preint::TfError::Json("expected ','".into()).into(), ExitKind::Usage),
            (tet_preint::TfError::AutoTf("degenerate mesh".into()).into(), ExitKind::Rejected),
            (tet_preint::TableError::TooLarge { entries: 1 << 40, max: 1 << 28 }.into(), ExitKind::Bake),
            (tet_preint::PolyError::Widgets(2).into(), ExitKind::Bake),
            (tet_render::RenderError::View("zero size".into()).into(), ExitKind::Usage),
            (
                tet_render::RenderError::Io { source: io(std::io::ErrorKind::NotFound), path: PathBuf::from("o.png") }
                    .into(),
                ExitKind::Output,
            ),
            (tet_render::RenderError::NotReady("no shader").into(), ExitKind::Internal),
            // The engine's own meanings, and its wrapped errors by their type.
            (tet_engine::EngineError::RangeForAbsoluteTf.into(), ExitKind::Usage),
            (tet_engine::EngineError::Adaptive { tol: -1.0, why: "x" }.into(), ExitKind::Usage),
            (
                tet_engine::EngineError::Bake {
                    method: tet_preint::Method::Table3d,
                    source: tet_preint::TableError::Resolution { what: "n_s", value: 1, min: 2, max: 4096 },
                }
                .into(),
                ExitKind::Bake,
            ),
            (
                tet_engine::EngineError::LutTf { path: "t.tetl".into(), source: tet_preint::TfError::Json("x".into()) }
                    .into(),
                ExitKind::Input,
            ),
            (tet_engine::EngineError::Tf(tet_preint::TfError::Json("x".into())).into(), ExitKind::Usage),
            (tet_engine::EngineError::Render(tet_render::RenderError::View("zero".into())).into(), ExitKind::Usage),
            (
                tet_engine::EngineError::Domain(tet_preint::TableError::Domain { what: "no span".into() }).into(),
                ExitKind::Rejected,
            ),
            (gpu(tet_engine::GpuFailure::NoDevice), ExitKind::NoGpu),
            (gpu(tet_engine::GpuFailure::Unsupported), ExitKind::Usage),
            (gpu(tet_engine::GpuFailure::Failed), ExitKind::Internal),
            (tet_engine::EngineError::NotBaked { method: tet_preint::Method::Table3d }.into(), ExitKind::Internal),
            (tet_engine::EngineError::NotCertifiable { method: tet_preint::Method::Poly2 }.into(), ExitKind::Internal),
            (tet_engine::EngineError::CertifyStopped.into(), ExitKind::Internal),
            (io(std::io::ErrorKind::PermissionDenied).into(), ExitKind::Output),
            (anyhow::anyhow!("something odd"), ExitKind::Internal),
        ];
        fn gpu(kind: tet_engine::GpuFailure) -> anyhow::Error {
            tet_engine::EngineError::Gpu { kind, source: "the device said no".into() }.into()
        }
        for (e, want) in cases {
            assert_eq!(ExitKind::of(&e), want, "{e:#}");
        }
    }

    #[test]
    fn a_tf_file_that_cannot_be_read_is_input_and_bad_contents_are_usage() {
        let dir = std::env::temp_dir().join(format!("tet_cli_tf_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let missing = dir.join("absent.json");
        let e = anyhow::Error::new(tet_preint::load_tf(&missing).unwrap_err());
        assert_eq!(ExitKind::of(&e), ExitKind::Input);
        assert!(describe(&e).ends_with(&missing.display().to_string()), "{}", describe(&e));
        // The io error's text is printed once.
        assert_eq!(describe(&e).matches("No such file").count(), 1, "{}", describe(&e));
        let bad = dir.join("bad.json");
        std::fs::write(&bad, "{\"color\": [[0, 1, 0, 0]],").unwrap();
        let e = anyhow::Error::new(tet_preint::load_tf(&bad).unwrap_err());
        assert_eq!(ExitKind::of(&e), ExitKind::Usage);
        assert!(describe(&e).contains("line 1 column"), "{}", describe(&e));
        // Under context, and for a variant the file wrapper holds.
        let inner =
            tet_preint::TfError::File { source: Box::new(tet_preint::TfError::AutoTf("x".into())), path: bad.clone() };
        assert_eq!(ExitKind::of(&anyhow::Error::new(inner).context("baking")), ExitKind::Rejected);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_library_error_under_context_is_still_found() {
        let r: Result<(), _> = Err(tet_mesh::MeshError::NoCells { points: 3 });
        let e = r.context("converting x.vtk failed").context("outer").unwrap_err();
        assert_eq!(exit_code(&e), 4);
    }

    #[test]
    fn an_untagged_io_error_reading_is_tagged_input_at_the_call_site() {
        let read = std::fs::read_to_string("/nonexistent/tf.json").kind(ExitKind::Input);
        assert_eq!(exit_code(&read.unwrap_err()), 3);
        let write = std::fs::write("/nonexistent/dir/out.json", "{}");
        assert_eq!(exit_code(&write.unwrap_err().into()), 5);
    }

    #[test]
    fn made_errors_carry_their_message_and_kind() {
        let e = usage("--range is only for normalized transfer functions");
        assert_eq!(exit_code(&e), 2);
        assert_eq!(e.to_string(), "--range is only for normalized transfer functions");
        let e = fail(ExitKind::NoGpu, "no adapter");
        assert_eq!(exit_code(&e), 7);
        assert_eq!(format!("{e:#}"), "no adapter");
    }
}
