//! The teacher's copilot: `suggest` finds the chunks of an execution where the task's `flaw`
//! clauses hold and proposes advice for each; `accept K` gives suggestion K as `select` then
//! `advise` would.
//!
//! **Chunks.** The stretches where flaws held ([`crate::interp::flaws::find`]), overlapping ones
//! joined (each named by all its flaws), in the order they happened, at most [`MAX_CHUNKS`]: a
//! run's first flaws are where it began to go wrong. Each is cut by the studies' one chunk rule
//! ([`crate::experiment::chunk_rule`]: its first 25 points): a person advises the moment things
//! went wrong, not the whole stretch after it.
//!
//! **Candidates.** Every operator of the task's domain, standard or the session's own, whose
//! application to the chunk changes at least one point (a guard that skips every point, or an
//! operator that only restates the executed actions, proposes nothing). An operator whose one
//! parameter is a `rate` or `gain` is tried at the paper's scale "a little / more / much more",
//! [`RATES`] (0.1, 0.25, 0.5, as the studies' advisor speaks; a rate outside the parameter's
//! limits is left out); any other operator at its defaults. Synthesized exactly as `preview`
//! and `advise` synthesize (`check::bind`, `interp::apply`), nothing added.
//!
//! **Effects.** On the simulator each candidate is given to a copy of the learner
//! ([`crate::policy::learner::Learner::copy`]) and the execution's start is run again with the
//! same simulator seed (the same noise): success, the task's error and heading error, and the
//! path length, before (the copy without advice, re-run the same way) and after. Candidates are
//! ranked by success, then by error plus heading error over pi (both ends of a run a person
//! judges), then by length; the best [`PER_CHUNK`] of each chunk are kept and numbered in that
//! order across chunks. The re-runs are bounded in count ([`MAX_RERUNS`]) and time (the session's
//! budget, [`DEFAULT_BUDGET_S`]); what the budget leaves out is listed without an effect and the
//! output says how many. On a real base (or a run the session cannot re-create) nothing is
//! re-run: each chunk's candidates at "more" are listed by how many points they change, and the
//! output says so. Suggestions are not journalled: they change nothing, and `accept` journals
//! what it does as the `select` and `advise` it is.

use std::fmt;
use std::time::Instant;

use serde::Serialize;

use super::{HeldExecution, Reply, Session, SessionError};
use crate::check;
use crate::diag::SourceMap;
use crate::experiment::advisor;
use crate::interp::{self, Synthesized};
use crate::syntax::parse_invocation;
use crate::task::{self, Execution, Start, TaskKind, episode_seed};
use crate::trace::{Chunk, PointRange};

/// Flawed chunks suggested on, at most.
pub const MAX_CHUNKS: usize = 4;
/// Suggestions kept per chunk.
pub const PER_CHUNK: usize = 3;
/// The paper's "a little", "more", "much more", as rates: the studies' advisor's
/// ([`crate::experiment::advisor::RATES`]), named.
pub const RATES: [(f64, &str); 3] = [
    (advisor::RATES[0], "a little"),
    (advisor::RATES[1], "more"),
    (advisor::RATES[2], "much more"),
];
/// Re-runs per `suggest`, at most (tried in turn across the chunks, so each gets its share).
pub const MAX_RERUNS: usize = 96;
/// Stretches of flaws at most this many points apart are one chunk (the studies' critic's
/// `merge_gap`: a person does not split a flaw at a twitch).
pub const MERGE_GAP: usize = 5;
/// The time `suggest` may spend re-running, s, unless the session was given another.
pub const DEFAULT_BUDGET_S: f64 = 30.0;

/// What a run showed, before or after advice.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Measure {
    pub success: bool,
    /// The task's `error` score (positioning: distance to the goal, m).
    pub error: f64,
    pub heading_error: Option<f64>,
    pub length_m: f64,
    pub steps: usize,
}

