//! The session's files: loading demonstrations, a trace or operators; saving, opening and
//! exporting the dataset.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use super::effect::{DemoEpisode, DemoSpan, Effect, ExecutionEntry};
use super::text::warnings_text;
use super::{Session, SessionError};
use crate::policy::learner::LearnerError;
use crate::task;
use crate::trace::Trace;

impl Session {
    /// Note a file a command read, so that no output replaces it.
    fn read_input(&mut self, path: &str, opened: bool) {
        let p = Path::new(path).to_path_buf();
        if !self.inputs.iter().any(|(q, o)| *q == p && *o == opened) {
            self.inputs.push((p, opened));
        }
    }

    /// Refuse an output that is a file the session read (the same file or a link to it): `export
    /// mcap x.json` after `open x.json` replaced the dataset on disk. `save` may replace the file
    /// `open` read: saving back is what it is for.
    pub(super) fn check_output(&self, path: &str, save: bool) -> Result<(), SessionError> {
        let inputs = self
            .inputs
            .iter()
            .filter(|(_, opened)| !(save && *opened))
            .map(|(p, _)| p.as_path());
        Ok(crate::files::refuse_overwriting_inputs(
            Path::new(path),
            inputs,
        )?)
    }

    /// `teacher:N` records N demonstrations by the task's teacher in the simulator; anything else
    /// is a demonstrations file.
    /// `options` name a bag's topics; a topic given for a file that is not a bag is refused.
    pub(super) fn load_demos(
        &mut self,
        path: &str,
        options: &crate::recording::ImportOptions,
    ) -> Result<String, SessionError> {
        let started = Instant::now();
        let mut from_dataset = String::new();
        // A stop raised while the demonstrations are recorded or read (Ctrl-C) ends the
        // statement before its effect: one raised before it began is not this statement's.
        self.stop.clear();
        let episodes = match path.strip_prefix("teacher:") {
            Some(n) => {
                // A file's topics are checked where it is read (`read_demos_file`).
                topics_only_for_a_bag(path, options)?;
                let count: usize = n
                    .parse()
                    .ok()
                    .filter(|c| (1..=10_000).contains(c))
                    .ok_or_else(|| SessionError::Io {
                        path: path.to_string(),
                        source: std::io::Error::new(
                            std::io::ErrorKind::InvalidInput,
                            "`teacher:N` takes a count from 1 to 10000",
                        ),
                    })?;
                let params = self.sim_params();
                // A distinct stream from the practice starts the teacher's runs use.
                let recorded =
                    task::record_demos(self.task.clone(), count, self.seed ^ 0xD3E0, &params);
                task::finite_demos(&self.task, &recorded)?;
                recorded.into_iter().map(|(e, _)| e).collect()
            }
            None => {
                let read = read_demos_file(
                    &mut self.sources,
                    &self.ops,
                    &self.domain,
                    self.task.def().as_ref(),
                    path,
                    options,
                )?;
                from_dataset = read.said;
                for note in read.notes {
                    from_dataset.push_str(&format!("\n{note}"));
                }
                read.episodes
            }
        };
        if !path.starts_with("teacher:") {
            self.read_input(path, false);
        }
        if self.stop.is_raised() {
            self.stop.clear();
            return Err(SessionError::Stopped {
                statement: format!("load demos {path}"),
            });
        }
        let points: usize = episodes.iter().map(|e| e.trace.len()).sum();
        let count = episodes.len();
        // A file's points are added without a copy when a journal line needs none of them: with
        // a journal (the sidecar holds them), or in a session that will never keep one.
        let no_copy = self.journal.is_some() || self.preamble.is_none();
        if no_copy && !path.starts_with("teacher:") {
            self.commit_demos_file(path, episodes)?;
        } else {
            self.commit(Effect::Demos {
                source: path.to_string(),
                episodes: episodes
                    .into_iter()
                    .map(|e| DemoEpisode {
                        name: e.name,
                        trace: e.trace.to_json(),
                    })
                    .collect(),
            })?;
        }
        // Warnings (a recording's) go after the sentence, each on its line.
        let (said, warned) = match from_dataset.find('\n') {
            Some(i) => from_dataset.split_at(i),
            None => (from_dataset.as_str(), ""),
        };
        let demonstrations = if count == 1 {
            "1 demonstration".to_string()
        } else {
            format!("{count} demonstrations")
        };
        Ok(format!(
            "loaded {demonstrations} ({points} points) from {path}{said}; the {} policy now has {} points ({} ms){warned}",
            self.state.learner.kind_name(),
            self.state.learner.len(),
            started.elapsed().as_millis()
        ))
    }

