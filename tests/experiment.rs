//! Reduced runs of both experiments: the JSON carries what the issue lists, with sane values.

use advise::experiment::aopi::{self, AopiParams};
use advise::experiment::bc::{self, BcParams, BcResult};
use serde_json::Value;

fn rate(v: &Value, path: &str) -> f64 {
    let r = v
        .pointer(path)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("{path} missing"));
    assert!((0.0..=1.0).contains(&r), "{path} = {r}");
    r
}

/// The rounds of a Figure 5 curve in the JSON.
fn rounds(curve: &Value) -> Vec<u64> {
    curve
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["round"].as_u64().unwrap())
        .collect()
}

#[test]
fn reduced_bc_study_reports_table_1() {
    let params = BcParams {
        demos: 15,
        rounds: 12,
        eval_every: 4,
        test_starts: 20,
        ..BcParams::default()
    };
    let result = bc::run(3, &params, false);
    let v = serde_json::to_value(&result).unwrap();
    assert_eq!(v["experiment"], "bc");
    assert_eq!(v["seed"], 3);
    assert_eq!(v["params"]["rounds"], 12);
    for who in ["learner_initial", "learner_final", "teacher"] {
        rate(&v, &format!("/{who}/success_rate"));
        assert_eq!(v[who]["episodes"], 20);
        // The length is compared on the paired runs only; present exactly when there are some.
        let paired = v["paired_runs"].as_u64().unwrap();
        assert_eq!(v[who]["mean_length_m"].is_f64(), paired > 0, "{who}");
        if let Some(l) = v[who]["mean_length_m"].as_f64() {
            assert!(l > 0.0 && l < 100.0);
        }
    }
    // Figure 5: round 0, then every 4 rounds; the last point is the final policy.
    assert_eq!(rounds(&v["curve"]), [0, 4, 8, 12]);
    assert_eq!(
        v["curve"][0]["success_rate"],
        v["learner_initial"]["success_rate"]
    );
    assert_eq!(
        v["curve"][3]["success_rate"],
        v["learner_final"]["success_rate"]
    );
    let c = &result.critiques;
    assert!(c.rounds_flagged <= 12);
    // Chunks are as many as the critic found, at least one in each flagged round.
    assert!(c.chunks_flagged >= c.rounds_flagged);
    assert!(c.points_flagged >= c.chunks_flagged);
    assert_eq!(c.flaws.values().sum::<usize>(), c.chunks_flagged);
    // Same seed, same figures.
    assert_eq!(bc::run(3, &params, false), result);
    assert!(result.render().contains("learner final π"));

    // The directional rule ran beside the paper's (the default), from the same starts.
    assert_eq!(v["rule"], "paper");
    let d = &v["directional"];
    assert_eq!(d["rule"], "directional");
    rate(&v, "/directional/learner_final/success_rate");
    assert_eq!(d["learner_final"]["episodes"], 20);
    let paired = d["paired_runs"].as_u64().unwrap();
    for key in ["learner_initial_length_m", "teacher_length_m"] {
        assert_eq!(d[key].is_f64(), paired > 0, "{key}");
    }
    assert_eq!(d["learner_final"]["mean_length_m"].is_f64(), paired > 0);
    assert_eq!(rounds(&d["curve"]), [0, 4, 8, 12]);
    assert_eq!(d["curve"][0], v["curve"][0], "the same initial policy");
    assert_eq!(d["critiques"]["rounds"], 12);
    let text = result.render();
    assert!(text.contains("learner final π (directional)"), "{text}");
    assert!(text.contains("Figure 5 (directional rule)"), "{text}");

    // The second protocol: the hand-written controller's arm first, the human-like hand's under
    // `hand`, each with critique's ceilings and endings that name the safety limit apart.
    assert_eq!(v["teacher_kind"], "controller");
    let h = &v["hand"];
    assert_eq!(h["teacher_kind"], "hand");
    assert!(h["hand"].is_null());
    for arm in [&v, h] {
        for oracle in ["successful_demos", "perfect_critique"] {
            let o = &arm["oracles"][oracle];
            let points = o["points"].as_u64().unwrap();
            assert!(points <= arm["demo_points"].as_u64().unwrap());
            assert_eq!(o["figures"].is_object(), points > 0, "{oracle}");
        }
        // Only successful demonstrations: their count is the teacher's successes.
        assert_eq!(
            arm["oracles"]["successful_demos"]["demos"],
            arm["demo_successes"]
        );
    }
    assert!(text.contains("teacher: hand-written controller"), "{text}");
    assert!(text.contains("teacher: human-like hand"), "{text}");
    assert!(text.contains("critique's ceiling"), "{text}");
    assert!(text.contains("at the 60 s safety limit"), "{text}");
    // The controller demonstrates the same way every time: one arm alone is the same arm.
    let controller_only = bc::run(
        3,
        &BcParams {
            teachers: bc::Teachers::Controller,
            ..params.clone()
        },
        false,
    );
    assert!(controller_only.hand.is_none());
    assert_eq!(
        BcResult {
            hand: None,
            ..result.clone()
        },
        BcResult {
            params: result.params.clone(),
            ..controller_only
        }
    );
    let hand_only = bc::run(
        3,
        &BcParams {
            teachers: bc::Teachers::Hand,
            ..params.clone()
        },
        false,
    );
    assert_eq!(hand_only.teacher_kind, bc::TeacherKind::Hand);
    assert_eq!(
        hand_only.learner_final,
        result.hand.as_ref().unwrap().learner_final
    );

    // The paper's rule alone gives the paper's figures unchanged: the directional rounds run on a
    // learner of their own.
    let paper_only = bc::run(
        3,
        &BcParams {
            critique: bc::Rules::Paper,
            teachers: bc::Teachers::Controller,
            ..params.clone()
        },
        false,
    );
    assert!(paper_only.directional.is_none());
    assert_eq!(paper_only.learner_final, result.learner_final);
    assert_eq!(paper_only.curve, result.curve);
    assert_eq!(paper_only.critiques, result.critiques);
    assert_eq!(paper_only.paired_runs, result.paired_runs);
    assert!(!paper_only.render().contains("directional"));

    // The directional rule alone is reported as the first rule, named as such.
    let dir_only = bc::run(
        3,
        &BcParams {
            critique: bc::Rules::Directional,
            teachers: bc::Teachers::Controller,
            ..params.clone()
        },
        false,
    );
    let dir = result.directional.as_ref().unwrap();
    assert_eq!(
        dir_only.rule,
        advise::policy::dataset::CritiqueRule::Directional
    );
    assert_eq!(
        dir_only.learner_final.success_rate,
        dir.learner_final.success_rate
    );
    assert_eq!(dir_only.curve, dir.curve);
    assert!(dir_only.render().contains("learner final π (directional)"));
}

