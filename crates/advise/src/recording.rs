//! Recordings in and out. In: recorded teleoperation turned into demonstrations, from ROS 2 bags
//! ([`bag`], MCAP ones read by [`mcap_read`]) and plain CSV logs, through [`import`]. Out: a saved
//! dataset written for other tools, as MCAP for Foxglove and ROS 2 ([`mcap_export`]) and as a
//! LeRobot dataset ([`lerobot`]).
//!
//! A CSV log `time,x,y,theta,v,w` has one row per command, with the odometry pose at that time.
//! Each row (each paired command of a bag) becomes one point of a task that reads its goal from a
//! recording (positioning, or a declared task with a `recorded` clause): the observation the
//! task's declaration computes from the pose and the goal (read by `recorded` from the pose the
//! episode ends at, or given), the action `(v, w)`.
//! `split_gap_s` splits episodes at pauses longer than it. Messy logs: a row whose time equals the
//! previous row's is dropped and counted (a warning); a row going back in time, a non-finite
//! value, or a row of the wrong width is refused with the row and time.

pub mod bag;
pub mod lerobot;
pub mod lerobot_in;
pub mod mcap_export;
pub mod mcap_read;
pub mod parquet_demos;
pub mod parquet_guard;

use std::path::{Path, PathBuf};

use miette::Diagnostic;
use thiserror::Error;

use std::sync::Arc;

use crate::backend::BaseState;
use crate::domain::Domain;
use crate::program::task::TaskDef;
use crate::task::{Declared, Task, positioning_def};
use crate::trace::{Episode, Pose, Trace};

impl ImportOptions {
    /// One run of samples as a demonstration of the options' task (positioning by default).
    pub fn episode(&self, name: String, run: &[Sample]) -> Episode {
        match &self.task {
            Some(def) => {
                let pose_goal = self.goal.map(|g| vec![g.x_m, g.y_m, g.theta_rad]);
                let goal = self.goal_values.as_deref().or(pose_goal.as_deref());
                episode_for(def, name, run, goal)
            }
            None => episode(name, run, self.goal),
        }
    }
}

/// The farthest from its origin a recording's odometry may be, m: beyond it a pose is a damaged
/// message (1,000 km; `1e300` was written by a broken driver).
pub const MAX_POSITION_M: f64 = 1e6;
/// The largest command a recording may hold, m/s or rad/s: beyond it a command is a damaged
/// message (whatever the task's limits, which are checked too).
pub const MAX_COMMAND: f64 = 1e3;

/// Where a sample of a recording is, for a diagnostic, from the sample's time (s).
pub type Locate<'a> = &'a dyn Fn(f64) -> String;

impl ImportOptions {
    /// [`ImportOptions::episode`], held to the rule every path into a dataset holds
    /// ([`crate::trace::ValueFault`]): a sample beyond the physical bounds ([`MAX_POSITION_M`],
    /// [`MAX_COMMAND`]) or a point `load demos` would refuse is refused here, at `at(t)` of
    /// `path`, so an import never writes (nor a session keeps) what `load demos` refuses.
    pub fn checked_episode(
        &self,
        path: &Path,
        name: String,
        run: &[Sample],
        at: Locate<'_>,
    ) -> Result<Episode, ImportError> {
        check_samples(path, run, at)?;
        let episode = self.episode(name, run);
        let domain = match &self.task {
            Some(def) => def.domain.clone(),
            None => positioning_def().domain.clone(),
        };
        check_demonstration(path, &domain, &episode, run, at)?;
        Ok(episode)
    }
}

/// Refuse a sample whose pose or command is not finite or beyond the physical bounds.
pub fn check_samples(path: &Path, run: &[Sample], at: Locate<'_>) -> Result<(), ImportError> {
    run.iter()
        .try_for_each(|s| check_sample(path, s, || at(s.0)))
}

