//! Task domains: the named observation and action dimensions of a task, with units and limits.
//!
//! A [`Domain`] is the contract between every other phase: operator files declare one, traces are
//! validated against one, policies map its observation space to its action space, and backends
//! produce points in it. This module only describes shapes; it does no IO and knows no task physics.
//! The two domains of the paper are declared once, in the language (`operators/*.adv`); their
//! constructors [`Domain::positioning`] and [`Domain::interception`] are defined beside the
//! embedded standard library (`check/standard.rs`), which reads them from there.

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

    /// Every dimension's name: the observations', then the actions'.
    pub fn names(&self) -> Vec<&str> {
        self.observe
            .iter()
            .chain(&self.act)
            .map(|d| d.name.as_str())
            .collect()
    }

    pub fn obs_dim(&self) -> usize {
        self.observe.len()
    }

    pub fn act_dim(&self) -> usize {
        self.act.len()
    }
}

/// The columns of the paper's two domains by name, for the code that computes or reads their
/// points directly (the tasks' observation functions and teachers, the automated advisor and
/// critic): one place that says which index is which dimension. `operators/*.adv` declares the
/// domains; a test below checks that these indices are where it puts each name.
pub mod columns {
    /// `domain positioning` (`operators/positioning.adv`).
    pub mod positioning {
        /// Observation: the squared distance to the goal, m^2.
        pub const DIST2: usize = 0;
        /// Observation: the goal's bearing from the robot's heading, rad.
        pub const BEARING: usize = 1;
        /// Observation: `theta_g - theta`, the heading still to turn, rad.
        pub const DHEADING: usize = 2;
        /// Action: translational speed, m/s.
        pub const TRANS: usize = 0;
        /// Action: rotational speed, rad/s.
        pub const ROT: usize = 1;
    }

    /// `domain interception` (`operators/interception.adv`).
    pub mod interception {
        /// Observation: the distance to the ball, m.
        pub const BALL_DIST: usize = 0;
        /// Observation: the ball's angle from the robot's heading, rad.
        pub const BALL_ANGLE: usize = 1;
        /// Observation: the change of `ball_dist` since the last step, m.
        pub const BALL_DIST_DELTA: usize = 2;
        /// Observation: the change of `ball_angle` since the last step, rad.
        pub const BALL_ANGLE_DELTA: usize = 3;
        /// Observation: the distance travelled since the last step, m.
        pub const TRAVEL_DELTA: usize = 4;
        /// Observation: the heading turned since the last step, rad.
        pub const HEADING_DELTA: usize = 5;
        /// Action: the change of the translational speed command, m/s.
        pub const TRANS_DELTA: usize = 0;
        /// Action: the change of the rotational speed command, rad/s.
        pub const ROT_DELTA: usize = 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every named column is where `operators/*.adv` declares its dimension.
    #[test]
    fn the_named_columns_are_the_declared_ones() {
        use columns::{interception as i, positioning as p};
        let obs = |d: &Domain, name| d.index_of(Space::Observation, name);
        let act = |d: &Domain, name| d.index_of(Space::Action, name);
        let d = Domain::positioning();
        assert_eq!(obs(&d, "dist2"), Some(p::DIST2));
        assert_eq!(obs(&d, "bearing"), Some(p::BEARING));
        assert_eq!(obs(&d, "dheading"), Some(p::DHEADING));
        assert_eq!(act(&d, "trans"), Some(p::TRANS));
        assert_eq!(act(&d, "rot"), Some(p::ROT));
        assert_eq!(d.obs_dim(), 3);
        let d = Domain::interception();
        assert_eq!(obs(&d, "ball_dist"), Some(i::BALL_DIST));
        assert_eq!(obs(&d, "ball_angle"), Some(i::BALL_ANGLE));
        assert_eq!(obs(&d, "ball_dist_delta"), Some(i::BALL_DIST_DELTA));
        assert_eq!(obs(&d, "ball_angle_delta"), Some(i::BALL_ANGLE_DELTA));
        assert_eq!(obs(&d, "travel_delta"), Some(i::TRAVEL_DELTA));
        assert_eq!(obs(&d, "heading_delta"), Some(i::HEADING_DELTA));
        assert_eq!(act(&d, "trans_delta"), Some(i::TRANS_DELTA));
        assert_eq!(act(&d, "rot_delta"), Some(i::ROT_DELTA));
        assert_eq!(d.obs_dim(), 6);
    }

    #[test]
    fn find_looks_in_both_spaces() {
        let d = Domain::positioning();
        assert_eq!(d.find("rot"), Some((Space::Action, 1)));
        assert_eq!(d.find("bearing"), Some((Space::Observation, 1)));
        assert_eq!(d.find("nope"), None);
    }
}
