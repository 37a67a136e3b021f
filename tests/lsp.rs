//! `advise lsp` end to end over stdio, driven by a client this project did not write: pytest-lsp
//! (pygls's language client) runs `tests/python/test_lsp.py` against the built binary, covering
//! diagnostics on open and change, hover, completion, definition (in the document and in the
//! standard library), formatting, document symbols and a session script. Without Python or the
//! packages the test prints why and passes without running (fails with ADVISE_REQUIRE_PEERS=1).

#[path = "python/mod.rs"]
mod python;

use std::process::Command;
use std::time::Duration;

const PACKAGES: [&str; 7] = [
    "pytest-lsp==1.0.1",
    "pygls==2.1.1",
    "lsprotocol==2025.0.0",
    "pytest==9.2.0",
    "pytest-asyncio==1.5.0",
    "attrs==26.1.0",
    "cattrs==26.2.1",
];

#[test]
fn pytest_lsp_drives_every_capability() {
    let python = match python::venv("lsp", &PACKAGES, "import pytest_lsp, pygls, lsprotocol") {
        Ok(p) => p,
        Err(why) => {
            eprintln!("skipping: no Python with pytest-lsp ({why})");
            return;
        }
    };
    let cache = tempfile::tempdir().unwrap();
    let out = {
        let mut cmd = Command::new(&python);
        cmd.args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .args(["-o", "asyncio_default_fixture_loop_scope=function"])
            .arg(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/tests/python/test_lsp.py"
            ))
            .env("ADVISE_BIN", env!("CARGO_BIN_EXE_advise"))
            .env("ADVISE_LSP_CACHE", cache.path())
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::inherit());
        let mut child = cmd.spawn().unwrap();
        let stdout = child.stdout.take().unwrap();
        let reader = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = std::io::Read::read_to_string(&mut { stdout }, &mut s);
            s
        });
        let status = python::wait_bounded(&mut child, Duration::from_secs(180));
        let text = reader.join().unwrap();
        (status, text)
    };
    let (status, text) = out;
    assert!(
        status.is_some_and(|s| s.success()),
        "pytest-lsp failed ({status:?}):\n{text}"
    );
    assert!(text.contains("7 passed"), "{text}");
}
