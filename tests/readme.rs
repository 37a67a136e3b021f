//! The README's numbers, checked (issue 33: "a README that cannot go stale"). Each test reads the
//! README as committed and fails when a number it quotes is not what the code prints (the
//! commands it shows, run here) or what the committed measurement says (the 20-seed studies, too
//! slow for the test suite, are checked against `docs/measured/*.json`, which their commands
//! wrote; the shipped calibration against `calibration/bc.json`, which a test of its own
//! reproduces). Editing a quoted number, or changing the code's output, fails `cargo test` until
//! the README is updated.
//!
//! `trycmd` was the intended tool; it needs the README's quotes to be whole `$ command` + output
//! blocks, while the README quotes its figures in tables and prose built from several commands,
//! so these tests compose each quoted line from the commands' `--json` output instead.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

const README: &str = include_str!("../README.md");

fn advise(args: &[&str], dir: &Path) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "advise {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn json_of(args: &[&str], dir: &Path) -> Value {
    serde_json::from_slice(&advise(args, dir).stdout).unwrap()
}

/// The README holds `line` as a whole line (tables) or, for prose, as text.
#[track_caller]
fn quoted(line: &str) {
    assert!(
        README.lines().any(|l| l.trim_end() == line) || README.contains(line),
        "the README does not quote, as the code/measurement gives it:\n{line}"
    );
}

fn f(v: &Value, path: &str) -> f64 {
    path.split('.')
        .fold(v, |v, k| &v[k])
        .as_f64()
        .unwrap_or_else(|| panic!("{path}"))
}

