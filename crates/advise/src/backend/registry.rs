//! The kinds of base, in one list: what reads a spec, suggests, completes, describes and connects.
//!
//! A [`BackendKind`] is one kind of base (the simulator, a Segway RMP, a ROS 2 base): its name,
//! how its spec is written, a line saying what it drives, the words completion offers, and the
//! reading of its spec into a [`Spec`] that connects. A [`Registry`] holds the kinds a session or
//! a command line accepts: [`Registry::standard`] is the crate's list ([`super::kinds`]), and
//! [`Registry::with`] adds another (a test's fake base). Everything that picks a base reads specs
//! here, so a spelling means the same at the prompt and on the command line, an unknown one gets
//! the same "did you mean" ([`crate::diag::suggest`]), and the REPL completes the same words
//! ([`completions`]). The grammar takes any spec as one word and leaves it to this module.

use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

use super::spec::{BackendSpec, BackendSpecError, Spec};
use crate::diag::suggest::closest_short;

/// One kind of base. Implemented once per backend, beside its driver, and registered in
/// [`super::kinds`].
pub trait BackendKind: Send + Sync {
    /// The word its specs begin with: `sim`, `rmp`, `ros2`.
    fn name(&self) -> &'static str;

    /// How a spec of this kind is written, for help: `rmp:HOST:PORT`.
    fn syntax(&self) -> &'static str;

    /// What it drives, for the list of backends: "a Segway RMP, or `advise rmp-emulator`".
    fn about(&self) -> &'static str;

    /// The words completion offers after `backend ` (by default the name).
    fn completions(&self) -> Vec<String> {
        vec![self.name().to_string()]
    }

    /// Whether `spec` is this kind's to read (and to diagnose): by default the name alone, or
    /// followed by `:` or `?`.
    fn claims(&self, spec: &str) -> bool {
        spec.strip_prefix(self.name())
            .is_some_and(|rest| rest.is_empty() || rest.starts_with([':', '?']))
    }

    /// Read a spec this kind claims (trimmed); a mistake is the kind's own coded diagnostic
    /// ([`BackendSpecError::of`]).
    fn parse(&self, spec: &str) -> Result<Box<dyn Spec>, BackendSpecError>;
}

/// Read by the standard kinds ([`Registry::standard`]), as `--backend` is.
impl FromStr for BackendSpec {
    type Err = BackendSpecError;

    fn from_str(s: &str) -> Result<BackendSpec, BackendSpecError> {
        Registry::standard().parse(s)
    }
}

/// A kind of base this build leaves out (its cargo feature is off, as in the Python package):
/// it still claims its specs, so `ros2` is refused for what it is, not as an unknown word.
#[derive(Clone, Copy, Debug)]
pub struct Absent {
    name: &'static str,
    syntax: &'static str,
    feature: &'static str,
}

impl Absent {
    /// The Segway RMP driver (the `rmp` feature).
    pub const RMP: Absent = Absent {
        name: "rmp",
        syntax: "rmp:HOST:PORT",
        feature: "rmp",
    };
    /// The ROS 2 driver (the `ros2` feature).
    pub const ROS2: Absent = Absent {
        name: "ros2",
        syntax: "ros2[:NAMESPACE]",
        feature: "ros2",
    };
}

/// A spec of a kind this build leaves out.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error("this build of advise has no `{kind}` backend")]
#[diagnostic(
    code(advise::backend::not_built),
    help(
        "it was built without the `{feature}` feature (the Python package leaves out ROS 2); drive this base from the `advise` command line, which has every backend"
    )
)]
pub struct NotBuilt {
    pub kind: &'static str,
    pub feature: &'static str,
}

impl BackendKind for Absent {
    fn name(&self) -> &'static str {
        self.name
    }

    fn syntax(&self) -> &'static str {
        self.syntax
    }

    fn about(&self) -> &'static str {
        "not in this build"
    }

    fn parse(&self, _spec: &str) -> Result<Box<dyn Spec>, BackendSpecError> {
        Err(BackendSpecError::of(NotBuilt {
            kind: self.name,
            feature: self.feature,
        }))
    }
}

/// The kinds of base one session (or command line) accepts.
#[derive(Clone)]
pub struct Registry {
    kinds: Vec<Arc<dyn BackendKind>>,
}

impl fmt::Debug for Registry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list()
            .entries(self.kinds.iter().map(|k| k.name()))
            .finish()
    }
}

impl Default for Registry {
    fn default() -> Registry {
        Registry::standard()
    }
}

impl Registry {
    /// The crate's kinds: the simulator, the Segway RMP, ROS 2 ([`super::kinds`]).
    pub fn standard() -> Registry {
        Registry {
            kinds: super::kinds(),
        }
    }

    /// This registry with `kind` too (in place of a kind of the same name, if there is one).
    pub fn with(mut self, kind: impl BackendKind + 'static) -> Registry {
        let kind: Arc<dyn BackendKind> = Arc::new(kind);
        match self.kinds.iter().position(|k| k.name() == kind.name()) {
            Some(i) => self.kinds[i] = kind,
            None => self.kinds.push(kind),
        }
        self
    }

