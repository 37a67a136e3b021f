//! Stopping a running execution from outside it: Ctrl-C in the REPL, or any other thread.
//!
//! This module owns [`StopSignal`], a cloneable handle that a signal handler holds, and
//! [`Interruptible`], a [`Backend`] wrapper that the control loop drives through. Raising the
//! signal does two things: it stops a real base at once from the signalling thread (through the
//! driver's stop handle: the RMP's commands zero and decelerate-to-zero, the ROS 2 driver's
//! publishes a zero `Twist`, without waiting for the control loop), and it makes the next `command` or `step` of the wrapped backend fail with
//! [`BackendError::Stopped`], so the loop ends and keeps what it recorded. It works the same for
//! every backend; only a base with a driver-side stop gets the immediate stop. It does no IO itself.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use super::{Backend, BackendError, BaseState};
use crate::trace::Pose;

/// A real base's driver-side stop, callable from any thread (the driver's own stop handle,
/// wrapped by its [`Base::remote_stop`](super::Base::remote_stop)).
#[derive(Clone)]
pub struct BaseStop(Arc<dyn Fn() + Send + Sync>);

impl BaseStop {
    pub fn new(stop: impl Fn() + Send + Sync + 'static) -> BaseStop {
        BaseStop(Arc::new(stop))
    }

    pub fn stop(&self) {
        (self.0)()
    }
}

impl std::fmt::Debug for BaseStop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("BaseStop")
    }
}

/// A cloneable "stop now" for whatever is running (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct StopSignal {
    raised: Arc<AtomicBool>,
    /// The real base currently connected, if any: stopped from the signalling thread.
    base: Arc<Mutex<Option<BaseStop>>>,
}

impl StopSignal {
    pub fn new() -> StopSignal {
        StopSignal::default()
    }

    /// Stop: a connected base is commanded to zero and decelerate-to-zero now, and the running
    /// execution ends at its next control step. Safe to call from a signal-handler thread.
    pub fn raise(&self) {
        self.raised.store(true, Ordering::SeqCst);
        if let Some(h) = self.base.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            h.stop();
        }
    }

    pub fn is_raised(&self) -> bool {
        self.raised.load(Ordering::SeqCst)
    }

    /// Forget an earlier stop (a new execution begins).
    pub fn clear(&self) {
        self.raised.store(false, Ordering::SeqCst);
    }

    /// The real base to stop on [`StopSignal::raise`] (`None` when driving the simulator).
    pub fn set_base(&self, handle: Option<BaseStop>) {
        *self.base.lock().unwrap_or_else(|e| e.into_inner()) = handle;
    }

    /// Whether a real base is connected (what the REPL tells the user after Ctrl-C).
    pub fn has_base(&self) -> bool {
        self.base
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .is_some()
    }
}

/// `inner` driven so that a raised [`StopSignal`] ends the execution at the next control step.
pub struct Interruptible<'a> {
    inner: &'a mut dyn Backend,
    signal: StopSignal,
}

impl<'a> Interruptible<'a> {
    pub fn new(inner: &'a mut dyn Backend, signal: StopSignal) -> Interruptible<'a> {
        Interruptible { inner, signal }
    }

    fn check(&mut self) -> Result<(), BackendError> {
        if self.signal.is_raised() {
            // The base is stopped before the error goes up (the loop's own stop follows).
            let _ = self.inner.stop();
            return Err(BackendError::Stopped {
                reason: "interrupted (Ctrl-C)".into(),
            });
        }
        Ok(())
    }
}

impl Backend for Interruptible<'_> {
    fn name(&self) -> String {
        self.inner.name()
    }

    fn period_s(&self) -> f64 {
        self.inner.period_s()
    }

    fn reset(&mut self, start: Pose) -> Result<BaseState, BackendError> {
        self.check()?;
        self.inner.reset(start)
    }

    fn command(&mut self, speed_mps: f64, rot_radps: f64) -> Result<(), BackendError> {
        self.check()?;
        self.inner.command(speed_mps, rot_radps)
    }

    fn step(&mut self) -> Result<BaseState, BackendError> {
        self.check()?;
        self.inner.step()
    }

    fn stop(&mut self) -> Result<(), BackendError> {
        self.inner.stop()
    }

    fn true_pose(&self) -> Option<Pose> {
        self.inner.true_pose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::sim::{SimBackend, SimParams};

    #[test]
    fn a_raised_signal_ends_the_next_step_and_stops_the_base() {
        let mut sim = SimBackend::new(SimParams::default().noiseless(), 0);
        let signal = StopSignal::new();
        let mut b = Interruptible::new(&mut sim, signal.clone());
        b.reset(Pose::default()).unwrap();
        b.command(0.5, 0.0).unwrap();
        b.step().unwrap();
        signal.raise();
        assert!(matches!(b.step(), Err(BackendError::Stopped { .. })));
        assert!(matches!(
            b.command(0.5, 0.0),
            Err(BackendError::Stopped { .. })
        ));
        drop(b);
        assert_eq!(sim.base().command(), (0.0, 0.0));
        signal.clear();
        let mut b = Interruptible::new(&mut sim, signal);
        assert!(b.reset(Pose::default()).is_ok());
    }
}
