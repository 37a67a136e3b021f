//! The physics under the emulated platform: the [`EmulatedBase`] trait, the team's simulator
//! behind it, and [`LagBase`], a noiseless stand-in.

use crate::backend::BaseState;
use crate::backend::sim::SimBase;
use crate::geometry::{Pose, integrate_arc, lag_fraction};

/// The physics under the emulated platform: a differential-drive base that takes the platform's
/// slewed speed commands ([`SimBase`] and [`LagBase`] implement it).
pub trait EmulatedBase: Send {
    /// Put the base at rest at `pose`.
    fn reset(&mut self, pose: Pose);
    /// The speeds the platform's motor controllers aim for from now on.
    fn set_command(&mut self, speed_mps: f64, rot_radps: f64);
    /// Advance `dt_s` seconds; the state's pose is the base's odometry.
    fn advance(&mut self, dt_s: f64) -> BaseState;
    /// The true pose (equal to odometry for a base without drift).
    fn true_pose(&self) -> Pose;
}

/// Stand-in base: each speed follows its command through a first-order lag (the motor and, on a
/// balancing base, the lean it must take before it can accelerate), and odometry is exact.
#[derive(Clone, Debug)]
pub struct LagBase {
    pub lag_s: f64,
    state: BaseState,
    cmd: (f64, f64),
}

impl LagBase {
    pub fn new(lag_s: f64) -> LagBase {
        LagBase {
            lag_s: lag_s.max(0.0),
            state: BaseState::default(),
            cmd: (0.0, 0.0),
        }
    }
}

impl EmulatedBase for LagBase {
    fn reset(&mut self, pose: Pose) {
        self.state = BaseState {
            pose,
            ..BaseState::default()
        };
        self.cmd = (0.0, 0.0);
    }

    fn set_command(&mut self, speed_mps: f64, rot_radps: f64) {
        self.cmd = (speed_mps, rot_radps);
    }

    fn advance(&mut self, dt_s: f64) -> BaseState {
        let s = &mut self.state;
        let alpha = lag_fraction(self.lag_s, dt_s);
        s.speed_mps += alpha * (self.cmd.0 - s.speed_mps);
        s.rot_radps += alpha * (self.cmd.1 - s.rot_radps);
        s.pose = integrate_arc(s.pose, s.speed_mps, s.rot_radps, dt_s);
        s.t_s += dt_s;
        *s
    }

    fn true_pose(&self) -> Pose {
        self.state.pose
    }
}

/// The team's simulator behind the emulator: the same lag, acceleration limits, encoder noise and
/// odometry drift as `advise eval` on `sim`, so a policy sees the same base over the wire. The
/// platform's own limits and slew act first, as on the real RMP.
impl EmulatedBase for SimBase {
    fn reset(&mut self, pose: Pose) {
        SimBase::reset(self, pose);
    }

    fn set_command(&mut self, speed_mps: f64, rot_radps: f64) {
        SimBase::set_command(self, speed_mps, rot_radps);
    }

    fn advance(&mut self, dt_s: f64) -> BaseState {
        SimBase::advance(self, dt_s)
    }

    fn true_pose(&self) -> Pose {
        SimBase::true_pose(self)
    }
}