/// [`check_samples`] of one sample, located by `at`.
pub fn check_sample(
    path: &Path,
    &(_, pose, v, w): &Sample,
    at: impl Fn() -> String,
) -> Result<(), ImportError> {
    {
        let values = [
            ("odometry x", pose.x_m, MAX_POSITION_M, "m"),
            ("odometry y", pose.y_m, MAX_POSITION_M, "m"),
            ("odometry heading", pose.theta_rad, f64::INFINITY, "rad"),
            ("commanded speed", v, MAX_COMMAND, "m/s"),
            ("commanded turn rate", w, MAX_COMMAND, "rad/s"),
        ];
        for (what, value, bound, unit) in values {
            if !value.is_finite() {
                return Err(ImportError::NotFinite {
                    path: path.to_path_buf(),
                    at: at(),
                    what: what.into(),
                    value: value.to_string(),
                });
            }
            if value.abs() > bound {
                return Err(ImportError::Implausible {
                    path: path.to_path_buf(),
                    at: at(),
                    what: what.into(),
                    value: format!("{value:e} {unit}"),
                    bound: format!("{bound:e} {unit}"),
                });
            }
        }
    }
    Ok(())
}

/// Refuse a demonstration made from `run` (point `i` from sample `i`) whose point breaks the
/// demonstration rule ([`crate::trace::demo_value_fault`]).
pub fn check_demonstration(
    path: &Path,
    domain: &Domain,
    episode: &Episode,
    run: &[Sample],
    at: Locate<'_>,
) -> Result<(), ImportError> {
    use crate::domain::Space;
    use crate::trace::ValueFault;
    let Some((i, space, k, v, fault)) = crate::trace::demo_fault(domain, &episode.trace) else {
        return Ok(());
    };
    let at = at(run.get(i).map_or(episode.trace.t[i], |s| s.0));
    let dim = &domain.dims(space)[k];
    Err(match fault {
        ValueFault::NotFinite => ImportError::NotFinite {
            path: path.to_path_buf(),
            at,
            what: format!(
                "{} `{}` {}",
                space.word(),
                dim.name,
                if space == Space::Observation {
                    "the task computes there"
                } else {
                    "there"
                }
            ),
            value: v.to_string(),
        },
        ValueFault::OutsideLimits(l) => ImportError::OutOfLimits {
            path: path.to_path_buf(),
            at,
            dim: dim.name.clone(),
            value: crate::number::fmt_num(v),
            lo: crate::number::fmt_num(l.lo),
            hi: crate::number::fmt_num(l.hi),
        },
    })
}

/// How a log is turned into episodes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// The goal of every episode (positioning); `None`: each episode's final pose.
    pub goal: Option<Pose>,
    /// The task the demonstrations are for; `None`: positioning. Its `recorded` clause reads
    /// each episode's goal from where it ends.
    pub task: Option<Arc<TaskDef>>,
    /// The goal of every episode of a declared task, a value for each goal parameter (overrides
    /// `recorded`).
    pub goal_values: Option<Vec<f64>>,
    /// Split an episode where consecutive rows are more than this apart, s.
    pub split_gap_s: Option<f64>,
    /// A bag's command and odometry topics; `None`: [`bag::DEFAULT_CMD_TOPIC`] and
    /// [`bag::DEFAULT_ODOM_TOPIC`].
    pub cmd_topic: Option<String>,
    pub odom_topic: Option<String>,
    /// Keep the standing-still points before the first moving command and after the base came
    /// to rest ([`trim_idle`]); `false` (the default) trims them.
    pub keep_idle: bool,
}

/// A base that moved less than this from its final pose is standing still there, m and rad.
pub const STILL_M: f64 = 1e-3;
pub const STILL_RAD: f64 = 2e-3;

/// What [`trim_idle`] keeps of a run: `run[start..end]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Trim {
    pub start: usize,
    pub end: usize,
}

impl Trim {
    /// The points trimmed: before the first moving command, and after the base came to rest.
    pub fn dropped(&self, len: usize) -> (usize, usize) {
        (self.start, len - self.end)
    }
}

