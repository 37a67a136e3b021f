//! The JSON forms of traces and demonstrations ([`JsonTrace`], [`JsonEpisodes`]) and their
//! loaders: serde reads the shape, then every point is validated as a CSV row would be. serde
//! keeps no positions past its own errors, so a point's error names its index.

use serde::{Deserialize, Serialize};

use super::{Episode, Pose, Trace, TraceError};
use crate::diag::{Src, locate};
use crate::domain::Domain;
use crate::number::fmt_num;

/// The JSON file format of several episodes:
/// `{"domain": "positioning", "episodes": [{"name": "demo-0", "points": [..]}]}`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonEpisodes {
    pub domain: String,
    pub episodes: Vec<JsonEpisode>,
}

/// One episode of [`JsonEpisodes`]; points as in [`JsonTrace`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonEpisode {
    pub name: String,
    pub points: Vec<JsonPoint>,
}

/// The JSON file format of a trace.
///
/// ```json
/// {"domain": "positioning",
///  "points": [{"t": 0.0, "z": [4.0, 0.1, 0.3], "a": [0.5, 0.0], "pose": [0.0, 0.0, 0.0]}]}
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonTrace {
    pub domain: String,
    pub points: Vec<JsonPoint>,
}

/// One point of a [`JsonTrace`]; `pose` is `[x_m, y_m, theta_rad]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JsonPoint {
    pub t: f64,
    pub z: Vec<f64>,
    pub a: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose: Option<[f64; 3]>,
}

/// serde's error, at its line and column.
fn json_error(src: Src<'_>, e: &serde_json::Error) -> TraceError {
    TraceError::Json {
        message: e.to_string(),
        at: src.at(locate::line_col(src.text, e.line(), e.column())),
    }
}

impl Trace {
    /// Parse a JSON trace (see [`JsonTrace`] for the format).
    pub fn parse_json(domain: &Domain, src: Src<'_>) -> Result<Trace, TraceError> {
        let doc: JsonTrace = serde_json::from_str(src.text).map_err(|e| json_error(src, &e))?;
        if doc.domain != domain.name {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: doc.domain,
            });
        }
        Trace::from_json_points(domain, &doc.points, false)
    }

    /// A trace from its JSON form, validated as a file's would be (a journal's traces).
    pub fn from_json(domain: &Domain, json: &JsonTrace) -> Result<Trace, TraceError> {
        if json.domain != domain.name {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: json.domain.clone(),
            });
        }
        Trace::from_json_points(domain, &json.points, false)
    }

    /// Validate parsed JSON points (dimensions, finiteness, time order, and for demonstrations
    /// the action limits) into a trace.
    fn from_json_points(
        domain: &Domain,
        points: &[JsonPoint],
        demo: bool,
    ) -> Result<Trace, TraceError> {
        let mut trace = Trace::new(domain);
        let with_pose = points.first().is_some_and(|p| p.pose.is_some());
        for (i, p) in points.iter().enumerate() {
            let bad = |what: String| TraceError::JsonPoint { index: i, what };
            if p.z.len() != domain.obs_dim() {
                return Err(bad(format!(
                    "`z` has {} values, the `{}` domain observes {}",
                    p.z.len(),
                    domain.name,
                    domain.obs_dim()
                )));
            }
            if p.a.len() != domain.act_dim() {
                return Err(bad(format!(
                    "`a` has {} values, the `{}` domain acts on {}",
                    p.a.len(),
                    domain.name,
                    domain.act_dim()
                )));
            }
            if p.pose.is_some() != with_pose {
                return Err(bad("some points have a `pose` and others do not".into()));
            }
            let vals = std::iter::once(p.t)
                .chain(p.z.iter().copied())
                .chain(p.a.iter().copied());
            if vals
                .chain(p.pose.into_iter().flatten())
                .any(|v| !v.is_finite())
            {
                return Err(bad("a value is not a finite number".into()));
            }
            if i > 0 && p.t < trace.t[i - 1] {
                return Err(bad(format!(
                    "time goes backwards ({} after {})",
                    p.t,
                    trace.t[i - 1]
                )));
            }
            if demo && let Some((k, v, l)) = outside_action_limits(domain, &p.a) {
                return Err(bad(format!(
                    "the action `{}` is {}, outside its limits [{}, {}]; a demonstration's actions are ones the robot can execute",
                    domain.act[k].name,
                    fmt_num(v),
                    fmt_num(l.lo),
                    fmt_num(l.hi)
                )));
            }
            if i > 0 && p.t == trace.t[i - 1] {
                return Err(bad(format!(
                    "the time {} repeats the point before; each point is one control step",
                    p.t
                )));
            }
            let pose = p.pose.map(|[x, y, th]| Pose::new(x, y, th));
            trace.push(p.t, &p.z, &p.a, pose);
        }
        Ok(trace)
    }

    /// The JSON form of the trace.
    pub fn to_json(&self) -> JsonTrace {
        JsonTrace {
            domain: self.domain.clone(),
            points: (0..self.len())
                .map(|i| JsonPoint {
                    t: self.t[i],
                    z: self.z(i).to_vec(),
                    a: self.a(i).to_vec(),
                    pose: self
                        .pose
                        .as_ref()
                        .map(|p| [p[i].x_m, p[i].y_m, p[i].theta_rad]),
                })
                .collect(),
        }
    }
}

