//! The platform's motion, one tick at a time: the command timeout, the velocity and yaw limits,
//! the slew (acceleration, deceleration, DTZ), the base underneath, then what the platform
//! measures of it (wheel positions, acceleration, the lean of a balancing base, the battery).

use super::platform::Platform;
use crate::backend::rmp::codec::{OpState, critical_fault};
use crate::geometry::{limit_speed, wheel_speeds};

const G_MPS2: f64 = 9.80665;

impl Platform {
    /// Advance the platform by `dt_s` seconds.
    pub fn tick(&mut self, dt_s: f64) {
        self.t_s += dt_s;
        self.advance_modes();

        let m = &self.machine;
        let fresh = self
            .last_motion_s
            .is_some_and(|t| self.t_s - t <= self.cfg.command_timeout_s);
        let (target, decel) = if self.state.drives() && !self.dtz && fresh {
            let v = f64::from(m.velocity_limit_mps);
            let w = f64::from(m.yaw_rate_limit_radps);
            (
                (limit_speed(self.cmd.0, v), limit_speed(self.cmd.1, w)),
                f64::from(m.decel_limit_mps2),
            )
        } else if self.dtz {
            ((0.0, 0.0), f64::from(m.dtz_decel_mps2))
        } else {
            // Timed out, standby or disabled: slew to zero at the deceleration limit.
            ((0.0, 0.0), f64::from(m.decel_limit_mps2))
        };
        let accel = f64::from(m.accel_limit_mps2);
        let yaw_accel = f64::from(m.yaw_accel_limit_radps2);
        let (v0, w0) = self.slewed;
        let dv = target.0 - v0;
        // Moving toward zero is decelerating; away from zero is accelerating.
        let lim = if v0 * dv < 0.0 { decel } else { accel } * dt_s;
        let v = v0 + dv.clamp(-lim, lim);
        let lim_w = yaw_accel * dt_s;
        let w = w0 + (target.1 - w0).clamp(-lim_w, lim_w);
        self.slewed = (v, w);
        if self.state == OpState::Disabled {
            self.slewed = (0.0, 0.0);
        }
        self.base.set_command(self.slewed.0, self.slewed.1);
        let prev = self.last;
        self.last = self.base.advance(dt_s);
        // DTZ ends once the base itself is at rest, not just its command: then it holds (standby).
        if self.dtz
            && !self.moving()
            && self.last.speed_mps.abs() < 1e-3
            && self.last.rot_radps.abs() < 1e-3
        {
            self.dtz = false;
            self.state = OpState::Standby;
        }
        self.accel_mps2 = (self.last.speed_mps - prev.speed_mps) / dt_s;
        self.odometer_m += self.last.speed_mps.abs() * dt_s;
        let (left, right) = wheel_speeds(
            self.last.speed_mps,
            self.last.rot_radps,
            f64::from(m.track_width_m),
        );
        for (i, v) in [right, left, right, left].into_iter().enumerate() {
            self.wheel_pos_m[i] += v * dt_s;
        }
        // A balancing base leans into its acceleration: tan(pitch) = a / g.
        self.pitch_deg = if self.state == OpState::Balance {
            (self.accel_mps2 / G_MPS2).atan().to_degrees()
        } else {
            0.0
        };
        if self.pitch_deg.abs() > 30.0 {
            self.raise_critical_fault(critical_fault::PITCH_ANGLE_EXCEEDED);
        }
        // About 8 hours from full to empty.
        self.soc_pct = (self.soc_pct - dt_s * 100.0 / (8.0 * 3600.0)).max(0.0);
    }
}