/// The part of `run` that demonstrates something: from the first moving command (the zero
/// commands before it are a teleop node publishing while nobody drives) to the last moving
/// command, then on while the base still moves, and the first sample where it stands still at
/// its final pose (so the demonstration ends at rest with the zero command, where the goal is
/// read). A run without a moving command is kept whole.
pub fn trim_idle(run: &[Sample]) -> Trim {
    let moving = |s: &Sample| s.2 != 0.0 || s.3 != 0.0;
    let (Some(first), Some(last)) = (run.iter().position(moving), run.iter().rposition(moving))
    else {
        return Trim {
            start: 0,
            end: run.len(),
        };
    };
    let end_pose = run[run.len() - 1].1;
    let still = |s: &Sample| {
        s.1.distance_to(end_pose) < STILL_M
            && crate::geometry::wrap_angle(s.1.theta_rad - end_pose.theta_rad).abs() < STILL_RAD
    };
    // The first sample of the final standing still after the last moving command.
    let mut rest = run.len();
    while rest > last + 1 && still(&run[rest - 1]) {
        rest -= 1;
    }
    Trim {
        start: first,
        end: (rest + 1).min(run.len()),
    }
}

/// `run` with its idle ends trimmed unless `keep`, adding the points dropped to `trimmed`.
pub fn trimmed<'a>(run: &'a [Sample], keep: bool, trimmed: &mut (usize, usize)) -> &'a [Sample] {
    if keep {
        return run;
    }
    let t = trim_idle(run);
    let (before, after) = t.dropped(run.len());
    trimmed.0 += before;
    trimmed.1 += after;
    &run[t.start..t.end]
}

/// The sentence that reports trimmed idle points, `None` when none was trimmed; `keep` names
/// the option that keeps them.
pub fn describe_trim((before, after): (usize, usize), keep: &str) -> Option<String> {
    (before + after > 0).then(|| {
        format!(
            "trimmed {} standing-still point{} ({before} before the first moving command, {after} after the base came to rest; {keep} keeps them)",
            before + after,
            if before + after == 1 { "" } else { "s" }
        )
    })
}

/// One sample of a recording: time (s), the base's pose, the commanded speed and turn rate.
pub type Sample = (f64, Pose, f64, f64);

/// Whether `path` is a recording [`import`] reads: a bag, or a CSV file whose first line is a
/// log's header (`time,x,y,theta,v,w`) rather than a demonstrations file's.
pub fn is_recording(path: &Path) -> bool {
    use std::io::Read;
    if bag::is_bag(path) {
        return true;
    }
    // Only a regular file is opened: opening a FIFO would block until a writer comes. Anything
    // else is left to the demonstrations reader, which refuses it with a diagnostic.
    let Ok((mut file, _)) = crate::files::open_regular(path, u64::MAX) else {
        return false;
    };
    let mut head = [0u8; 64];
    let Ok(n) = file.read(&mut head) else {
        return false;
    };
    let head = String::from_utf8_lossy(&head[..n]);
    let first = head
        .trim_start_matches('\u{feff}')
        .lines()
        .next()
        .unwrap_or("");
    first.replace(' ', "").trim_end() == COLUMNS.join(",")
}

/// Import a recording, a bag ([`bag::is_bag`]) or a CSV log, into positioning demonstrations and
/// the warnings its messy parts earned.
pub fn import(
    path: &Path,
    options: &ImportOptions,
) -> Result<(Vec<Episode>, Vec<String>), ImportError> {
    import_recording(path, options).map(|i| (i.episodes, i.warnings))
}

/// What [`import_recording`] made of a recording.
#[derive(Clone, Debug)]
pub struct Imported {
    pub episodes: Vec<Episode>,
    /// What the user should know about the messy parts.
    pub warnings: Vec<String>,
    /// A bag's command topic and the types its commands were read as (`geometry_msgs/msg/Twist`,
    /// `.../TwistStamped`); `None` for a CSV log.
    pub commands: Option<(String, Vec<String>)>,
    /// Standing-still points trimmed: before the first moving command, after the base came to
    /// rest ([`trim_idle`]).
    pub idle_trimmed: (usize, usize),
}

impl Imported {
    /// What was read and trimmed, in words (`keep` names the option that keeps idle points).
    pub fn notes(&self, keep: &str) -> Vec<String> {
        let mut notes = Vec::new();
        if let Some((topic, types)) = &self.commands {
            notes.push(format!(
                "commands read as {} on {topic}",
                types.join(" and ")
            ));
        }
        notes.extend(describe_trim(self.idle_trimmed, keep));
        notes
    }
}

