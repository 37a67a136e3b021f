//! The Python package `advise` (crates/advise-py, python/advise, issue 38), tested from Python:
//! the extension is built with maturin into a wheel and installed in a virtual environment under
//! the target directory (pinned numpy, gymnasium, pytest, maturin), then
//! `tests/python/test_advise_*.py` run under pytest against it and the built `advise` binary.
//!
//! The extension builds in the target directory `cargo test` itself uses, at the `dev` profile,
//! so the dependency tree it shares with the `advise` crate is built once (Cargo 1.95 holds the
//! directory's lock while it builds, not while the test binaries run: the nested build does not
//! wait). Only pyo3, numpy and the extension are compiled for it: about 1.5 minutes cold here,
//! against 5.8 when it had a target directory of its own; once built, the test takes seconds.
//! No Python 3: the test skips saying why (with `ADVISE_REQUIRE_PEERS=1` it fails instead).

#[path = "python/mod.rs"]
mod python;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

const PACKAGES: [&str; 8] = [
    "numpy==2.4.6",
    "gymnasium==1.4.0",
    "pytest==9.2.0",
    "maturin==1.16.0",
    // The LeRobot tests (test_advise_lerobot.py), the versions tests/bags.rs pins.
    "pyarrow==26.0.1",
    "pandas==2.3.3",
    // A rosbag2 bag for `advise.load_demos` (test_advise_demos.py), the version tests/bags.rs pins.
    "rosbags==0.11.9",
    // The README's Ray example (test_advise_readme.py runs it): 11 s to install here.
    "ray==2.60.0",
];

#[test]
fn the_python_package_passes_its_pytest_files() {
    let probe = "import numpy, gymnasium, pytest, maturin, pyarrow, pandas, ray, rosbags";
    let python = match python::venv("advise", &PACKAGES, probe) {
        Ok(p) => p,
        Err(why) => {
            eprintln!("skipped: the Python package's tests need Python 3 with pip: {why}");
            return;
        }
    };
    if let Err(why) = python::install_advise(&python, "py-pkg-wheels") {
        panic!("the Python package did not build and install: {why}");
    }
    let root = env!("CARGO_MANIFEST_DIR");
    let files: Vec<String> = std::fs::read_dir(Path::new(root).join("tests/python"))
        .expect("tests/python exists")
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("test_advise_") && n.ends_with(".py"))
        })
        .map(|p| p.display().to_string())
        .collect();
    assert!(!files.is_empty(), "no tests/python/test_advise_*.py");
    let mut child = Command::new(&python)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .args(&files)
        .current_dir(root)
        .env("ADVISE_BIN", env!("CARGO_BIN_EXE_advise"))
        // The installed package, not python/advise of the source tree.
        .env_remove("PYTHONPATH")
        .stdout(Stdio::inherit())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("pytest starts");
    let status = python::wait_bounded(&mut child, Duration::from_secs(600));
    assert!(
        status.is_some_and(|s| s.success()),
        "pytest failed or timed out: {status:?}"
    );
}
