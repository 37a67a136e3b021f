//! A dataset out as MCAP for Foxglove and ROS 2 tools: profile `ros2`, ROS 2 message schemas
//! (`ros2msg`, each with the definitions it depends on) and CDR messages, in uncompressed chunks
//! (legal MCAP that every reader takes; `mcap` is built without its C compressors, issue 32).
//!
//! One timeline, in wall-clock time from [`McapOptions::start_unix_ns`] (the session's start, or
//! the saved dataset's time), with a second between episodes: first each demonstration (its
//! commands only, at its recorded times: a dataset keeps a demonstration's times but not its
//! poses; a file written before datasets kept times at the task's rate), then each execution at
//! its own times. Commands are `geometry_msgs/msg/Twist` on
//! `/cmd_vel`; an execution's poses are `nav_msgs/msg/Odometry` on `/odom` (frame `odom`, child
//! `base_link`) and the same pose as `tf2_msgs/msg/TFMessage` on `/tf` (`odom` -> `base_link`), so
//! a 3D view follows the base; `/tf_static` holds `map` -> `odom` (identity) once at the start, a
//! fixed frame to view in. `/advise/episode` says where each episode starts (its kind, name and
//! length). Each piece of advice and each critique is a `std_msgs/msg/String` on `/advise/advice`
//! and `/advise/critique` at its chunk's first point, saying the operator (or kappa), the
//! execution, the chunk, its times and the counts. A metadata record `advise` describes the
//! dataset. Only ROS message types are used: a JSON-schema channel makes ROS tooling reject a file.

use std::collections::{BTreeMap, HashMap};
use std::io::Cursor;
use std::path::Path;

use byteorder::LittleEndian;
use serde::Serialize;

use crate::backend::ros2::msg::{Odometry, TfMessage, Time, TransformStamped, Twist};
use crate::policy::dataset::{Dataset, DemoTimes, Provenance};
use miette::Diagnostic;
use thiserror::Error;

/// `geometry_msgs/msg/Twist` with its dependencies, as `ros2msg` schemas carry them.
const TWIST_DEF: &str = "Vector3 linear\nVector3 angular\n\
================================================================================\n\
MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";

/// `nav_msgs/msg/Odometry` with its dependencies.
const ODOMETRY_DEF: &str = "std_msgs/Header header\nstring child_frame_id\n\
geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n\
================================================================================\n\
MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
================================================================================\n\
MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
================================================================================\n\
MSG: geometry_msgs/PoseWithCovariance\nPose pose\nfloat64[36] covariance\n\
================================================================================\n\
MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n\
================================================================================\n\
MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n\
================================================================================\n\
MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n\
================================================================================\n\
MSG: geometry_msgs/TwistWithCovariance\nTwist twist\nfloat64[36] covariance\n\
================================================================================\n\
MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n\
================================================================================\n\
MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";

const STRING_DEF: &str = "string data\n";

/// `tf2_msgs/msg/TFMessage` with its dependencies.
const TF_DEF: &str = "geometry_msgs/TransformStamped[] transforms\n\
================================================================================\n\
MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\nTransform transform\n\
================================================================================\n\
MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
================================================================================\n\
MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
================================================================================\n\
MSG: geometry_msgs/Transform\nVector3 translation\nQuaternion rotation\n\
================================================================================\n\
MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n\
================================================================================\n\
MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";

/// Where the timeline starts and how demonstrations are paced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct McapOptions {
    /// The wall-clock time of the timeline's start, ns since the Unix epoch.
    pub start_unix_ns: u64,
    /// The time between a demonstration's points, s, for one the dataset keeps no times of (a
    /// file written before it kept them): the task's control period.
    pub period_s: f64,
}

impl McapOptions {
    /// A timeline starting at `start` with the default simulator's control period.
    pub fn starting_at(start: std::time::SystemTime) -> McapOptions {
        McapOptions {
            start_unix_ns: start
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX / 2)),
            period_s: crate::backend::sim::SimParams::default().period_s(),
        }
    }
}

/// The time between two executions on the exported timeline, ns.
const GAP_NS: u64 = 1_000_000_000;