/// [`import`], with what was read and trimmed.
pub fn import_recording(path: &Path, options: &ImportOptions) -> Result<Imported, ImportError> {
    if let Some(gap) = options.split_gap_s
        && !(gap.is_finite() && gap > 0.0)
    {
        return Err(ImportError::SplitGap(gap));
    }
    if bag::is_bag(path) {
        bag::import_bag(path, options).map(|(episodes, r)| Imported {
            warnings: r.warnings(),
            commands: Some((r.cmd_topic.clone(), r.command_types.clone())),
            idle_trimmed: r.idle_trimmed,
            episodes,
        })
    } else {
        import_csv_log(path, options).map(|(episodes, r)| Imported {
            warnings: r.warnings(),
            commands: None,
            idle_trimmed: r.idle_trimmed,
            episodes,
        })
    }
}

/// What an import found that it did not refuse: reported to the user as warnings.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ImportReport {
    /// Rows read.
    pub rows: usize,
    /// Rows dropped because their time repeated the previous row's.
    pub duplicate_times: usize,
    /// Episodes made.
    pub episodes: usize,
    /// Standing-still points trimmed, before and after ([`trim_idle`]).
    pub idle_trimmed: (usize, usize),
}

impl ImportReport {
    /// One line per thing the user should know about, empty when the log was clean.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.duplicate_times > 0 {
            w.push(format!(
                "dropped {} of {} rows whose time repeated the previous row's",
                self.duplicate_times, self.rows
            ));
        }
        w
    }
}

