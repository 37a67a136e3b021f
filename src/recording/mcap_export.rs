//! A dataset out as MCAP for Foxglove and ROS 2 tools: profile `ros2`, ROS 2 message schemas
//! (`ros2msg`, each with the definitions it depends on) and CDR messages, in uncompressed chunks
//! (legal MCAP that every reader takes; `mcap` is built without its C compressors, issue 32).
//!
//! Each execution of the dataset is laid on one timeline, one after another with a second
//! between them: its commands as `geometry_msgs/msg/Twist` on `/cmd_vel` and, when the execution
//! has poses, its poses as `nav_msgs/msg/Odometry` on `/odom` (frame `odom`, child `base_link`),
//! at its own times. Each piece of advice and each critique is a `std_msgs/msg/String` on
//! `/advise/advice` and `/advise/critique` at its chunk's first point, saying the operator (or
//! kappa), the execution, the chunk and the counts. A metadata record `advise` describes the
//! dataset. Only ROS message types are used: a JSON-schema channel makes ROS tooling reject a file.

use std::collections::{BTreeMap, HashMap};
use std::io::Cursor;
use std::path::Path;

use byteorder::LittleEndian;
use serde::Serialize;

use crate::backend::ros2::msg::{Odometry, Time, Twist};
use crate::policy::dataset::{Dataset, Provenance};
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
        "wrote {path}: {} executions{poses}, {} advice and {} critiques, {} messages on /cmd_vel, /odom, /advise/advice and /advise/critique (ROS 2 types, CDR; open it in Foxglove)",
        s.executions, s.advice, s.critiques, s.messages
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

/// Write `dataset` to `path` as MCAP (atomically).
pub fn export_mcap(dataset: &Dataset, path: &Path) -> Result<McapSummary, ExportError> {
    let fail = |e: String| ExportError::Mcap {
        path: path.to_path_buf(),
        reason: e,
    };
    let bytes = mcap_bytes(dataset).map_err(fail)?;
    crate::files::write_atomic(path, |w| w.write_all(&bytes.0))?;
    Ok(bytes.1)
}

fn mcap_bytes(dataset: &Dataset) -> Result<(Vec<u8>, McapSummary), String> {
    let err = |e: mcap::McapError| e.to_string();
    let options = mcap::WriteOptions::new()
        .profile("ros2")
        .library(concat!("advise ", env!("CARGO_PKG_VERSION")))
        .compression(None);
    let mut out = options.create(Cursor::new(Vec::new())).map_err(err)?;
    let none = BTreeMap::new();
    let channel = |out: &mut mcap::Writer<_>, topic: &str, ty: &str, def: &str| {
        let schema = out.add_schema(ty, "ros2msg", def.as_bytes()).map_err(err)?;
        out.add_channel(schema, topic, "cdr", &none).map_err(err)
    };
    let cmd = channel(&mut out, "/cmd_vel", "geometry_msgs/msg/Twist", TWIST_DEF)?;
    let odom = channel(&mut out, "/odom", "nav_msgs/msg/Odometry", ODOMETRY_DEF)?;
    let advice_ch = channel(
        &mut out,
        "/advise/advice",
        "std_msgs/msg/String",
        STRING_DEF,
    )?;
    let critique_ch = channel(
        &mut out,
        "/advise/critique",
        "std_msgs/msg/String",
        STRING_DEF,
    )?;
    let mut summary = McapSummary::default();
    let mut sequence = 0u32;
    let mut write = |out: &mut mcap::Writer<_>, channel_id: u16, t_ns: u64, data: &[u8]| {
        sequence = sequence.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence,
            log_time: t_ns,
            publish_time: t_ns,
        };
        out.write_to_known_channel(&header, data).map_err(err)
    };
    // Synthesized points per advice, for the advice messages.
    let mut synthesized: HashMap<_, usize> = HashMap::new();
    for i in 0..dataset.len() {
        if let Provenance::Advice { advice, .. } = dataset.provenance(i) {
            *synthesized.entry(advice).or_default() += 1;
        }
    }
    // Where each execution's points start on the timeline.
    let mut starts = HashMap::new();
    let mut next = 0u64;
    for (number, rec) in dataset.executions().iter().enumerate() {
        let trace = dataset.execution(rec.id).map_err(|e| e.to_string())?;
        let t0 = trace.t.first().copied().unwrap_or(0.0);
        starts.insert(rec.id, (number, next, t0));
        let poses = trace.pose.as_deref();
        if poses.is_none() {
            summary.without_poses += 1;
        }
        for i in 0..trace.len() {
            let t_ns = next + secs_to_ns(trace.t[i] - t0);
            let a = trace.a(i);
            let (v, w) = (
                a.first().copied().unwrap_or(0.0),
                a.get(1).copied().unwrap_or(0.0),
            );
            write(&mut out, cmd, t_ns, &cdr(&Twist::planar(v, w))?)?;
            summary.messages += 1;
            if let Some(poses) = poses {
                let stamp = Time::from_secs_f64(t_ns as f64 * 1e-9);
                let o = Odometry::planar(stamp, "odom", "base_link", poses[i], v, w);
                write(&mut out, odom, t_ns, &cdr(&o)?)?;
                summary.messages += 1;
            }
        }
        summary.executions += 1;
        let end = next + secs_to_ns(trace.t.last().copied().unwrap_or(0.0) - t0);
        next = end + GAP_NS;
    }
    let at = |execution, point: usize| -> Result<(usize, u64), String> {
        let &(number, start, t0) = starts
            .get(&execution)
            .ok_or_else(|| "advice on an execution the dataset does not hold".to_string())?;
        let trace = dataset.execution(execution).map_err(|e| e.to_string())?;
        let t = trace.t.get(point).copied().unwrap_or(t0);
        Ok((number, start + secs_to_ns(t - t0)))
    };
    for rec in dataset.advice() {
        let (number, t_ns) = at(rec.execution, rec.applied.chunk.start)?;
        let text = format!(
            "{} on execution {number}, points {}..{}: {} points synthesized ({} space)",
            rec.applied.invocation(),
            rec.applied.chunk.start,
            rec.applied.chunk.end,
            synthesized.get(&rec.id).copied().unwrap_or(0),
            rec.applied.space.word(),
        );
        write(&mut out, advice_ch, t_ns, &cdr(&StringMsg { data: text })?)?;
        summary.messages += 1;
        summary.advice += 1;
    }
    for rec in dataset.critiques() {
        let c = &rec.critique;
        let (number, t_ns) = at(rec.execution, c.chunk.start)?;
        let text = format!(
            "critique with kappa {} on execution {number}, points {}..{}: {} dataset points reweighted{}",
            c.kappa,
            c.chunk.start,
            c.chunk.end,
            c.increments.len(),
            if c.directional { " (directional)" } else { "" }
        );
        write(
            &mut out,
            critique_ch,
            t_ns,
            &cdr(&StringMsg { data: text })?,
        )?;
        summary.messages += 1;
        summary.critiques += 1;
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
            ("executions".to_string(), summary.executions.to_string()),
            ("advice".to_string(), summary.advice.to_string()),
            ("critiques".to_string(), summary.critiques.to_string()),
            (
                "timeline".to_string(),
                "executions one after another, 1 s apart".to_string(),
            ),
        ]),
    };
    out.write_metadata(&metadata).map_err(err)?;
    out.finish().map_err(err)?;
    Ok((out.into_inner().into_inner(), summary))
}
