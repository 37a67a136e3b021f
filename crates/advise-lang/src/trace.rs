//! Traces (recorded executions and demonstrations) and chunks of them.
//!
//! A [`Trace`] is a time series of points `(t, z, a)`, optionally with the robot pose at each point
//! for plots. Storage is flat (`z` is `len * obs_dim` values in row order) so that operators and
//! policies stream over contiguous memory. A [`Chunk`] is a validated half-open index range into a
//! trace ([`chunk`]); an [`Episode`] is one named trace of a demonstrations file ([`episode`]).
//! Traces load from CSV ([`csv`]) and JSON ([`json`]) text held in the caller's
//! [`SourceMap`]; every malformed input becomes a [`TraceError`] ([`error`]) that points into it
//! (file, line and column), never a panic. This module knows nothing of operators or policies.

pub mod chunk;
pub mod csv;
pub mod episode;
pub mod error;
pub mod json;

use std::path::Path;

pub use chunk::{Chunk, ChunkError, PointRange, RangeStart};
pub use episode::Episode;
pub use error::TraceError;
pub use json::{JsonEpisode, JsonEpisodes, JsonPoint, JsonTrace};

use crate::diag::SourceMap;
use crate::domain::Domain;

/// The pose type lives in [`crate::geometry`]; traces hold one per point when recorded.
pub use crate::geometry::Pose;

/// Why a value may not enter a dataset as part of a demonstration: the one rule every path into
/// a dataset applies (issues 31 and 35): `load demos FILE` (CSV and JSON), `advise import` and
/// `load demos BAG` (bags and CSV logs), and `record demo` / `teleop`. A value that breaks it is
/// refused with a diagnostic naming where it is (a file's line, a bag's topic and time, a
/// recording's time), never clamped or written: an import writes only what `load demos` reads.
///
/// Why refused rather than clamped: a demonstration's actions are what the robot is taught to do;
/// an action beyond the domain's limits means the recording and the domain disagree (the task's
/// limits are not this robot's, or the teleoperation drove it past them), which the teacher
/// settles (declare the robot's limits, record again), and a clamped demonstration would teach
/// states and actions that never happened together. Non-finite values poison every distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ValueFault {
    /// NaN or an infinity.
    NotFinite,
    /// An action beyond its dimension's limits.
    OutsideLimits(crate::domain::Limits),
}

/// Whether `v`, the `k`-th value of a demonstration point's observation or action, breaks the
/// demonstration rule ([`ValueFault`]): every value finite; every action within its dimension's
/// limits. Observations may lie beyond their limits (a goal 20 m away is what the robot saw).
pub fn demo_value_fault(
    domain: &Domain,
    space: crate::domain::Space,
    k: usize,
    v: f64,
) -> Option<ValueFault> {
    if !v.is_finite() {
        return Some(ValueFault::NotFinite);
    }
    match space {
        crate::domain::Space::Observation => None,
        crate::domain::Space::Action => domain
            .act
            .get(k)
            .and_then(|d| d.limits)
            .filter(|l| !l.contains(v))
            .map(ValueFault::OutsideLimits),
    }
}

/// The first value of a demonstration that breaks the rule: (point, space, dimension, value,
/// fault).
pub fn demo_fault(
    domain: &Domain,
    trace: &Trace,
) -> Option<(usize, crate::domain::Space, usize, f64, ValueFault)> {
    use crate::domain::Space;
    (0..trace.len()).find_map(|i| {
        let z = trace
            .z(i)
            .iter()
            .enumerate()
            .map(|(k, v)| (Space::Observation, k, *v));
        let a = trace
            .a(i)
            .iter()
            .enumerate()
            .map(|(k, v)| (Space::Action, k, *v));
        z.chain(a).find_map(|(space, k, v)| {
            demo_value_fault(domain, space, k, v).map(|f| (i, space, k, v, f))
        })
    })
}

