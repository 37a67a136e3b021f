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

/// `set` with the standard operators by role ([`role_operators`]) added for each of `tasks`
/// whose actions drive speed and turn. With `leave_out_own`, the operators `set` already has for
/// a task shadow them (they are left out); without, every one is added, on top (`advise check`
/// then checks the task files again over them, so that their own operators warn). The texts go into `map` under [`role_source_name`]. A rewritten operator
/// that does not check for the task (a name clash with one of its dimensions) is left out, not
/// reported: the task file is not wrong. The session and `advise check` both come here.
pub fn with_role_operators(
    mut set: OperatorSet,
    map: &mut SourceMap,
    tasks: &[Arc<crate::program::task::TaskDef>],
    leave_out_own: bool,
) -> OperatorSet {
    for task in tasks {
        let own: Vec<String> = set
            .operators(task.name())
            .filter(|_| leave_out_own)
            .map(|o| o.name().to_string())
            .collect();
        let own: Vec<&str> = own.iter().map(String::as_str).collect();
        let Some(text) = role_operators(task, &own) else {
            continue;
        };
        let id = map.add(role_source_name(task.name()), text);
        if let Ok(checked) = set.merge_in(map, &[id]) {
            set = checked.set;
        }
    }
    set
}

impl OperatorSet {
    /// `ids` checked on top of this set, every task they declare (that this set does not) given
    /// the standard operators by role ([`with_role_operators`]), then `ids` checked again over
    /// them, so that a task's own operator of a standard name shadows it and says so
    /// (`shadows_standard`, after the first check's warnings). The one way task files are taken in:
    /// a session's `tasks FILE`, `advise check --tasks`, the command line's `--tasks` and the
    /// Python package all come here. The role texts join `map` under [`role_source_name`].
    pub fn merge_declaring(
        &self,
        map: &mut SourceMap,
        ids: &[SourceId],
    ) -> Result<Checked, CheckErrors> {
        let first = self.merge_in(map, ids)?;
        let new: Vec<_> = first
            .set
            .tasks()
            .iter()
            .filter(|t| self.tasks().iter().all(|b| b.name() != t.name()))
            .cloned()
            .collect();
        if new.is_empty() {
            return Ok(first);
        }
        let under = with_role_operators(first.set.clone(), map, &new, false);
        match under.merge_in(map, ids) {
            // The first check's warnings, and those only the second gives (a standard operator
            // by role shadowed): some checks (a task's finiteness) are not made again for a
            // domain the set already holds, and the rest would come twice.
            Ok(again) => {
                let mut warnings = first.warnings;
                let seen: Vec<String> = warnings.iter().map(|w| format!("{w:?}")).collect();
                warnings.extend(
                    again
                        .warnings
                        .into_iter()
                        .filter(|w| !seen.contains(&format!("{w:?}"))),
                );
                Ok(Checked {
                    set: again.set,
                    warnings,
                })
            }
            // They checked a moment ago on a set without them: leave out the role operators the
            // task has its own of rather than lose the files.
            Err(_) => Ok(Checked {
                set: with_role_operators(first.set, map, &new, true),
                warnings: first.warnings,
            }),
        }
    }
}

/// The name of the source that holds `task`'s standard operators by role: an operator from it is
/// standard, so a task's operator defined later under the same name warns that it shadows it.
pub fn role_source_name(task: &str) -> String {
    format!("{ROLE_SOURCE_PREFIX}{task}")
}

/// What every [`role_source_name`] starts with.
pub(super) const ROLE_SOURCE_PREFIX: &str = "standard operators for ";

/// The standard operators written against roles: positioning's action-side operators, whose
/// `trans` drives the base's speed and `rot` its turn, rewritten for `task`, whose own actions
/// drive those roles (`act NAME ... drives speed`, `drives turn`). `None` when its actions do not
/// both command a speed directly (an action added to the command each step, as interception's
/// changes, is another role). Operators named in `own` (the task's) are left out: they shadow the
/// standard ones. Observation-side operators are left out too: they name positioning's
/// observations. The text is checked like any file, on top of the set that declares `task`.
pub fn role_operators(task: &crate::program::task::TaskDef, own: &[&str]) -> Option<String> {
    let direct = |d: &Option<crate::program::task::Drive>| {
        d.as_ref()
            .filter(|d| d.integrate.is_none())
            .map(|d| task.domain.act[d.action].name.clone())
    };
    let (speed, turn) = (direct(&task.speed)?, direct(&task.turn)?);
    let rename = |word: &str| match word {
        "trans" => speed.clone(),
        "rot" => turn.clone(),
        "positioning" => task.name().to_string(),
        w => w.to_string(),
    };
    let mut out = String::new();
    for item in STANDARD_SOURCES[0].1.split("\n\n") {
        let Some(head) = item.lines().find(|l| l.starts_with("operator ")) else {
            continue;
        };
        let name: String = head["operator ".len()..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if !head.contains(" on action") || own.contains(&name.as_str()) {
            continue;
        }
        out.push_str(&rename_words(item.trim(), &rename));
        out.push_str("\n\n");
    }
    (!out.is_empty()).then_some(out)
}

/// `text` with every whole word (letters, digits, `_`) passed through `f`.
fn rename_words(text: &str, f: &dyn Fn(&str) -> String) -> String {
    let mut out = String::with_capacity(text.len());
    let mut word = String::new();
    for c in text.chars() {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
            continue;
        }
        if !word.is_empty() {
            out.push_str(&f(&word));
            word.clear();
        }
        out.push(c);
    }
    if !word.is_empty() {
        out.push_str(&f(&word));
    }
    out
}

#[cfg(test)]
mod role_tests {
    use super::*;

    #[test]
    fn a_task_whose_actions_drive_speed_and_turn_gets_the_standard_operators_by_role() {
        let text = "domain dock {\n  observe range \"m\" in [0, 10] = hypot(gx - x, gy - y)\n  act fwd \"m/s\" in [-0.5, 0.5] drives speed, yaw \"rad/s\" in [-1, 1] drives turn\n  goal gx \"m\" in [1, 3], gy \"m\" in [-1, 1]\n  score error = range\n  success when error < 0.3\n  end after 20\n}\n\noperator stop for dock on action { fwd = 0 }\n";
        let set = check(&[Source::new("dock.adv", text)]).unwrap();
        let task = set.task("dock").unwrap();
        let roles = role_operators(task, &["stop"]).unwrap();
        assert!(roles.contains("operator slow_down(rate = 0.2 in [0, 1]) for dock on action where fwd != 0 or yaw != 0 {"), "{roles}");
        assert!(
            !roles.contains("operator stop"),
            "the task's own shadows it"
        );
        assert!(
            !roles.contains("start_turning_earlier"),
            "observation-side: positioning's observations"
        );
        let both = check(&[Source::new("dock.adv", text), Source::new("roles", &roles)]).unwrap();
        let names: Vec<&str> = both.operators("dock").map(|o| o.name()).collect();
        assert!(
            names.contains(&"slow_down") && names.contains(&"brake_straight"),
            "{names:?}"
        );
        // Interception's actions change the command each step: another role, no operators.
        let interception = OperatorSet::standard();
        assert!(
            interception
                .task("interception")
                .is_none_or(|t| role_operators(t, &[]).is_none())
        );
    }
}