    /// A file's demonstrations in a journalled session: added (what applying their effect
    /// does), their points written once into a sidecar beside the journal, and a journal line
    /// that names it ([`Effect::DemosFile`]) instead of copying every point.
    fn commit_demos_file(
        &mut self,
        path: &str,
        episodes: Vec<crate::trace::Episode>,
    ) -> Result<(), SessionError> {
        let before = self.state.learner.len();
        let spans: Vec<DemoSpan> = episodes
            .iter()
            .map(|e| {
                let times = crate::policy::dataset::DemoTimes::of(&e.trace.t);
                let (period_s, times_s) = crate::policy::dataset::DemoTimes::fields(times);
                DemoSpan {
                    name: e.name.clone(),
                    points: e.trace.len() as u64,
                    period_s,
                    times_s,
                }
            })
            .collect();
        self.state.learner.add_demonstrations_owned(episodes)?;
        let Some(j) = &self.journal else {
            return Ok(());
        };
        let journal_path = j.path().to_path_buf();
        let dir = journal_path.parent().unwrap_or(Path::new("."));
        let (od, ad) = (self.domain.obs_dim(), self.domain.act_dim());
        let pts = self.state.learner.dataset().points();
        let rows = (&pts.z[before * od..], &pts.a[before * ad..]);
        let added = self.state.learner.len() - before;
        match super::sidecar::write(dir, rows, (od, ad), added) {
            Ok(sidecar) => self.journal_effect(Effect::DemosFile {
                source: path.to_string(),
                sidecar,
                episodes: spans,
            }),
            Err(source) => {
                self.journal = None;
                Err(SessionError::Journal {
                    path: journal_path.display().to_string(),
                    source,
                })
            }
        }
    }

    pub(super) fn load_trace(&mut self, path: &str) -> Result<String, SessionError> {
        let trace = Trace::load(&mut self.sources, &self.domain, Path::new(path))?;
        self.read_input(path, false);
        let n = trace.len();
        self.commit(Effect::Execution(Box::new(ExecutionEntry {
            label: path.to_string(),
            trace: trace.to_json(),
            goal: None,
            goal_values: None,
            run: None,
        })))?;
        Ok(format!(
            "loaded execution {} from {path}: {n} points",
            self.state.executions.len() - 1
        ))
    }

    /// `tasks FILE`: the file is checked and added as `operators FILE` does; the reply names
    /// its tasks. A file that declares none is refused before anything changes.
    pub(super) fn load_tasks(&mut self, path: &str) -> Result<String, SessionError> {
        let id = crate::files::read_source(&mut self.sources, Path::new(path))?;
        let text = self.sources.text(id).to_string();
        let before = self.declared_task_names();
        let checked = self.ops.merge_in(&self.sources, &[id])?;
        let new: Vec<std::sync::Arc<crate::program::task::TaskDef>> = checked
            .set
            .tasks()
            .iter()
            .filter(|t| !before.iter().any(|b| b == t.name()))
            .cloned()
            .collect();
        if new.is_empty() {
            return Err(SessionError::NoTasksInFile {
                path: path.to_string(),
            });
        }
        self.read_input(path, false);
        self.commit(Effect::Define {
            origin: path.to_string(),
            text,
            file: absolute(path),
        })?;
        let described: Vec<String> = new
            .iter()
            .map(|t| {
                let goal: Vec<&str> = t.goal.iter().map(|g| g.name.as_str()).collect();
                format!(
                    "`{}` (goal {}; {} observations, {} actions; {})",
                    t.name(),
                    if goal.is_empty() {
                        "none".into()
                    } else {
                        goal.join(", ")
                    },
                    t.domain.obs_dim(),
                    t.domain.act_dim(),
                    if t.teacher.is_some() {
                        "a teacher"
                    } else {
                        "no teacher"
                    }
                )
            })
            .collect();
        let warnings = warnings_text(&self.sources, &std::mem::take(&mut self.warnings));
        Ok(format!(
            "checked {path}: task{} {}; switch with `task {}`",
            if new.len() == 1 { "" } else { "s" },
            described.join(", "),
            new[0].name()
        ) + &warnings)
    }

