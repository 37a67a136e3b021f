//! The Cyclone DDS robot (tests/peers/ros2_robot.py) and the Python environment it needs.
//!
//! The parent test process makes (once, reused across runs) a virtual environment under the
//! target directory with `cyclonedds==11.0.1`, whose wheel ships the C library; the namespaced
//! child runs the peer from it. No Python, no venv module or no package: the test is skipped with
//! the reason printed.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

pub const PYTHON_ENV: &str = "ADVISE_TEST_PYTHON";

/// Cyclone DDS on a loopback-only namespace: use `lo`, and multicast on it (off by default there).
pub const CYCLONE_URI: &str = r#"<CycloneDDS><Domain><General><Interfaces><NetworkInterface name="lo" multicast="true"/></Interfaces><AllowMulticast>true</AllowMulticast></General></Domain></CycloneDDS>"#;

/// Cyclone DDS as ROS 2's LOCALHOST discovery range sets it up (rmw_cyclonedds): no multicast,
/// unicast discovery to 127.0.0.1, a well-known port (`ParticipantIndex` auto).
pub const CYCLONE_UNICAST_URI: &str = r#"<CycloneDDS><Domain><General><Interfaces><NetworkInterface name="lo" multicast="false"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers></Discovery></Domain></CycloneDDS>"#;

/// The venv's Python with `cyclonedds` (made once per test process), or why not.
pub fn python() -> Result<PathBuf, String> {
    static PY: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    PY.get_or_init(|| {
        super::python::venv(
            "cyclonedds",
            &["cyclonedds==11.0.1"],
            "import cyclonedds.domain",
        )
    })
    .clone()
}

/// The running peer: killed when dropped.
pub struct Peer {
    pub child: Child,
    pub log: PathBuf,
    lines: Receiver<String>,
}

impl Peer {
    /// Start the peer with `args` (after `--log`) and wait (bounded) until it is publishing.
    pub fn start(dir: &Path, args: &[&str]) -> Peer {
        Peer::start_with(dir, args, CYCLONE_URI)
    }

    /// [`Peer::start`] with Cyclone DDS configured by `uri` (`CYCLONEDDS_URI`).
    pub fn start_with(dir: &Path, args: &[&str], uri: &str) -> Peer {
        let python = std::env::var(PYTHON_ENV).expect("the parent passes the venv's python");
        let log = dir.join("commands.log");
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/ros2_robot.py");
        let mut child = Command::new(python)
            .arg(script)
            .arg("--log")
            .arg(&log)
            .args(args)
            .env("CYCLONEDDS_URI", uri)
            .stdout(Stdio::piped())
            .spawn()
            .expect("the peer starts");
        let out = child.stdout.take().expect("piped");
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut peer = Peer { child, log, lines };
        peer.expect_line("ready", Duration::from_secs(30));
        peer
    }

    /// Wait (bounded) for the peer to print `want`.
    pub fn expect_line(&mut self, want: &str, limit: Duration) {
        let began = Instant::now();
        while began.elapsed() < limit {
            match self.lines.recv_timeout(Duration::from_millis(100)) {
                Ok(l) if l.trim() == want => return,
                Ok(_) => {}
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                Err(_) => break,
            }
        }
        panic!("the peer did not print `{want}` within {limit:?}");
    }

    /// Every command the robot received: `(t_s, v, w)`.
    pub fn commands(&self) -> Vec<(f64, f64, f64)> {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        text.lines()
            .filter_map(|l| {
                let mut f = l.split_whitespace().map(|x| x.parse::<f64>());
                Some((f.next()?.ok()?, f.next()?.ok()?, f.next()?.ok()?))
            })
            .collect()
    }

    /// When the peer began publishing corrupt odometry (`--odom-bad-after`), on the commands' clock.
    pub fn bad_since(&self) -> Option<f64> {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        text.lines()
            .find_map(|l| l.strip_prefix("# bad ")?.trim().parse().ok())
    }

    /// Wait (bounded) until `pred` holds on the received commands.
    pub fn wait_for(&self, limit: Duration, pred: impl Fn(&[(f64, f64, f64)]) -> bool) -> bool {
        let began = Instant::now();
        while began.elapsed() < limit {
            if pred(&self.commands()) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