/// `1234.5` as `1,235` (halves rounded away from zero, as a person rounds).
fn thousands(x: f64) -> String {
    let n = format!("{}", x.abs().round());
    let mut out = String::new();
    for (i, c) in n.chars().enumerate() {
        if i > 0 && (n.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    if x.round() < 0.0 {
        format!("-{out}")
    } else {
        out
    }
}

fn signed_thousands(x: f64) -> String {
    if x.round() >= 0.0 {
        format!("+{}", thousands(x))
    } else {
        thousands(x)
    }
}

fn pct_sd(v: &Value) -> String {
    format!("{:.0}% ± {:.0}", f(v, "mean") * 100.0, f(v, "sd") * 100.0)
}

fn m_sd(v: &Value) -> String {
    format!("{:.2} ± {:.2}", f(v, "mean"), f(v, "sd"))
}

/// A claim's cell pair: `10 of 20` and `+0.016 [-0.007, +0.038]` (with `unit`).
fn claim_cells(c: &Value, unit: &str) -> (String, String) {
    let seeds = f(&c["difference"], "seeds");
    let held = c["seeds_held"].as_array().unwrap().len();
    let d = &c["difference"];
    let diff = if unit == " points" {
        format!(
            "{}{unit} [{}, {}]",
            signed_thousands(f(d, "mean")),
            signed_thousands(f(d, "lo95")),
            signed_thousands(f(d, "hi95"))
        )
    } else {
        format!(
            "{:+.3}{unit} [{:+.3}, {:+.3}]",
            f(d, "mean"),
            f(d, "lo95"),
            f(d, "hi95")
        )
    };
    (format!("{held} of {seeds:.0}"), diff)
}

/// `0 of 20`, `1 of 20 (seed 5)`, `2 of 20 (seeds 9, 12)`.
fn all_held(shape: &Value) -> String {
    let seeds: Vec<String> = shape["seeds_all_held"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let n = f(shape, "seeds");
    match seeds.len() {
        0 => format!("0 of {n:.0}"),
        1 => format!("1 of {n:.0} (seed {})", seeds[0]),
        k => format!("{k} of {n:.0} (seeds {})", seeds.join(", ")),
    }
}

fn measured(name: &str) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("docs/measured")
        .join(name);
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Table 1 (both teachers' arms and critique's ceilings), its claims and endings in the README
/// are the committed 20-seed measurement's (the second protocol).
#[test]
fn the_bc_tables_are_the_measured_json() {
    let d = measured("bc-seeds-0-20.json");
    let h = &d["hand"];
    assert_eq!(d["teacher_kind"], "controller");
    assert_eq!(h["teacher_kind"], "hand");
    let cells = |v: &Value, policy: &str| {
        format!(
            "{} | {}",
            pct_sd(&v[format!("{policy}_success").as_str()]),
            m_sd(&v[format!("{policy}_length_m").as_str()])
        )
    };
    for (label, sub, policy, paper) in [
        (
            "learner, initial policy",
            None,
            "learner_initial",
            "56%, 2.73",
        ),
        (
            "learner, final policy (paper's rule)",
            None,
            "learner_final",
            "70%, 1.96",
        ),
        (
            "learner, final policy (directional rule)",
            Some("directional"),
            "learner_final",
            "-",
        ),
        ("teacher", None, "teacher", "62%, 2.87"),
        (
            "ceiling: 1-NN on the successful demonstrations",
            Some("oracles"),
            "successful_demos",
            "-",
        ),
        (
            "ceiling: 1-NN after perfect critique",
            Some("oracles"),
            "perfect_critique",
            "-",
        ),
    ] {
        let (c, hh) = match sub {
            Some(k) => (&d[k], &h[k]),
            None => (&d, h),
        };
        quoted(&format!(
            "| {label} | {} | {} | {paper} |",
            cells(c, policy),
            cells(hh, policy)
        ));
    }
    for arm in [&d, h] {
        let dir = &arm["directional"];
        let paper = arm["shape"]["claims"].as_array().unwrap();
        let directional = dir["shape"]["claims"].as_array().unwrap();
        for (p, q) in paper.iter().zip(directional) {
            let name = p["claim"].as_str().unwrap();
            assert_eq!(name, q["claim"].as_str().unwrap());
            let unit = if name.contains("length") { " m" } else { "" };
            let (ps, pd) = claim_cells(p, unit);
            let (qs, qd) = claim_cells(q, unit);
            quoted(&format!("| {name} | {ps} | {pd} | {qs} | {qd} |"));
        }
        quoted(&format!(
            "| all three | {} | | {} | |",
            all_held(&arm["shape"]),
            all_held(&dir["shape"])
        ));
    }
    for (arm, v) in [("controller", &d), ("hand", h)] {
        for who in ["teacher", "initial", "final"] {
            let e = &v["endings"][who];
            quoted(&format!(
                "| {arm}: {who} | {:.1} | {:.1} | {:.1} | {:.1} |",
                f(&e["captured"], "mean"),
                f(&e["ball_out"], "mean"),
                f(&e["robot_out"], "mean"),
                f(&e["time_limit"], "mean")
            ));
        }
    }
    // The demonstrations' size, in the section's first lines.
    let runs = d["runs"].as_array().unwrap();
    let mean = |of: &dyn Fn(&Value) -> f64| runs.iter().map(of).sum::<f64>() / runs.len() as f64;
    quoted(&format!(
        "100 demonstrations, {} points)",
        thousands(mean(&|r| f(r, "demo_points")))
    ));
    quoted(&format!(
        "(S2; {} points)",
        thousands(mean(&|r| f(&r["hand"], "demo_points")))
    ));
    // The orbit explanation's figures.
    quoted(&format!(
        "{:.1} of its 100 test runs still orbit at\n60 s",
        f(&d["endings"]["teacher"]["time_limit"], "mean")
    ));
    let failed_points =
        mean(&|r| f(r, "demo_points")) - f(&d["oracles"]["successful_demos_points"], "mean");
    quoted(&format!("hold {},000 of", (failed_points / 1000.0).round()));
    quoted(&format!(
        "critic flags ({:.0}% of the points)",
        f(&d["oracles"]["perfect_critique_removed_share"], "mean") * 100.0
    ));
}

/// The A-OPI tables in the README are the committed 20-seed measurement's.
#[test]
fn the_aopi_tables_are_the_measured_json() {
    let d = measured("aopi-seeds-0-20.json");
    let runs = d["runs"].as_array().unwrap();
    let best = |arm: &str| {
        let v: Vec<f64> = runs
            .iter()
            .map(|r| f(&r["arms"][arm]["best"], "success_rate"))
            .collect();
        format!("{:.0}%", v.iter().sum::<f64>() / v.len() as f64 * 100.0)
    };
    let row = |label: &str, arm: &str, best: String, paper: &str| {
        let a = &d["arms"][arm];
        let ex = &a["executions"];
        let executions = if f(ex, "sd") == 0.0 {
            format!("{:.0}", f(ex, "mean"))
        } else {
            format!("{:.0} ± {:.0}", f(ex, "mean"), f(ex, "sd"))
        };
        format!(
            "| {label} | {} | {} | {} | {} ± {} | {executions} | {best} | {paper} |",
            pct_sd(&a["success_rate"]),
            m_sd(&a["mean_position_error_m"]),
            m_sd(&a["mean_heading_error_rad"]),
            thousands(f(&a["dataset_size"], "mean")),
            thousands(f(&a["dataset_size"], "sd")),
        )
    };
    quoted(&row("baseline", "baseline", "-".into(), "32% (9)"));
    quoted(&row(
        "A-OPI advised",
        "advised",
        best("advised"),
        "88% (69)",
    ));
    quoted(&row("A-OPI hybrid", "hybrid", best("hybrid"), "92% (68)"));
    quoted(&row("teleoperation", "teleop", best("teleop"), "80% (60)"));
    // A shape's claims as the README's rows, differences of datasets in points.
    let claim_rows = |shape: &Value, all: &str| {
        for c in shape["claims"].as_array().unwrap() {
            let name = c["claim"].as_str().unwrap();
            let unit = if name.contains("dataset") {
                " points"
            } else {
                ""
            };
            let (s, diff) = claim_cells(c, unit);
            quoted(&format!("| {name} | {s} | {diff} |"));
        }
        quoted(&format!("| {all} | {} | |", all_held(shape)));
    };
    claim_rows(&d["shape"], "all six");
    // The takeover arm (issue 53): its row, its pre-registered claims and the two comparisons.
    quoted(&row("takeover (ours)", "takeover", best("takeover"), "-"));
    let t = &d["takeover"];
    claim_rows(&t["shape"], "all three");
    for (name, key) in [
        ("takeover minus advised", "minus_advised"),
        ("takeover minus hybrid", "minus_hybrid"),
    ] {
        let d = &t[key];
        quoted(&format!(
            "| {name} (a figure, not a claim) | | {:+.3} [{:+.3}, {:+.3}] |",
            f(d, "mean"),
            f(d, "lo95"),
            f(d, "hi95")
        ));
    }
    let base = &d["arms"]["baseline"]["dataset_size"];
    quoted(&format!(
        "(the baseline;\n{} ± {} points)",
        thousands(f(base, "mean")),
        thousands(f(base, "sd"))
    ));
}

/// The calibration figures the README quotes are the shipped calibration's record.
#[test]
fn the_calibration_figures_are_the_shipped_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bc: Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("calibration/bc.json")).unwrap())
            .unwrap();
    let aopi: Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("calibration/aopi.json")).unwrap())
            .unwrap();
    let cal = &bc["calibration"];
    let c = &cal["constraints"];
    quoted(&format!(
        "BC (the second protocol, with the hand-written controller): the ideal interceptor catches {:.1}% of the 600 practice starts (floor {:.0}%); the ball's top\nspeed is {:.2} of the teacher's cruise ({} against {} m/s)",
        f(c, "ideal_interceptor_success") * 100.0,
        f(c, "ideal_interceptor_floor") * 100.0,
        f(c, "ball_teacher_speed_ratio"),
        bc["world"]["ball_speed_mps"][1],
        bc["teacher"]["cruise_mps"],
    ));
    let w = &bc["world"];
    quoted(&format!(
        "the ball starts\n{}-{} m away at up to {} m/s, a {} m arena, a {} m capture",
        w["ball_dist_m"][0].as_f64().unwrap() as u32,
        w["ball_dist_m"][1],
        w["ball_speed_mps"][1],
        f(w, "arena_half_m") * 2.0,
        w["capture_m"],
    ));
    // The second protocol's main arm has no hand (S1, S7).
    assert_eq!(bc["teacher"]["hand"]["reaction_s"][1], 0.0);
    assert_eq!(bc["teacher"]["gain"][1], 1.0);
    let t = cal["targets"].as_array().unwrap();
    let after = |i: usize| f(&t[i], "after");
    quoted(&format!(
        "the teacher makes {:.1}% / {:.2} m (paper\n62% / 2.87 m) and the initial learner {:.1}% / {:.2} m (paper 56% / 2.73 m); loss {:.1} (the first",
        after(0) * 100.0,
        after(1),
        after(2) * 100.0,
        after(3),
        f(cal, "loss_after"),
    ));
    let at = aopi["calibration"]["targets"].as_array().unwrap();
    quoted(&format!(
        "the baseline makes {:.1}% (paper\n32%",
        f(&at[1], "after") * 100.0
    ));
    quoted(&format!(
        "set the arms' patience to {} validation evaluations",
        aopi["patience"]
    ));
    quoted(&format!(
        "Each arm halts when {} evaluations on 25 validation\ngoals in a row did not improve",
        aopi["patience"]
    ));
}

