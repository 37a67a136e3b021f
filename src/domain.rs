//! Task domains: the named observation and action dimensions of a task, with units and limits.
//!
//! A [`Domain`] is the contract between every other phase: operator files declare one, traces are
//! validated against one, policies map its observation space to its action space, and backends
//! produce points in it. This module only describes shapes; it does no IO and knows no task physics.
//! The two domains of the paper are available as [`Domain::positioning`] and
//! [`Domain::interception`]; `operators/*.adv` declares the same domains in the language, and a test
//! keeps the two in agreement.

use serde::{Deserialize, Serialize};

/// Which side of a data point a dimension (or an operator) belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Space {
    /// The observation `z` the policy reads.
    Observation,
    /// The action `a` the policy outputs.
    Action,
}

impl Space {
    /// The word the language and the diagnostics use for this space.
    pub fn word(self) -> &'static str {
        match self {
            Space::Observation => "observation",
            Space::Action => "action",
        }
    }
}

impl std::fmt::Display for Space {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.word())
    }
}

/// Closed interval `[lo, hi]` a dimension's values are clamped to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    pub lo: f64,
    pub hi: f64,
}

impl Limits {
    pub fn new(lo: f64, hi: f64) -> Self {
        Limits { lo, hi }
    }

    /// Clamp `v` into the interval.
    #[inline]
    pub fn clamp(&self, v: f64) -> f64 {
        v.clamp(self.lo, self.hi)
    }

    pub fn contains(&self, v: f64) -> bool {
        v >= self.lo && v <= self.hi
    }

    /// Width of the interval (used to scale distances inversely with range).
    pub fn width(&self) -> f64 {
        self.hi - self.lo
    }
}

/// One named dimension of a domain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Dim {
    pub name: String,
    /// Unit as written in the operator file, e.g. `"m/s"`; empty when unitless.
    pub unit: String,
    /// Values are clamped to these limits when an operator writes them; `None` means unbounded.
    pub limits: Option<Limits>,
}

impl Dim {
    pub fn new(name: &str, unit: &str, limits: Option<(f64, f64)>) -> Self {
        Dim {
            name: name.to_string(),
            unit: unit.to_string(),
            limits: limits.map(|(lo, hi)| Limits::new(lo, hi)),
        }
    }
}

/// The observation and action dimensions of a task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    pub name: String,
    pub observe: Vec<Dim>,
    pub act: Vec<Dim>,
}

impl Domain {
    /// The dimensions of one space.
    pub fn dims(&self, space: Space) -> &[Dim] {
        match space {
            Space::Observation => &self.observe,
            Space::Action => &self.act,
        }
    }

    /// Index of a dimension by name within one space.
    pub fn index_of(&self, space: Space, name: &str) -> Option<usize> {
        self.dims(space).iter().position(|d| d.name == name)
    }

    /// Find a dimension by name in either space.
    pub fn find(&self, name: &str) -> Option<(Space, usize)> {
        [Space::Observation, Space::Action]
            .into_iter()
            .find_map(|s| self.index_of(s, name).map(|i| (s, i)))
    }

    pub fn obs_dim(&self) -> usize {
        self.observe.len()
    }

    pub fn act_dim(&self) -> usize {
        self.act.len()
    }

    /// The paper's spatial positioning domain (A-OPI, Segway RMP).
    ///
    /// Observation: squared distance to the goal, angle between the goal vector and the heading,
    /// and `theta_g - theta_r`. Action: translational and rotational speed.
    pub fn positioning() -> Domain {
        Domain {
            name: "positioning".into(),
            observe: vec![
                Dim::new("dist2", "m^2", Some((0.0, 100.0))),
                Dim::new(
                    "bearing",
                    "rad",
                    Some((-std::f64::consts::PI, std::f64::consts::PI)),
                ),
                Dim::new(
                    "dheading",
                    "rad",
                    Some((-std::f64::consts::PI, std::f64::consts::PI)),
                ),
            ],
            act: vec![
                Dim::new("trans", "m/s", Some((-1.0, 1.0))),
                Dim::new("rot", "rad/s", Some((-1.0, 1.0))),
            ],
        }
    }

    /// The paper's ball interception domain (BC, simulated differential drive).
    ///
    /// Observation: distance and angle to the ball, their changes since the last step, the change in
    /// travelled distance and in heading. Action: change in translational and rotational speed.
    pub fn interception() -> Domain {
        Domain {
            name: "interception".into(),
            observe: vec![
                Dim::new("ball_dist", "m", Some((0.0, 20.0))),
                Dim::new(
                    "ball_angle",
                    "rad",
                    Some((-std::f64::consts::PI, std::f64::consts::PI)),
                ),
                Dim::new("ball_dist_delta", "m", Some((-1.0, 1.0))),
                Dim::new("ball_angle_delta", "rad", Some((-1.0, 1.0))),
                Dim::new("travel_delta", "m", Some((-1.0, 1.0))),
                Dim::new("heading_delta", "rad", Some((-1.0, 1.0))),
            ],
            act: vec![
                Dim::new("trans_delta", "m/s", Some((-0.1, 0.1))),
                Dim::new("rot_delta", "rad/s", Some((-0.2, 0.2))),
            ],
        }
    }

    /// A built-in domain by name.
    pub fn builtin(name: &str) -> Option<Domain> {
        match name {
            "positioning" => Some(Domain::positioning()),
            "interception" => Some(Domain::interception()),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn find_looks_in_both_spaces() {
        let d = Domain::positioning();
        assert_eq!(d.find("rot"), Some((Space::Action, 1)));
        assert_eq!(d.find("bearing"), Some((Space::Observation, 1)));
        assert_eq!(d.find("nope"), None);
    }
}
