//! The journal and the effects: starting a journal, restoring a session from one, and
//! committing an [`Effect`](super::effect::Effect) (applied to the state, appended to the journal).

use std::path::{Path, PathBuf};

use super::effect::{Effect, Entry, Header};
use super::journal::Journal;
use super::text::first_chars;
use super::undo::Edit;
use super::{HeldExecution, Restored, Session, SessionError, TaskState, effect, journal};
use crate::interp::Synthesized;
use crate::policy::dataset::{Critique, Dataset};
use crate::policy::learner::{Learner, LearnerError};
use crate::task::Execution;
use crate::trace::{Chunk, Episode, Trace, TraceError};

impl Session {
    /// The header a journal of this session starts with.
    pub fn journal_header(&self) -> Header {
        Header {
            format: effect::JOURNAL_FORMAT.into(),
            task: self.started_on.clone(),
            seed: self.seed,
            sim: self.sim_params(),
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            pid: std::process::id(),
        }
    }

    /// Start journalling into a new journal in `dir`. What the session already holds (the
    /// starting demonstrations) is written first, so the journal alone restores it.
    pub fn start_journal(&mut self, dir: &Path) -> Result<PathBuf, journal::JournalError> {
        let mut j = Journal::create_in(dir, &self.journal_header())?;
        for entry in self.preamble.take().unwrap_or_default() {
            j.append(&entry)
                .map_err(|source| journal::JournalError::Create {
                    path: j.path().display().to_string(),
                    source,
                })?;
        }
        let path = j.path().to_path_buf();
        self.journal = Some(j);
        Ok(path)
    }

    /// Restore a journalled session: every effect is applied as it was recorded, held to the
    /// rules a live statement is held to; nothing is re-run, no file but the journal is read, and
    /// no robot is connected or driven. The session then journals into the same file (or, if a
    /// line was damaged or refused, a fresh one in `dir`). A journal another session holds is
    /// refused before anything is read.
    pub fn restore(path: &Path, dir: &Path) -> Result<Restored, SessionError> {
        let mut held = Journal::continue_at(path)?;
        let loaded = journal::read(path)?;
        let h = &loaded.header;
        // A header edited by hand is held to the simulator's ranges like any parameters file.
        h.sim.validate()?;
        let mut s = Session::empty(h.task.clone(), h.seed, h.sim.clone());
        s.restoring = true;
        let mut notes = Vec::new();
        // The first line not restored: damaged (unreadable), or refused by a rule.
        let mut stop: Option<(usize, Result<String, SessionError>)> = loaded
            .damaged
            .clone()
            .map(|(line, message)| (line, Ok(message)));
        let mut restored = 0;
        let journal_dir = path.parent().unwrap_or(Path::new("."));
        for (line, entry) in &loaded.entries {
            let applied = match &entry.effect {
                Effect::DemosFile {
                    sidecar, episodes, ..
                } => s.apply_demos_file(journal_dir, sidecar, episodes),
                effect => s.apply(effect),
            };
            if let Err(e) = applied {
                stop = Some((*line, Err(e)));
                break;
            }
            if let Effect::Define {
                file: Some(file),
                text,
                ..
            } = &entry.effect
                && let Some(note) = changed_since(file, text)
            {
                notes.push(note);
            }
            restored += 1;
        }
        s.restoring = false;
        if let Some(cut) = &loaded.cut {
            notes.push(format!(
                "the last statement was cut off by the crash and is dropped ({} bytes: {})",
                cut.len(),
                first_chars(cut, 60)
            ));
        }
        let journal_error = |path: &Path, source| SessionError::Journal {
            path: path.display().to_string(),
            source,
        };
        let (journal, stopped) = match stop {
            None => {
                held.cut_to(loaded.good_len)
                    .map_err(|e| journal_error(path, e))?;
                (held, None)
            }
            Some((line, why)) => {
                drop(held);
                let mut j = Journal::create_in(dir, h)?;
                let new_dir = j.path().parent().unwrap_or(Path::new(".")).to_path_buf();
                for (_, entry) in loaded.entries.iter().take(restored) {
                    // The new journal refers to the same sidecars: beside it too.
                    if let Effect::DemosFile { sidecar, .. } = &entry.effect {
                        super::sidecar::carry(journal_dir, &new_dir, sidecar)
                            .map_err(|e| journal_error(j.path(), e))?;
                    }
                    j.append(entry).map_err(|e| journal_error(j.path(), e))?;
                }
                notes.push(format!(
                    "this session continues in a new journal: {}",
                    j.path().display()
                ));
                let shown = path.display().to_string();
                let stopped = match why {
                    Ok(message) => journal::Stopped::Damaged {
                        path: shown,
                        line,
                        before: line - 1,
                        message,
                    },
                    Err(cause) => journal::Stopped::at(
                        shown,
                        line,
                        loaded
                            .entries
                            .get(restored)
                            .map_or_else(String::new, |(_, e)| first_chars(&e.statement, 80)),
                        cause,
                    ),
                };
                (j, Some(stopped))
            }
        };
        if let Some(spec) = s.restored_backend.as_deref().filter(|b| *b != "sim") {
            notes.push(format!(
                "the session was on `{spec}`; it is on `sim` now, and nothing was driven: `backend {spec}` connects again"
            ));
        }
        let journal_path = journal.path().to_path_buf();
        s.journal = Some(journal);
        Ok(Restored {
            session: s,
            entries: restored,
            stopped,
            notes,
            journal: journal_path,
        })
    }

