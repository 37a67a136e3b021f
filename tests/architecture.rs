//! The import graph follows the pipeline. Between crates the compiler keeps it (issues 32, 50):
//! `advise-lang` knows no other crate of ours, `advise-learn` and `advise-lsp` only the language,
//! the library `advise` the language and the learners, the front ends (`advise-cli` at the root,
//! `advise-py`) the library. Inside a crate, a module uses only the modules before it in its
//! `LAYERS`, so there is no cycle between phases (issue 16): `syntax` cannot reach for `check`, a
//! backend for the session. A new top-level module must be placed in the order. Inside a module,
//! no file imports another that imports it back, however long the way round (issue 50).

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
        "crates/advise/src",
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
            "choice",
            "progress",
            "backend",
            "task",
            "eval",
            "recording",
            "experiment",
            "session",
        ],
    ),
    ("src", &["repl", "terminal", "web", "cli"]),
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

/// Every crate's source folder, for the checks that cover all of them.
const SOURCES: &[&str] = &[
    "crates/advise-lang/src",
    "crates/advise-learn/src",
    "crates/advise-lsp/src",
    "crates/advise/src",
    "src",
    "crates/advise-py/src",
];

/// A file's module path under its crate's `src`: `session/record.rs` is `session::record`,
/// `session.rs` is `session`, `lib.rs` and `main.rs` the crate itself.
fn module_of(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if let Some(last) = parts.last_mut() {
        *last = last.trim_end_matches(".rs").to_string();
    }
    if parts.len() == 1 && (parts[0] == "lib" || parts[0] == "main") {
        parts.clear();
    }
    parts
}

/// The code of `text` without comments and string literals (a path in either is not an import).
fn code_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut in_str = false;
        let mut prev = ' ';
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            if in_str {
                if c == '"' && prev != '\\' {
                    in_str = false;
                }
                prev = if prev == '\\' && c == '\\' { ' ' } else { c };
                continue;
            }
            if c == '/' && chars.peek() == Some(&'/') {
                break;
            }
            if c == '"' {
                in_str = true;
                prev = ' ';
                continue;
            }
            // A char literal (`'{'`, `'\''`), not a lifetime (`'a`): left out.
            if c == '\'' {
                let ahead: Vec<char> = chars.clone().take(3).collect();
                if ahead.first() == Some(&'\\') {
                    let mut skipped = 0;
                    for d in chars.by_ref() {
                        skipped += 1;
                        if d == '\'' && skipped > 2 {
                            break;
                        }
                    }
                    continue;
                }
                if ahead.get(1) == Some(&'\'') {
                    chars.next();
                    chars.next();
                    continue;
                }
            }
            out.push(c);
        }
        out.push('\n');
    }
    out
}