/// `std_msgs/msg/String`.
#[derive(Serialize)]
struct StringMsg {
    data: String,
}

/// Why a dataset could not be exported.
#[derive(Debug, Error, Diagnostic)]
pub enum ExportError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error("cannot export to {path}: {reason}")]
    #[diagnostic(code(advise::export::mcap))]
    Mcap {
        path: std::path::PathBuf,
        reason: String,
    },
}

/// What an export wrote.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct McapSummary {
    pub demonstrations: usize,
    pub executions: usize,
    /// Executions without poses: their commands only, no `/odom`.
    pub without_poses: usize,
    pub messages: usize,
    pub advice: usize,
    pub critiques: usize,
}

/// What a user is told of an export to `path`.
pub fn describe(s: &McapSummary, path: &str) -> String {
    let poses = match s.without_poses {
        0 => String::new(),
        n => format!(" ({n} without poses: commands only)"),
    };
    format!(
        "wrote {path}: {} demonstrations (commands only) and {} executions{poses}, {} advice and {} critiques, {} messages on /cmd_vel, /odom, /tf, /tf_static, /advise/episode, /advise/advice and /advise/critique (ROS 2 types, CDR; open it in Foxglove)",
        s.demonstrations, s.executions, s.advice, s.critiques, s.messages
    )
}

/// A CDR message: the little-endian encapsulation header, then the body.
fn cdr<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    let body = cdr_encoding::to_vec::<T, LittleEndian>(value).map_err(|e| e.to_string())?;
    let mut out = Vec::with_capacity(4 + body.len());
    out.extend_from_slice(&[0x00, 0x01, 0x00, 0x00]);
    out.extend_from_slice(&body);
    Ok(out)
}

fn secs_to_ns(t: f64) -> u64 {
    if t.is_finite() && t > 0.0 {
        (t * 1e9).round().min(u64::MAX as f64 / 2.0) as u64
    } else {
        0
    }
}

/// Write `dataset` to `path` as MCAP (atomically), its timeline starting at `options`' time.
pub fn export_mcap(
    dataset: &Dataset,
    path: &Path,
    options: &McapOptions,
) -> Result<McapSummary, ExportError> {
    let fail = |e: String| ExportError::Mcap {
        path: path.to_path_buf(),
        reason: e,
    };
    let bytes = mcap_bytes(dataset, options).map_err(fail)?;
    crate::files::write_atomic(path, |w| w.write_all(&bytes.0))?;
    Ok(bytes.1)
}

fn err(e: mcap::McapError) -> String {
    e.to_string()
}

/// The MCAP writer with its channels, a running sequence number and the summary's counts.
struct Out {
    mcap: mcap::Writer<Cursor<Vec<u8>>>,
    sequence: u32,
    summary: McapSummary,
    cmd: u16,
    odom: u16,
    tf: u16,
    tf_static: u16,
    episode: u16,
    advice: u16,
    critique: u16,
}

impl Out {
    fn new() -> Result<Out, String> {
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("advise ", env!("CARGO_PKG_VERSION")))
            .compression(None);
        let mut mcap = options.create(Cursor::new(Vec::new())).map_err(err)?;
        let none = BTreeMap::new();
        let mut channel = |topic: &str, ty: &str, def: &str| {
            let schema = mcap
                .add_schema(ty, "ros2msg", def.as_bytes())
                .map_err(err)?;
            mcap.add_channel(schema, topic, "cdr", &none).map_err(err)
        };
        let cmd = channel("/cmd_vel", "geometry_msgs/msg/Twist", TWIST_DEF)?;
        let odom = channel("/odom", "nav_msgs/msg/Odometry", ODOMETRY_DEF)?;
        let tf = channel("/tf", "tf2_msgs/msg/TFMessage", TF_DEF)?;
        let tf_static = channel("/tf_static", "tf2_msgs/msg/TFMessage", TF_DEF)?;
        let episode = channel("/advise/episode", "std_msgs/msg/String", STRING_DEF)?;
        let advice = channel("/advise/advice", "std_msgs/msg/String", STRING_DEF)?;
        let critique = channel("/advise/critique", "std_msgs/msg/String", STRING_DEF)?;
        Ok(Out {
            mcap,
            sequence: 0,
            summary: McapSummary::default(),
            cmd,
            odom,
            tf,
            tf_static,
            episode,
            advice,
            critique,
        })
    }

    /// One message of `value` on `channel_id` at `t_ns`.
    fn write<T: Serialize>(&mut self, channel_id: u16, t_ns: u64, value: &T) -> Result<(), String> {
        self.sequence = self.sequence.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: t_ns,
            publish_time: t_ns,
        };
        self.mcap
            .write_to_known_channel(&header, &cdr(value)?)
            .map_err(err)?;
        self.summary.messages += 1;
        Ok(())
    }

    fn text(&mut self, channel_id: u16, t_ns: u64, data: String) -> Result<(), String> {
        self.write(channel_id, t_ns, &StringMsg { data })
    }
}