    /// Apply `effect` and journal it. The one way a command changes the session.
    pub(super) fn commit(&mut self, effect: Effect) -> Result<(), SessionError> {
        self.apply(&effect)?;
        self.journal_effect(effect)
    }

    pub(super) fn journal_effect(&mut self, effect: Effect) -> Result<(), SessionError> {
        let (statement, origin) = self
            .statement
            .clone()
            .unwrap_or_else(|| (String::new(), String::new()));
        let entry = Entry {
            statement,
            origin,
            effect,
        };
        let Some(j) = &mut self.journal else {
            if let Some(preamble) = &mut self.preamble {
                preamble.push(entry);
            }
            return Ok(());
        };
        if let Err(source) = j.append(&entry) {
            let path = j.path().display().to_string();
            self.journal = None;
            return Err(SessionError::Journal { path, source });
        }
        Ok(())
    }

    /// Make the change an effect describes. Reads no file and drives no robot: a journal is
    /// restored by calling this on each of its effects.
    pub(super) fn apply(&mut self, effect: &Effect) -> Result<(), SessionError> {
        match effect {
            Effect::Define { origin, text, .. } => {
                let id = self.sources.add(origin.as_str(), text.as_str());
                // A task it declares gets the standard operators by role.
                let checked = self.ops.merge_declaring(&mut self.sources, &[id])?;
                self.ops = checked.set;
                self.warnings = checked.warnings;
            }
            Effect::Task { task } => {
                let task = self.resolve_task(task)?;
                self.switch_task(task)
            }
            Effect::Backend { spec } => {
                if self.restoring {
                    self.restored_backend = Some(spec.clone());
                }
            }
            Effect::Demos { episodes, .. } => {
                let episodes = episodes
                    .iter()
                    .map(|e| {
                        Ok(Episode {
                            name: e.name.clone(),
                            trace: Trace::from_json(&self.domain, &e.trace)?,
                        })
                    })
                    .collect::<Result<Vec<_>, TraceError>>()?;
                self.state.learner.add_demonstrations(&episodes)?;
            }
            Effect::DemosFile { .. } => {
                // Only a restore meets one (it reads the sidecar: `apply_demos_file`); a live
                // `load demos` applies its episodes before journalling the line.
                return Err(SessionError::Journal {
                    path: String::new(),
                    source: std::io::Error::other("a sidecar line is applied by a restore"),
                });
            }
            Effect::Execution(entry) => self.apply_execution(entry)?,
            Effect::Select { execution, chunk } => {
                let rec = self.numbered(*execution)?;
                let chunk = Chunk::new(chunk.start, chunk.end, rec.trace.len())?;
                self.state.current = Some(*execution);
                self.state.selection = Some(chunk);
            }
            Effect::Advice {
                execution,
                applied,
                points,
                source_index,
            } => {
                let syn = Synthesized {
                    points: Trace::from_json(&self.domain, points)?,
                    source_index: source_index.clone(),
                    advice: applied.clone(),
                };
                let number = self.state.take_number();
                self.add_advice(*execution, Box::new(syn), number)?;
                self.state.redo.clear();
            }
            Effect::Takeover {
                execution,
                steps,
                every,
                name,
                points,
            } => self.apply_takeover(*execution, *steps, *every, name, points)?,
            Effect::Critique {
                execution,
                critique,
            } => {
                super::advice::check_kappa(critique.kappa)?;
                let number = self.state.take_number();
                self.add_critique(*execution, critique.clone(), number)?;
                self.state.redo.clear();
            }
            Effect::Undo => self.undo_edit()?,
            Effect::Redo => self.redo_edit()?,
            Effect::Rederive => {
                self.state.learner.rederive();
            }
            Effect::Learner { learner, k } => {
                self.state.learner.set_kind(*learner);
                self.state.learner.set_lwr_k(*k);
                self.state.learner.rederive();
            }
            Effect::Evaluated { report } => {
                self.state.prev_eval = self.state.last_eval.replace((**report).clone());
            }
            Effect::Open { path, dataset } => {
                let ds = self
                    .sources
                    .scratch(path.as_str(), dataset.as_str(), Dataset::parse)
                    .map_err(LearnerError::from)?;
                // The rule a live `open` applies: another task's dataset is refused.
                let learner = self.task.adopt_dataset(ds, self.seed)?;
                self.adopt_opened(learner, path)?;
            }
        }
        Ok(())
    }