    pub(super) fn load_operators(&mut self, path: &str) -> Result<String, SessionError> {
        let id = crate::files::read_source(&mut self.sources, Path::new(path))?;
        let text = self.sources.text(id).to_string();
        let before = self.ops.operator_count();
        self.commit(Effect::Define {
            origin: path.to_string(),
            text,
            file: absolute(path),
        })?;
        self.read_input(path, false);
        let warnings = warnings_text(&self.sources, &std::mem::take(&mut self.warnings));
        Ok(format!(
            "checked {path}: {} operators now ({} for {})",
            self.ops.operator_count(),
            self.ops.operator_names(&self.domain.name).len(),
            self.domain.name
        ) + &if self.ops.operator_count() == before {
            " (the file replaced existing operators)".to_string()
        } else {
            String::new()
        } + &warnings)
    }

    pub(super) fn save(&self, path: &str) -> Result<String, SessionError> {
        self.check_output(path, true)?;
        let format = self.state.learner.save(Path::new(path))?;
        Ok(format!(
            "saved {} points to {path} ({})",
            self.state.learner.len(),
            format.describe()
        ))
    }

    pub(super) fn open(&mut self, path: &str) -> Result<String, SessionError> {
        // Validated whole before anything changes; the journal keeps the dataset itself.
        let learner = self
            .task
            .open_learner(&mut self.sources, Path::new(path), self.seed)?;
        let dataset = learner.dataset().to_json_string();
        let dropped = self.dropped_by_open();
        let restored = self.adopt_opened(learner, path)?;
        // Applied above without deriving the policy twice; `apply` does the same on restore.
        self.journal_effect(Effect::Open {
            path: path.to_string(),
            dataset,
        })?;
        self.read_input(path, true);
        let mut reply = format!("opened {path}: {} points", self.state.learner.len());
        if let Some(said) = restored.said() {
            let _ = write!(reply, "; {said}");
        }
        if !dropped.is_empty() {
            let _ = write!(
                reply,
                "\nreplaced this task's {} (the journal keeps them: `advise resume`)",
                dropped.join(", ")
            );
        }
        if let Some(lost) = restored.not_restored() {
            let _ = write!(reply, "\nwarning: {lost}");
        }
        Ok(reply)
    }

    /// Put an opened dataset in place of this task's work and bring back what the file holds of
    /// the session besides its points: every execution advice or critique could refer to (each
    /// run is kept in the dataset) and the history of edits (each piece of advice and critique
    /// still in it, in the order made, so `history`, `why`, `show` and `undo` find them). The
    /// live `open` and a journal's `open` line both come here, so a resumed session restores the
    /// same numbering.
    /// A saved execution's goal as the session's task holds it: positioning's pose, or a declared
    /// task's values; held to the rules a run's goal is held to. Nothing for a file without one
    /// (a loaded trace, or a file written before goals were kept) or for interception.
    fn opened_goal(
        &self,
        goal: Option<&[f64]>,
    ) -> Result<(Option<crate::trace::Pose>, Option<Vec<f64>>), SessionError> {
        let Some(values) = goal else {
            return Ok((None, None));
        };
        match &self.task {
            task::TaskKind::Positioning => match *values {
                [x, y, theta] => {
                    super::run::check_goal(x, y, theta)?;
                    Ok((Some(crate::trace::Pose::new(x, y, theta)), None))
                }
                _ => Err(SessionError::BadGoal {
                    goal: values
                        .iter()
                        .take(8)
                        .map(|v| crate::number::fmt_num(*v))
                        .collect::<Vec<_>>()
                        .join(", "),
                }),
            },
            task::TaskKind::Declared(_) => {
                super::run::check_goal_values(&self.task, values)?;
                Ok((None, Some(values.to_vec())))
            }
            task::TaskKind::Interception => Ok((None, None)),
        }
    }

