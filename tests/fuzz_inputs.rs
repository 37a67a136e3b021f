//! Hostile inputs, bounded: a seeded mutator (byte flips, deletions, duplicated slices, spliced
//! tokens) over the inputs a user hands the program — the standard operator files through parse
//! and check (and every operator that checks, applied to a chunk), the example session scripts'
//! statements through `Session::execute`, a saved dataset through the dataset loader and the
//! learner, simulator parameters through their loader and the base, a session journal through
//! `Session::restore`. Every input must come back as
//! a value or as a diagnostic whose code, and the code of every diagnostic inside it, starts with
//! `advise::`; a panic is a failure. A few thousand mutants, each capped in size, so the whole file
//! runs in seconds in the test profile.
//!
//! What the session target leaves out, and why: statements that write files (`save`, `plot`,
//! `export`; a mutated path could land anywhere), `backend` other than `sim` (a mutated address
//! would send UDP off this machine), and `load demos teacher:N` above 12 and `eval` (legitimate
//! work measured in seconds, which would make the test slow rather than find a fault).

use std::panic::{AssertUnwindSafe, catch_unwind};

use advise::backend::sim::{SimBase, SimParams};
use advise::check::{self, OperatorSet, Source};
use advise::diag::SourceMap;
use advise::domain::Domain;
use advise::interp;
use advise::policy::dataset::Dataset;
use advise::policy::learner::{Learner, LearnerKind};
use advise::session::{Session, SessionOptions, script};
use advise::syntax::Invocation;
use advise::task::TaskKind;
use advise::trace::{Chunk, Pose, Trace};
use miette::Diagnostic;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Tokens spliced into inputs: the languages' words and punctuation, and values that have broken
/// programs before (huge, tiny, negative, non-finite, overflowing integers).
const TOKENS: &[&str] = &[
    "operator",
    "domain",
    "for",
    "on",
    "action",
    "observation",
    "where",
    "then",
    "and",
    "or",
    "not",
    "positioning",
    "interception",
    "trans",
    "rot",
    "dist2",
    "bearing",
    "rate",
    "{",
    "}",
    "(",
    ")",
    "[",
    "]",
    ",",
    ";",
    "=",
    "==",
    "<=",
    "*=",
    "+=",
    "-",
    "/",
    "..",
    "0",
    "-1",
    "1.5",
    "1e999",
    "-1e308",
    "1e-320",
    "NaN",
    "inf",
    "18446744073709551615",
    "4294967296",
    "\"",
    "\\u0000",
    "null",
    "true",
    "[]",
    "{}",
    "\n",
    "///",
    "//",
    "run",
    "start",
    "goal",
    "select",
    "advise",
    "critique",
    "undo",
    "redo",
    "why",
    "show",
    "history",
    "rederive",
    "help",
    "task",
    "slow_down",
    "speed_up",
    "é",
    "\u{202e}",
];

/// Seeded byte-level mutations of `input`, at most `cap` bytes long (then made UTF-8).
struct Mutator {
    rng: ChaCha8Rng,
}