/// A command `(v, w)` from an action: its first two values.
fn command(a: &[f64]) -> Twist {
    Twist::planar(
        a.first().copied().unwrap_or(0.0),
        a.get(1).copied().unwrap_or(0.0),
    )
}

fn stamp(t_ns: u64) -> Time {
    Time::from_nanos(t_ns)
}

/// Each demonstration's commands at `period` on the timeline from `next`; the time after them.
fn write_demonstrations(
    out: &mut Out,
    dataset: &Dataset,
    mut next: u64,
    period_ns: u64,
) -> Result<u64, String> {
    let mut points: HashMap<_, Vec<(u32, usize)>> = HashMap::new();
    for i in 0..dataset.len() {
        if let Provenance::Demonstration { demo, index } = dataset.provenance(i) {
            points.entry(demo).or_default().push((index, i));
        }
    }
    for demo in dataset.demos() {
        let Some(mut pts) = points.remove(&demo.id) else {
            continue;
        };
        pts.sort_unstable();
        // Its own times where the dataset keeps them; the task's period for an older file's.
        let times = demo.times();
        let spacing = match &times {
            Some(DemoTimes::Period(p)) => format!("{:.3} s apart", p),
            Some(DemoTimes::Each(_)) => "at their recorded times".to_string(),
            None => format!("{:.3} s apart", period_ns as f64 * 1e-9),
        };
        out.text(
            out.episode,
            next,
            format!(
                "demonstration `{}`: {} points (commands only, {spacing})",
                demo.name,
                pts.len(),
            ),
        )?;
        let at = |index: u32| match &times {
            Some(t) => secs_to_ns(t.time_s(index as usize)),
            None => u64::from(index).saturating_mul(period_ns),
        };
        let mut last = 0;
        for &(index, i) in &pts {
            last = at(index);
            out.write(out.cmd, next + last, &command(dataset.a(i)))?;
        }
        out.summary.demonstrations += 1;
        next += last + GAP_NS;
    }
    Ok(next)
}

