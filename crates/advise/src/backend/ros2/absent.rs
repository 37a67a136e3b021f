//! This build has no ROS 2 driver (the library was built without its `ros2` feature, as the
//! Python package is): only the message types, which bags and MCAP files hold. A `ros2` spec is
//! refused by [`crate::backend::registry::Absent::ROS2`].

#[path = "msg.rs"]
pub mod msg;