    pub(super) fn adopt_opened(
        &mut self,
        learner: crate::policy::learner::Learner,
        path: &str,
    ) -> Result<Restored, SessionError> {
        // Everything is built and checked from the opened dataset before the session's state is
        // touched: a failed open changes nothing (issue 47).
        let ds = learner.dataset();
        let mut executions = Vec::new();
        for (i, rec) in ds.executions().iter().enumerate() {
            let (goal, goal_values) = self.opened_goal(rec.goal.as_deref())?;
            executions.push(super::HeldExecution {
                label: format!("{path} execution {i}"),
                trace: ds.execution(rec.id).map_err(LearnerError::from)?,
                goal,
                goal_values,
                execution: None,
                support: None,
                id: rec.id,
                run_number: None,
                flagged: Vec::new(),
                advised: Vec::new(),
                teacher: Vec::new(),
            });
        }
        let index_of = |id| ds.execution_number(id).unwrap_or(usize::MAX);
        // Advice and critiques share one id counter, so id order is the order they were made.
        let mut edits: Vec<super::undo::Edit> = Vec::new();
        for r in ds.advice() {
            let execution = index_of(r.execution);
            let Some(held) = executions.get_mut(execution) else {
                continue;
            };
            held.advised.push(r.applied.chunk);
            edits.push(super::undo::Edit::Advice {
                number: 0,
                id: r.id,
                execution,
                syn: Box::new(advice_points(ds, r, &held.trace)),
            });
        }
        for r in ds.critiques() {
            let execution = index_of(r.execution);
            let Some(held) = executions.get_mut(execution) else {
                continue;
            };
            held.flagged.push(r.critique.chunk);
            edits.push(super::undo::Edit::Critique {
                number: 0,
                id: r.id,
                execution,
                critique: r.critique.clone(),
            });
        }
        // A takeover's demonstration is an edit too (`undo` takes it back), when its run is here.
        for d in ds.demos() {
            let Some(link) = d.takeover else { continue };
            let execution = index_of(link.execution);
            let Some(held) = executions.get_mut(execution) else {
                continue;
            };
            held.teacher.push(link.steps);
            let mut trace = crate::trace::Trace::new(ds.domain());
            let times = crate::policy::dataset::DemoTimes::trace_times(
                d.times().as_ref(),
                d.points as usize,
            );
            for k in 0..d.points {
                let p = crate::policy::dataset::Provenance::Demonstration {
                    demo: d.id,
                    index: k,
                };
                if let Some(i) = ds.position(p) {
                    trace.push(times[k as usize], ds.z(i), ds.a(i), None);
                }
            }
            edits.push(super::undo::Edit::Takeover {
                number: 0,
                id: d.id,
                taken: Box::new(super::undo::Taken {
                    execution,
                    steps: link.steps,
                    every: link.every,
                    name: d.name.clone(),
                    trace,
                }),
            });
        }
        edits.sort_by_key(|e| e.id());
        for (i, e) in edits.iter_mut().enumerate() {
            e.renumber(i + 1);
        }
        self.take_learner(learner);
        let st = &mut self.state;
        st.runs = executions.len() as u64;
        st.current = executions.len().checked_sub(1);
        st.executions = executions;
        st.next_edit = edits.len() + 1;
        st.undo = edits;
        Ok(Restored {
            executions: st.executions.len(),
            edits: st.undo.len(),
        })
    }