fn mcap_bytes(dataset: &Dataset, options: &McapOptions) -> Result<(Vec<u8>, McapSummary), String> {
    let mut out = Out::new()?;
    let start = options.start_unix_ns;
    let identity = crate::geometry::Pose::new(0.0, 0.0, 0.0);
    let fixed = TfMessage {
        transforms: vec![TransformStamped::planar(
            stamp(start),
            "map",
            "odom",
            identity,
        )],
    };
    out.write(out.tf_static, start, &fixed)?;
    let period_ns = secs_to_ns(options.period_s).max(1);
    let mut next = write_demonstrations(&mut out, dataset, start, period_ns)?;
    // Synthesized points per advice, for the advice messages.
    let mut synthesized: HashMap<_, usize> = HashMap::new();
    for i in 0..dataset.len() {
        if let Provenance::Advice { advice, .. } = dataset.provenance(i) {
            *synthesized.entry(advice).or_default() += 1;
        }
    }
    // Where each execution's points start on the timeline.
    let mut starts = HashMap::new();
    for (number, rec) in dataset.executions().iter().enumerate() {
        let trace = dataset.execution(rec.id).map_err(|e| e.to_string())?;
        let t0 = trace.t.first().copied().unwrap_or(0.0);
        starts.insert(rec.id, (number, next, t0));
        out.text(
            out.episode,
            next,
            format!("execution {number}: {} points", trace.len()),
        )?;
        let poses = trace.pose.as_deref();
        if poses.is_none() {
            out.summary.without_poses += 1;
        }
        for i in 0..trace.len() {
            let t_ns = next + secs_to_ns(trace.t[i] - t0);
            let twist = command(trace.a(i));
            out.write(out.cmd, t_ns, &twist)?;
            if let Some(poses) = poses {
                let (v, w) = (twist.linear.x, twist.angular.z);
                let o = Odometry::planar(stamp(t_ns), "odom", "base_link", poses[i], v, w);
                out.write(out.odom, t_ns, &o)?;
                let tf = TfMessage {
                    transforms: vec![TransformStamped::planar(
                        stamp(t_ns),
                        "odom",
                        "base_link",
                        poses[i],
                    )],
                };
                out.write(out.tf, t_ns, &tf)?;
            }
        }
        out.summary.executions += 1;
        let end = next + secs_to_ns(trace.t.last().copied().unwrap_or(0.0) - t0);
        next = end + GAP_NS;
    }
    // A chunk's execution number and the log times of its first and last points.
    let at = |execution, chunk: &crate::trace::Chunk| -> Result<(usize, u64, u64), String> {
        let &(number, start, t0) = starts
            .get(&execution)
            .ok_or_else(|| "advice on an execution the dataset does not hold".to_string())?;
        let trace = dataset.execution(execution).map_err(|e| e.to_string())?;
        let t = |i: usize| start + secs_to_ns(trace.t.get(i).copied().unwrap_or(t0) - t0);
        Ok((number, t(chunk.start), t(chunk.end.saturating_sub(1))))
    };
    let span = |from: u64, to: u64| {
        format!(
            "{:.3} s to {:.3} s into the recording",
            (from - start) as f64 * 1e-9,
            (to - start) as f64 * 1e-9
        )
    };
    for rec in dataset.advice() {
        let (number, from, to) = at(rec.execution, &rec.applied.chunk)?;
        let text = format!(
            "{} on execution {number}, points {}..{} ({}): {} points synthesized ({} space)",
            rec.applied.invocation(),
            rec.applied.chunk.start,
            rec.applied.chunk.end,
            span(from, to),
            synthesized.get(&rec.id).copied().unwrap_or(0),
            rec.applied.space.word(),
        );
        out.text(out.advice, from, text)?;
        out.summary.advice += 1;
    }
    for rec in dataset.critiques() {
        let c = &rec.critique;
        let (number, from, to) = at(rec.execution, &c.chunk)?;
        let text = format!(
            "critique with kappa {} on execution {number}, points {}..{} ({}): {} dataset points reweighted{}",
            c.kappa,
            c.chunk.start,
            c.chunk.end,
            span(from, to),
            c.increments.len(),
            if c.directional { " (directional)" } else { "" }
        );
        out.text(out.critique, from, text)?;
        out.summary.critiques += 1;
    }
    let demos: Vec<String> = dataset
        .demos()
        .iter()
        .map(|d| format!("{} ({} points)", d.name, d.points))
        .collect();
    let metadata = mcap::records::Metadata {
        name: "advise".into(),
        metadata: BTreeMap::from([
            ("domain".to_string(), dataset.domain().name.clone()),
            ("points".to_string(), dataset.len().to_string()),
            ("demonstrations".to_string(), demos.join("; ")),
            ("executions".to_string(), out.summary.executions.to_string()),
            ("advice".to_string(), out.summary.advice.to_string()),
            ("critiques".to_string(), out.summary.critiques.to_string()),
            (
                "timeline".to_string(),
                "demonstrations (commands only), then executions, one after another, 1 s apart, from the session's wall clock; /advise/episode marks each start".to_string(),
            ),
        ]),
    };
    out.mcap.write_metadata(&metadata).map_err(err)?;
    out.mcap.finish().map_err(err)?;
    let summary = out.summary;
    Ok((out.mcap.into_inner().into_inner(), summary))
}
