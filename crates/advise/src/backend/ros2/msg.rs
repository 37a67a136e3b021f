//! The ROS 2 messages the backend speaks, as serde structs in CDR field order.
//!
//! `ros2-client` ships no `geometry_msgs` or `nav_msgs`, so the two messages a mobile base uses are
//! written out here from their `.msg` definitions (ros2/common_interfaces): `geometry_msgs/Twist`
//! on `cmd_vel` and `nav_msgs/Odometry` on `odom`. Field order is the wire format; nothing else in
//! the crate knows these layouts. No IO here.

use std::fmt;

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::trace::Pose;

/// The DDS type names ROS 2 registers (what `ros2 topic info -v` calls the topic type).
pub const TWIST_TYPE: (&str, &str) = ("geometry_msgs", "Twist");
pub const TWIST_STAMPED_TYPE: (&str, &str) = ("geometry_msgs", "TwistStamped");

/// A message type's name as DDS discovery reports it: `geometry_msgs::msg::dds_::Twist_`.
pub fn dds_type_name(ty: (&str, &str)) -> String {
    format!("{}::msg::dds_::{}_", ty.0, ty.1)
}
pub const ODOMETRY_TYPE: (&str, &str) = ("nav_msgs", "Odometry");

/// `geometry_msgs/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/Twist`: a differential base reads `linear.x` (m/s) and `angular.z` (rad/s).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    pub linear: Vector3,
    pub angular: Vector3,
}

impl Twist {
    pub const ZERO: Twist = Twist {
        linear: Vector3 {
            x: 0.0,
            y: 0.0,
            z: 0.0,
        },
        angular: Vector3 {
            x: 0.0,
            y: 0.0,
            z: 0.0,
        },
    };

    /// A planar command.
    pub fn planar(speed_mps: f64, rot_radps: f64) -> Twist {
        Twist {
            linear: Vector3 {
                x: speed_mps,
                ..Vector3::default()
            },
            angular: Vector3 {
                z: rot_radps,
                ..Vector3::default()
            },
        }
    }

    pub fn is_zero(&self) -> bool {
        *self == Twist::ZERO
    }
}

/// `geometry_msgs/TwistStamped`: what teleoperation publishes on newer ROS 2 (Jazzy's
/// `teleop_twist_keyboard` with `stamped:=true`); read from bags.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    pub header: Header,
    pub twist: Twist,
}

/// `builtin_interfaces/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// The wall clock now, as ROS 2 stamps messages.
    pub fn now() -> Time {
        Time::from_secs_f64(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0.0, |d| d.as_secs_f64()),
        )
    }

    /// `t_ns` nanoseconds since the epoch, exactly (seconds past `i32::MAX` are clamped).
    pub fn from_nanos(t_ns: u64) -> Time {
        Time {
            sec: i32::try_from(t_ns / 1_000_000_000).unwrap_or(i32::MAX),
            nanosec: (t_ns % 1_000_000_000) as u32,
        }
    }

    /// Seconds since the epoch of `t` (negative times are clamped to the epoch).
    pub fn from_secs_f64(t: f64) -> Time {
        let t = if t.is_finite() { t.max(0.0) } else { 0.0 };
        let sec = t.floor().min(f64::from(i32::MAX));
        Time {
            sec: sec as i32,
            nanosec: (((t - sec) * 1e9) as u32).min(999_999_999),
        }
    }
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// `geometry_msgs/Point`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`: `child_frame_id`'s pose in `header.frame_id`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`, what `/tf` and `/tf_static` carry.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    pub transforms: Vec<TransformStamped>,
}

impl TransformStamped {
    /// The planar pose of `child` in `parent` at `stamp`.
    pub fn planar(stamp: Time, parent: &str, child: &str, pose: Pose) -> TransformStamped {
        let half = 0.5 * pose.theta_rad;
        TransformStamped {
            header: Header {
                stamp,
                frame_id: parent.to_string(),
            },
            child_frame_id: child.to_string(),
            transform: Transform {
                translation: Vector3 {
                    x: pose.x_m,
                    y: pose.y_m,
                    z: 0.0,
                },
                rotation: Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: half.sin(),
                    w: half.cos(),
                },
            },
        }
    }
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseMsg {
    pub position: Point,
    pub orientation: Quaternion,
}

/// A row-major 6x6 covariance (`float64[36]`): a fixed array, so CDR writes no length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Covariance([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Covariance, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Covariance;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("36 floats")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut c = [0.0; 36];
                for (i, slot) in c.iter_mut().enumerate() {
                    *slot = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(c))
            }
        }
        d.deserialize_tuple(36, V)
    }
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    pub pose: PoseMsg,
    pub covariance: Covariance,
}

/// `geometry_msgs/TwistWithCovariance`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    pub twist: Twist,
    pub covariance: Covariance,
}

/// `nav_msgs/Odometry`: the pose in `header.frame_id` (usually `odom`), the twist in
/// `child_frame_id` (usually `base_link`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    pub header: Header,
    pub child_frame_id: String,
    pub pose: PoseWithCovariance,
    pub twist: TwistWithCovariance,
}

impl Odometry {
    /// The planar pose: position x, y and the yaw of the orientation (roll and pitch ignored).
    pub fn planar_pose(&self) -> Pose {
        let p = self.pose.pose.position;
        let q = self.pose.pose.orientation;
        let yaw = (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z));
        Pose::new(p.x, p.y, yaw)
    }

    /// A planar odometry message: `pose` in `frame_id`, speeds in `child_frame_id`.
    pub fn planar(
        stamp: Time,
        frame_id: &str,
        child_frame_id: &str,
        pose: Pose,
        speed_mps: f64,
        rot_radps: f64,
    ) -> Odometry {
        let half = 0.5 * pose.theta_rad;
        Odometry {
            header: Header {
                stamp,
                frame_id: frame_id.to_string(),
            },
            child_frame_id: child_frame_id.to_string(),
            pose: PoseWithCovariance {
                pose: PoseMsg {
                    position: Point {
                        x: pose.x_m,
                        y: pose.y_m,
                        z: 0.0,
                    },
                    orientation: Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: half.sin(),
                        w: half.cos(),
                    },
                },
                covariance: Covariance::default(),
            },
            twist: TwistWithCovariance {
                twist: Twist::planar(speed_mps, rot_radps),
                covariance: Covariance::default(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_survives_the_quaternion() {
        for theta in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            let o = Odometry::planar(
                Time::default(),
                "odom",
                "base_link",
                Pose::new(1.0, -2.0, theta),
                0.1,
                0.2,
            );
            let p = o.planar_pose();
            assert!((p.theta_rad - theta).abs() < 1e-12, "{theta}: {p:?}");
            assert_eq!((p.x_m, p.y_m), (1.0, -2.0));
        }
    }

    #[test]
    fn time_splits_seconds() {
        assert_eq!(
            Time::from_secs_f64(12.25),
            Time {
                sec: 12,
                nanosec: 250_000_000
            }
        );
        assert_eq!(Time::from_secs_f64(-1.0), Time::default());
        assert_eq!(Time::from_secs_f64(f64::NAN), Time::default());
    }
}