/// The simulator section's table and its `advise eval` block are what its commands print.
#[test]
fn the_simulator_table_is_what_its_commands_print() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    // Positioning: 9 demonstrations of seed 1, at 15 Hz, within the paper's 810-990 points.
    advise(
        &[
            "demo",
            "--task",
            "positioning",
            "--count",
            "9",
            "--seed",
            "1",
            "--out",
            "demos.csv",
        ],
        dir,
    );
    let csv = std::fs::read_to_string(dir.join("demos.csv")).unwrap();
    let points = csv.lines().count() - 1;
    assert!((810..=990).contains(&points), "{points} points");
    // The README's `--policy bc --seed 0` evaluation: its table row from `--json`, its text block
    // from the same command without it.
    let bc_eval = [
        "eval",
        "--task",
        "positioning",
        "--dataset",
        "demos.csv",
        "--policy",
        "bc",
        "--seed",
        "0",
    ];
    let bc = json_of(&[&bc_eval[..], &["--json"]].concat(), dir);
    let row = |label: &str, r: &Value, count: bool| {
        let n = r["episodes"].as_u64().unwrap();
        let ok = r["successes"].as_u64().unwrap();
        let rate = if count {
            format!("{:.0}% ({ok}/{n})", f(r, "success_rate") * 100.0)
        } else {
            format!("{:.0}%", f(r, "success_rate") * 100.0)
        };
        format!(
            "| {label} | {rate} | {:.2} m |",
            f(r, "mean_length_success_m")
        )
    };
    quoted(&row(
        &format!("positioning BC 1-NN from 9 demos (seed 1, {points} points at 15 Hz)"),
        &bc,
        true,
    ));
    quoted(&format!(
        "`advise demo --task positioning\n--count 9 --seed 1` records {points} points"
    ));
    let teacher = json_of(
        &[
            "eval",
            "--task",
            "positioning",
            "--policy",
            "teacher",
            "--json",
        ],
        dir,
    );
    quoted(&row("positioning teacher, test set", &teacher, true));
    // The text block the README shows under its commands: the `--policy bc --seed 0` evaluation.
    let text = advise(&bc_eval, dir);
    let text = String::from_utf8(text.stdout).unwrap();
    quoted(text.trim_end());

    // Interception: 100 demonstrations of seed 1.
    advise(
        &[
            "demo",
            "--task",
            "interception",
            "--count",
            "100",
            "--seed",
            "1",
            "--out",
            "intercept.json",
        ],
        dir,
    );
    let bc = json_of(
        &[
            "eval",
            "--task",
            "interception",
            "--dataset",
            "intercept.json",
            "--policy",
            "bc",
            "--seed",
            "0",
            "--json",
        ],
        dir,
    );
    let domain = advise::domain::Domain::builtin("interception").unwrap();
    let eps = advise::trace::Episode::load_all(
        &mut advise::diag::SourceMap::new(),
        &domain,
        &dir.join("intercept.json"),
    )
    .unwrap();
    let points: usize = eps.iter().map(|e| e.trace.len()).sum();
    quoted(&row(
        &format!(
            "interception BC 1-NN from 100 demos (seed 1, {} points)",
            thousands(points as f64)
        ),
        &bc,
        false,
    ));
    let teacher = json_of(
        &[
            "eval",
            "--task",
            "interception",
            "--policy",
            "teacher",
            "--json",
        ],
        dir,
    );
    quoted(&row("interception teacher, test set", &teacher, false));
}