impl Episode {
    /// Parse a JSON demonstrations file: one trace ([`JsonTrace`]) or [`JsonEpisodes`].
    pub fn parse_json(domain: &Domain, src: Src<'_>) -> Result<Vec<Episode>, TraceError> {
        let Src { name, text, .. } = src;
        let json_err = |e: serde_json::Error| json_error(src, &e);
        // Peek at the top-level keys, then parse again with the typed form so errors keep their
        // line and column.
        let value: serde_json::Value = serde_json::from_str(text).map_err(json_err)?;
        if value.get("episodes").is_none() {
            let doc: JsonTrace = serde_json::from_str(text).map_err(json_err)?;
            if doc.domain != domain.name {
                return Err(TraceError::DomainMismatch {
                    expected: domain.name.clone(),
                    found: doc.domain,
                });
            }
            if doc.points.is_empty() {
                return Err(TraceError::NoDemonstrations {
                    name: name.to_string(),
                });
            }
            return Ok(vec![Episode {
                name: name.to_string(),
                trace: Trace::from_json_points(domain, &doc.points, true)?,
            }]);
        }
        let many: JsonEpisodes = serde_json::from_str(text).map_err(json_err)?;
        if many.domain != domain.name {
            return Err(TraceError::DomainMismatch {
                expected: domain.name.clone(),
                found: many.domain,
            });
        }
        if many.episodes.is_empty() {
            return Err(TraceError::NoDemonstrations {
                name: name.to_string(),
            });
        }
        // Where the n-th `"name": "NAME"` is in the text, for a label (serde keeps no positions).
        let name_span = |episode: &str, nth: usize| {
            let quoted = serde_json::to_string(episode).ok()?;
            let mut at = 0;
            let mut seen = 0;
            while let Some(i) = text[at..].find(&quoted) {
                let start = at + i;
                let before = text[..start].trim_end();
                if before.ends_with(':')
                    && before[..before.len() - 1].trim_end().ends_with("\"name\"")
                {
                    if seen == nth {
                        return Some(src.at(start..start + quoted.len()));
                    }
                    seen += 1;
                }
                at = start + quoted.len();
            }
            None
        };
        let mut seen: Vec<&str> = Vec::new();
        for e in &many.episodes {
            let nth = seen.iter().filter(|n| **n == e.name).count();
            if nth > 0 {
                return Err(TraceError::DuplicateEpisode {
                    episode: e.name.clone(),
                    at: name_span(&e.name, nth),
                });
            }
            if e.points.is_empty() {
                return Err(TraceError::EmptyEpisode {
                    episode: e.name.clone(),
                    at: name_span(&e.name, 0),
                });
            }
            seen.push(&e.name);
        }
        many.episodes
            .into_iter()
            .map(|e| {
                let trace = Trace::from_json_points(domain, &e.points, true)?;
                Ok(Episode {
                    name: e.name,
                    trace,
                })
            })
            .collect()
    }

    /// The JSON form of several episodes.
    pub fn to_json(domain: &Domain, episodes: &[Episode]) -> JsonEpisodes {
        JsonEpisodes {
            domain: domain.name.clone(),
            episodes: episodes
                .iter()
                .map(|e| JsonEpisode {
                    name: e.name.clone(),
                    points: e.trace.to_json().points,
                })
                .collect(),
        }
    }
}

/// The first action value outside its dimension's limits: (dimension, value, limits).
fn outside_action_limits(
    domain: &Domain,
    a: &[f64],
) -> Option<(usize, f64, crate::domain::Limits)> {
    // The demonstration rule ([`super::demo_value_fault`]); finiteness is refused before.
    a.iter().enumerate().find_map(|(k, v)| {
        match super::demo_value_fault(domain, crate::domain::Space::Action, k, *v) {
            Some(super::ValueFault::OutsideLimits(l)) => Some((k, *v, l)),
            _ => None,
        }
    })
}