    /// What `open` replaces of the current task's work, counted for its reply: the file's points,
    /// executions and history take their place.
    fn dropped_by_open(&self) -> Vec<String> {
        let st = &self.state;
        let count = |n: usize, one: &str, many: &str| match n {
            1 => format!("1 {one}"),
            n => format!("{n} {many}"),
        };
        let mut out = Vec::new();
        if !st.executions.is_empty() {
            out.push(count(st.executions.len(), "execution", "executions"));
        }
        if st.selection.is_some() {
            out.push("the selection".to_string());
        }
        if !st.undo.is_empty() {
            let first = st.undo.iter().map(|e| e.number()).min().unwrap_or(0);
            let last = st.undo.iter().map(|e| e.number()).max().unwrap_or(0);
            let numbers = if first == last {
                format!("#{first}")
            } else {
                format!("#{first}-#{last}")
            };
            out.push(format!(
                "{} ({numbers})",
                count(st.undo.len(), "edit of the history", "edits of the history")
            ));
        }
        if !st.redo.is_empty() {
            out.push(count(
                st.redo.len(),
                "undone edit `redo` could put back",
                "undone edits `redo` could put back",
            ));
        }
        if st.last_eval.is_some() {
            out.push("the last evaluation".to_string());
        }
        out
    }

    pub(super) fn export_mcap(&self, path: &str) -> Result<String, SessionError> {
        self.check_output(path, false)?;
        // The timeline in the session's wall-clock time, demonstrations at the task's rate.
        let options = crate::recording::mcap_export::McapOptions {
            period_s: self.sim_params().period_s(),
            ..crate::recording::mcap_export::McapOptions::starting_at(self.started)
        };
        let s = crate::recording::mcap_export::export_mcap(
            self.state.learner.dataset(),
            Path::new(path),
            &options,
        )?;
        Ok(crate::recording::mcap_export::describe(&s, path))
    }

    pub(super) fn export_lerobot(&self, dir: &str) -> Result<String, SessionError> {
        self.check_output(dir, false)?;
        use crate::recording::lerobot;
        // The task's rate for demonstrations without times; every other source at its own.
        let fps = self.sim_params().rate_hz.round().clamp(1.0, 1000.0) as u32;
        let parts = lerobot::export_lerobot(self.state.learner.dataset(), Path::new(dir), fps)?;
        Ok(lerobot::describe_parts(&parts, dir))
    }

    pub(super) fn export_advice(&self, path: &str) -> Result<String, SessionError> {
        self.check_output(path, false)?;
        let n = self.state.learner.export_advice(Path::new(path))?;
        Ok(format!(
            "wrote {n} advised points with their provenance to {path}"
        ))
    }
}

/// What `open` brought back of a saved session besides its points, for its reply.
pub(super) struct Restored {
    executions: usize,
    edits: usize,
}

impl Restored {
    fn said(&self) -> Option<String> {
        let count = |n: usize, one: &str, many: &str| match n {
            1 => format!("1 {one}"),
            n => format!("{n} {many}"),
        };
        let mut parts = Vec::new();
        if self.executions > 0 {
            parts.push(count(self.executions, "execution", "executions"));
        }
        if self.edits > 0 {
            parts.push(format!(
                "{} (#1-#{}: `history` lists them, `undo` takes them back)",
                count(self.edits, "edit of the history", "edits of the history"),
                self.edits
            ));
        }
        (!parts.is_empty()).then(|| format!("restored {}", parts.join(" and ")))
    }

    /// What a dataset file of a session (one with executions) cannot give back, said whenever
    /// it brought some back, so nothing is dropped silently. A file of demonstrations only was
    /// never a session's: nothing of one is missing.
    fn not_restored(&self) -> Option<String> {
        (self.executions > 0).then(|| {
            "a dataset file does not hold a run's label and outcome (the executions are \
             named by the file; `critique` needs a run made in this session, which knows what \
             recommended each step), the selection, undone edits or the last evaluation: they \
             were not restored"
                .to_string()
        })
    }
}

