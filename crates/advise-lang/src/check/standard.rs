//! The standard library, `operators/*.adv`, embedded in the binary and checked like any user's
//! file, once per process. It is also the only source of the paper's two domains: the constructors
//! [`Domain::positioning`] and [`Domain::interception`] live here (Rust lets an inherent `impl` sit
//! in any module of the crate) because they read the `domain` declarations of those files, as jaq
//! parses its own standard library; `crate::domain` only describes shapes and imports no phase.

use std::sync::OnceLock;

use super::*;
use crate::syntax::ast::Item;

/// The standard operator library, embedded so the binary works from any directory.
pub const STANDARD_SOURCES: [(&str, &str); 2] = [
    (
        "operators/positioning.adv",
        include_str!("../../../../operators/positioning.adv"),
    ),
    (
        "operators/interception.adv",
        include_str!("../../../../operators/interception.adv"),
    ),
];

fn sources() -> Vec<Source> {
    STANDARD_SOURCES
        .iter()
        .map(|(n, t)| Source::new(*n, *t))
        .collect()
}

/// The standard set, checked on first use.
fn standard_set() -> &'static OperatorSet {
    static STANDARD: OnceLock<OperatorSet> = OnceLock::new();
    STANDARD.get_or_init(|| match check(&sources()) {
        Ok(set) => set,
        // A test checks the embedded library; reaching this is a build defect.
        Err(e) => panic!("the standard operators do not check:\n{}", render_all(&e)),
    })
}

/// The domains the standard files declare, checked on first use: only their `domain` items, so
/// that the checker may consult them (for hints) while it checks the standard operators.
pub(super) fn standard_domains() -> &'static [Domain] {
    static DOMAINS: OnceLock<Vec<Domain>> = OnceLock::new();
    DOMAINS.get_or_init(|| {
        let mut map = SourceMap::new();
        let ids: Vec<SourceId> = STANDARD_SOURCES
            .iter()
            .map(|(n, t)| map.add(*n, *t))
            .collect();
        let srcs: Vec<Src<'_>> = ids.iter().map(|&id| map.src(id)).collect();
        let mut c = Checker::new(&srcs);
        let mut read = Read::new(None);
        for (f, s) in srcs.iter().enumerate() {
            for item in syntax::items(*s) {
                match item {
                    Ok(Item::Domain(d)) => c.read_domain(f, &d, &mut read),
                    Ok(Item::Operator(_)) => {}
                    Err(e) => panic!(
                        "the standard operators do not parse:\n{}",
                        crate::diag::render(&map, &e, false)
                    ),
                }
            }
        }
        if !c.errors.is_empty() {
            let errors = c.errors.into_iter().map(|(_, _, e)| e).collect();
            panic!(
                "the standard domains do not check:\n{}",
                crate::diag::render(&map, &CheckErrors { errors }, false)
            );
        }
        read.doms.iter().map(|d| d.domain().clone()).collect()
    })
}

impl OperatorSet {
    /// The standard library (`operators/*.adv`), checked once per process.
    pub fn standard() -> OperatorSet {
        standard_set().clone()
    }

    /// A task the standard files declare (`positioning`), shared.
    pub fn standard_task(name: &str) -> Option<Arc<crate::program::task::TaskDef>> {
        standard_set().task(name).cloned()
    }
}

impl Domain {
    /// The paper's spatial positioning domain (A-OPI, Segway RMP), as `operators/positioning.adv`
    /// declares it.
    ///
    /// Observation: squared distance to the goal, angle between the goal vector and the heading,
    /// and `theta_g - theta_r`. Action: translational and rotational speed.
    pub fn positioning() -> Domain {
        Self::standard("positioning")
    }

    /// The paper's ball interception domain (BC, simulated differential drive), as
    /// `operators/interception.adv` declares it.
    ///
    /// Observation: distance and angle to the ball, their changes since the last step, the change
    /// in travelled distance and in heading. Action: change in translational and rotational speed.
    pub fn interception() -> Domain {
        Self::standard("interception")
    }

    /// A built-in domain (one the standard files declare) by name.
    pub fn builtin(name: &str) -> Option<Domain> {
        standard_domains().iter().find(|d| d.name == name).cloned()
    }

    fn standard(name: &str) -> Domain {
        // The embedded files declare both; `tests/operators.rs` and the unit test below check it.
        Self::builtin(name).unwrap_or_else(|| panic!("operators/*.adv declares no `{name}` domain"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standard_files_declare_the_papers_domains() {
        let p = Domain::positioning();
        let names = |d: &Domain, s: crate::domain::Space| -> Vec<String> {
            d.dims(s).iter().map(|x| x.name.clone()).collect()
        };
        use crate::domain::Space::{Action, Observation};
        assert_eq!(names(&p, Observation), ["dist2", "bearing", "dheading"]);
        assert_eq!(names(&p, Action), ["trans", "rot"]);
        let i = Domain::interception();
        assert_eq!(i.obs_dim(), 6);
        assert_eq!(names(&i, Action), ["trans_delta", "rot_delta"]);
        assert_eq!(i.act[1].limits.map(|l| (l.lo, l.hi)), Some((-0.2, 0.2)));
        assert_eq!(Domain::builtin("nope"), None);
        // The full check of the library declares the same domains.
        assert_eq!(OperatorSet::standard().domains(), standard_domains());
    }
}
