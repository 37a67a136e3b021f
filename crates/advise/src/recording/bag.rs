//! ROS 2 bags in: a rosbag2 directory (`metadata.yaml` and its `.mcap` files) or one `.mcap`
//! file, read record by record ([`super::mcap_read`]: zstd and lz4 chunks, each decompressed within
//! bounds) and decoded from CDR with the message
//! types the ROS 2 backend speaks ([`crate::backend::ros2::msg`]).
//!
//! Commands come from a `geometry_msgs/msg/Twist` (or `TwistStamped`) topic, poses from a
//! `nav_msgs/msg/Odometry` topic. Times are the bag's log times (when the recorder received each
//! message: one clock for both topics, whatever the senders' clocks say). Each command becomes one
//! sample paired with the latest odometry at or before it. The messy cases, each counted in the
//! [`BagReport`] and reported as a warning, never silently:
//! - messages out of time order in the file (several files, or a recorder's reordering): sorted;
//! - two messages of one topic at the same time: the later one in the file is kept;
//! - commands before the first odometry: dropped;
//! - commands whose latest odometry is older than [`MAX_ODOMETRY_AGE_S`] (odometry lost for a
//!   while): dropped, and the longest such gap named;
//! - a file that ends early (a recorder killed mid-write): the messages before the damage kept.
//!
//! Refused, with the file, topic and time: a topic missing (the bag's topics and types listed), a
//! topic of another type, a message that does not decode, a bag stored in SQLite.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use byteorder::{BigEndian, LittleEndian};
use serde::de::DeserializeOwned;

use super::mcap_read::Channel;
use super::{ImportError, ImportOptions, Sample};
use crate::backend::ros2::msg::{Odometry, Twist, TwistStamped};
use crate::trace::{Episode, Pose};

/// Odometry older than this before a command does not say where the base was, s.
pub const MAX_ODOMETRY_AGE_S: f64 = 0.5;

/// The topics read when none are given.
pub const DEFAULT_CMD_TOPIC: &str = "/cmd_vel";
pub const DEFAULT_ODOM_TOPIC: &str = "/odom";

/// What an import of a bag found and did not refuse.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BagReport {
    /// Command and odometry messages read.
    pub commands: usize,
    pub odometry: usize,
    /// Messages that came after a later one of their topic in the files, and were sorted.
    pub out_of_order: usize,
    /// Messages dropped because another of their topic had the same time.
    pub duplicate_times: usize,
    /// Commands dropped because no odometry had arrived yet.
    pub before_odometry: usize,
    /// Commands dropped because the latest odometry was too old, and the longest such age (s)
    /// with the bag time (s from its start) where it ended.
    pub stale_odometry: usize,
    pub longest_odometry_gap: Option<(f64, f64)>,
    /// A file that ended early: its name, the reader's words, and the messages kept from it.
    pub truncated: Vec<(PathBuf, String)>,
    /// Episodes made.
    pub episodes: usize,
    /// The command topic and the types its commands were read as (`geometry_msgs/msg/Twist`).
    pub cmd_topic: String,
    pub command_types: Vec<String>,
    /// Standing-still points trimmed, before and after ([`super::trim_idle`]).
    pub idle_trimmed: (usize, usize),
}

impl BagReport {
    /// One line per thing the user should know about, empty when the bag was clean.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.out_of_order > 0 {
            w.push(format!(
                "{} were out of time order in the file and were sorted by their log time",
                messages(self.out_of_order)
            ));
        }
        if self.duplicate_times > 0 {
            w.push(format!(
                "dropped {} whose topic had another at the same time (kept the later one)",
                messages(self.duplicate_times)
            ));
        }
        if self.before_odometry > 0 {
            w.push(format!(
                "dropped {} of {} commands sent before the first odometry",
                self.before_odometry, self.commands
            ));
        }
        if self.stale_odometry > 0 {
            let gap = self
                .longest_odometry_gap
                .map(|(age, at)| {
                    format!("; the longest gap was {age:.2} s, ending {at:.2} s into the bag")
                })
                .unwrap_or_default();
            w.push(format!(
                "dropped {} of {} commands whose latest odometry was more than {MAX_ODOMETRY_AGE_S} s old{gap}",
                self.stale_odometry, self.commands
            ));
        }
        for (file, why) in &self.truncated {
            w.push(format!(
                "{} ends early ({why}); kept the messages before it",
                file.display()
            ));
        }
        w
    }
}

fn messages(n: usize) -> String {
    if n == 1 {
        "1 message".into()
    } else {
        format!("{n} messages")
    }
}