/// Why a recording could not be imported.
#[derive(Debug, Error, Diagnostic)]
pub enum ImportError {
    /// The log file itself: missing, not a regular file, too large, not UTF-8.
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error("{path} is a rosbag2 bag stored in SQLite, which `advise` does not read")]
    #[diagnostic(
        code(advise::import::sqlite_bag),
        help(
            "convert it to MCAP storage: `ros2 bag convert -i BAG -o out.yaml` with `storage_id: mcap` in out.yaml (or record with `ros2 bag record -s mcap`, the default since Iron)"
        )
    )]
    SqliteBag { path: PathBuf },
    #[error("{path} holds no `.mcap` file")]
    #[diagnostic(
        code(advise::import::no_mcap),
        help(
            "give a rosbag2 directory (its `metadata.yaml` and `.mcap` files) or an `.mcap` file"
        )
    )]
    NoMcap { path: PathBuf },
    #[error("{path} is not an MCAP file: {reason}")]
    #[diagnostic(
        code(advise::import::not_mcap),
        help("a bag's files are MCAP (`ros2 bag record -s mcap`); check that the file is whole")
    )]
    NotMcap { path: PathBuf, reason: String },
    #[error("{path} has no messages on {topic}")]
    #[diagnostic(
        code(advise::import::topic_missing),
        help(
            "the bag has {present}; name the topics with `advise import BAG --cmd-topic TOPIC --odom-topic TOPIC` (a session's `load demos BAG` reads /cmd_vel and /odom)"
        )
    )]
    TopicMissing {
        path: PathBuf,
        topic: String,
        present: String,
    },
    #[error("{path}: {topic} is {found}, not {expected}")]
    #[diagnostic(
        code(advise::import::wrong_type),
        help(
            "commands are read from a geometry_msgs Twist or TwistStamped topic and poses from a nav_msgs Odometry topic; name others with `--cmd-topic` and `--odom-topic`"
        )
    )]
    WrongType {
        path: PathBuf,
        topic: String,
        found: String,
        expected: &'static str,
    },
    #[error("{path}: the message on {topic} at log time {t_ns} ns does not decode: {reason}")]
    #[diagnostic(
        code(advise::import::bad_message),
        help("the bag is damaged, or its topic's type differs from its schema's name")
    )]
    BadMessage {
        path: PathBuf,
        topic: String,
        t_ns: u64,
        reason: String,
    },
    #[error(
        "{path}: the chunk at byte {offset} would decompress to {size} (from {compressed}), more than the {cap} a chunk may"
    )]
    #[diagnostic(
        code(advise::import::chunk_too_large),
        help(
            "nothing was decompressed; a bag's chunks are well under 1 MiB, so this is a damaged file or a decompression bomb. If the bag is genuine, keep only the topics the import reads: `mcap filter BAG -o small.mcap -y /cmd_vel -y /odom`"
        )
    )]
    ChunkTooLarge {
        path: PathBuf,
        offset: u64,
        size: String,
        compressed: String,
        cap: String,
    },
    #[error(
        "{path}: the chunk at byte {offset} would expand {compressed} into {size}, {ratio} times or more"
    )]
    #[diagnostic(
        code(advise::import::chunk_ratio),
        help(
            "nothing was decompressed; recorded messages compress a few dozen times at most, so this is a damaged file or a decompression bomb. If the bag is genuine, keep only the topics the import reads: `mcap filter BAG -o small.mcap -y /cmd_vel -y /odom`"
        )
    )]
    ChunkRatio {
        path: PathBuf,
        offset: u64,
        size: String,
        compressed: String,
        ratio: u64,
    },
    #[error(
        "{path}: its chunks decompress to more than {cap} in all (reached at the chunk at byte {offset})"
    )]
    #[diagnostic(
        code(advise::import::decompressed_too_large),
        help(
            "`advise` reads at most {cap} of messages from one bag; keep only the topics the import reads: `mcap filter BAG -o small.mcap -y /cmd_vel -y /odom`"
        )
    )]
    DecompressedTooLarge {
        path: PathBuf,
        offset: u64,
        cap: String,
    },
    #[error(
        "{path}: the chunk at byte {offset} decompresses to more than the {size} its header says"
    )]
    #[diagnostic(
        code(advise::import::chunk_size_lies),
        help(
            "reading stopped one byte past the declared size; the file is damaged or crafted, and was not imported"
        )
    )]
    ChunkSizeLies {
        path: PathBuf,
        offset: u64,
        size: String,
    },
    #[error(
        "{path}: none of its {commands} commands has odometry within {} s before it",
        bag::MAX_ODOMETRY_AGE_S
    )]
    #[diagnostic(
        code(advise::import::nothing_paired),
        help("check that the odometry topic was recorded while the base was driven")
    )]
    NothingPaired { path: PathBuf, commands: usize },

    #[error("{path}, {at}: the {what} is {value}, not a finite number")]
    #[diagnostic(
        code(advise::import::not_finite),
        help(
            "a demonstration holds finite numbers only, and `load demos` refuses NaN and infinity; the recording is damaged there: cut it before that time or repair the message"
        )
    )]
    NotFinite {
        path: PathBuf,
        at: String,
        what: String,
        value: String,
    },
    #[error(
        "{path}, {at}: the {what} is {value}, beyond the {bound} any recording of a base holds"
    )]
    #[diagnostic(
        code(advise::import::implausible),
        help(
            "no odometry is {MAX_POSITION_M:e} m from its origin and no base is commanded at {MAX_COMMAND:e} m/s or rad/s: the message is damaged; cut the recording before that time or repair it"
        )
    )]
    Implausible {
        path: PathBuf,
        at: String,
        what: String,
        value: String,
        bound: String,
    },
    #[error("{path}, {at}: the action `{dim}` is {value}, outside its limits [{lo}, {hi}]")]
    #[diagnostic(
        code(advise::import::action_out_of_limits),
        help(
            "a demonstration's actions are ones the robot can execute, and `load demos` refuses this one as it refuses it in a file: record within [{lo}, {hi}], or declare a task whose limits are this robot's (`tasks FILE`, then `task NAME`)"
        )
    )]
    OutOfLimits {
        path: PathBuf,
        at: String,
        dim: String,
        value: String,
        lo: String,
        hi: String,
    },
    #[error("cannot read {path}: {source}")]
    #[diagnostic(code(advise::import::read))]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path} is not a CSV log: {reason}")]
    #[diagnostic(
        code(advise::import::header),
        help("a log has the header `time,x,y,theta,v,w`")
    )]
    Header { path: PathBuf, reason: String },
    #[error("{path}, row {row}: {reason}")]
    #[diagnostic(code(advise::import::row))]
    Row {
        path: PathBuf,
        row: usize,
        reason: String,
    },
    #[error("{path}, row {row}: time {t} s is before the previous row's {prev} s")]
    #[diagnostic(
        code(advise::import::time_backwards),
        help("sort the log by time; rows are taken in the order they were recorded")
    )]
    TimeBackwards {
        path: PathBuf,
        row: usize,
        t: f64,
        prev: f64,
    },
    #[error("{path} has no rows")]
    #[diagnostic(code(advise::import::empty))]
    Empty { path: PathBuf },
    #[error("the split gap {0} s is not a positive number")]
    #[diagnostic(code(advise::import::split_gap))]
    SplitGap(f64),
}