/// Every path `use` statements and code name in `code` that starts at `crate`, `super` or `self`,
/// as its segments (a `use` tree's groups expanded).
fn paths_in(code: &str) -> Vec<Vec<String>> {
    fn expand(tree: &str, prefix: &[String], out: &mut Vec<Vec<String>>) {
        let tree = tree.trim();
        if tree.is_empty() {
            return;
        }
        // Split at the first top-level `{`.
        if let Some(open) = tree.find('{') {
            let head: Vec<String> = tree[..open]
                .split("::")
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .collect();
            let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
            let mut base = prefix.to_vec();
            base.extend(head);
            let mut depth = 0;
            let mut start = 0;
            for (i, c) in inner.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        expand(&inner[start..i], &base, out);
                        start = i + 1;
                    }
                    _ => {}
                }
            }
            expand(&inner[start..], &base, out);
        } else {
            let item = tree.split(" as ").next().unwrap_or(tree);
            let mut path = prefix.to_vec();
            path.extend(
                item.split("::")
                    .map(|s| s.trim().to_string())
                    .filter(|s| !s.is_empty()),
            );
            out.push(path);
        }
    }
    let mut out = Vec::new();
    // `use` statements, over lines.
    let mut rest = code;
    while let Some(i) = rest.find("use ") {
        let before = rest[..i].chars().last();
        rest = &rest[i + 4..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let end = rest.find(';').unwrap_or(rest.len());
        expand(&rest[..end], &[], &mut out);
    }
    // Paths in code: `crate::a::b`, `super::a`.
    for start in ["crate::", "super::", "self::"] {
        let mut rest = code;
        while let Some(i) = rest.find(start) {
            let before = rest[..i].chars().last();
            let tail = &rest[i..];
            rest = &rest[i + start.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            let path: String = tail
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                .collect();
            out.push(
                path.split("::")
                    .filter(|s| !s.is_empty())
                    .map(str::to_string)
                    .collect(),
            );
        }
    }
    out.retain(|p| {
        p.first()
            .is_some_and(|f| f == "crate" || f == "super" || f == "self")
    });
    out
}

/// The files of one crate and which of them each imports: an edge for every path that names
/// another file's module (or an item in it), leaving out a file's own ancestors and descendants
/// (a module declares its children and they see it: Rust's own tree, not an import).
fn file_graph(src: &Path) -> (Vec<String>, Vec<Vec<usize>>) {
    let (names, edges, _) = file_graph_named(src);
    (names, edges)
}

/// [`file_graph`], with the path that made each edge.
#[allow(clippy::type_complexity)]
fn file_graph_named(src: &Path) -> (Vec<String>, Vec<Vec<usize>>, Vec<Vec<String>>) {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let modules: Vec<Vec<String>> = files
        .iter()
        .map(|f| module_of(f.strip_prefix(src).unwrap()))
        .collect();
    let index: BTreeMap<Vec<String>, usize> = modules
        .iter()
        .enumerate()
        .map(|(i, m)| (m.clone(), i))
        .collect();
    let mut edges = vec![Vec::new(); files.len()];
    let mut why = vec![Vec::new(); files.len()];
    for (i, file) in files.iter().enumerate() {
        let own = &modules[i];
        let code = code_only(&std::fs::read_to_string(file).unwrap());
        for path in paths_in(&code) {
            let mut at: Vec<String> = Vec::new();
            let mut segs = path.iter().peekable();
            match segs.peek().map(|s| s.as_str()) {
                Some("crate") => {
                    segs.next();
                }
                Some("self") => {
                    at = own.clone();
                    segs.next();
                }
                _ => {
                    at = own.clone();
                    while segs.peek().is_some_and(|s| *s == "super") {
                        segs.next();
                        at.pop();
                    }
                }
            }
            // The longest prefix that is a file's module.
            let mut target = index.get(&at).copied();
            for seg in segs {
                at.push(seg.clone());
                match index.get(&at) {
                    Some(&t) => target = Some(t),
                    None => break,
                }
            }
            let Some(t) = target else { continue };
            let other = &modules[t];
            let related = other.starts_with(own) || own.starts_with(other);
            if t != i && !related && !edges[i].contains(&t) {
                edges[i].push(t);
                why[i].push(path.join("::"));
            }
        }
    }
    let names = files
        .iter()
        .map(|f| f.strip_prefix(src).unwrap().display().to_string())
        .collect();
    (names, edges, why)
}

/// The strongly connected components of more than one file (Tarjan's algorithm).
fn circles(edges: &[Vec<usize>]) -> Vec<Vec<usize>> {
    struct State<'a> {
        edges: &'a [Vec<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(s: &mut State<'_>, v: usize) {
        s.index[v] = Some(s.next);
        s.low[v] = s.next;
        s.next += 1;
        s.stack.push(v);
        s.on_stack[v] = true;
        for &w in &s.edges[v] {
            match s.index[w] {
                None => {
                    visit(s, w);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(iw) if s.on_stack[w] => s.low[v] = s.low[v].min(iw),
                Some(_) => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
            }
        }
    }
    let n = edges.len();
    let mut s = State {
        edges,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if s.index[v].is_none() {
            visit(&mut s, v);
        }
    }
    s.out
}

#[test]
fn no_file_imports_one_that_imports_it_back() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    let mut scanned = 0;
    for dir in SOURCES {
        let (names, edges, why) = file_graph_named(&root.join(dir));
        scanned += names.len();
        for comp in circles(&edges) {
            let files: Vec<String> = comp.iter().map(|&i| names[i].clone()).collect();
            found.push(format!("{dir}: {}", files.join(" <-> ")));
            for &i in &comp {
                for (k, &t) in edges[i].iter().enumerate() {
                    if comp.contains(&t) {
                        found.push(format!("  {} uses {} ({})", names[i], names[t], why[i][k]));
                    }
                }
            }
        }
    }
    assert!(scanned > 150, "the scan found only {scanned} files");
    assert!(
        found.is_empty(),
        "files that import each other, however long the way round (break the circle: move \
         what both need into one of them or a file of its own):\n{}",
        found.join("\n")
    );
}

