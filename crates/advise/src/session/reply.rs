//! What a statement did, as data: [`Reply`]. The REPL, `advise run` and the tests render it with
//! `Display` (the text the teacher reads); a program driving a session (a test, a front end)
//! reads the fields instead of parsing that text.

use std::fmt;

use crate::domain::Space;
use crate::eval::Report;
use crate::policy::learner::{KernelCoverage, kernel_warning};
use crate::trace::Chunk;

use super::text::eval_change;

/// The reply to one statement.
#[derive(Clone, Debug, PartialEq)]
pub enum Reply {
    /// A blank or comment-only statement.
    Nothing,
    /// An operator or a domain defined on the spot, with the checker's warnings (rendered).
    Defined {
        item: Defined,
        warnings: Vec<String>,
    },
    /// `run`: execution `index` recorded.
    Ran(Ran),
    /// `select`: a chunk of an execution is now what advice and critique act on.
    Selected { execution: usize, chunk: Chunk },
    /// `advise`: synthesized points added to the dataset.
    Advised(Advised),
    /// `critique`: the weights of the points that acted were raised.
    Critiqued {
        execution: usize,
        chunk: Chunk,
        /// What changed, in words (the learner's account).
        summary: String,
    },
    /// `eval`: the policy on the task's test set, and what changed since the last `eval`.
    Evaluated(Evaluated),
    /// `suggest`: flawed chunks with candidate advice and their simulated effects.
    Suggested(Box<super::suggest::Suggestions>),
    /// `quit`: the session ends.
    Quit,
    /// Any other command's answer, in words (help, history, show, why, preview, files, task and
    /// backend switches).
    Message(String),
}

/// What a definition defined.
#[derive(Clone, Debug, PartialEq)]
pub enum Defined {
    Operator {
        name: String,
        domain: String,
        space: Space,
    },
    Domain {
        name: String,
    },
}

/// A recorded run.
#[derive(Clone, Debug, PartialEq)]
pub struct Ran {
    /// Its execution number (what `select ... in N`, `show N` and `plot compare` take).
    pub index: usize,
    pub label: String,
    pub points: usize,
    /// The goal it drove to, named: `px = 2.31 m, py = -0.5 m` (none for interception).
    pub goal: Option<String>,
    /// The outcome in words: success or failure, time, distance, errors.
    pub outcome: String,
    /// The stretch worth a look (where the robot slowed or turned most), and what it did there.
    pub worth_a_look: Option<(Chunk, &'static str)>,
    /// LWR: how many of the run's steps found data in the kernel (`None` for BC).
    pub kernel: Option<KernelCoverage>,
    /// The windows the teacher took over, each kept as a demonstration.
    pub takeovers: Vec<super::TookOver>,
    /// A `takeover A..B` window the run ended before.
    pub takeover_missed: Option<String>,
}

/// Advice given.
#[derive(Clone, Debug, PartialEq)]
pub struct Advised {
    pub execution: usize,
    pub chunk: Chunk,
    /// The invocation with every argument (`slow_down(rate = 0.3)`).
    pub invocation: String,
    /// Points added, and points of the chunk the operator's guard skipped.
    pub added: usize,
    pub skipped: usize,
    /// The dataset's size after it.
    pub dataset: usize,
    /// From the command to the policy ready to run again, in milliseconds.
    pub ready_ms: f64,
    /// What it contradicts in earlier advice or demonstrations (the warning
    /// `advise::session::conflicting_advice`), if anything.
    pub conflict: Option<super::conflict::Conflict>,
}

/// What an evaluation is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Since {
    /// The last evaluation (the policy changed since).
    LastEval,
    /// The last evaluation, whose report this one repeats (same results: the policy did not
    /// change, or changed where no test goes).
    Unchanged,
    /// Same results as the last evaluation (`eval --detail`): the last one against the one before
    /// it, the changes the last `eval` counted.
    LastAgainstPrevious,
}