#[test]
fn reduced_aopi_study_reports_every_arm() {
    let params = AopiParams {
        max_practice: 12,
        hybrid_teleop: 4,
        eval_every: 3,
        patience: 10,
        test_goals: 10,
        ..AopiParams::default()
    };
    // The same study without the takeover arm (checked at the end) on a thread of its own: the
    // two runs are this test binary's longest.
    let without = std::thread::spawn({
        let params = AopiParams {
            takeover_arm: false,
            ..params.clone()
        };
        move || aopi::run(5, &params, false)
    });
    let result = aopi::run(5, &params, false);
    let v = serde_json::to_value(&result).unwrap();
    assert_eq!(v["experiment"], "aopi");
    assert_eq!(v["seed"], 5);
    let seed_points = v["seed_demo_points"].as_u64().unwrap();
    for arm in ["baseline", "advised", "hybrid", "teleop", "takeover"] {
        rate(&v, &format!("/arms/{arm}/success_rate"));
        let a = &v["arms"][arm];
        assert!(a["mean_position_error_m"].as_f64().unwrap() >= 0.0);
        let h = a["mean_heading_error_rad"].as_f64().unwrap();
        assert!((0.0..=std::f64::consts::PI).contains(&h));
        let size = a["dataset_size"].as_u64().unwrap();
        assert!(size >= seed_points, "{arm}: {size} < {seed_points}");
        assert_eq!(a["episodes"], 10);
        // Each arm carries the halted policy (reported) and the best test evaluation, with the
        // same fields; the reported figures are the halted policy's.
        let fields = |k: &str| {
            let mut f: Vec<String> = a[k].as_object().unwrap().keys().cloned().collect();
            f.sort();
            f
        };
        assert_eq!(fields("halted"), fields("best"), "{arm}");
        assert_eq!(a["halted"]["success_rate"], a["success_rate"], "{arm}");
        assert_eq!(a["halted"]["dataset_size"], a["dataset_size"], "{arm}");
        assert!(
            a["best"]["successes"].as_u64() >= a["halted"]["successes"].as_u64(),
            "{arm}"
        );
    }
    // The stopping rule read validation goals at every evaluation.
    for arm in ["advised", "hybrid", "teleop", "takeover"] {
        for p in v["arms"][arm]["curve"].as_array().unwrap() {
            rate(p, "/validation_success_rate");
        }
    }
    let arms = &result.arms;
    assert_eq!(arms.baseline.dataset_size, result.seed_demo_points);
    assert_eq!(arms.baseline.executions, 9);
    // Advice adds only the advised chunks; teleoperation adds whole executions.
    assert_eq!(
        arms.advised.dataset_size,
        result.seed_demo_points + arms.advised.advice_points
    );
    assert_eq!(arms.advised.teleop_demos, 0);
    assert_eq!(arms.teleop.advice_given, 0);
    assert_eq!(arms.advised.executions, 9 + arms.advised.advised_executions);
    assert_eq!(arms.teleop.executions, 9 + arms.teleop.teleop_demos);
    if arms.advised.advised_executions > 0 && arms.teleop.teleop_demos > 0 {
        let per_advised =
            arms.advised.advice_points as f64 / arms.advised.advised_executions as f64;
        let per_demo = (arms.teleop.dataset_size - result.seed_demo_points) as f64
            / arms.teleop.teleop_demos as f64;
        assert!(per_advised < per_demo, "{per_advised} vs {per_demo}");
    }
    // Takeovers add only the teacher's windows, each one execution, and nothing else.
    let takeover = arms
        .takeover
        .as_ref()
        .expect("the takeover arm runs by default");
    assert_eq!(
        takeover.dataset_size,
        result.seed_demo_points + takeover.takeover_points
    );
    assert_eq!(takeover.executions, 9 + takeover.takeovers);
    assert_eq!(
        (takeover.advice_given, takeover.teleop_demos),
        (0, 0),
        "the takeover arm neither advises nor demonstrates whole runs"
    );
    assert!(
        takeover.takeovers > 0,
        "the baseline's poor practice runs were taken over"
    );
    assert!(result.render().contains("takeover "));
    // Figure 11's curves grow with the executions.
    for arm in [&arms.advised, &arms.hybrid, &arms.teleop, takeover] {
        for w in arm.curve.windows(2) {
            assert!(w[1].executions >= w[0].executions);
            assert!(w[1].dataset_size >= w[0].dataset_size);
        }
        assert!(arm.practice_final <= arm.practice_run && arm.practice_run <= 12);
    }
    // The other arms do not depend on the takeover arm (docs/protocol.md, T7): without it they
    // come out the same to the last bit (which also shows the study repeats itself), and the
    // result has no takeover.
    let without = without
        .join()
        .expect("the study without the takeover arm ran");
    assert_eq!(without.arms.takeover, None);
    assert_eq!(
        (&without.arms.baseline, &without.arms.advised),
        (&arms.baseline, &arms.advised)
    );
    assert_eq!(
        (&without.arms.hybrid, &without.arms.teleop),
        (&arms.hybrid, &arms.teleop)
    );
    let v = serde_json::to_value(&without).unwrap();
    assert!(v["arms"].get("takeover").is_none());
}

