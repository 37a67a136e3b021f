//! Python test peers' environments: one virtual environment per purpose, made once under the
//! target directory (reused across runs) with pinned packages from pip. No Python, no venv module
//! or a package that does not install: `Err` with the reason, and the test skips printing it.
//!
//! Use it from a test file with `#[path = "python/mod.rs"] mod python;` (or `mod python;` from a
//! test's own folder) and `python::venv("NAME", &["pkg==1.2.3"], "import pkg")`.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Waits for `child` at most `limit` (polling), killing it past that.
pub fn wait_bounded(child: &mut Child, limit: Duration) -> Option<ExitStatus> {
    let start = Instant::now();
    loop {
        if let Ok(Some(status)) = child.try_wait() {
            return Some(status);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Runs `cmd` to its end within `limit`; its stderr is the error's text on failure.
pub fn run(cmd: &mut Command, limit: Duration) -> Result<(), String> {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{cmd:?}: {e}"))?;
    let stderr = child.stderr.take();
    match wait_bounded(&mut child, limit) {
        Some(s) if s.success() => Ok(()),
        Some(s) => {
            let mut text = String::new();
            if let Some(mut e) = stderr {
                let _ = std::io::Read::read_to_string(&mut e, &mut text);
            }
            Err(format!("{cmd:?} failed ({s}): {}", text.trim()))
        }
        None => Err(format!("{cmd:?} took longer than {limit:?}")),
    }
}

/// The Python of the virtual environment `py-venv-NAME` under the target directory, with
/// `packages` installed; `probe` is Python code that succeeds only when they are usable. Made once
/// and reused while `probe` passes.
///
/// With `ADVISE_REQUIRE_PEERS=1` (as `.ci/run` sets where Python 3 is), a peer that cannot be
/// made fails the test instead: an interoperability test must not pass by skipping unnoticed.
pub fn venv(name: &str, packages: &[&str], probe: &str) -> Result<PathBuf, String> {
    // Tests of one file run in parallel threads: one makes a venv while the others wait, instead
    // of racing `python -m venv` into the same folder.
    static MAKING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = MAKING.lock().unwrap_or_else(|e| e.into_inner());
    // Other processes too (another test binary, or `.ci/run` installing LeRobot's venv beside the
    // build) make it under the same lock, `flock(2)` on `py-venv-NAME.lock`.
    let made = locked(name).and_then(|_lock| make_venv(name, packages, probe));
    if let Err(why) = &made
        && std::env::var("ADVISE_REQUIRE_PEERS").is_ok_and(|v| v == "1")
    {
        panic!("ADVISE_REQUIRE_PEERS=1, but the Python peer `{name}` cannot be made: {why}");
    }
    made
}

/// The lock on making the venv `name`, waited for at most 20 minutes.
fn locked(name: &str) -> Result<std::fs::File, String> {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("py-venv-{name}.lock"));
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let start = Instant::now();
    loop {
        match file.try_lock() {
            Ok(()) => return Ok(file),
            Err(std::fs::TryLockError::WouldBlock) if start.elapsed() < LOCK_WAIT => {
                std::thread::sleep(Duration::from_millis(500));
            }
            Err(e) => {
                return Err(format!(
                    "{}: {e} (waited {:?})",
                    path.display(),
                    start.elapsed()
                ));
            }
        }
    }
}

/// How long a test waits for another process making the same venv.
const LOCK_WAIT: Duration = Duration::from_secs(20 * 60);

/// The packages of a requirements file under tests/python (`#` comments and blank lines left out).
pub fn requirements(file: &str) -> Vec<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(file);
    std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim().to_string())
        .filter(|l| !l.is_empty())
        .collect()
}

fn make_venv(name: &str, packages: &[&str], probe: &str) -> Result<PathBuf, String> {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("py-venv-{name}"));
    let python = dir.join("bin").join("python");
    let usable = |p: &Path| run(Command::new(p).args(["-c", probe]), Duration::from_secs(60));
    if python.exists() && usable(&python).is_ok() {
        return Ok(python);
    }
    run(
        Command::new("python3").args(["-m", "venv", &dir.to_string_lossy()]),
        Duration::from_secs(120),
    )?;
    let mut pip = Command::new(&python);
    pip.args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
    ])
    .args(packages);
    run(&mut pip, Duration::from_secs(600))?;
    usable(&python).map(|()| python)
}

/// Build the wheel of the Python package `advise` with the venv's maturin, in the target directory
/// `cargo test` uses (see tests/python_pkg.rs), into `target/WHEELS`, and install it in that venv.
///
/// The wheel is built for the interpreter the venv was made from, not for the venv's own path:
/// every venv here comes from the same `python3`, so the Python package's test and LeRobot's
/// build the extension with one PyO3 configuration, and the second build reuses the first's
/// artifacts instead of compiling the extension again (13 s warm here, more cold).
pub fn install_advise(python: &Path, wheels: &str) -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let target = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .map_or_else(|| root.join("target"), Path::to_path_buf);
    let wheels = target.join(wheels);
    let _ = std::fs::remove_dir_all(&wheels);
    let interpreter = base_interpreter(python);
    let mut build = Command::new(python);
    build
        .args([
            "-m",
            "maturin",
            "build",
            "--profile",
            "dev",
            "--interpreter",
        ])
        .arg(&interpreter)
        .arg("--out")
        .arg(&wheels)
        .current_dir(root)
        .env("CARGO_TARGET_DIR", &target);
    run(&mut build, Duration::from_secs(1800))?;
    let wheel: PathBuf = std::fs::read_dir(&wheels)
        .map_err(|e| format!("{}: {e}", wheels.display()))?
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .ok_or_else(|| format!("maturin wrote no wheel to {}", wheels.display()))?;
    run(
        Command::new(python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--no-deps",
                "--force-reinstall",
            ])
            .arg(&wheel),
        Duration::from_secs(300),
    )
}

/// The interpreter the venv of `python` was made from (`sys._base_executable`), or `python`
/// itself where that cannot be told.
fn base_interpreter(python: &Path) -> PathBuf {
    let out = Command::new(python)
        .args(["-c", "import sys; print(sys._base_executable)"])
        .output();
    match out {
        Ok(o) if o.status.success() => {
            let base = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim());
            if base.is_file() {
                base
            } else {
                python.to_path_buf()
            }
        }
        _ => python.to_path_buf(),
    }
}

/// What the Python peer `tests/python/SCRIPT` prints as JSON for `arg`; it must succeed.
pub fn peer_json(py: &Path, script: &str, arg: &Path) -> serde_json::Value {
    let out = Command::new(py)
        .arg(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/python")
                .join(script),
        )
        .arg(arg)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}