/// An evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluated {
    pub report: Box<Report>,
    /// The previous evaluation of this task in the session, if any.
    pub before: Option<Box<Report>>,
    /// `eval --detail`: list the tests that changed outcome.
    pub detail: bool,
    /// Which evaluation `before` is.
    pub since: Since,
    /// The connected robot's name when the session is on one (the evaluation ran in the
    /// simulator all the same).
    pub robot: Option<String>,
}

impl Reply {
    /// Whether the session should end.
    pub fn is_quit(&self) -> bool {
        matches!(self, Reply::Quit)
    }
}

impl fmt::Display for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reply::Nothing | Reply::Quit => Ok(()),
            Reply::Defined { item, warnings } => {
                match item {
                    Defined::Operator {
                        name,
                        domain,
                        space,
                    } => write!(f, "defined operator `{name}` for {domain} (on {space})")?,
                    Defined::Domain { name } => write!(f, "defined domain `{name}`")?,
                }
                for w in warnings {
                    write!(f, "\n\n{}", w.trim_end())?;
                }
                Ok(())
            }
            Reply::Ran(r) => {
                write!(f, "execution {}: {}", r.index, r.label)?;
                if let Some(goal) = &r.goal {
                    write!(f, " (goal {goal})")?;
                }
                write!(f, ": {} points; {}", r.points, r.outcome)?;
                for t in &r.takeovers {
                    write!(
                        f,
                        "\nthe teacher drove from {:.2} s to {:.2} s (steps {}); its {} points joined the data as takeover #{} (`why`, `history`, `undo`)",
                        t.from_s, t.to_s, t.steps, t.points, t.number
                    )?;
                }
                if let Some(w) = &r.takeover_missed {
                    write!(
                        f,
                        "\nthe run ended before the takeover window {w} s: the learner drove all of it"
                    )?;
                }
                if let Some((chunk, what)) = r.worth_a_look {
                    write!(
                        f,
                        "\nthe robot {what} most over {chunk}: `select {chunk}` to critique or advise it"
                    )?;
                }
                if let Some(k) = r.kernel {
                    write!(f, "\n{}", k.line("steps"))?;
                    f.write_str(&kernel_warning(
                        k,
                        "steps of this run",
                        "the run went where the data is sparse: look at its steps with `why N`, then demonstrate near them (`teleop`, `record demo`) or advise the run; `rederive` re-tunes the kernel on the data as it is",
                    ))?;
                }
                Ok(())
            }
            Reply::Selected { execution, chunk } => write!(
                f,
                "selected {chunk} of execution {execution} ({} points)",
                chunk.len()
            ),
            Reply::Advised(a) => {
                write!(
                    f,
                    "advised {} of execution {} with {}: {} points added",
                    a.chunk, a.execution, a.invocation, a.added
                )?;
                if a.skipped > 0 {
                    write!(f, " ({} skipped by the operator's guard)", a.skipped)?;
                }
                write!(
                    f,
                    "; the policy has {} points, ready in {}",
                    a.dataset,
                    super::text::fmt_ms(a.ready_ms)
                )?;
                if let Some(c) = &a.conflict {
                    let shown = crate::diag::render(&crate::diag::SourceMap::new(), c, false);
                    write!(f, "\n\n{}", shown.trim_end())?;
                }
                Ok(())
            }
            Reply::Critiqued { summary, .. } => f.write_str(summary),
            Reply::Evaluated(e) => {
                f.write_str(&e.report.render())?;
                let since = match e.since {
                    Since::LastAgainstPrevious => {
                        "the same results as the last eval; that eval against the one before it"
                    }
                    Since::Unchanged => "the same results as the last eval",
                    Since::LastEval => "since the last eval",
                };
                match &e.before {
                    Some(before) => {
                        f.write_str(&eval_change(since, before, &e.report, e.detail))?
                    }
                    None => f.write_str("  (the first evaluation of this task in the session: the next `eval` says what changed)\n")?,
                }
                if let Some(name) = &e.robot {
                    writeln!(
                        f,
                        "(in the simulator; `advise eval --backend {name}` runs the test set on the robot)"
                    )?;
                }
                Ok(())
            }
            Reply::Suggested(s) => write!(f, "{s}"),
            Reply::Message(text) => f.write_str(text),
        }
    }
}