#[test]
fn advised_arm_dataset_is_smaller_than_teleop_on_a_full_length_run() {
    // With every practice goal used by both arms, advice grows the dataset less.
    let params = AopiParams {
        max_practice: 15,
        eval_every: 15,
        patience: 100,
        test_goals: 5,
        ..AopiParams::default()
    };
    let r = aopi::run(2, &params, false);
    let (adv, tele) = (
        r.arms.advised.curve.last().unwrap(),
        r.arms.teleop.curve.last().unwrap(),
    );
    assert!(
        adv.dataset_size < tele.dataset_size,
        "{} vs {}",
        adv.dataset_size,
        tele.dataset_size
    );
}

#[test]
fn plots_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let b = bc::run(
        1,
        &BcParams {
            demos: 5,
            rounds: 2,
            eval_every: 1,
            test_starts: 5,
            ..BcParams::default()
        },
        false,
    );
    let files = advise::experiment::plot::bc(&b, dir.path()).unwrap();
    let a = aopi::run(
        1,
        &AopiParams {
            max_practice: 3,
            eval_every: 1,
            test_goals: 3,
            ..AopiParams::default()
        },
        false,
    );
    let more = advise::experiment::plot::aopi(&a, dir.path()).unwrap();
    // BC: one figure per teacher's arm; A-OPI: three.
    assert_eq!(files.len() + more.len(), 6);
    for f in files.iter().chain(&more) {
        let text = std::fs::read_to_string(f).unwrap();
        assert!(text.starts_with("<svg"), "{}", f.display());
        assert!(!text.contains(">-0.0"), "{}", f.display());
    }
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap();
    // Figure 5 draws both critique rules' curves, each named.
    let figure5 = read("bc-seed1-success.svg");
    assert!(
        figure5.contains("learner, paper&apos;s rule") || figure5.contains("learner, paper's rule")
    );
    assert!(figure5.contains("learner, directional rule"), "{figure5}");
    assert!(figure5.contains("hand-written controller"), "{figure5}");
    // Critique's ceilings, drawn where the oracle had data.
    let o = b.oracles.as_ref().unwrap();
    assert_eq!(
        figure5.contains("ceiling: successful demonstrations"),
        o.successful_demos.figures.is_some()
    );
    assert!(read("bc-seed1-hand-success.svg").contains("human-like hand"));
    // Value labels on the bars, the paper's value beside ours.
    let success = read("aopi-seed1-success.svg");
    let ours = format!("{:.0}%", 100.0 * a.arms.advised.success_rate);
    assert!(success.contains(&ours), "{ours}");
    assert!(success.contains("paper 88%") && success.contains("paper 32%"));
    let error = read("aopi-seed1-position-error.svg");
    assert!(error.contains(&format!("{:.2}", a.arms.teleop.mean_position_error_m)));
    // The kept policy is named and marked on the dataset curves.
    let dataset = read("aopi-seed1-dataset.svg");
    let kept = format!(
        "Advised: kept at {} executions (paper 69)",
        a.arms.advised.executions
    );
    assert!(dataset.contains(&kept), "{kept}");
    // The takeover arm is drawn beside the paper's, with no paper value of its own.
    let takeover = a.arms.takeover.as_ref().unwrap();
    let kept = format!(
        "Takeover: kept at {} executions (ours)",
        takeover.executions
    );
    assert!(dataset.contains(&kept), "{kept}");
    assert!(success.contains("Takeover"));
    // Four legend entries, the axis note, and a "kept" beside each arm's ring.
    assert_eq!(dataset.matches("kept").count(), 9);
}