impl Measure {
    fn of(e: &Execution) -> Measure {
        Measure {
            success: e.outcome.success,
            error: e.outcome.position_error_m,
            heading_error: e.outcome.heading_error_rad,
            length_m: e.outcome.length_m,
            steps: e.outcome.steps,
        }
    }

    /// Lower is better: failure after success, then error (heading as a share of pi), then length.
    fn rank(&self) -> (bool, f64, f64) {
        let h = self.heading_error.unwrap_or(0.0) / std::f64::consts::PI;
        let e = self.error + h;
        (
            !self.success,
            if e.is_finite() { e } else { f64::MAX },
            if self.length_m.is_finite() {
                self.length_m
            } else {
                f64::MAX
            },
        )
    }
}

/// A stretch where flaws held, as suggested on.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Flawed {
    pub chunk: Chunk,
    /// The stretch before the chunk rule cut it.
    pub held: Chunk,
    pub flaws: Vec<String>,
}

/// One piece of advice proposed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Suggestion {
    /// What `accept` takes, from 1.
    pub number: usize,
    pub execution: usize,
    pub chunk: Chunk,
    pub flaws: Vec<String>,
    /// With every argument: `translational_deceleration(gain = 0.25)`.
    pub invocation: String,
    pub operator: String,
    /// "a little", "more", "much more", for a rate or gain.
    pub rate: Option<&'static str>,
    /// Points it would add.
    pub points: usize,
    /// The re-run with it (`None`: not re-run).
    pub after: Option<Measure>,
    /// What it would add, as `preview` shows it (the web view draws it on hover).
    pub preview: Points,
}

/// A suggestion's synthesized points beside the executed ones they came from, in the operator's
/// space: what `preview` would show.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Points {
    pub space: String,
    pub dims: Vec<String>,
    /// The executed point each synthesized point came from.
    pub source_index: Vec<usize>,
    pub before: Vec<Vec<f64>>,
    pub after: Vec<Vec<f64>>,
}

impl Points {
    fn of(trace: &crate::trace::Trace, syn: &Synthesized, dims: &[crate::domain::Dim]) -> Points {
        let (before, after) = syn
            .source_index
            .iter()
            .enumerate()
            .map(|(j, &src)| {
                let (b, a) = super::advice::before_after(trace, syn, j, src);
                (b.to_vec(), a.to_vec())
            })
            .unzip();
        Points {
            space: syn.advice.space.to_string(),
            dims: dims.iter().map(|d| d.name.clone()).collect(),
            source_index: syn.source_index.clone(),
            before,
            after,
        }
    }
}

/// Whether and how candidates were tried.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Trial {
    /// Re-run on the simulator: `before` is the copy of the learner without advice.
    Simulated { before: Measure, seed: u64 },
    /// Not re-run, and why.
    NotRun { why: String },
}

/// What `suggest` found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Suggestions {
    pub execution: usize,
    pub label: String,
    pub flawed: Vec<Flawed>,
    /// Flawed stretches beyond [`MAX_CHUNKS`], not suggested on.
    pub more_flawed: usize,
    pub trial: Trial,
    pub suggestions: Vec<Suggestion>,
    /// Flawed chunks none of whose re-run candidates did better than the run without advice.
    pub no_better: Vec<Chunk>,
    /// Candidates tried in all.
    pub candidates: usize,
    /// Candidates the budget left without a re-run.
    pub not_rerun: usize,
    /// Whether the time budget (rather than [`MAX_RERUNS`]) left them.
    pub out_of_time: bool,
    pub budget_s: f64,
}

/// A candidate before ranking.
struct Candidate {
    chunk: usize,
    invocation: String,
    operator: String,
    rate: Option<&'static str>,
    syn: Synthesized,
    after: Option<Measure>,
}