/// The "Your own task" commands' figures, as the README's comments quote them.
#[test]
fn the_standoff_figures_are_what_its_commands_print() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let tasks = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/tasks/standoff.adv");
    let tasks = tasks.to_str().unwrap();
    let on = ["--tasks", tasks, "--task", "standoff"];
    let with = |args: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = args[..1].iter().map(|s| s.to_string()).collect();
        v.extend(on.iter().map(|s| s.to_string()));
        v.extend(args[1..].iter().map(|s| s.to_string()));
        v
    };
    let run = |args: &[&str]| {
        let v = with(args);
        json_of(&v.iter().map(String::as_str).collect::<Vec<_>>(), dir)
    };
    let rate = |r: &Value| {
        format!(
            "{:.0}% ({}/{})",
            f(r, "success_rate") * 100.0,
            r["successes"],
            r["outcomes"].as_array().unwrap().len()
        )
    };
    let teacher = run(&["eval", "--policy", "teacher", "--json"]);
    quoted(&format!(
        "advise eval --tasks examples/tasks/standoff.adv --task standoff --policy teacher     # {}, {:.1} s",
        rate(&teacher),
        f(&teacher, "mean_efficiency_success")
    ));
    let demo = with(&["demo", "--count", "9", "--seed", "1", "--out", "so.csv"]);
    advise(&demo.iter().map(String::as_str).collect::<Vec<_>>(), dir);
    let lwr = run(&["eval", "--dataset", "so.csv", "--policy", "lwr", "--json"]);
    quoted(&format!(
        "advise eval --tasks examples/tasks/standoff.adv --task standoff --dataset so.csv --policy lwr   # {}",
        rate(&lwr)
    ));
}

