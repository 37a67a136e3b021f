//! Planar geometry: the one home of poses, frames, angles and the differential drive's kinematics.
//!
//! A [`Pose`] is stored as three numbers with their units (`x_m`, `y_m`, `theta_rad`: what traces,
//! journals and plots hold); frame arithmetic goes through nalgebra ([`Pose::isometry`] is the
//! pose as an `Isometry2`, rotations are `UnitComplex`). Headings are kept as angles in
//! `(-pi, pi]`: a composed heading is the wrapped sum of the two angles, not `atan2` of the product
//! rotation, so composing with the identity gives back the very same bits.
//!
//! The simulator, the RMP driver and emulator, the tasks and traces all use this module; it must
//! not know about any of them (no IO, no randomness, no robot parameters).

use nalgebra::{Isometry2, Point2, UnitComplex, Vector2};
use serde::{Deserialize, Serialize};

/// Planar robot pose in the world (or odometry) frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub x_m: f64,
    pub y_m: f64,
    pub theta_rad: f64,
}

impl Pose {
    pub fn new(x_m: f64, y_m: f64, theta_rad: f64) -> Self {
        Pose {
            x_m,
            y_m,
            theta_rad,
        }
    }

    /// The position, m.
    pub fn position(&self) -> Point2<f64> {
        Point2::new(self.x_m, self.y_m)
    }

    /// The heading as a rotation.
    pub fn rotation(&self) -> UnitComplex<f64> {
        UnitComplex::new(self.theta_rad)
    }

    /// The transform from this pose's frame to the frame it is expressed in.
    pub fn isometry(&self) -> Isometry2<f64> {
        Isometry2::from_parts(self.position().into(), self.rotation())
    }

    /// The pose of a transform; the heading is the rotation's angle, in `(-pi, pi]`.
    pub fn from_isometry(iso: &Isometry2<f64>) -> Pose {
        let t = iso.translation.vector;
        Pose::new(t.x, t.y, wrap_angle(iso.rotation.angle()))
    }

    /// Distance between the two positions, m (headings are ignored).
    pub fn distance_to(&self, other: Pose) -> f64 {
        distance(self.x_m, self.y_m, other.x_m, other.y_m)
    }
}

/// An angle in `(-pi, pi]`. An angle already in range is returned as it is (bit for bit).
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if a > -PI && a <= PI {
        return a;
    }
    let w = a.rem_euclid(TAU);
    if w > PI { w - TAU } else { w }
}

/// `local` (a pose in the frame of `origin`) expressed in the frame `origin` lives in.
pub fn compose_pose(origin: Pose, local: Pose) -> Pose {
    let p = origin.isometry() * local.position();
    Pose::new(p.x, p.y, wrap_angle(origin.theta_rad + local.theta_rad))
}

/// `pose` expressed in the frame whose origin is `origin` (the inverse of [`compose_pose`]).
pub fn relative_pose(origin: Pose, pose: Pose) -> Pose {
    let p = origin.isometry().inverse_transform_point(&pose.position());
    Pose::new(p.x, p.y, wrap_angle(pose.theta_rad - origin.theta_rad))
}

/// Re-zeroed odometry: the pose `odom` reads, moved so that a reading of `odom_origin` is at
/// `start`. A base's odometry restarts wherever its integrators were reset; a session wants poses
/// in its own frame, in which the base stood at `start` when the odometry read `odom_origin`.
pub fn rezero(odom_origin: Pose, start: Pose, odom: Pose) -> Pose {
    compose_pose(start, relative_pose(odom_origin, odom))
}

/// Distance between two points, m (`hypot`, exact in either order).
pub fn distance(x0_m: f64, y0_m: f64, x1_m: f64, y1_m: f64) -> f64 {
    (x1_m - x0_m).hypot(y1_m - y0_m)
}

/// The direction of the point `(x_m, y_m)` seen from `pose`, relative to its heading, in
/// `(-pi, pi]`. At the pose's own position the direction is `atan2(0, 0) = 0` less the heading.
pub fn bearing(pose: Pose, x_m: f64, y_m: f64) -> f64 {
    let (dx, dy) = (x_m - pose.x_m, y_m - pose.y_m);
    wrap_angle(dy.atan2(dx) - pose.theta_rad)
}

/// The point at distance `d_m` in direction `angle_rad` from the origin.
pub fn polar(d_m: f64, angle_rad: f64) -> Vector2<f64> {
    Vector2::new(d_m * angle_rad.cos(), d_m * angle_rad.sin())
}

/// Move along the arc of constant speeds `v` (m/s), `w` (rad/s) for `h` seconds: the exact
/// unicycle motion (straight, to second order in the turn, when the turn is below 1e-9 rad).
pub fn integrate_arc(p: Pose, v: f64, w: f64, h: f64) -> Pose {
    let dth = w * h;
    let (dx, dy) = if dth.abs() < 1e-9 {
        let mid = p.theta_rad + 0.5 * dth;
        (v * h * mid.cos(), v * h * mid.sin())
    } else {
        // The closed form of the arc's integral (not a rotated chord: the same bits as ever).
        let r = v / w;
        (
            r * ((p.theta_rad + dth).sin() - p.theta_rad.sin()),
            -r * ((p.theta_rad + dth).cos() - p.theta_rad.cos()),
        )
    };
    Pose::new(p.x_m + dx, p.y_m + dy, wrap_angle(p.theta_rad + dth))
}

/// A differential drive's wheel speeds `(left, right)`, m/s, for body speeds `v` (m/s) and `w`
/// (rad/s) on wheels `track_m` apart.
pub fn wheel_speeds(v: f64, w: f64, track_m: f64) -> (f64, f64) {
    let half = 0.5 * track_m;
    (v - w * half, v + w * half)
}