impl Session {
    /// `suggest [N]`.
    pub(super) fn suggest(&mut self, n: Option<usize>) -> Result<Reply, SessionError> {
        let i = self.execution_or_last(n)?;
        let rec = self.numbered(i)?.clone();
        let flawed = self.flawed(i, &rec)?;
        let mut cands = self.candidates(&rec, &flawed);
        let start = self.rerun_start(&rec);
        let (trial, not_rerun, out_of_time) = match start {
            Ok((start, seed)) => self.try_candidates(&rec, &start, seed, &mut cands),
            Err(why) => (Trial::NotRun { why }, 0, false),
        };
        let total = cands.len();
        let suggestions = rank(i, &flawed.0, cands, &trial, &rec.trace, &self.domain);
        let no_better = match trial {
            Trial::Simulated { .. } => flawed
                .0
                .iter()
                .map(|f| f.chunk)
                .filter(|c| !suggestions.iter().any(|s| s.chunk == *c))
                .collect(),
            Trial::NotRun { .. } => Vec::new(),
        };
        let s = Suggestions {
            execution: i,
            label: rec.label.clone(),
            flawed: flawed.0,
            more_flawed: flawed.1,
            trial,
            suggestions,
            no_better,
            candidates: total,
            not_rerun,
            out_of_time,
            budget_s: self.suggest_budget_s,
        };
        self.state.suggested = Some(s.clone());
        Ok(Reply::Suggested(Box::new(s)))
    }

    /// `accept K`: suggestion K of the last `suggest`, as `select` then `advise`, each journalled
    /// under its own statement text.
    pub(super) fn accept(&mut self, k: usize) -> Result<Reply, SessionError> {
        let s = self
            .state
            .suggested
            .as_ref()
            .ok_or(SessionError::NoSuggestions {
                why: "no `suggest` on this task since the session (or the task) started",
            })?;
        let count = s.suggestions.len();
        let sug = k
            .checked_sub(1)
            .and_then(|j| s.suggestions.get(j))
            .ok_or(SessionError::NoSuchSuggestion { k, count })?
            .clone();
        let inv = parse_invocation(&sug.invocation).map_err(|e| SessionError::Parse(e.error))?;
        let outer = self.statement.clone();
        let origin = outer.as_ref().map_or(String::new(), |o| o.1.clone());
        self.statement = Some((
            format!("select {} in {}", sug.chunk, sug.execution),
            origin.clone(),
        ));
        let selected = self.select(
            PointRange::new(sug.chunk.start, sug.chunk.end),
            Some(sug.execution),
        );
        let reply = selected.and_then(|_| {
            self.statement = Some((format!("advise {}", sug.invocation), origin));
            self.advise(&inv)
        });
        self.statement = outer;
        reply
    }

    /// The flawed chunks of execution `i` (at most [`MAX_CHUNKS`]) and how many more there were.
    fn flawed(&self, i: usize, rec: &HeldExecution) -> Result<(Vec<Flawed>, usize), SessionError> {
        let def = self
            .task
            .def()
            .filter(|d| !d.flaws.is_empty())
            .ok_or(SessionError::NoFlaws {
                task: self.task.clone(),
            })?;
        let unreadable = |why| SessionError::FlawsUnreadable {
            n: i,
            label: rec.label.clone(),
            why,
        };
        let goal = match (&rec.goal_values, rec.goal) {
            (Some(g), _) => g.clone(),
            (None, Some(g)) => vec![g.x_m, g.y_m, g.theta_rad],
            (None, None) => return Err(unreadable("no goal")),
        };
        let mut held = interp::flaws::find(&def, &goal, &rec.trace).map_err(|e| {
            unreadable(match e {
                interp::flaws::Unreadable::NoPoses => "no poses",
                interp::flaws::Unreadable::WrongShape => "another task's dimensions",
            })
        })?;
        held.sort_by_key(|h| (h.chunk.start, h.chunk.end));
        let mut joined: Vec<(Chunk, Vec<String>)> = Vec::new();
        for h in held {
            let name = def.flaws[h.flaw].name.clone();
            match joined.last_mut() {
                Some((c, names)) if h.chunk.start <= c.end + MERGE_GAP => {
                    c.end = c.end.max(h.chunk.end);
                    if !names.contains(&name) {
                        names.push(name);
                    }
                }
                _ => joined.push((h.chunk, vec![name])),
            }
        }
        let more = joined.len().saturating_sub(MAX_CHUNKS);
        let flawed = joined
            .into_iter()
            .take(MAX_CHUNKS)
            .map(|(held, flaws)| Flawed {
                chunk: crate::experiment::chunk_rule(held),
                held,
                flaws,
            })
            .collect();
        Ok((flawed, more))
    }

