//! The Segway RMP backend: a driver for the RMP v3 UDP protocol (Stanley Innovation command set)
//! and an emulator that speaks the same protocol on loopback.
//!
//! This module owns everything RMP: [`codec`] (bytes), [`config`] (limits, timeouts, the machine
//! configuration), [`driver`] (the [`Backend`](crate::backend::Backend) that talks to a real or
//! emulated base) and [`emulator`] (a fake platform for tests and rehearsal). Tasks never see any of
//! it: they get speeds in and odometry out, as from the simulator. Nothing here may send to an
//! address the user did not give.

pub mod codec;
pub mod config;
pub mod driver;
pub mod emulator;

pub use config::{EmulatorConfig, RmpConfig};
pub use driver::RmpBackend;
pub use emulator::{Emulator, EmulatorHandle};