use super::mcap_read::MAX_BAG_FILE_BYTES;

/// Whether `path` names a bag rather than a CSV log: a directory, or a `.mcap` or `.db3` file.
pub fn is_bag(path: &Path) -> bool {
    path.is_dir()
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap") || e.eq_ignore_ascii_case("db3"))
}

/// The MCAP files of a bag, in recording order.
fn bag_files(path: &Path) -> Result<Vec<PathBuf>, ImportError> {
    let sqlite = |path: &Path| ImportError::SqliteBag {
        path: path.to_path_buf(),
    };
    if !path.is_dir() {
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("db3"))
        {
            return Err(sqlite(path));
        }
        return Ok(vec![path.to_path_buf()]);
    }
    let read_err = |source| ImportError::Read {
        path: path.to_path_buf(),
        source,
    };
    let metadata = path.join("metadata.yaml");
    if let Ok(text) = crate::files::read_text_limited(&metadata, 1024 * 1024)
        && text
            .lines()
            .any(|l| l.trim() == "storage_identifier: sqlite3")
    {
        return Err(sqlite(path));
    }
    let mut files = Vec::new();
    let mut db3 = false;
    for entry in std::fs::read_dir(path).map_err(read_err)? {
        let p = entry.map_err(read_err)?.path();
        match p.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("mcap") => files.push(p),
            Some(e) if e.eq_ignore_ascii_case("db3") => db3 = true,
            _ => {}
        }
    }
    if files.is_empty() {
        return Err(if db3 {
            sqlite(path)
        } else {
            ImportError::NoMcap {
                path: path.to_path_buf(),
            }
        });
    }
    // rosbag2 numbers its files `NAME_0.mcap`, `NAME_1.mcap`, ...: in numeric order.
    files.sort_by_key(|p| {
        let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned());
        let n = stem
            .as_deref()
            .and_then(|s| s.rsplit('_').next())
            .and_then(|n| n.parse::<u64>().ok());
        (n, p.clone())
    });
    Ok(files)
}

/// A topic's role in the import.
#[derive(Clone, Copy, PartialEq)]
enum Role {
    Twist,
    TwistStamped,
    Odometry,
}

/// One message of a topic: its log time (ns) and file order.
struct Timed<T> {
    t_ns: u64,
    value: T,
}

/// The topic name as the bag writes it: with its leading slash.
fn absolute(topic: &str) -> String {
    if topic.starts_with('/') {
        topic.to_string()
    } else {
        format!("/{topic}")
    }
}

/// Decode a CDR message (its 4-byte encapsulation header says the byte order).
fn decode<T: DeserializeOwned>(data: &[u8]) -> Result<T, String> {
    let Some((head, body)) = data.split_at_checked(4) else {
        return Err(format!("{} bytes, shorter than the CDR header", data.len()));
    };
    let r = match head[1] {
        0x01 | 0x03 => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        0x00 | 0x02 => cdr_encoding::from_bytes::<T, BigEndian>(body),
        other => return Err(format!("unknown CDR encapsulation {other:#04x}")),
    };
    r.map(|(v, _)| v).map_err(|e| e.to_string())
}

/// The role of a channel with schema `name`, for the topic the user asked for as `want`.
fn role_of(schema: &str, want: Role) -> Option<Role> {
    let bare = schema.replace("/msg/", "/");
    match (bare.as_str(), want) {
        ("geometry_msgs/Twist", Role::Twist) => Some(Role::Twist),
        ("geometry_msgs/TwistStamped", Role::Twist) => Some(Role::TwistStamped),
        ("nav_msgs/Odometry", Role::Odometry) => Some(Role::Odometry),
        _ => None,
    }
}

/// A message's place in a bag, for a diagnostic.
fn located(channel: &Channel, t_ns: u64) -> String {
    format!("the message on {} at log time {t_ns} ns", channel.topic)
}

/// Refuse a command that is not finite or beyond the physical bound, where it is in the bag (a
/// command the pairing would drop is refused too: the bag is damaged there).
fn check_command(
    file: &Path,
    channel: &Channel,
    t_ns: u64,
    (v, w): (f64, f64),
) -> Result<(), ImportError> {
    let sample = (0.0, Pose::new(0.0, 0.0, 0.0), v, w);
    super::check_sample(file, &sample, || located(channel, t_ns))
}