/// The fraction of the gap to its command a first-order lag of time constant `lag_s` closes in
/// `dt_s` seconds (`1 - exp(-dt/lag)`; all of it without a lag).
pub fn lag_fraction(lag_s: f64, dt_s: f64) -> f64 {
    if lag_s > 0.0 {
        1.0 - (-dt_s / lag_s).exp()
    } else {
        1.0
    }
}

/// A speed limited to `[-max, max]`; a non-finite speed counts as zero (a base never acts on one).
pub fn limit_speed(v: f64, max: f64) -> f64 {
    if v.is_finite() {
        v.clamp(-max, max)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::{PI, TAU};

    #[test]
    fn wrap_angle_lands_in_range_and_keeps_angles_in_range() {
        for a in [-10.0, -PI, -3.0, -0.1, 0.0, 3.0, PI, 7.0, 100.0] {
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
        }
        assert_eq!(wrap_angle(-PI), PI);
        assert_eq!(wrap_angle(-0.1).to_bits(), (-0.1f64).to_bits());
    }

    #[test]
    fn compose_moves_along_the_origin_heading() {
        let p = compose_pose(Pose::new(1.0, 2.0, PI / 2.0), Pose::new(1.0, 0.0, PI / 2.0));
        assert!(
            (p.x_m - 1.0).abs() < 1e-12 && (p.y_m - 3.0).abs() < 1e-12,
            "{p:?}"
        );
        assert_eq!(p.theta_rad, PI);
        let r = relative_pose(Pose::new(1.0, 2.0, PI / 2.0), Pose::new(1.0, 3.0, 0.0));
        assert!((r.x_m - 1.0).abs() < 1e-12 && r.y_m.abs() < 1e-12, "{r:?}");
        assert_eq!(r.theta_rad, -PI / 2.0);
        assert_eq!(
            bearing(Pose::new(0.0, 0.0, 0.5), 3.0, 4.0),
            4f64.atan2(3.0) - 0.5
        );
        assert_eq!(wheel_speeds(1.0, 2.0, 0.5), (0.5, 1.5));
        assert_eq!(limit_speed(f64::NAN, 1.0), 0.0);
        assert_eq!(limit_speed(-3.0, 1.0), -1.0);
    }

    #[test]
    fn an_arc_of_a_quarter_turn_ends_where_the_circle_does() {
        // 1 m/s at 1 rad/s for pi/2 s: a quarter of the unit circle to the left.
        let p = integrate_arc(Pose::default(), 1.0, 1.0, PI / 2.0);
        assert!(
            (p.x_m - 1.0).abs() < 1e-12 && (p.y_m - 1.0).abs() < 1e-12,
            "{p:?}"
        );
        assert_eq!(p.theta_rad, PI / 2.0);
    }

    fn pose() -> impl Strategy<Value = Pose> {
        (-10.0f64..10.0, -10.0f64..10.0, -PI..PI).prop_map(|(x, y, t)| Pose::new(x, y, t))
    }

    fn close(a: Pose, b: Pose) -> bool {
        (a.x_m - b.x_m).abs() < 1e-9
            && (a.y_m - b.y_m).abs() < 1e-9
            && wrap_angle(a.theta_rad - b.theta_rad).abs() < 1e-9
    }

    proptest! {
        #[test]
        fn wrap_angle_is_in_range_and_a_whole_number_of_turns_away(a in -1e4f64..1e4) {
            let w = wrap_angle(a);
            prop_assert!(w > -PI && w <= PI);
            let turns = (a - w) / TAU;
            prop_assert!((turns - turns.round()).abs() < 1e-9);
        }

        #[test]
        fn relative_then_compose_is_identity(o in pose(), p in pose()) {
            prop_assert!(close(compose_pose(o, relative_pose(o, p)), p));
            prop_assert!(close(relative_pose(o, compose_pose(o, p)), p));
        }

        #[test]
        fn the_identity_changes_nothing_and_a_pose_is_its_own_origin(p in pose()) {
            prop_assert_eq!(compose_pose(Pose::default(), p), p);
            prop_assert_eq!(compose_pose(p, Pose::default()), p);
            prop_assert!(close(relative_pose(p, p), Pose::default()));
            prop_assert!(close(Pose::from_isometry(&p.isometry()), p));
        }

        #[test]
        fn composition_is_associative(a in pose(), b in pose(), c in pose()) {
            let left = compose_pose(compose_pose(a, b), c);
            let right = compose_pose(a, compose_pose(b, c));
            prop_assert!((left.x_m - right.x_m).abs() < 1e-8 && (left.y_m - right.y_m).abs() < 1e-8);
            prop_assert!(wrap_angle(left.theta_rad - right.theta_rad).abs() < 1e-9);
        }

        #[test]
        fn rezeroing_puts_the_origin_reading_at_the_start(o in pose(), s in pose(), p in pose()) {
            prop_assert!(close(rezero(o, s, o), s));
            // Distances travelled are the same in both frames.
            prop_assert!((rezero(o, s, p).distance_to(s) - p.distance_to(o)).abs() < 1e-9);
        }

        #[test]
        fn an_arc_keeps_its_distance_from_the_turning_centre(
            p in pose(), v in -2.0f64..2.0, w in 0.01f64..3.0, h in 0.001f64..0.5,
        ) {
            // The centre of the turn is v/w to the left of the heading.
            let c = compose_pose(p, Pose::new(0.0, v / w, 0.0));
            let q = integrate_arc(p, v, w, h);
            prop_assert!((q.distance_to(c) - (v / w).abs()).abs() < 1e-9);
        }
    }
}