#[test]
fn summaries_count_the_shape_claims_seed_by_seed() {
    use advise::experiment::summary;
    let params = BcParams {
        demos: 12,
        rounds: 6,
        eval_every: 3,
        test_starts: 12,
        ..BcParams::default()
    };
    let runs: Vec<_> = [4, 7].iter().map(|&s| bc::run(s, &params, false)).collect();
    let s = summary::bc(runs.clone());
    assert_eq!(s.seeds, [4, 7]);
    assert_eq!(s.shape.seeds, 2);
    assert_eq!(s.shape.claims.len(), summary::BC_CLAIMS.len());
    for (c, claim) in s.shape.claims.iter().enumerate() {
        let expect: Vec<u64> = runs
            .iter()
            .filter(|r| summary::bc_checks(r)[c])
            .map(|r| r.seed)
            .collect();
        assert_eq!(claim.seeds_held, expect, "{}", claim.claim);
    }
    let all: Vec<u64> = runs
        .iter()
        .filter(|r| summary::bc_checks(r).iter().all(|&b| b))
        .map(|r| r.seed)
        .collect();
    assert_eq!(s.shape.seeds_all_held, all);
    let mean = (runs[0].teacher.success_rate + runs[1].teacher.success_rate) / 2.0;
    assert!((s.teacher_success.mean - mean).abs() < 1e-12);
    let text = s.render();
    assert!(text.contains("final matches or beats the teacher on success"));
    assert!(text.contains("of 2 seeds"));
    let v = serde_json::to_value(&s).unwrap();
    assert_eq!(v["runs"].as_array().unwrap().len(), 2);
    // The directional rule's own spreads and claim counts.
    let d = s.directional.as_ref().unwrap();
    assert_eq!(d.shape.seeds, 2);
    for (c, claim) in d.shape.claims.iter().enumerate() {
        let expect: Vec<u64> = runs
            .iter()
            .filter(|r| summary::bc_rule_checks(r, r.directional.as_ref().unwrap())[c])
            .map(|r| r.seed)
            .collect();
        assert_eq!(claim.seeds_held, expect, "{}", claim.claim);
    }
    let dmean = runs
        .iter()
        .map(|r| r.directional.as_ref().unwrap().learner_final.success_rate)
        .sum::<f64>()
        / 2.0;
    assert!((d.learner_final_success.mean - dmean).abs() < 1e-12);
    assert!(text.contains("learner final π (directional)"), "{text}");
    assert!(
        text.contains("with the directional rule's final π"),
        "{text}"
    );
    assert!(v["directional"]["shape"]["claims"].is_array());

    let a = AopiParams {
        max_practice: 4,
        eval_every: 2,
        test_goals: 4,
        ..AopiParams::default()
    };
    let runs: Vec<_> = [1, 2].iter().map(|&s| aopi::run(s, &a, false)).collect();
    let s = summary::aopi(runs.clone());
    assert_eq!(s.shape.claims.len(), summary::AOPI_CLAIMS.len());
    for (c, claim) in s.shape.claims.iter().enumerate() {
        let expect: Vec<u64> = runs
            .iter()
            .filter(|r| summary::aopi_checks(r)[c])
            .map(|r| r.seed)
            .collect();
        assert_eq!(claim.seeds_held, expect, "{}", claim.claim);
    }
    assert!(s.render().contains("A-OPI Hybrid"));
    // The takeover arm's pre-registered claims, counted the same way, and its comparisons.
    let t = s.takeover.as_ref().expect("every run has the takeover arm");
    assert_eq!(t.shape.claims.len(), summary::TAKEOVER_CLAIMS.len());
    for (c, claim) in t.shape.claims.iter().enumerate() {
        let expect: Vec<u64> = runs
            .iter()
            .filter(|r| summary::takeover_checks(r).unwrap()[c])
            .map(|r| r.seed)
            .collect();
        assert_eq!(claim.seeds_held, expect, "{}", claim.claim);
    }
    let minus: Vec<f64> = runs
        .iter()
        .map(|r| r.arms.takeover.as_ref().unwrap().success_rate - r.arms.advised.success_rate)
        .collect();
    let d = t.minus_advised.unwrap();
    assert!((d.mean - (minus[0] + minus[1]) / 2.0).abs() < 1e-12);
    let text = s.render();
    assert!(text.contains("Takeover"), "{text}");
    assert!(
        text.contains("takeover matches or beats teleoperation on success"),
        "{text}"
    );
    // A summary of results made before the arm has no takeover part.
    let mut older = runs.clone();
    for r in &mut older {
        r.arms.takeover = None;
    }
    let o = summary::aopi(older);
    assert!(o.takeover.is_none() && o.arms.takeover.is_none());
    assert!(!o.render().contains("Takeover"));
}