/// The role of a channel seen for the first time (`None`: a topic the import does not read),
/// recorded in `topics` for the diagnostic of a missing one; a read topic of the wrong type or
/// encoding is refused.
fn channel_role(
    file: &Path,
    channel: &Channel,
    cmd_topic: &str,
    odom_topic: &str,
    topics: &mut Vec<(String, String)>,
) -> Result<Option<Role>, ImportError> {
    let schema = channel.schema.clone();
    if !topics.iter().any(|(t, _)| *t == channel.topic) {
        topics.push((channel.topic.clone(), schema.clone()));
    }
    let want = if channel.topic == cmd_topic {
        Role::Twist
    } else if channel.topic == odom_topic {
        Role::Odometry
    } else {
        return Ok(None);
    };
    let Some(role) = role_of(&schema, want) else {
        return Err(ImportError::WrongType {
            path: file.to_path_buf(),
            topic: channel.topic.clone(),
            found: schema,
            expected: match want {
                Role::Odometry => "nav_msgs/msg/Odometry",
                _ => "geometry_msgs/msg/Twist or TwistStamped",
            },
        });
    };
    if channel.message_encoding != "cdr" {
        return Err(ImportError::WrongType {
            path: file.to_path_buf(),
            topic: channel.topic.clone(),
            found: format!("{schema} in {} encoding", channel.message_encoding),
            expected: "ROS 2 messages in CDR encoding",
        });
    }
    Ok(Some(role))
}

/// Import a bag (a rosbag2 directory or an `.mcap` file) into positioning demonstrations named
/// after it (`NAME.k` when split).
pub fn import_bag(
    path: &Path,
    options: &ImportOptions,
) -> Result<(Vec<Episode>, BagReport), ImportError> {
    let cmd_topic = absolute(options.cmd_topic.as_deref().unwrap_or(DEFAULT_CMD_TOPIC));
    let odom_topic = absolute(options.odom_topic.as_deref().unwrap_or(DEFAULT_ODOM_TOPIC));
    let mut report = BagReport {
        cmd_topic: cmd_topic.clone(),
        ..BagReport::default()
    };
    let mut commands: Vec<Timed<(f64, f64)>> = Vec::new();
    let mut odometry: Vec<Timed<Pose>> = Vec::new();
    // Every topic seen, with its type, for the diagnostic of a missing one.
    let mut topics: Vec<(String, String)> = Vec::new();
    let mut budget = super::mcap_read::Budget::default();
    for file in bag_files(path)? {
        // Bounded, and a FIFO or device named `x.mcap` is refused without being opened.
        let bytes = crate::files::read_bytes_limited(&file, MAX_BAG_FILE_BYTES)?;
        let mut roles: HashMap<u16, Option<Role>> = HashMap::new();
        let mut on_message =
            |id: u16, channel: &Channel, t_ns: u64, data: &[u8]| -> Result<(), ImportError> {
                let role = match roles.get(&id) {
                    Some(r) => *r,
                    None => {
                        let role =
                            channel_role(&file, channel, &cmd_topic, &odom_topic, &mut topics)?;
                        roles.insert(id, role);
                        role
                    }
                };
                let Some(role) = role else {
                    return Ok(());
                };
                if role != Role::Odometry && !report.command_types.contains(&channel.schema) {
                    report.command_types.push(channel.schema.clone());
                }
                let bad = |reason: String| ImportError::BadMessage {
                    path: file.clone(),
                    topic: channel.topic.clone(),
                    t_ns,
                    reason,
                };
                match role {
                    Role::Twist => {
                        let m: Twist = decode(data).map_err(bad)?;
                        let value = (m.linear.x, m.angular.z);
                        check_command(&file, channel, t_ns, value)?;
                        commands.push(Timed { t_ns, value });
                    }
                    Role::TwistStamped => {
                        let m: TwistStamped = decode(data).map_err(bad)?;
                        let value = (m.twist.linear.x, m.twist.angular.z);
                        check_command(&file, channel, t_ns, value)?;
                        commands.push(Timed { t_ns, value });
                    }
                    Role::Odometry => {
                        let m: Odometry = decode(data).map_err(bad)?;
                        let pose = m.planar_pose();
                        let sample = (0.0, pose, 0.0, 0.0);
                        super::check_sample(&file, &sample, || located(channel, t_ns))?;
                        odometry.push(Timed { t_ns, value: pose });
                    }
                }
                Ok(())
            };
        let read = super::mcap_read::read_messages(
            &file,
            &bytes,
            &super::mcap_read::Bounds::DEFAULT,
            &mut budget,
            &mut on_message,
        )?;
        if let super::mcap_read::Read::Damaged(why) = read {
            // A file of a directory is named; a bag that is one file, the warning's.
            let shown = match path.is_dir() {
                true => file.file_name().map_or(file.clone(), PathBuf::from),
                false => PathBuf::from("the file"),
            };
            report.truncated.push((shown, why));
        }
    }
    for (topic, found) in [(&cmd_topic, commands.len()), (&odom_topic, odometry.len())] {
        if found == 0 {
            return Err(ImportError::TopicMissing {
                path: path.to_path_buf(),
                topic: topic.clone(),
                present: if topics.is_empty() {
                    "no messages at all".into()
                } else {
                    topics
                        .iter()
                        .map(|(t, s)| format!("{t} ({s})"))
                        .collect::<Vec<_>>()
                        .join(", ")
                },
            });
        }
    }
    report.commands = commands.len();
    report.odometry = odometry.len();
    report.out_of_order = sort_and_dedup(&mut commands, &mut report.duplicate_times)
        + sort_and_dedup(&mut odometry, &mut report.duplicate_times);
    // Gaps are reported from the bag's start, as a viewer shows its time.
    let t0 = commands[0].t_ns.min(odometry[0].t_ns);
    let samples = pair(&commands, &odometry, t0, &mut report);
    let stem = path
        .file_stem()
        .or_else(|| path.file_name())
        .map_or_else(|| "bag".to_string(), |s| s.to_string_lossy().into_owned());
    let runs = split(&samples, options.split_gap_s);
    if runs.iter().all(|r| r.is_empty()) {
        return Err(ImportError::NothingPaired {
            path: path.to_path_buf(),
            commands: report.commands,
        });
    }
    let split = runs.len() > 1;
    let episodes: Vec<Episode> = runs
        .iter()
        .enumerate()
        .map(|(k, run)| {
            let name = if split {
                format!("{stem}.{}", k + 1)
            } else {
                stem.clone()
            };
            let at = |t: f64| format!("the command on {cmd_topic} at log time {t:.6} s");
            let run = super::trimmed(run, options.keep_idle, &mut report.idle_trimmed);
            options.checked_episode(path, name, run, &at)
        })
        .collect::<Result<_, _>>()?;
    report.episodes = episodes.len();
    Ok((episodes, report))
}

