//! A base as the user names it, read: [`BackendSpec`], and the one way to connect it.
//!
//! A kind of base ([`BackendKind`](super::registry::BackendKind)) reads its spelling into a
//! [`Spec`] of its own type; [`BackendSpec`] carries it with the kind's name, prints it back the
//! way the kind writes it, and connects it ([`BackendSpec::connect`]): the session's `backend`
//! command and `--backend` on the command line both connect through here and nowhere else. This
//! module knows no kind of base by name; the kinds' own files do (`sim.rs`, `rmp.rs`,
//! `ros2/spec.rs`). It never sends anything: connecting is the kind's driver's.

use std::any::Any;
use std::fmt;
use std::sync::Arc;

use miette::Diagnostic;
use thiserror::Error;

use super::sim::SimParams;
use super::{BackendError, Base};
use crate::diag::Loc;

/// What connecting a base needs besides its spec: the task's simulator parameters (the limits and
/// control rate every driver clamps and paces to, and the simulator itself) and the seed of a
/// simulator.
#[derive(Clone, Copy, Debug)]
pub struct Connect<'a> {
    pub sim: &'a SimParams,
    pub seed: u64,
}

/// A spec that its kind has read: it prints itself as the user would write it (the name a status
/// line and the journal show) and connects the base it names.
pub trait Spec: fmt::Display + fmt::Debug + Send + Sync + Any {
    /// Open the base: a simulator made now, or a robot's driver after its start-up (which fails
    /// with a diagnostic when nothing answers).
    fn connect(&self, with: &Connect<'_>) -> Result<Box<dyn Base>, BackendError>;

    /// Whether the spec names the in-process simulator (an evaluation then runs the whole test
    /// set at once, not in real time).
    fn is_simulator(&self) -> bool {
        false
    }
}

/// A base to drive, as read by the kind that claimed its spelling.
#[derive(Clone, Debug)]
pub struct BackendSpec {
    kind: &'static str,
    spec: Arc<dyn Spec>,
}

impl BackendSpec {
    pub fn new(kind: &'static str, spec: Box<dyn Spec>) -> BackendSpec {
        BackendSpec {
            kind,
            spec: Arc::from(spec),
        }
    }

    /// The name of the kind that read it: `sim`, `rmp`, `ros2`.
    pub fn kind(&self) -> &'static str {
        self.kind
    }

    /// Connect the base (see [`Spec::connect`]): the one place a base is opened.
    pub fn connect(&self, with: &Connect<'_>) -> Result<Box<dyn Base>, BackendError> {
        self.spec.connect(with)
    }

    pub fn is_simulator(&self) -> bool {
        self.spec.is_simulator()
    }

    /// The kind's own reading, e.g. a [`Ros2Spec`](super::ros2::spec::Ros2Spec) for `ros2-sim`.
    pub fn get<T: Any>(&self) -> Option<&T> {
        let spec: &dyn Any = self.spec.as_ref();
        spec.downcast_ref()
    }
}

impl PartialEq for BackendSpec {
    fn eq(&self, other: &BackendSpec) -> bool {
        self.kind == other.kind && self.to_string() == other.to_string()
    }
}

impl Eq for BackendSpec {}

impl fmt::Display for BackendSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.spec.fmt(f)
    }
}

/// A backend spelling that names no base, or that its kind could not read.
#[derive(Debug, Error, Diagnostic)]
pub enum BackendSpecError {
    #[error("unknown backend `{spec}`")]
    #[diagnostic(code(advise::backend::unknown), help("{help}"))]
    Unknown {
        spec: String,
        help: String,
        /// Where the statement names it, when it came from one.
        #[label("not a backend")]
        at: Option<Loc>,
    },
    /// The kind's own diagnostic (an RMP address without a port, a ROS 2 option misspelt).
    #[error(transparent)]
    #[diagnostic(transparent)]
    Kind(KindError),
}

impl BackendSpecError {
    /// A kind's diagnostic as a spec error.
    pub fn of(error: impl Diagnostic + Send + Sync + 'static) -> BackendSpecError {
        BackendSpecError::Kind(KindError(Box::new(error)))
    }

    /// The error pointed at `loc`, where a statement names the spec (an unknown name only: a
    /// kind's diagnostic says which part is wrong in its message).
    pub fn at(self, loc: Loc) -> BackendSpecError {
        match self {
            BackendSpecError::Unknown { spec, help, .. } => BackendSpecError::Unknown {
                spec,
                help,
                at: Some(loc),
            },
            other => other,
        }
    }

    /// The kind's diagnostic, if it is one of type `E`.
    pub fn downcast_ref<E: Diagnostic + 'static>(&self) -> Option<&E> {
        match self {
            BackendSpecError::Kind(KindError(e)) => {
                let e: &(dyn Diagnostic + Send + Sync) = e.as_ref();
                let any: &dyn std::error::Error = e;
                any.downcast_ref()
            }
            BackendSpecError::Unknown { .. } => None,
        }
    }
}

/// A kind's own diagnostic, boxed: every part of it (code, help, labels) is shown as the kind
/// wrote it.
pub struct KindError(Box<dyn Diagnostic + Send + Sync + 'static>);

impl fmt::Debug for KindError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.0, f)
    }
}

impl fmt::Display for KindError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

impl std::error::Error for KindError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

impl Diagnostic for KindError {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.0.code()
    }
    fn severity(&self) -> Option<miette::Severity> {
        self.0.severity()
    }
    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.0.help()
    }
    fn url<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.0.url()
    }
    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        self.0.source_code()
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = miette::LabeledSpan> + '_>> {
        self.0.labels()
    }
    fn related<'a>(&'a self) -> Option<Box<dyn Iterator<Item = &'a dyn Diagnostic> + 'a>> {
        self.0.related()
    }
    fn diagnostic_source(&self) -> Option<&dyn Diagnostic> {
        self.0.diagnostic_source()
    }
}