    /// Hold an execution as journalled (a run's, with what it measured, or a loaded trace's),
    /// checked whole before anything changes.
    fn apply_execution(&mut self, entry: &effect::ExecutionEntry) -> Result<(), SessionError> {
        let trace = Trace::from_json(&self.domain, &entry.trace)?;
        if let Some(g) = &entry.goal {
            super::run::check_goal(g.x_m, g.y_m, g.theta_rad)?;
        }
        if let Some(values) = &entry.goal_values {
            super::run::check_goal_values(&self.task, values)?;
        }
        // Everything is checked before anything changes.
        let runs = match &entry.run {
            Some(run) => Some(
                run.number
                    .checked_add(1)
                    .ok_or(SessionError::RunNumber { number: run.number })?,
            ),
            None => None,
        };
        if let Some(run) = &entry.run {
            super::takeover::check_windows(&run.teacher, trace.len())?;
        }
        let id = self.state.learner.try_add_execution(&trace)?;
        // The dataset keeps the goal too, so that `open` gives the run back with it.
        let goal = entry
            .goal
            .map(|g| vec![g.x_m, g.y_m, g.theta_rad])
            .or_else(|| entry.goal_values.clone());
        if let Some(goal) = goal {
            self.state.learner.set_execution_goal(id, goal)?;
        }
        let (execution, support) = match &entry.run {
            Some(run) => {
                self.state.runs = runs.unwrap_or(self.state.runs);
                (
                    Some(Execution {
                        trace: trace.clone(),
                        true_poses: run.true_poses.clone(),
                        ball: run.ball.clone(),
                        outcome: run.outcome.clone(),
                    }),
                    Some(run.support.clone()),
                )
            }
            None => (None, None),
        };
        let st = &mut self.state;
        st.executions.push(HeldExecution {
            label: entry.label.clone(),
            trace,
            goal: entry.goal,
            goal_values: entry.goal_values.clone(),
            execution,
            support,
            id,
            run_number: entry.run.as_ref().map(|r| r.number),
            flagged: Vec::new(),
            advised: Vec::new(),
            teacher: entry
                .run
                .as_ref()
                .map(|r| r.teacher.clone())
                .unwrap_or_default(),
        });
        st.current = Some(st.executions.len() - 1);
        st.selection = None;
        Ok(())
    }