/// Sort by time (stable: file order breaks ties) and keep the last of equal times; the number of
/// messages that were out of order, duplicates added to `dropped`.
fn sort_and_dedup<T>(v: &mut Vec<Timed<T>>, dropped: &mut usize) -> usize {
    let mut out_of_order = 0;
    let mut latest = 0;
    for m in v.iter() {
        if m.t_ns < latest {
            out_of_order += 1;
        }
        latest = latest.max(m.t_ns);
    }
    if out_of_order > 0 {
        v.sort_by_key(|m| m.t_ns);
    }
    let before = v.len();
    // Keep the later of equal times: dedup keeps the first, so reverse around it.
    v.reverse();
    v.dedup_by_key(|m| m.t_ns);
    v.reverse();
    *dropped += before - v.len();
    out_of_order
}

/// Each command with the latest odometry at or before it, as samples `(t s, pose, v, w)`.
fn pair(
    commands: &[Timed<(f64, f64)>],
    odometry: &[Timed<Pose>],
    t0_ns: u64,
    report: &mut BagReport,
) -> Vec<Sample> {
    let mut samples = Vec::with_capacity(commands.len());
    let mut j = 0;
    for c in commands {
        while j < odometry.len() && odometry[j].t_ns <= c.t_ns {
            j += 1;
        }
        let Some(o) = j.checked_sub(1).map(|k| &odometry[k]) else {
            report.before_odometry += 1;
            continue;
        };
        let age = (c.t_ns - o.t_ns) as f64 * 1e-9;
        if age > MAX_ODOMETRY_AGE_S {
            report.stale_odometry += 1;
            if report.longest_odometry_gap.is_none_or(|(a, _)| age > a) {
                report.longest_odometry_gap = Some((age, (c.t_ns - t0_ns) as f64 * 1e-9));
            }
            continue;
        }
        let (v, w) = c.value;
        samples.push((c.t_ns as f64 * 1e-9, o.value, v, w));
    }
    samples
}

/// Split samples where consecutive ones are more than `gap` s apart.
fn split(samples: &[Sample], gap: Option<f64>) -> Vec<Vec<Sample>> {
    let mut runs: Vec<Vec<Sample>> = vec![Vec::new()];
    for s in samples {
        if let (Some(gap), Some(prev)) = (gap, runs.last().and_then(|r| r.last()))
            && s.0 - prev.0 > gap
        {
            runs.push(Vec::new());
        }
        if let Some(run) = runs.last_mut() {
            run.push(*s);
        }
    }
    runs
}