    /// Every candidate on every flawed chunk: the domain's operators at the rates that apply.
    fn candidates(&self, rec: &HeldExecution, flawed: &(Vec<Flawed>, usize)) -> Vec<Candidate> {
        let mut out = Vec::new();
        let domain = rec.trace.domain.clone();
        for (ci, f) in flawed.0.iter().enumerate() {
            for op in self.ops.operators(&domain) {
                for (text, rate) in invocations(op) {
                    let Ok(inv) = parse_invocation(&text) else {
                        continue;
                    };
                    let mut scratch = SourceMap::new();
                    let Ok(call) = check::bind(&mut scratch, &self.ops, &domain, &inv) else {
                        continue;
                    };
                    let Ok(syn) = interp::apply(&call, &rec.trace, f.chunk) else {
                        continue;
                    };
                    if !changes(&rec.trace, &syn) {
                        continue;
                    }
                    out.push(Candidate {
                        chunk: ci,
                        invocation: syn.advice.invocation(),
                        operator: op.name().to_string(),
                        rate,
                        syn,
                        after: None,
                    });
                }
            }
        }
        out
    }

    /// Where and with what noise a re-run of `rec` starts, or why there is none.
    fn rerun_start(&self, rec: &HeldExecution) -> Result<(Start, u64), String> {
        if !self.backend.is_simulator() {
            return Err(format!(
                "on a real base, {}: nothing is driven for a suggestion; `backend sim` shows their effects in the simulator",
                self.backend.name()
            ));
        }
        let Some(number) = rec.run_number else {
            return Err("the execution is not a run of this session".into());
        };
        let start = match (&self.task, rec.goal, &rec.goal_values) {
            (TaskKind::Positioning, Some(g), _) => Start::Goal(g),
            (TaskKind::Declared(d), _, Some(v)) => Start::Declared(d.clone(), v.clone()),
            _ => return Err("the run's start is not kept".into()),
        };
        Ok((start, episode_seed(self.seed, 1_000_000 + number)))
    }

    /// Re-run every candidate the budget allows: the trial, and how many were left out.
    fn try_candidates(
        &mut self,
        rec: &HeldExecution,
        start: &Start,
        seed: u64,
        cands: &mut [Candidate],
    ) -> (Trial, usize, bool) {
        let began = Instant::now();
        let runs = cands.len().min(MAX_RERUNS);
        let bar = crate::progress::bar(
            self.progress,
            runs as u64 + 1,
            crate::progress::Unit::Items,
            "suggest: re-running the start with each candidate",
        );
        self.state.learner.prepare();
        let sim = self.sim_params();
        let run = |learner: &crate::policy::learner::Learner| {
            let mut controller = learner.policy();
            task::run_sim(start, &mut controller, &sim, seed)
        };
        let before = Measure::of(&run(&self.state.learner.copy()));
        bar.inc(1);
        let (mut left, mut out_of_time) = (0, false);
        // In turn across the chunks: the first candidate of each chunk, then the second...
        let mut order: Vec<(usize, usize)> = Vec::with_capacity(cands.len());
        let mut seen_in_chunk = std::collections::HashMap::new();
        for (j, c) in cands.iter().enumerate() {
            let k = seen_in_chunk.entry(c.chunk).or_insert(0usize);
            order.push((*k, j));
            *k += 1;
        }
        order.sort_unstable();
        for (tried, (_, j)) in order.into_iter().enumerate() {
            let c = &mut cands[j];
            if tried >= MAX_RERUNS {
                left += 1;
                continue;
            }
            if began.elapsed().as_secs_f64() > self.suggest_budget_s {
                out_of_time = true;
                left += 1;
                continue;
            }
            let mut copy = self.state.learner.copy();
            if copy.add_advice(rec.id, &c.syn).is_err() {
                left += 1;
                continue;
            }
            copy.prepare();
            c.after = Some(Measure::of(&run(&copy)));
            bar.inc(1);
        }
        bar.finish();
        (Trial::Simulated { before, seed }, left, out_of_time)
    }
}