#[test]
fn bad_seed_ranges_are_diagnostics() {
    for (args, expect) in [
        (&["experiment", "bc", "--seeds", "3..3"][..], "bad_seeds"),
        (&["experiment", "bc", "--seeds", "five"][..], "bad_seeds"),
        (
            &["experiment", "aopi", "--seed", "1", "--seeds", "0..2"][..],
            "cannot be used with",
        ),
        (
            &["experiment", "aopi", "--critique", "paper"][..],
            "advise::cli::critique_without_bc",
        ),
        (
            &["experiment", "aopi", "--teacher", "hand"][..],
            "advise::cli::teacher_without_bc",
        ),
        (
            &["experiment", "bc", "--teacher", "robot"][..],
            "possible values: controller, hand, both",
        ),
        (
            &["experiment", "bc", "--critique", "sideways"][..],
            "possible values: paper, directional, both",
        ),
        (
            &["experiment", "aopi", "--revert", "chunks"][..],
            "advise::cli::revert_not_in_study",
        ),
        (
            &["experiment", "bc", "--revert", "advisor"][..],
            "`advise experiment aopi --revert advisor`",
        ),
        (
            &["experiment", "bc", "--revert", "speed"][..],
            "invalid value 'speed' for '--revert <CHOICE>'",
        ),
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_advise"))
            .args(args)
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expect), "{args:?}: {err}");
    }
}

/// `calibrate --write` into a folder that does not exist is refused before the calibration runs
/// (it takes a minute), naming the folder; nothing is written.
#[test]
fn calibrating_into_a_missing_folder_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("no-such-folder").join("bc.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_advise"))
        .args(["calibrate", "bc", "--write"])
        .arg(&target)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("advise::cli::no_folder"), "{err}");
    assert!(err.contains("no-such-folder"), "{err}");
    assert!(out.stdout.is_empty(), "nothing ran, nothing printed");
    assert!(!target.exists());
}