const COLUMNS: [&str; 6] = ["time", "x", "y", "theta", "v", "w"];

/// Import a CSV log file into positioning episodes named `<file stem>` (or `<stem>.<k>` when
/// split).
pub fn import_csv_log(
    path: &Path,
    options: &ImportOptions,
) -> Result<(Vec<Episode>, ImportReport), ImportError> {
    let text = crate::files::read_text(path)?;
    let stem = path.file_stem().map_or_else(
        || "recording".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    parse_csv_log(path, &stem, &text, options)
}

/// [`import_csv_log`] on text already read.
pub fn parse_csv_log(
    path: &Path,
    stem: &str,
    text: &str,
    options: &ImportOptions,
) -> Result<(Vec<Episode>, ImportReport), ImportError> {
    if let Some(gap) = options.split_gap_s
        && !(gap.is_finite() && gap > 0.0)
    {
        return Err(ImportError::SplitGap(gap));
    }
    let path_buf = || path.to_path_buf();
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.as_bytes());
    let header = reader.headers().map_err(|e| ImportError::Header {
        path: path_buf(),
        reason: e.to_string(),
    })?;
    let names: Vec<&str> = header.iter().collect();
    if names != COLUMNS {
        return Err(ImportError::Header {
            path: path_buf(),
            reason: format!("the header is `{}`", names.join(",")),
        });
    }
    let mut report = ImportReport::default();
    // Rows of the current run: (t, pose, v, w).
    let mut runs: Vec<Vec<Sample>> = vec![Vec::new()];
    let mut prev: Option<f64> = None;
    for (i, record) in reader.records().enumerate() {
        let row = i + 2;
        let bad = |reason: String| ImportError::Row {
            path: path_buf(),
            row,
            reason,
        };
        let record = record.map_err(|e| bad(e.to_string()))?;
        if record.len() != COLUMNS.len() {
            return Err(bad(format!(
                "{} fields, the header has {}",
                record.len(),
                COLUMNS.len()
            )));
        }
        let mut v = [0.0; 6];
        for (k, field) in record.iter().enumerate() {
            let x: f64 = field.parse().map_err(|_| {
                bad(format!(
                    "`{field}` in column {} is not a number",
                    COLUMNS[k]
                ))
            })?;
            if !x.is_finite() {
                return Err(bad(format!(
                    "{} is {field}, not a finite number",
                    COLUMNS[k]
                )));
            }
            v[k] = x;
        }
        report.rows += 1;
        let t = v[0];
        if let Some(p) = prev {
            if t < p {
                return Err(ImportError::TimeBackwards {
                    path: path_buf(),
                    row,
                    t,
                    prev: p,
                });
            }
            if t == p {
                report.duplicate_times += 1;
                continue;
            }
            if options.split_gap_s.is_some_and(|gap| t - p > gap) {
                runs.push(Vec::new());
            }
        }
        prev = Some(t);
        if let Some(run) = runs.last_mut() {
            run.push((t, Pose::new(v[1], v[2], v[3]), v[4], v[5]));
        }
    }
    if report.rows == 0 {
        return Err(ImportError::Empty { path: path_buf() });
    }
    let split = runs.len() > 1;
    let episodes: Vec<Episode> = runs
        .iter()
        .enumerate()
        .map(|(k, run)| {
            let name = if split {
                format!("{stem}.{}", k + 1)
            } else {
                stem.to_string()
            };
            let run = trimmed(run, options.keep_idle, &mut report.idle_trimmed);
            options.checked_episode(path, name, run, &|t: f64| format!("the row at time {t}"))
        })
        .collect::<Result<_, _>>()?;
    report.episodes = episodes.len();
    Ok((episodes, report))
}