    /// The kinds, in the order help lists them.
    pub fn kinds(&self) -> impl Iterator<Item = &dyn BackendKind> {
        self.kinds.iter().map(|k| k.as_ref())
    }

    /// Read `spec` by the kind that claims it; a spelling no kind claims is
    /// [`BackendSpecError::Unknown`], with the nearest kind's syntax or else the list.
    pub fn parse(&self, spec: &str) -> Result<BackendSpec, BackendSpecError> {
        let spec = spec.trim();
        if let Some(kind) = self.kinds.iter().find(|k| k.claims(spec)) {
            return kind
                .parse(spec)
                .map(|parsed| BackendSpec::new(kind.name(), parsed));
        }
        // The word before any address or option is what was meant as a kind's name.
        let head = spec.split([':', '?', ' ']).next().unwrap_or(spec);
        let near = closest_short(head, self.kinds.iter().map(|k| k.name()))
            .and_then(|name| self.kinds.iter().find(|k| k.name() == name));
        let help = match near {
            Some(k) => format!("did you mean `{}`?", k.syntax()),
            None => format!("the backends are {}", self.describe()),
        };
        Err(BackendSpecError::Unknown {
            spec: spec.to_string(),
            help,
            at: None,
        })
    }

    /// The words completion offers for `prefix` after `backend `, sorted.
    pub fn completions(&self, prefix: &str) -> Vec<String> {
        let mut words: Vec<String> = self
            .kinds
            .iter()
            .flat_map(|k| k.completions())
            .filter(|w| w.starts_with(prefix))
            .collect();
        words.sort();
        words.dedup();
        words
    }

    /// Every kind's syntax, as a signature shows them: `sim|rmp:HOST:PORT|ros2[:NAMESPACE]`.
    pub fn syntaxes(&self) -> String {
        let all: Vec<&str> = self.kinds.iter().map(|k| k.syntax()).collect();
        all.join("|")
    }

    /// Every kind with what it drives: "`sim` (the simulator), `rmp:HOST:PORT` (…) and …".
    pub fn describe(&self) -> String {
        let items: Vec<String> = self
            .kinds
            .iter()
            .map(|k| format!("`{}` ({})", k.syntax(), k.about()))
            .collect();
        match items.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
            Some((last, _)) => last.clone(),
            None => "none".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use miette::Diagnostic;

    fn code(spec: &str) -> String {
        let e = Registry::standard().parse(spec).unwrap_err();
        e.code().map(|c| c.to_string()).unwrap_or_default()
    }

    fn help(spec: &str) -> String {
        let e = Registry::standard().parse(spec).unwrap_err();
        e.help().map(|c| c.to_string()).unwrap_or_default()
    }

    #[test]
    fn each_spelling_goes_to_its_kind() {
        let r = Registry::standard();
        for (spec, kind, shown) in [
            ("sim", "sim", "sim"),
            (" sim ", "sim", "sim"),
            ("rmp:127.0.0.1:8080", "rmp", "rmp:127.0.0.1:8080"),
            ("rmp 127.0.0.1:8080", "rmp", "rmp:127.0.0.1:8080"),
            ("ros2", "ros2", "ros2:/"),
            ("ros2:/robot1?domain=3", "ros2", "ros2:/robot1?domain=3"),
        ] {
            let s = r.parse(spec).unwrap();
            assert_eq!((s.kind(), s.to_string().as_str()), (kind, shown), "{spec}");
            assert_eq!(s.is_simulator(), kind == "sim");
        }
    }

    #[test]
    fn unknown_spellings_are_suggested_through_diag_suggest() {
        assert_eq!(code("smi"), "advise::backend::unknown");
        assert_eq!(help("smi"), "did you mean `sim`?");
        assert_eq!(help("rpm:1.2.3.4:5"), "did you mean `rmp:HOST:PORT`?");
        assert_eq!(help("ros"), "did you mean `ros2[:NAMESPACE]`?");
        assert_eq!(help("ros3:/x"), "did you mean `ros2[:NAMESPACE]`?");
        assert_eq!(
            help("robot"),
            "the backends are `sim` (the simulator), `rmp:HOST:PORT` (a Segway RMP, or `advise rmp-emulator`) and `ros2[:NAMESPACE]` (a ROS 2 base, or `advise ros2-sim`)"
        );
        assert_eq!(code(""), "advise::backend::unknown");
        assert_eq!(
            Registry::standard().syntaxes(),
            "sim|rmp:HOST:PORT|ros2[:NAMESPACE]"
        );
    }

    #[test]
    fn completion_offers_every_kind() {
        assert_eq!(
            Registry::standard().completions(""),
            ["rmp:", "ros2", "ros2:", "sim"]
        );
        assert_eq!(
            Registry::standard().completions("r"),
            ["rmp:", "ros2", "ros2:"]
        );
        assert_eq!(Registry::standard().completions("x"), Vec::<String>::new());
    }
}