/// Advice `r`'s synthesized points as the dataset holds them, in order, with the time and pose
/// of the execution point each came from: what `redo` adds back after an `undo`.
fn advice_points(
    ds: &crate::policy::dataset::Dataset,
    r: &crate::policy::dataset::AdviceRecord,
    execution: &Trace,
) -> crate::interp::Synthesized {
    use crate::policy::dataset::Provenance;
    let mut found: Vec<(u32, u32, usize)> = (0..ds.len())
        .filter_map(|i| match ds.provenance(i) {
            Provenance::Advice {
                advice,
                index,
                source,
            } if advice == r.id => Some((index, source, i)),
            _ => None,
        })
        .collect();
    found.sort_unstable();
    let mut points = Trace::new(ds.domain());
    let mut source_index = Vec::with_capacity(found.len());
    for (_, source, i) in found {
        let s = source as usize;
        let t = execution.t.get(s).copied().unwrap_or(0.0);
        let pose = execution.pose.as_ref().and_then(|p| p.get(s).copied());
        points.push(t, ds.z(i), ds.a(i), pose);
        source_index.push(s);
    }
    crate::interp::Synthesized {
        points,
        source_index,
        advice: r.applied.clone(),
    }
}

/// What [`read_demos_file`] read.
#[derive(Debug)]
pub struct DemosFile {
    pub episodes: Vec<crate::trace::Episode>,
    /// What `load demos` says of the file after its path (`: a saved dataset's ...`), or empty.
    pub said: String,
    /// A recording's warnings (`warning: ...`) and what was trimmed of it, a line each.
    pub notes: Vec<String>,
}

/// The demonstrations of the file `path` for `domain`, read as `load demos FILE` reads them,
/// whatever the file: a ROS 2 bag or a CSV log of a base's drive (made into demonstrations of
/// `task`, which must read its goal from where a recording ends, as `advise import` does, idle
/// points trimmed unless `options.keep_idle`), a Parquet file of demonstrations, or a CSV or JSON
/// demonstrations file or a saved dataset. `options` name a bag's topics; a topic given for a
/// file that is not a bag is refused. A progress bar shows on a terminal while a large file is
/// read. The session and the Python package (`advise.load_demos`, `fit_file`) both read with it.
pub fn read_demos_file(
    sources: &mut crate::diag::SourceMap,
    ops: &crate::check::OperatorSet,
    domain: &crate::domain::Domain,
    task: Option<&std::sync::Arc<crate::program::task::TaskDef>>,
    path: &str,
    options: &crate::recording::ImportOptions,
) -> Result<DemosFile, SessionError> {
    let recording = Path::new(path);
    topics_only_for_a_bag(path, options)?;
    let mut read = DemosFile {
        episodes: Vec::new(),
        said: String::new(),
        notes: Vec::new(),
    };
    if crate::recording::is_recording(recording) {
        // A task whose actions are the speeds commanded and which reads its goal from where a
        // recording ends.
        let def = task.filter(|d| {
            d.recorded.is_some()
                && [&d.speed, &d.turn]
                    .iter()
                    .all(|x| x.as_ref().is_none_or(|x| x.integrate.is_none()))
        });
        let Some(def) = def else {
            return Err(SessionError::RecordingNeedsPositioning {
                path: path.to_string(),
            });
        };
        let options = crate::recording::ImportOptions {
            task: Some(def.clone()),
            ..options.clone()
        };
        let imported = crate::recording::import_recording(recording, &options)?;
        read.notes = imported
            .warnings
            .iter()
            .map(|w| format!("warning: {w}"))
            .collect();
        // Idle points are trimmed as `advise import` trims them (its `--keep-idle` keeps them):
        // the same demonstrations either way.
        read.notes.extend(crate::recording::describe_trim(
            imported.idle_trimmed,
            "`advise import --keep-idle`",
        ));
        read.episodes = imported.episodes;
    } else if crate::recording::parquet_demos::is_parquet(recording) {
        let mut bar = Progress::rows();
        let episodes = crate::recording::parquet_demos::read_demos(
            domain,
            recording,
            crate::policy::dataset::MAX_STREAM_POINTS,
            &mut |done, total| bar.show(done, total),
        );
        bar.done();
        read.episodes = episodes?;
    } else {
        let mut bar = Progress::default();
        let demos = crate::policy::dataset::load_demonstrations_with(
            sources,
            domain,
            recording,
            &mut |done, total| bar.show(done, total),
        );
        bar.done();
        let demos = demos.map_err(|e| match recorded_for_another_task(ops, domain, path) {
            Some(found) => SessionError::DemosOfAnotherTask {
                path: path.to_string(),
                found,
                task: domain.name.clone(),
            },
            None => LearnerError::from(e).into(),
        })?;
        if let Some((d, a)) = demos.from_dataset {
            read.said = format!(
                ": a saved dataset's {d} demonstration{} and {a} piece{} of advice, each as one demonstration (critique weights are not carried)",
                if d == 1 { "" } else { "s" },
                if a == 1 { "" } else { "s" },
            );
        }
        read.episodes = demos.episodes;
    }
    Ok(read)
}