/// The invocations an operator is tried with: at each rate of [`RATES`] for a lone `rate` or
/// `gain` parameter (within its limits), else once at its defaults (when every parameter has one).
fn invocations(op: &crate::program::Operator) -> Vec<(String, Option<&'static str>)> {
    let params = op.params();
    match params {
        [p] if p.name == "rate" || p.name == "gain" => RATES
            .iter()
            .filter(|(r, _)| p.limits.is_none_or(|l| l.lo <= *r && *r <= l.hi))
            .map(|(r, word)| (format!("{}({} = {r})", op.name(), p.name), Some(*word)))
            .collect(),
        ps if ps.iter().all(|p| p.default.is_some()) => vec![(op.name().to_string(), None)],
        _ => Vec::new(),
    }
}

/// Whether the synthesized points differ from the executed ones they came from.
fn changes(trace: &crate::trace::Trace, syn: &Synthesized) -> bool {
    syn.source_index.iter().enumerate().any(|(j, &src)| {
        let (before, after) = super::advice::before_after(trace, syn, j, src);
        before.iter().zip(after).any(|(b, a)| (b - a).abs() > 1e-12)
    })
}

/// The suggestions kept, numbered: the best [`PER_CHUNK`] of each chunk, ranked by their re-run
/// (or, without one, each chunk's candidates at "more" by the points they change), then in
/// that order across chunks.
fn rank(
    execution: usize,
    flawed: &[Flawed],
    cands: Vec<Candidate>,
    trial: &Trial,
    trace: &crate::trace::Trace,
    domain: &crate::domain::Domain,
) -> Vec<Suggestion> {
    let before = match trial {
        Trial::Simulated { before, .. } => Some(before.rank()),
        Trial::NotRun { .. } => None,
    };
    let simulated = before.is_some();
    let mut kept: Vec<Candidate> = Vec::new();
    let mut by_chunk: Vec<Vec<Candidate>> = (0..flawed.len()).map(|_| Vec::new()).collect();
    for c in cands {
        if let Some(v) = by_chunk.get_mut(c.chunk) {
            v.push(c);
        }
    }
    for mut v in by_chunk {
        if simulated {
            // Only what the re-run showed to help: better than the run without it.
            v.retain(|c| c.after.is_some_and(|m| Some(m.rank()) < before));
            v.sort_by(|a, b| {
                let (x, y) = (a.after.map(|m| m.rank()), b.after.map(|m| m.rank()));
                x.partial_cmp(&y).unwrap_or(std::cmp::Ordering::Equal)
            });
        } else {
            v.retain(|c| c.rate.is_none_or(|r| r == "more"));
            // Stable: among equals, the operator set's order.
            v.sort_by_key(|c| std::cmp::Reverse(c.syn.points.len()));
        }
        kept.extend(v.into_iter().take(PER_CHUNK));
    }
    if simulated {
        kept.sort_by(|a, b| {
            let (x, y) = (a.after.map(|m| m.rank()), b.after.map(|m| m.rank()));
            x.partial_cmp(&y).unwrap_or(std::cmp::Ordering::Equal)
        });
    }
    kept.into_iter()
        .enumerate()
        .map(|(j, c)| Suggestion {
            number: j + 1,
            execution,
            chunk: flawed[c.chunk].chunk,
            flaws: flawed[c.chunk].flaws.clone(),
            points: c.syn.points.len(),
            preview: Points::of(trace, &c.syn, domain.dims(c.syn.advice.space)),
            invocation: c.invocation,
            operator: c.operator,
            rate: c.rate,
            after: c.after,
        })
        .collect()
}