/// Timings (`0.2 ms`, `40 µs`) vary from run to run: masked on both sides.
fn mask_timings(line: &str) -> String {
    let words: Vec<&str> = line.split(' ').collect();
    let mut out = Vec::new();
    for (i, w) in words.iter().enumerate() {
        let next_is_ms = words
            .get(i + 1)
            .is_some_and(|n| matches!(n.trim_end_matches([',', ';', ')']), "ms" | "µs"));
        if next_is_ms && w.parse::<f64>().is_ok() {
            out.push("<t>");
        } else {
            out.push(w);
        }
    }
    out.join(" ")
}

/// The README's session (under "A session") is what the REPL replies, line for line: a line
/// `...` stands for any lines the README leaves out (it is abridged); timings are masked.
#[test]
fn the_session_transcript_is_what_the_repl_prints() {
    let start = README.find("## A session").unwrap();
    let block = &README[start..];
    let block = &block[block.find("```\n").unwrap() + 4..];
    let block = &block[..block.find("```").unwrap()];
    let mut lines = block.lines();
    // `cargo run --release`: the REPL on the simulator, 9 teacher demonstrations loaded.
    let mut session = common::positioning(9);
    assert_eq!(
        lines.next().unwrap(),
        format!("advise: {}", session.status())
    );
    let mut expected: Vec<(String, Vec<String>)> = Vec::new();
    for l in lines {
        match l.strip_prefix("advise> ") {
            Some(cmd) => expected.push((cmd.to_string(), Vec::new())),
            None => expected.last_mut().unwrap().1.push(l.to_string()),
        }
    }
    assert!(expected.len() >= 5);
    for (cmd, want) in expected {
        let got = session.execute(&cmd, "<readme>").unwrap().to_string();
        let got: Vec<String> = got.trim_end().lines().map(mask_timings).collect();
        let mut g = 0;
        let mut skipping = false;
        for w in &want {
            if w.trim() == "..." {
                skipping = true;
                continue;
            }
            let w = mask_timings(w);
            while skipping && g < got.len() && got[g] != w {
                g += 1;
            }
            skipping = false;
            assert_eq!(
                got.get(g),
                Some(&w),
                "README's reply to `{cmd}` differs from the REPL's:\n{}",
                got.join("\n")
            );
            g += 1;
        }
        assert!(
            skipping || g == got.len(),
            "the README leaves out lines of the reply to `{cmd}` without `...`:\n{}",
            got.join("\n")
        );
    }
}