/// One positioning demonstration from samples `(t, pose, v, w)`: times from the first sample,
/// observations of each pose towards `goal` (the last pose when `None`), the commanded speeds as
/// actions. What a CSV log's run and a recorded teleoperation become.
pub fn episode(name: String, run: &[Sample], goal: Option<Pose>) -> Episode {
    let goal = goal.map(|g| vec![g.x_m, g.y_m, g.theta_rad]);
    episode_for(&positioning_def(), name, run, goal.as_deref())
}

/// One demonstration of the declared task `def` from samples `(t, pose, v, w)`: the task's
/// observations computed along the samples exactly as a run computes them (`prev` reads the
/// sample before), towards `goal` or, when `None`, the goal its `recorded` clause reads from
/// the last pose (all zeros for a task without one). The commanded speeds are the actions (a task
/// whose actions are changes of speed is not importable this way; the caller checks) and stand
/// in for the measured speeds `v` and `w`, which a log does not hold.
pub fn episode_for(
    def: &Arc<TaskDef>,
    name: String,
    run: &[Sample],
    goal: Option<&[f64]>,
) -> Episode {
    let goal: Vec<f64> = match goal {
        Some(g) => g.to_vec(),
        None => run
            .last()
            .and_then(|r| crate::task::declared::recorded_goal(def, r.1))
            .unwrap_or_else(|| vec![0.0; def.goal.len()]),
    };
    let domain = &def.domain;
    let mut task = Declared::new(def.clone(), &goal);
    let t0 = run.first().map_or(0.0, |r| r.0);
    let mut trace = Trace::new(domain);
    let mut z = vec![0.0; domain.obs_dim()];
    let mut a = vec![0.0; domain.act_dim()];
    let state = |t: f64, pose: Pose, v: f64, w: f64| BaseState {
        t_s: t - t0,
        pose,
        speed_mps: v,
        rot_radps: w,
    };
    if let Some(&(t, pose, v, w)) = run.first() {
        task.begin(&state(t, pose, v, w));
    }
    for &(t, pose, v, w) in run {
        let s = state(t, pose, v, w);
        task.observe(&s, &mut z);
        // The speeds by axis, in the domain's action order.
        a.iter_mut().for_each(|x| *x = 0.0);
        if let Some(d) = &def.speed {
            a[d.action] = v;
        }
        if let Some(d) = &def.turn {
            a[d.action] = w;
        }
        trace.push(t - t0, &z, &a, Some(pose));
        task.command(&s, &a);
    }
    Episode { name, trace }
}

/// Write `episodes` as a demonstration file `load demos FILE` reads: JSON when `path` ends in
/// `.json`, CSV with an `episode` column otherwise.
pub fn write_demonstrations(
    path: &Path,
    domain: &Domain,
    episodes: &[Episode],
) -> Result<(), ImportError> {
    let write_err = |source| ImportError::Read {
        path: path.to_path_buf(),
        source,
    };
    // The backstop of the rule: an import writes nothing `load demos` refuses (a point at
    // least, finite times that increase within each demonstration, finite values, actions
    // within limits).
    if episodes.iter().all(|e| e.trace.is_empty()) {
        return Err(ImportError::Empty {
            path: path.to_path_buf(),
        });
    }
    for e in episodes {
        let t = &e.trace.t;
        if let Some(i) = t.iter().position(|t| !t.is_finite()) {
            return Err(ImportError::NotFinite {
                path: path.to_path_buf(),
                at: format!("demonstration `{}`, point {i}", e.name),
                what: "time".into(),
                value: t[i].to_string(),
            });
        }
        if let Some(i) = (1..t.len()).find(|&i| t[i] <= t[i - 1]) {
            return Err(ImportError::TimeBackwards {
                path: path.to_path_buf(),
                row: i,
                t: t[i],
                prev: t[i - 1],
            });
        }
        check_demonstration(path, domain, e, &[], &|t: f64| {
            format!("demonstration `{}` at {t} s", e.name)
        })?;
    }
    let is_json = path.extension().is_some_and(|e| e == "json");
    let bytes = if is_json {
        serde_json::to_vec_pretty(&Episode::to_json(domain, episodes))
            .map_err(|e| write_err(std::io::Error::other(e)))?
    } else {
        let mut buf = Vec::new();
        Episode::write_csv(domain, episodes, &mut buf).map_err(write_err)?;
        buf
    };
    Ok(crate::files::write_bytes(path, &bytes)?)
}