impl Mutator {
    fn new(seed: u64) -> Mutator {
        Mutator {
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    fn mutate(&mut self, input: &str, cap: usize) -> String {
        let mut b = input.as_bytes().to_vec();
        let rounds = self.rng.random_range(1..=4);
        for _ in 0..rounds {
            let len = b.len();
            let at = self.rng.random_range(0..=len);
            match self.rng.random_range(0..5) {
                0 if len > 0 => {
                    let i = at.min(len - 1);
                    b[i] ^= 1 << self.rng.random_range(0..8);
                }
                1 if len > 0 => {
                    let i = at.min(len - 1);
                    const BYTES: &[u8] = b"0123456789.-e(){}[],;:\"\\ \n";
                    b[i] = BYTES[self.rng.random_range(0..BYTES.len())];
                }
                2 if len > 0 => {
                    let end = (at + self.rng.random_range(1..=16)).min(len);
                    b.drain(at.min(end)..end);
                }
                3 if len > 0 => {
                    let from = self.rng.random_range(0..len);
                    let end = (from + self.rng.random_range(1..=64)).min(len);
                    let slice = b[from..end].to_vec();
                    let times = self.rng.random_range(1..=8);
                    for _ in 0..times {
                        b.splice(at..at, slice.iter().copied());
                    }
                }
                _ => {
                    let t = TOKENS[self.rng.random_range(0..TOKENS.len())];
                    let sep: &[u8] = if self.rng.random_bool(0.5) { b" " } else { b"" };
                    b.splice(at..at, sep.iter().chain(t.as_bytes()).copied());
                }
            }
            b.truncate(cap);
        }
        String::from_utf8_lossy(&b).into_owned()
    }
}

/// Problems found (the input and what went wrong), and how many inputs were refused.
#[derive(Default)]
struct Findings(Vec<String>, usize);

impl Findings {
    /// Every code in the diagnostic tree starts with `advise::`.
    fn check_codes(&mut self, target: &str, input: &str, d: &dyn Diagnostic) {
        self.1 += 1;
        let mut bad = Vec::new();
        codes(d, &mut bad);
        if !bad.is_empty() {
            self.0.push(format!(
                "{target}: diagnostic without an advise:: code ({}) for {input:?}: {d}",
                bad.join(", ")
            ));
        }
    }

    /// Run `f`; a panic becomes a finding.
    fn guard(&mut self, target: &str, input: &str, f: impl FnOnce(&mut Findings)) {
        if catch_unwind(AssertUnwindSafe(|| f(self))).is_err() {
            self.0.push(format!("{target}: panic for {input:?}"));
        }
    }

    fn assert_none(self, what: &str, inputs: usize) {
        // The mutants must exercise both ways out, or the test proves nothing.
        assert!(
            self.1 * 10 >= inputs && self.1 < inputs,
            "{what}: {} of {inputs} inputs refused; the mutator should give both outcomes",
            self.1
        );
        assert!(
            self.0.is_empty(),
            "{} of {inputs} {what} inputs failed:\n{}",
            self.0.len(),
            self.0
                .iter()
                .take(10)
                .map(|f| f.chars().take(600).collect::<String>())
                .collect::<Vec<_>>()
                .join("\n")
        );
    }
}

fn codes(d: &dyn Diagnostic, bad: &mut Vec<String>) {
    match d.code().map(|c| c.to_string()) {
        Some(c) if c.starts_with("advise::") => {}
        Some(c) => bad.push(c),
        None => bad.push("no code".into()),
    }
    if let Some(related) = d.related() {
        for r in related {
            codes(r, bad);
        }
    }
}

fn read(path: &str) -> String {
    std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap()
}

/// A small positioning trace to apply operators to.
fn chunk_trace() -> Trace {
    let d = Domain::positioning();
    let mut t = Trace::new(&d);
    for i in 0..8 {
        let rot = if i % 2 == 0 { 0.0 } else { 0.3 };
        t.push(
            i as f64 / 30.0,
            &[2.0 - 0.1 * i as f64, 0.2, -0.1],
            &[0.5, rot],
            None,
        );
    }
    t
}

#[test]
fn mutated_operator_files_are_values_or_diagnostics() {
    let std = OperatorSet::standard();
    let tr = chunk_trace();
    let mut findings = Findings::default();
    let mut inputs = 0;
    for (k, file) in ["operators/positioning.adv", "operators/interception.adv"]
        .into_iter()
        .enumerate()
    {
        let text = read(file);
        let mut m = Mutator::new(100 + k as u64);
        for _ in 0..1500 {
            let input = m.mutate(&text, 2 * text.len());
            inputs += 1;
            findings.guard("operators", &input, |f| {
                match std.merge(&[Source::new("fuzz.adv", input.clone())]) {
                    Err(e) => f.check_codes("operators", &input, &e),
                    Ok(set) => {
                        for name in set.operator_names("positioning") {
                            match check::bind(
                                &mut SourceMap::new(),
                                &set,
                                &tr.domain,
                                &Invocation::bare(name),
                            ) {
                                Err(e) => f.check_codes("apply", &input, &e),
                                Ok(call) => {
                                    if let Err(e) = interp::apply(&call, &tr, Chunk::all(8)) {
                                        f.check_codes("apply", &input, &e);
                                    }
                                }
                            }
                        }
                    }
                }
            });
        }
    }
    findings.assert_none("operator-file", inputs);
}

/// Statements a mutant may not run here (see the module docs).
fn excluded(statement: &str) -> bool {
    let lower = statement.to_ascii_lowercase();
    let first = lower.split_whitespace().next().unwrap_or("");
    if matches!(first, "save" | "plot" | "export" | "eval") {
        return true;
    }
    if first == "backend" && lower.split_whitespace().nth(1) != Some("sim") {
        return true;
    }
    // Anything that may record teacher demonstrations: allow only small counts.
    if let Some(rest) = lower.split("teacher:").nth(1) {
        let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
        return digits.len() > 2 || digits.parse::<u32>().is_ok_and(|n| n > 12);
    }
    false
}

#[test]
fn mutated_session_statements_are_replies_or_diagnostics() {
    let mut findings = Findings::default();
    let mut inputs = 0;
    for (k, file) in [
        "examples/sessions/positioning.adv",
        "examples/sessions/interception.adv",
    ]
    .into_iter()
    .enumerate()
    {
        let text = read(file);
        let statements: Vec<String> = script::statements(&text)
            .into_iter()
            .map(|s| s.text)
            .collect();
        let task = if k == 0 {
            TaskKind::Positioning
        } else {
            TaskKind::Interception
        };
        let fresh = || {
            Session::new(SessionOptions {
                task: task.clone(),
                default_demos: 2,
                ..SessionOptions::default()
            })
            .unwrap()
        };
        let mut session = fresh();
        let mut m = Mutator::new(200 + k as u64);
        for round in 0..1000 {
            if round % 200 == 0 {
                session = fresh();
            }
            let original = &statements[m.rng.random_range(0..statements.len())];
            let input = m.mutate(original, 512);
            if excluded(&input) {
                continue;
            }
            inputs += 1;
            findings.guard("session", &input, |f| {
                if let Err(e) = session.execute(&input, "<fuzz>") {
                    f.check_codes("session", &input, &e);
                }
            });
        }
    }
    findings.assert_none("session", inputs);
}

/// A saved dataset with a demonstration, an execution, advice and a critique.
fn saved_dataset() -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.json");
    let mut s = Session::new(SessionOptions {
        task: TaskKind::Positioning,
        default_demos: 1,
        ..SessionOptions::default()
    })
    .unwrap();
    for line in [
        "run goal 1 -0.5 0",
        "select 2..12",
        "advise slow_down(0.5)",
        "critique 0.5",
    ] {
        s.execute(line, "<setup>").unwrap();
    }
    s.execute(&format!("save {}", path.display()), "<setup>")
        .unwrap();
    std::fs::read_to_string(&path).unwrap()
}

#[test]
fn mutated_datasets_are_loaded_or_refused_with_diagnostics() {
    let text = saved_dataset();
    let z = [1.0, 0.3, -0.2];
    let mut findings = Findings::default();
    let mut m = Mutator::new(300);
    let count = 800;
    for _ in 0..count {
        let input = m.mutate(&text, text.len() + 4096);
        findings.guard("dataset", &input, |f| {
            match Dataset::from_json_str("fuzz.json", &input) {
                Err(e) => f.check_codes("dataset", &input, &e),
                Ok(ds) => {
                    // Whatever loads can be learned from and queried.
                    let l = Learner::with_dataset(ds, LearnerKind::Lwr, 0);
                    let mut a = vec![0.0; l.domain().act_dim()];
                    if l.domain().obs_dim() == z.len() {
                        advise::policy::Policy::act(&l, &z, &mut a);
                    }
                }
            }
        });
    }
    findings.assert_none("dataset", count);
}

#[test]
fn mutated_simulator_parameters_are_refused_or_run_finitely() {
    let text = serde_json::to_string_pretty(&SimParams::default()).unwrap();
    let mut findings = Findings::default();
    let mut m = Mutator::new(400);
    let count = 3000;
    for _ in 0..count {
        let input = m.mutate(&text, 1024);
        findings.guard("sim", &input, |f| {
            match SimParams::from_json_str("fuzz.json", &input) {
                Err(e) => f.check_codes("sim", &input, &e),
                Ok(p) => {
                    let period = p.period_s();
                    let mut base = SimBase::new(p, 0);
                    base.reset(Pose::default());
                    base.set_command(1.0, 1.0);
                    for _ in 0..30 {
                        let s = base.advance(period);
                        if !(s.pose.x_m.is_finite() && s.speed_mps.is_finite()) {
                            f.0.push(format!("sim: non-finite state {s:?} for {input:?}"));
                            break;
                        }
                    }
                }
            }
        });
    }
    findings.assert_none("simulator-parameter", count);
}

/// A journal of a short session: demonstrations, a run, a selection, advice, a critique, undo.
fn journal_text(dir: &std::path::Path) -> String {
    let mut s = Session::new(SessionOptions {
        default_demos: 1,
        ..SessionOptions::default()
    })
    .unwrap();
    let path = s.start_journal(dir).unwrap();
    for st in [
        "run goal 1 -1 0",
        "select 2..12",
        "advise speed_up(0.3)",
        "critique",
        "undo",
        "operator creep for positioning on action { trans = 0.1 }",
        "task interception",
    ] {
        s.execute(st, "<setup>").unwrap();
    }
    std::fs::read_to_string(path).unwrap()
}

#[test]
fn mutated_journals_are_restored_or_refused_with_diagnostics() {
    let dir = tempfile::tempdir().unwrap();
    let text = journal_text(dir.path());
    let mut findings = Findings::default();
    let mut m = Mutator::new(500);
    let count = 300;
    for i in 0..count {
        let input = m.mutate(&text, text.len() + 2048);
        let path = dir.path().join(format!("fuzz-{i}.jsonl"));
        std::fs::write(&path, &input).unwrap();
        findings.guard("journal", &input, |f| {
            match Session::restore(&path, dir.path()) {
                Err(e) => f.check_codes("journal", &input, &e),
                // A damaged line stops the restore where it is (it says so): a refusal too.
                Ok(r) if r.stopped.is_some() || !r.notes.is_empty() => f.1 += 1,
                Ok(_) => {}
            }
        });
    }
    findings.assert_none("journal", count);
}