/// docs/ablation.md's tables are the committed ablation runs' (`docs/measured/ablation-*.json`,
/// written by `advise experiment bc|aopi --seeds 0..20 --revert CHOICE --json`).
#[test]
fn the_ablation_tables_are_the_measured_json() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/ablation.md"))
            .unwrap();
    // Each study's table, from its heading on (the teacher's row is in both).
    let row_of = |study: &str, label: &str| -> String {
        let from = doc.find(&format!("## {study}")).unwrap();
        doc[from..]
            .lines()
            .find(|l| l.starts_with(&format!("| {label} |")))
            .unwrap_or_else(|| panic!("docs/ablation.md has no row `{label}`"))
            .to_string()
    };
    let cells = |c: &Value| {
        let d = &c["difference"];
        let held = c["seeds_held"].as_array().unwrap().len();
        let unit = if c["claim"].as_str().unwrap().contains("length") {
            " m"
        } else {
            ""
        };
        format!(
            "{held} of 20, {:+.3}{unit} [{:+.3}, {:+.3}]",
            f(d, "mean"),
            f(d, "lo95"),
            f(d, "hi95")
        )
    };
    for (n, choice) in [(1, "ball"), (2, "teacher"), (3, "chunks"), (4, "support")] {
        let d = measured(&format!("ablation-bc-{choice}.json"));
        assert_eq!(d["revert"], choice);
        let row = row_of("Binary", &format!("{n}. `--revert {choice}`"));
        let want = format!(
            "| {n}. `--revert {choice}` | {} | {} | {} | ",
            pct_sd(&d["learner_initial_success"]),
            pct_sd(&d["learner_final_success"]),
            pct_sd(&d["teacher_success"])
        );
        assert!(row.starts_with(&want), "{row}\n{want}");
        for c in d["shape"]["claims"].as_array().unwrap() {
            assert!(row.contains(&cells(c)), "{row}\n{}", cells(c));
        }
    }
    for (n, choice) in [(2, "teacher"), (5, "advisor"), (6, "stopping"), (7, "rate")] {
        let d = measured(&format!("ablation-aopi-{choice}.json"));
        assert_eq!(d["revert"], choice);
        let row = row_of("A-OPI", &format!("{n}. `--revert {choice}`"));
        let arms: Vec<String> = ["baseline", "advised", "hybrid", "teleop"]
            .iter()
            .map(|a| pct_sd(&d["arms"][a]["success_rate"]))
            .collect();
        let want = format!("| {n}. `--revert {choice}` | {} | ", arms.join(" | "));
        assert!(row.starts_with(&want), "{row}\n{want}");
        for c in d["shape"]["claims"].as_array().unwrap() {
            if !c["claim"].as_str().unwrap().contains("dataset") {
                assert!(row.contains(&cells(c)), "{row}\n{}", cells(c));
            }
        }
        assert!(row.ends_with(&format!(
            "| {} |",
            all_held(&d["shape"]).split(" (").next().unwrap()
        )));
    }
}