    /// Restore a [`Effect::DemosFile`] line: read its sidecar beside the journal (in
    /// `journal_dir`), checked whole before anything changes, and add its demonstrations as a
    /// live `load demos` does, under the same rules.
    pub(super) fn apply_demos_file(
        &mut self,
        journal_dir: &Path,
        sidecar: &super::sidecar::SidecarRef,
        spans: &[effect::DemoSpan],
    ) -> Result<(), SessionError> {
        let (od, ad) = (self.domain.obs_dim(), self.domain.act_dim());
        let total = spans.iter().try_fold(0u64, |t, s| t.checked_add(s.points));
        if total != Some(sidecar.points) {
            return Err(super::sidecar::SidecarError::Altered {
                path: sidecar.file.clone(),
                what: format!(
                    "the line's demonstrations hold {} points; it names a file of {}",
                    total.map_or_else(|| "too many".to_string(), |t| t.to_string()),
                    sidecar.points
                ),
            }
            .into());
        }
        let (z, a) = super::sidecar::read(journal_dir, sidecar, od, ad)?;
        let mut episodes = Vec::with_capacity(spans.len());
        let mut first = 0;
        for span in spans {
            let n = span.points as usize;
            let times = crate::policy::dataset::DemoTimes::from_fields(
                span.period_s,
                span.times_s.as_ref().filter(|t| t.len() == n),
            );
            let t = crate::policy::dataset::DemoTimes::trace_times(times.as_ref(), n);
            let mut trace = Trace::new(&self.domain);
            for i in first..first + n {
                trace.push(
                    t[i - first],
                    &z[i * od..(i + 1) * od],
                    &a[i * ad..(i + 1) * ad],
                    None,
                );
            }
            first += n;
            episodes.push(Episode {
                name: span.name.clone(),
                trace,
            });
        }
        drop((z, a));
        self.state.learner.add_demonstrations_owned(episodes)?;
        Ok(())
    }

    /// Work on `learner`'s dataset from now on, with no executions or history (`open` then
    /// brings back the file's: [`Session::adopt_opened`]).
    pub(super) fn take_learner(&mut self, learner: Learner) {
        self.domain = learner.domain().clone();
        self.state = TaskState::with_learner(learner);
    }

    pub(super) fn add_advice(
        &mut self,
        execution: usize,
        syn: Box<Synthesized>,
        number: usize,
    ) -> Result<(), SessionError> {
        let rec = self.numbered(execution)?;
        let conflict = super::conflict::find(
            &self.state.learner,
            &self.state.undo,
            &syn,
            &rec.trace,
            execution,
            number,
        );
        let id = self.state.learner.add_advice(rec.id, &syn)?;
        let st = &mut self.state;
        st.conflicts.retain(|c| c.number != number);
        st.conflicts.extend(conflict);
        st.executions[execution].advised.push(syn.advice.chunk);
        st.undo.push(Edit::Advice {
            number,
            id,
            execution,
            syn,
        });
        Ok(())
    }

    pub(super) fn add_critique(
        &mut self,
        execution: usize,
        critique: Critique,
        number: usize,
    ) -> Result<(), SessionError> {
        let rec = self.numbered(execution)?;
        let id = self.state.learner.add_critique(rec.id, critique.clone())?;
        let st = &mut self.state;
        st.executions[execution].flagged.push(critique.chunk);
        st.undo.push(Edit::Critique {
            number,
            id,
            execution,
            critique,
        });
        Ok(())
    }
}

/// What to say of a file a `tasks FILE` or `operators FILE` entry read, if it no longer holds the
/// text the journal holds: the restore keeps the journalled text (what the session's data was
/// made under), and the teacher learns the file moved on.
fn changed_since(file: &str, journalled: &str) -> Option<String> {
    // A file of another length has changed; only one of the same length is read to compare.
    let same_len = std::fs::metadata(file).map(|m| m.len() == journalled.len() as u64);
    match same_len.and_then(|same| {
        if same {
            std::fs::read_to_string(file).map(|now| now == journalled)
        } else {
            Ok(false)
        }
    }) {
        Ok(true) => None,
        Ok(_) => Some(format!(
            "`{file}` has changed since the session read it: restored with the text the journal holds (a new session reads the file as it is now)"
        )),
        Err(e) => Some(format!(
            "`{file}` cannot be read now ({e}): restored with the text the journal holds"
        )),
    }
}