/// A recorded execution or demonstration in one domain.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// Name of the domain the points belong to.
    pub domain: String,
    obs_dim: usize,
    act_dim: usize,
    /// Time stamp of each point, seconds, non-decreasing.
    pub t: Vec<f64>,
    /// Observations, `len * obs_dim` values, row after row.
    pub z: Vec<f64>,
    /// Actions, `len * act_dim` values, row after row.
    pub a: Vec<f64>,
    /// Robot pose at each point, when recorded.
    pub pose: Option<Vec<Pose>>,
}

impl Trace {
    /// An empty trace for `domain`.
    pub fn new(domain: &Domain) -> Self {
        Trace::with_dims(&domain.name, domain.obs_dim(), domain.act_dim())
    }

    /// An empty trace with explicit dimensions (for code that has no [`Domain`] at hand).
    pub fn with_dims(domain: &str, obs_dim: usize, act_dim: usize) -> Self {
        Trace {
            domain: domain.to_string(),
            obs_dim,
            act_dim,
            t: Vec::new(),
            z: Vec::new(),
            a: Vec::new(),
            pose: None,
        }
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    pub fn act_dim(&self) -> usize {
        self.act_dim
    }

    /// Observation of point `i`. Panics if `i >= len()` (an index the caller validated).
    #[inline]
    pub fn z(&self, i: usize) -> &[f64] {
        &self.z[i * self.obs_dim..(i + 1) * self.obs_dim]
    }

    /// Action of point `i`. Panics if `i >= len()` (an index the caller validated).
    #[inline]
    pub fn a(&self, i: usize) -> &[f64] {
        &self.a[i * self.act_dim..(i + 1) * self.act_dim]
    }

    #[inline]
    pub fn z_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.z[i * self.obs_dim..(i + 1) * self.obs_dim]
    }

    #[inline]
    pub fn a_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.a[i * self.act_dim..(i + 1) * self.act_dim]
    }

    /// Append a point. `z` and `a` must have the trace's dimensions; a pose is kept only if every
    /// point so far has one.
    pub fn push(&mut self, t: f64, z: &[f64], a: &[f64], pose: Option<Pose>) {
        assert_eq!(z.len(), self.obs_dim, "observation has the wrong dimension");
        assert_eq!(a.len(), self.act_dim, "action has the wrong dimension");
        let was_empty = self.is_empty();
        self.t.push(t);
        self.z.extend_from_slice(z);
        self.a.extend_from_slice(a);
        match (pose, &mut self.pose) {
            (Some(p), Some(poses)) => poses.push(p),
            (Some(p), None) if was_empty => self.pose = Some(vec![p]),
            _ => self.pose = None,
        }
    }

    /// The points of `chunk` as a new trace (same domain).
    pub fn slice(&self, chunk: Chunk) -> Trace {
        let r = chunk.range();
        Trace {
            domain: self.domain.clone(),
            obs_dim: self.obs_dim,
            act_dim: self.act_dim,
            t: self.t[r.clone()].to_vec(),
            z: self.z[r.start * self.obs_dim..r.end * self.obs_dim].to_vec(),
            a: self.a[r.start * self.act_dim..r.end * self.act_dim].to_vec(),
            pose: self.pose.as_ref().map(|p| p[r].to_vec()),
        }
    }

    /// Check the trace against a domain: name and dimensions.
    pub fn check_domain(&self, domain: &Domain) -> Result<(), TraceError> {
        if self.domain != domain.name
            || self.obs_dim != domain.obs_dim()
            || self.act_dim != domain.act_dim()
        {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: self.domain.clone(),
            });
        }
        Ok(())
    }

    /// Load a trace from a file, read into `sources`; `.json` is JSON, anything else is CSV.
    pub fn load(
        sources: &mut SourceMap,
        domain: &Domain,
        path: &Path,
    ) -> Result<Trace, TraceError> {
        crate::files::parse_file(sources, path, |src| {
            if is_json(path) {
                Trace::parse_json(domain, src)
            } else {
                Trace::parse_csv(domain, src)
            }
        })
    }
}

