//! Command-to-odometry round trip over ROS 2 on loopback: the backend's node publishes a `Twist`,
//! a robot node (in the same process, its own DDS participant) answers with an `Odometry` carrying
//! that speed, and the time until it arrives is measured. Median and p99 are printed over 2,000
//! round trips, then criterion times the same.
//!
//! Like the tests, it runs only inside a private network namespace with only loopback: the binary
//! re-executes itself in one (see tests/ros2/netns.rs), or prints why not and measures nothing.

#[path = "../tests/ros2/netns.rs"]
mod netns;
#[path = "../tests/python/mod.rs"]
mod python;

use std::hint::black_box;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use advise::backend::ros2::Ros2Spec;
use advise::backend::ros2::msg::{ODOMETRY_TYPE, Odometry, TWIST_TYPE, Time, Twist};
use advise::backend::ros2::{Ros2Node, command_qos, odometry_publisher_qos, odometry_qos};
use advise::trace::Pose;
use criterion::Criterion;
use ros2_client::{Publisher, Subscription};

struct Pair {
    cmd: Publisher<Twist>,
    odom: Subscription<Odometry>,
    _node: Ros2Node,
    stop: Arc<AtomicBool>,
    echo: Option<std::thread::JoinHandle<()>>,
    next: f64,
}

impl Pair {
    fn new() -> Pair {
        let spec = Ros2Spec {
            domain_id: Some(0),
            ..Ros2Spec::default()
        };
        let stop = Arc::new(AtomicBool::new(false));
        let echo = {
            let spec = spec.clone();
            let stop = stop.clone();
            let (ready_tx, ready_rx) = std::sync::mpsc::channel();
            let h = std::thread::spawn(move || {
                let mut robot = Ros2Node::open(&spec, "bench_robot").expect("robot node");
                let cmds = robot
                    .subscription::<Twist>(&spec.cmd(), TWIST_TYPE, command_qos())
                    .expect("cmd_vel");
                let odom = robot
                    .publisher::<Odometry>(&spec.odom(), ODOMETRY_TYPE, odometry_publisher_qos())
                    .expect("odom");
                let _ = ready_tx.send(());
                while !stop.load(Ordering::Relaxed) {
                    match cmds.take() {
                        Ok(Some((t, _))) => {
                            let o = Odometry::planar(
                                Time::default(),
                                "odom",
                                "base_link",
                                Pose::default(),
                                t.linear.x,
                                0.0,
                            );
                            let _ = odom.publish(o);
                        }
                        _ => std::thread::yield_now(),
                    }
                }
            });
            ready_rx.recv().expect("the robot node starts");
            h
        };
        let mut node = Ros2Node::open(&spec, "bench_driver").expect("driver node");
        let cmd = node
            .publisher(&spec.cmd(), TWIST_TYPE, command_qos())
            .expect("cmd_vel");
        let odom = node
            .subscription(&spec.odom(), ODOMETRY_TYPE, odometry_qos())
            .expect("odom");
        let mut pair = Pair {
            cmd,
            odom,
            _node: node,
            stop,
            echo: Some(echo),
            next: 0.0,
        };
        // Discovery: round trips until one answers (bounded).
        let began = Instant::now();
        while pair.round_trip(Duration::from_millis(200)).is_none() {
            assert!(
                began.elapsed() < Duration::from_secs(30),
                "the robot never answered"
            );
        }
        pair
    }

    /// One command out, its odometry back; `None` after `limit`.
    fn round_trip(&mut self, limit: Duration) -> Option<Duration> {
        self.next += 1.0;
        let want = self.next;
        let t0 = Instant::now();
        self.cmd.publish(Twist::planar(want, 0.0)).ok()?;
        while t0.elapsed() < limit {
            match self.odom.take() {
                Ok(Some((o, _))) if o.twist.twist.linear.x == want => return Some(t0.elapsed()),
                Ok(Some(_)) => {}
                _ => std::thread::yield_now(),
            }
        }
        None
    }
}

impl Drop for Pair {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.echo.take() {
            let _ = h.join();
        }
    }
}

fn main() {
    if !netns::inside() {
        let exe = std::env::current_exe().expect("the bench binary's path");
        let mut cmd = std::process::Command::new(exe);
        cmd.args(std::env::args_os().skip(1));
        match netns::spawn_isolated(cmd) {
            Ok(mut child) => {
                let status = netns::wait_bounded(&mut child, Duration::from_secs(600));
                std::process::exit(status.and_then(|s| s.code()).unwrap_or(1));
            }
            Err(e) => {
                eprintln!(
                    "ros2 bench skipped: cannot create a private network namespace with only loopback ({e})"
                );
                return;
            }
        }
    }
    let mut pair = Pair::new();
    let mut samples: Vec<Duration> = (0..2000)
        .filter_map(|_| pair.round_trip(Duration::from_secs(1)))
        .collect();
    samples.sort();
    if !samples.is_empty() {
        let q = |f: f64| samples[((samples.len() - 1) as f64 * f).round() as usize];
        println!(
            "ros2 command-to-odometry round trip on loopback: median {:?}, p99 {:?} over {} round trips",
            q(0.5),
            q(0.99),
            samples.len()
        );
    }
    let mut c = Criterion::default().configure_from_args();
    c.bench_function("ros2_cmd_to_odom_round_trip", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                total += black_box(pair.round_trip(Duration::from_secs(1)))
                    .unwrap_or(Duration::from_secs(1));
            }
            total
        })
    });
    c.final_summary();
}
