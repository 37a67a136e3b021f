//! An RMP v3 platform on a UDP socket: the protocol, the state machine, limits and slew, the 0.5 s
//! command timeout, 100 Hz streaming, the config echo, fault bits for bad packets, either feedback
//! byte order, and injected datagram faults (drop, corrupt, delay).
//!
//! This module owns the emulated platform ([`Platform`], no sockets, stepped by the caller) and the
//! socket loop around it ([`Emulator::bind`], a background thread with a clean shutdown). The
//! physics of the base sits behind [`EmulatedBase`]: the team's simulator ([`SimBase`], what the
//! CLI runs, [`Emulator::bind_sim`]) or a simple noiseless stand-in ([`LagBase`]). It must not
//! send anywhere but to the source of the last valid datagram it received, and it never panics on
//! what arrives.
//!
//! Split along its seams: `platform` (the state and its modes), `protocol` (datagrams in,
//! feedback out), `motion` (limits, slew, the base underneath), `faults` (critical faults and the
//! fault log), `base` (the physics), `socket` (the thread, the socket and fault injection).
//!
//! [`SimBase`]: crate::backend::sim::SimBase

mod base;
mod faults;
mod motion;
mod platform;
mod protocol;
mod socket;
#[cfg(test)]
mod tests;

pub use base::{EmulatedBase, LagBase};
pub use platform::{EmulatorCounts, Platform, Reply, Snapshot};
pub use socket::{Emulator, EmulatorError, EmulatorHandle};

/// The pose arithmetic lives in [`crate::geometry`]; kept here under its old paths.
pub use crate::geometry::{compose_pose, relative_pose, wrap_angle};