/// The file graph sees `use` trees, `super::` and code paths, and finds a circle of three.
#[test]
fn the_file_graph_finds_a_circle_through_groups_and_super() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("m")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod m;\n").unwrap();
    std::fs::write(src.join("m.rs"), "mod a; mod b; mod c;\n").unwrap();
    std::fs::write(
        src.join("m/a.rs"),
        "use super::{b::{X, Y}, other};\n// crate::m::c in a comment\n",
    )
    .unwrap();
    std::fs::write(
        src.join("m/b.rs"),
        "fn f() { crate::m::c::g(\"crate::m::a\") }\n",
    )
    .unwrap();
    std::fs::write(src.join("m/c.rs"), "use crate::m::{self, a::Z};\n").unwrap();
    let (names, edges) = file_graph(src);
    let found: Vec<Vec<String>> = circles(&edges)
        .into_iter()
        .map(|c| c.into_iter().map(|i| names[i].clone()).collect())
        .collect();
    assert_eq!(found, [["m/a.rs", "m/b.rs", "m/c.rs"]]);
    // Without c's import of a, no circle; m.rs (their parent) is never one.
    std::fs::write(src.join("m/c.rs"), "use crate::m::self;\nuse super::Q;\n").unwrap();
    let (_, edges) = file_graph(src);
    assert!(circles(&edges).is_empty());
}

/// Every function of more than `limit` lines in `code` (comments and strings stripped, so a brace
/// in either does not count): its name, its first line (1-based) and its length.
fn long_functions(code: &str, limit: usize) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let t = lines[i].trim_start();
        let t = t
            .strip_prefix("pub(crate) ")
            .or_else(|| t.strip_prefix("pub(super) "))
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        let t = t.strip_prefix("const ").unwrap_or(t);
        let Some(rest) = t.strip_prefix("fn ") else {
            i += 1;
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // The body: from the first `{` after the signature to its match (a declaration without
        // a body, `fn f();`, ends at its `;`).
        let mut depth = 0usize;
        let mut opened = false;
        let mut end = i;
        'scan: for (k, line) in lines.iter().enumerate().skip(i) {
            for c in line.chars() {
                match c {
                    ';' if !opened && depth == 0 => {
                        end = k;
                        break 'scan;
                    }
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => {
                        depth = depth.saturating_sub(1);
                        if opened && depth == 0 {
                            end = k;
                            break 'scan;
                        }
                    }
                    _ => {}
                }
            }
        }
        let len = end + 1 - i;
        if opened && len > limit {
            out.push((name, i + 1, len));
        }
        // Functions inside this one are counted as part of it.
        i = end.max(i) + 1;
    }
    out
}

/// The most functions over 150 lines the crates may hold, each with its reason.
const LONG_FUNCTIONS_ALLOWED: usize = 3;

#[test]
fn few_functions_are_long_and_each_says_why() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut long = Vec::new();
    let mut unexplained = Vec::new();
    for dir in SOURCES {
        let mut files = Vec::new();
        rust_files(&root.join(dir), &mut files);
        files.sort();
        for file in files {
            let text = std::fs::read_to_string(&file).unwrap();
            let raw: Vec<&str> = text.lines().collect();
            let shown = file.strip_prefix(root).unwrap().display().to_string();
            for (name, line, len) in long_functions(&code_only(&text), 150) {
                long.push(format!("{shown}:{line}: `{name}`, {len} lines"));
                // Its doc comment (the lines above, through attributes) gives the reason.
                let doc: Vec<&str> = raw[..line - 1]
                    .iter()
                    .rev()
                    .take_while(|l| {
                        let l = l.trim_start();
                        l.starts_with("///") || l.starts_with("#[")
                    })
                    .copied()
                    .collect();
                if !doc.iter().any(|l| l.contains("Over 150 lines because")) {
                    unexplained.push(format!("{shown}:{line}: `{name}`"));
                }
            }
        }
    }
    eprintln!("functions over 150 lines:\n{}", long.join("\n"));
    assert!(
        unexplained.is_empty(),
        "functions over 150 lines without \"Over 150 lines because ...\" in their doc:\n{}",
        unexplained.join("\n")
    );
    assert!(
        long.len() <= LONG_FUNCTIONS_ALLOWED,
        "{} functions over 150 lines (at most {LONG_FUNCTIONS_ALLOWED}): split some\n{}",
        long.len(),
        long.join("\n")
    );
}

#[test]
fn the_length_scan_counts_bodies_not_braces_in_strings() {
    let body = "    x();\n".repeat(160);
    let text = format!(
        "/// Over 150 lines because a test says so.\nfn long() {{\n    let s = \"}}}}\"; // }}\n    let c = ('}}', '\\'', '\\u{{7d}}');\n{body}}}\nfn short<'a>(x: &'a str) {{}}\nfn decl();\n"
    );
    let found = long_functions(&code_only(&text), 150);
    assert_eq!(found, [("long".to_string(), 2, 164)]);
}