impl fmt::Display for Measure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}, error {:.2}",
            if self.success { "succeeded" } else { "failed" },
            self.error
        )?;
        if let Some(h) = self.heading_error {
            write!(f, ", heading {h:.2} rad")?;
        }
        write!(f, ", length {:.2} m", self.length_m)
    }
}

/// `before -> after` of each measure.
fn compare(before: &Measure, after: &Measure) -> String {
    let word = |s: bool| if s { "succeeded" } else { "failed" };
    let mut out = if before.success == after.success {
        word(after.success).to_string()
    } else {
        format!("{} -> {}", word(before.success), word(after.success))
    };
    out.push_str(&format!(
        ", error {:.2} -> {:.2}",
        before.error, after.error
    ));
    if let (Some(b), Some(a)) = (before.heading_error, after.heading_error) {
        out.push_str(&format!(", heading {b:.2} -> {a:.2} rad"));
    }
    out.push_str(&format!(
        ", length {:.2} -> {:.2} m",
        before.length_m, after.length_m
    ));
    out
}

impl fmt::Display for Suggestions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.flawed.is_empty() {
            return write!(
                f,
                "execution {} ({}): no flaw of the task holds anywhere; nothing to suggest",
                self.execution, self.label
            );
        }
        write!(
            f,
            "execution {} ({}): flaws hold on {}",
            self.execution,
            self.label,
            self.flawed
                .iter()
                .map(|c| {
                    let cut = if c.held != c.chunk {
                        format!(" (of {})", c.held)
                    } else {
                        String::new()
                    };
                    format!("{}{cut} {}", c.chunk, c.flaws.join(", "))
                })
                .collect::<Vec<_>>()
                .join("; ")
        )?;
        if self.more_flawed > 0 {
            write!(f, "; {} later stretches not suggested on", self.more_flawed)?;
        }
        f.write_str("\n")?;
        match &self.trial {
            Trial::Simulated { before, .. } => writeln!(
                f,
                "the same start re-run with the same noise on a copy of the learner as it is now, without advice ({before}) and with each candidate; the ones that did better, best first:"
            )?,
            Trial::NotRun { why } => writeln!(
                f,
                "candidates without a re-run ({why}); for each chunk the first {PER_CHUNK} operators that change it, at \"more\" (`preview` shows what each adds):"
            )?,
        }
        if self.suggestions.is_empty() && self.no_better.is_empty() {
            writeln!(
                f,
                "  no operator of the task changes these chunks (their guards skip every point)"
            )?;
        }
        for s in &self.suggestions {
            let rate = s.rate.map_or(String::new(), |r| format!(", {r}"));
            write!(
                f,
                "  {}. select {} in {}, advise {}  [{}{rate}; {} points]",
                s.number,
                s.chunk,
                s.execution,
                s.invocation,
                s.flaws.join(", "),
                s.points
            )?;
            if let (Trial::Simulated { before, .. }, Some(after)) = (&self.trial, &s.after) {
                write!(f, "\n       {}", compare(before, after))?;
            }
            f.write_str("\n")?;
        }
        for c in &self.no_better {
            writeln!(
                f,
                "  on {c} no candidate did better in the re-run: look at it yourself (`select {c} in {}`, `preview OP`)",
                self.execution
            )?;
        }
        if self.not_rerun > 0 {
            let spent = if self.out_of_time {
                format!("the budget of {} s was spent", self.budget_s)
            } else {
                format!("at most {MAX_RERUNS} re-runs")
            };
            writeln!(
                f,
                "({} of {} candidates not re-run: {spent})",
                self.not_rerun, self.candidates
            )?;
        }
        if !self.suggestions.is_empty() {
            f.write_str("`accept K` gives suggestion K (as `select` then `advise`)")?;
        }
        Ok(())
    }
}