/// The task another domain's demonstrations file was recorded for: the session's domain
/// (a declared task's or a paper's) whose every observation and action is a column of the
/// file's header (its first line, read to at most 64 KiB), the one with the most columns
/// when several fit. `None` for a file that is not such a CSV.
fn recorded_for_another_task(
    ops: &crate::check::OperatorSet,
    domain: &crate::domain::Domain,
    path: &str,
) -> Option<String> {
    use std::io::{BufRead as _, Read as _};
    // A regular file only (the one check): opening a FIFO would wait for a writer.
    let (file, _) = crate::files::open_regular(Path::new(path), u64::MAX).ok()?;
    let mut header = String::new();
    std::io::BufReader::new(file.take(64 * 1024))
        .read_line(&mut header)
        .ok()?;
    let columns: Vec<&str> = header.trim_end().split(',').map(str::trim).collect();
    ops.domains()
        .iter()
        .filter(|d| d.name != domain.name && !d.act.is_empty())
        .filter(|d| {
            d.observe
                .iter()
                .chain(&d.act)
                .all(|dim| columns.contains(&dim.name.as_str()))
        })
        .max_by_key(|d| d.observe.len() + d.act.len())
        .map(|d| d.name.clone())
}

/// `options` name a bag's topics only for a bag.
fn topics_only_for_a_bag(
    path: &str,
    options: &crate::recording::ImportOptions,
) -> Result<(), SessionError> {
    if (options.cmd_topic.is_some() || options.odom_topic.is_some())
        && !crate::recording::bag::is_bag(Path::new(path))
    {
        return Err(SessionError::TopicsNeedABag {
            path: path.to_string(),
        });
    }
    Ok(())
}

/// A progress bar for a large demonstrations file read in a stream ([`crate::progress`]: drawn
/// where the front end draws, never into a reply), from the first report on.
#[derive(Default)]
struct Progress {
    bar: Option<Box<dyn crate::progress::Bar>>,
    /// Counted in rows (a Parquet file), not bytes.
    rows: bool,
}

impl Progress {
    fn rows() -> Progress {
        Progress {
            bar: None,
            rows: true,
        }
    }

    fn show(&mut self, done: u64, total: u64) {
        use crate::progress::{Unit, bar};
        let unit = if self.rows { Unit::Rows } else { Unit::Bytes };
        self.bar
            .get_or_insert_with(|| bar(true, total, unit, "reading demonstrations"))
            .set_position(done);
    }

    fn done(self) {
        if let Some(bar) = self.bar {
            bar.finish();
        }
    }
}

/// `path` made absolute (without resolving links), for a journal that may be resumed elsewhere.
fn absolute(path: &str) -> Option<String> {
    std::path::absolute(path)
        .ok()
        .map(|p| p.display().to_string())
}
