//! The import graph follows the pipeline. Between crates the compiler keeps it (issue 32):
//! `advise-lang` knows no other crate of ours, `advise-learn` and `advise-lsp` only the language,
//! the application all three. Inside a crate, a module uses only the modules before it in its
//! `LAYERS`, so there is no cycle between phases (issue 16): `syntax` cannot reach for `check`, a
//! backend for the session. A new top-level module must be placed in the order.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Each crate's source folder and its top-level modules, each allowed to use only those listed
/// before it. The application's first entries are the libraries it re-exports (`crate::check`
/// is `advise_lang::check`), which any of its own modules may use.
const CRATES: &[(&str, &[&str])] = &[
    (
        "crates/advise-lang/src",
        &[
            "diag", "number", "files", "geometry", "domain", "syntax", "trace", "program", "check",
            "interp", "doctest",
        ],
    ),
    (
        "crates/advise-learn/src",
        &["Policy", "exp", "index", "dataset", "bc", "lwr", "learner"],
    ),
    ("crates/advise-lsp/src", &["frame", "analysis"]),
    (
        "src",
        &[
            "diag",
            "number",
            "files",
            "geometry",
            "domain",
            "syntax",
            "trace",
            "program",
            "check",
            "interp",
            "doctest",
            "policy",
            "lsp",
            "backend",
            "task",
            "eval",
            "recording",
            "experiment",
            "session",
            "repl",
            "web",
            "cli",
        ],
    ),
];

/// Every `crate::NAME` in code (comments and doc links are not imports) of `file`, with its line.
fn uses(file: &Path) -> Vec<(String, usize)> {
    let text = std::fs::read_to_string(file).unwrap();
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + "crate::".len()..];
            if let Some(group) = rest.strip_prefix('{') {
                let inner = group.split('}').next().unwrap_or("");
                for item in inner.split(',') {
                    let name: String = item
                        .trim()
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    if !name.is_empty() {
                        out.push((name, n + 1));
                    }
                }
            } else {
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                out.push((name, n + 1));
            }
        }
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn each_module_uses_only_the_modules_before_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut wrong = Vec::new();
    let mut scanned = 0;
    for (dir, layers) in CRATES {
        let src = root.join(dir);
        let mut files = Vec::new();
        rust_files(&src, &mut files);
        files.sort();
        scanned += files.len();
        let rank: BTreeMap<&str, usize> = layers.iter().enumerate().map(|(i, m)| (*m, i)).collect();
        for file in &files {
            let rel = file.strip_prefix(&src).unwrap();
            let first = rel
                .components()
                .next()
                .unwrap()
                .as_os_str()
                .to_string_lossy();
            let module = first.trim_end_matches(".rs");
            let shown = format!("{dir}/{}", rel.display());
            if module == "lib" || module == "main" {
                continue;
            }
            let Some(&own) = rank.get(module) else {
                wrong.push(format!(
                    "{shown}: module `{module}` is not in LAYERS; place it in the pipeline's order"
                ));
                continue;
            };
            for (used, line) in uses(file) {
                if used == module {
                    continue;
                }
                match rank.get(used.as_str()) {
                    Some(&r) if r < own => {}
                    Some(_) => wrong.push(format!(
                        "{shown}:{line}: `{module}` uses `{used}`, which comes after it in the pipeline"
                    )),
                    None => wrong.push(format!(
                        "{shown}:{line}: `crate::{used}` is not a module in LAYERS"
                    )),
                }
            }
        }
    }
    assert!(scanned > 100, "the scan found only {scanned} files");
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// The scanner sees every form an import takes, so the test above can fail.
#[test]
fn the_scanner_finds_paths_and_groups_but_not_comments() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("x.rs");
    std::fs::write(
        &f,
        "use crate::task::TaskKind;\nuse crate::{eval, session::Session};\n// crate::repl in a comment\n/// [`crate::cli`]\nlet x = crate::check::bind(a);\n",
    )
    .unwrap();
    let got: Vec<String> = uses(&f).into_iter().map(|(m, _)| m).collect();
    assert_eq!(got, ["task", "eval", "session", "check"]);
}

/// Each diagnostic code names one mistake: no two error variants share a code, so a user (or a
/// test) that sees a code knows which one it was.
#[test]
fn each_diagnostic_code_is_defined_once() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for (dir, _) in CRATES {
        rust_files(&src.join(dir), &mut files);
    }
    files.sort();
    let mut seen: BTreeMap<String, String> = BTreeMap::new();
    let mut twice = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for (n, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(i) = rest.find("code(advise::") {
                rest = &rest[i + "code(".len()..];
                let code: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                    .collect();
                let at = format!("{}:{}", file.strip_prefix(src).unwrap().display(), n + 1);
                if let Some(first) = seen.get(&code) {
                    twice.push(format!("{code}: {first} and {at}"));
                } else {
                    seen.insert(code, at);
                }
            }
        }
    }
    assert!(seen.len() > 100, "the scan found only {} codes", seen.len());
    assert!(twice.is_empty(), "codes used twice:\n{}", twice.join("\n"));
}
