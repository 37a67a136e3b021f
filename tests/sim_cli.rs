//! `advise demo` and `advise eval` as a user runs them.

use std::path::Path;
use std::process::{Command, Output};

use advise::domain::Domain;
use advise::trace::Episode;

fn advise(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn demo_writes_episodes_that_load_back_as_csv_and_json() {
    let dir = tempfile::tempdir().unwrap();
    for (task, file) in [("positioning", "p.csv"), ("interception", "i.json")] {
        let o = advise(
            &[
                "demo", "--task", task, "--count", "3", "--seed", "4", "--out", file,
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains(&format!("recorded 3 {task} demonstrations")));
        let domain = Domain::builtin(task).unwrap();
        let eps = Episode::load_all(
            &mut advise::diag::SourceMap::new(),
            &domain,
            &dir.path().join(file),
        )
        .unwrap();
        assert_eq!(
            eps.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(),
            ["demo-0", "demo-1", "demo-2"]
        );
        assert!(
            eps.iter()
                .all(|e| e.trace.len() > 10 && e.trace.pose.is_some())
        );
        // The same seed records the same file.
        let again = advise(
            &[
                "demo", "--task", task, "--count", "3", "--seed", "4", "--out", "again",
            ],
            dir.path(),
        );
        assert!(again.status.success());
        let a = Episode::load_all(
            &mut advise::diag::SourceMap::new(),
            &domain,
            &dir.path().join("again"),
        )
        .unwrap();
        let b: Vec<_> = eps.iter().map(|e| e.trace.clone()).collect();
        assert_eq!(a.iter().map(|e| e.trace.clone()).collect::<Vec<_>>(), b);
    }
}

#[test]
fn eval_prints_the_papers_measures_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let o = advise(
        &[
            "demo",
            "--task",
            "positioning",
            "--count",
            "4",
            "--out",
            "d.csv",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = advise(
        &[
            "eval",
            "--task",
            "positioning",
            "--dataset",
            "d.csv",
            "--policy",
            "bc",
            "--seed",
            "3",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["task"], "positioning");
    assert_eq!(v["episodes"], 25);
    for field in [
        "success_rate",
        "mean_position_error_m",
        "mean_heading_error_rad",
        "mean_length_m",
    ] {
        assert!(v[field].is_f64(), "{field}: {}", v[field]);
    }
    assert_eq!(v["outcomes"].as_array().unwrap().len(), 25);

    let o = advise(
        &[
            "eval",
            "--task",
            "interception",
            "--policy",
            "teacher",
            "--json",
        ],
        dir.path(),
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["episodes"], 100);
    // Interception has no goal heading.
    assert!(v.get("mean_heading_error_rad").is_none());
}

#[test]
fn eval_prints_a_summary_on_a_terminal_style_run() {
    let dir = tempfile::tempdir().unwrap();
    let o = advise(
        &["eval", "--task", "positioning", "--policy", "teacher"],
        dir.path(),
    );
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.starts_with("positioning test set, 25 episodes, seed 0\n  success rate"));
    assert!(text.contains("mean heading error"));
}

#[test]
fn cli_diagnostics() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("params.json"), "{\"lag\": 0.3}\n").unwrap();
    std::fs::write(
        dir.path().join("wrong.csv"),
        "t,dist2,bearing,dheading,trans,rot\n0,1,0,0,0,0\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("empty.csv"),
        "t,dist2,bearing,dheading,trans,rot\n",
    )
    .unwrap();
    let cases: &[&[&str]] = &[
        &["eval", "--task", "positioning"],
        &[
            "eval",
            "--task",
            "positioning",
            "--dataset",
            "empty.csv",
            "--policy",
            "lwr",
        ],
        &["eval", "--task", "positioning", "--dataset", "empty.csv"],
        &["eval", "--task", "interception", "--dataset", "wrong.csv"],
        &[
            "eval",
            "--task",
            "positioning",
            "--policy",
            "teacher",
            "--sim-params",
            "params.json",
        ],
        &[
            "demo",
            "--task",
            "positioning",
            "--out",
            "no/such/dir/d.csv",
        ],
    ];
    let mut out = String::new();
    for args in cases {
        let o = advise(args, dir.path());
        assert!(!o.status.success(), "{args:?} should fail");
        out.push_str(&format!(
            "----- advise {}\n{}\n",
            args.join(" "),
            stderr(&o)
        ));
    }
    insta::assert_snapshot!(out);
}