/// Whether a path names a JSON file (by its extension, in any case).
pub fn is_json(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::{SourceMap, Src};

    /// Parse `text` named `name` with `parse`, in a map of its own.
    fn parse<T>(
        name: &str,
        text: &str,
        parse: impl Fn(&Domain, Src<'_>) -> Result<T, TraceError>,
    ) -> Result<T, TraceError> {
        let mut map = SourceMap::new();
        let id = map.add(name, text);
        parse(&Domain::positioning(), map.src(id))
    }

    fn csv_trace(name: &str, text: &str) -> Result<Trace, TraceError> {
        parse(name, text, Trace::parse_csv)
    }

    fn json_trace(name: &str, text: &str) -> Result<Trace, TraceError> {
        parse(name, text, Trace::parse_json)
    }

    fn csv_episodes(name: &str, text: &str) -> Result<Vec<Episode>, TraceError> {
        parse(name, text, Episode::parse_csv)
    }

    fn json_episodes(name: &str, text: &str) -> Result<Vec<Episode>, TraceError> {
        parse(name, text, Episode::parse_json)
    }

    const GOOD: &str = "t,dist2,bearing,dheading,trans,rot,x,y,theta\n\
                        0,4,0.1,0.2,0.5,0,0,0,0\n\
                        0.033,3.9,0.1,0.2,0.5,0.1,0.01,0,0\n";

    #[test]
    fn csv_round_trip() {
        let d = Domain::positioning();
        let tr = csv_trace("t.csv", GOOD).unwrap();
        assert_eq!(tr.len(), 2);
        assert_eq!(tr.a(1), &[0.5, 0.1]);
        let mut out = Vec::new();
        tr.write_csv(&d, &mut out).unwrap();
        let back = csv_trace("t.csv", std::str::from_utf8(&out).unwrap()).unwrap();
        assert_eq!(tr, back);
    }

    #[test]
    fn json_round_trip() {
        let tr = csv_trace("t.csv", GOOD).unwrap();
        let text = serde_json::to_string(&tr.to_json()).unwrap();
        assert_eq!(json_trace("t.json", &text).unwrap(), tr);
    }

    #[test]
    fn csv_errors_name_the_problem() {
        let missing = "t,dist2,bearing,trans,rot\n0,1,2,3,4\n";
        assert!(matches!(
            csv_trace("m.csv", missing),
            Err(TraceError::MissingColumn { column, .. }) if column == "dheading"
        ));
        let nan = "t,dist2,bearing,dheading,trans,rot\n0,1,NaN,0,0,0\n";
        assert!(matches!(
            csv_trace("n.csv", nan),
            Err(TraceError::NotFinite { line: 2, .. })
        ));
        let typo = "t,dist2,bearing,dheading,trans,rott\n";
        match csv_trace("u.csv", typo) {
            Err(TraceError::UnknownColumn { help, .. }) => assert!(help.contains("`rot`")),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn episodes_round_trip_through_csv_and_json() {
        let d = Domain::positioning();
        let tr = csv_trace("t.csv", GOOD).unwrap();
        let eps = vec![
            Episode {
                name: "a".into(),
                trace: tr.clone(),
            },
            Episode {
                name: "b".into(),
                trace: tr.slice(Chunk::new(1, 2, 2).unwrap()),
            },
        ];
        let mut out = Vec::new();
        Episode::write_csv(&d, &eps, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(csv_episodes("e.csv", &text).unwrap(), eps);
        assert!(matches!(
            csv_trace("e.csv", &text),
            Err(TraceError::ManyEpisodes { count: 2 })
        ));
        let json = serde_json::to_string(&Episode::to_json(&d, &eps)).unwrap();
        assert_eq!(json_episodes("e.json", &json).unwrap(), eps);
    }

    #[test]
    fn errors_point_into_the_file_they_came_from() {
        let mut map = SourceMap::new();
        map.add("other.csv", "t\n");
        let text = "t,dist2,bearing,dheading,trans,rot\n0,1,x,0,0,0\n";
        let id = map.add("bad.csv", text);
        let err = Trace::parse_csv(&Domain::positioning(), map.src(id)).unwrap_err();
        let out = crate::diag::render(&map, &err, false);
        assert!(out.contains("[bad.csv:2:5]"), "{out}");
        assert!(out.contains("not a number"), "{out}");
    }
}
