//! The simulated base: deterministic for a seed, never beyond its limits, and its parameter files
//! report mistakes clearly.

use advise::backend::Backend;
use advise::backend::sim::{SimBackend, SimBase, SimParams};
use advise::trace::Pose;
use proptest::prelude::*;

/// As the REPL draws it (the errors bring their own sources).
fn render(err: &dyn miette::Diagnostic) -> String {
    advise::diag::render(&advise::diag::SourceMap::new(), err, false)
}

/// A wiggly command sequence that exercises turning, reversing and the limits.
fn drive(base: &mut SimBase, steps: usize) -> Vec<(Pose, Pose, f64, f64)> {
    base.reset(Pose::new(0.3, -0.2, 0.1));
    (0..steps)
        .map(|k| {
            let t = k as f64 / 30.0;
            base.set_command(1.5 * (0.7 * t).sin(), 2.0 * (1.3 * t).cos());
            let s = base.advance(1.0 / 30.0);
            (s.pose, base.true_pose(), s.speed_mps, s.rot_radps)
        })
        .collect()
}

#[test]
fn same_seed_same_run_other_seed_other_run() {
    let p = SimParams::default();
    let a = drive(&mut SimBase::new(p.clone(), 7), 300);
    let b = drive(&mut SimBase::new(p.clone(), 7), 300);
    let c = drive(&mut SimBase::new(p, 8), 300);
    assert_eq!(a, b);
    assert_ne!(a, c);
    // The noise reaches odometry only: the true path does not depend on the seed.
    assert!(a.iter().zip(&c).all(|(x, y)| x.1 == y.1));
}

#[test]
fn odometry_drifts_mostly_in_heading() {
    let mut base = SimBase::new(SimParams::default(), 3);
    let run = drive(&mut base, 600);
    let (odom, truth, _, _) = run.last().copied().unwrap();
    let heading_err = advise::backend::sim::wrap_angle(odom.theta_rad - truth.theta_rad).abs();
    assert!(
        heading_err > 0.01,
        "dead reckoning should drift: {heading_err}"
    );
    assert!(heading_err < 0.5, "but not absurdly: {heading_err}");
}

#[test]
fn a_base_at_rest_reads_zero_and_stays_put() {
    let mut base = SimBase::new(SimParams::default(), 1);
    base.reset(Pose::new(1.0, 1.0, 1.0));
    for _ in 0..100 {
        let s = base.advance(1.0 / 30.0);
        assert_eq!((s.speed_mps, s.rot_radps), (0.0, 0.0));
        assert_eq!(s.pose, Pose::new(1.0, 1.0, 1.0));
    }
}

#[test]
fn the_backend_runs_the_base_at_the_control_rate() {
    let mut b = SimBackend::new(SimParams::default(), 5);
    assert_eq!(b.name(), "sim");
    assert!((b.period_s() - 1.0 / 30.0).abs() < 1e-15);
    b.reset(Pose::default()).unwrap();
    b.command(0.5, 0.0).unwrap();
    let mut last = b.step().unwrap();
    for _ in 0..59 {
        last = b.step().unwrap();
    }
    assert!((last.t_s - 2.0).abs() < 1e-9);
    assert!(b.true_pose().unwrap().x_m > 0.5);
    b.stop().unwrap();
    for _ in 0..60 {
        last = b.step().unwrap();
    }
    assert!(last.speed_mps.abs() < 1e-3);
}

proptest! {
    /// Whatever is commanded (huge, reversed, NaN), the true speeds stay within the limits and
    /// change no faster than the acceleration limits allow.
    #[test]
    fn the_base_never_exceeds_its_limits(
        cmds in proptest::collection::vec(
            (prop_oneof![-5.0..5.0f64, Just(f64::NAN), Just(f64::INFINITY)],
             prop_oneof![-5.0..5.0f64, Just(f64::NAN), Just(f64::NEG_INFINITY)],
             1usize..20),
            1..40),
        dt_s in prop_oneof![Just(1.0 / 30.0), 0.001..0.2f64],
        seed in any::<u64>(),
    ) {
        let p = SimParams::default();
        let mut base = SimBase::new(p.clone(), seed);
        base.reset(Pose::default());
        let eps = 1e-12;
        let (mut v0, mut w0) = base.true_speeds();
        for (v, w, repeat) in cmds {
            base.set_command(v, w);
            let (cv, cw) = base.command();
            prop_assert!(cv.abs() <= p.max_speed_mps && cw.abs() <= p.max_rot_radps);
            for _ in 0..repeat {
                let s = base.advance(dt_s);
                prop_assert!(s.pose.x_m.is_finite() && s.pose.theta_rad.is_finite());
                let (v1, w1) = base.true_speeds();
                prop_assert!(v1.abs() <= p.max_speed_mps + eps);
                prop_assert!(w1.abs() <= p.max_rot_radps + eps);
                prop_assert!((v1 - v0).abs() <= p.max_accel_mps2 * dt_s + eps);
                prop_assert!((w1 - w0).abs() <= p.max_rot_accel_radps2 * dt_s + eps);
                v0 = v1;
                w0 = w1;
            }
        }
    }
}

/// Each field's bounds are accepted, just outside them is refused with a diagnostic naming the
/// field, the defaults are inside, and NaN and infinities never pass.
#[test]
fn every_parameter_has_a_range() {
    let defaults = SimParams::default().values();
    for (i, r) in SimParams::RANGES.iter().enumerate() {
        assert!(r.min <= defaults[i] && defaults[i] <= r.max, "{r:?}");
        let with = |v: f64| {
            let text = format!(
                "{{\"{}\": {}}}",
                r.field,
                serde_json::to_string(&v).unwrap()
            );
            SimParams::from_json_str("p.json", &text)
        };
        for ok in [r.min, r.max] {
            let p = with(ok).unwrap_or_else(|e| panic!("{}: {ok}: {e}", r.field));
            assert_eq!(p.values()[i], ok);
        }
        let step = (r.max - r.min) * 1e-3;
        for bad in [r.min - step, r.max + step, 1e300, -1e300] {
            let e = with(bad).unwrap_err();
            let code = miette::Diagnostic::code(&e).unwrap().to_string();
            assert_eq!(code, "advise::sim::params_invalid", "{}: {bad}", r.field);
            assert!(e.to_string().contains(r.field), "{e}");
            assert!(miette::Diagnostic::labels(&e).is_some_and(|mut l| l.next().is_some()));
        }
        // Parameters built in code (not from a file) are checked too, without a span.
        let mut values = SimParams::default();
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            set(&mut values, i, bad);
            let e = values.validate().unwrap_err();
            assert!(e.to_string().contains(r.field), "{e}");
        }
    }
}

fn set(p: &mut SimParams, i: usize, v: f64) {
    let fields = [
        &mut p.rate_hz,
        &mut p.max_speed_mps,
        &mut p.max_rot_radps,
        &mut p.max_accel_mps2,
        &mut p.max_rot_accel_radps2,
        &mut p.lag_s,
        &mut p.track_width_m,
        &mut p.encoder_noise_frac,
        &mut p.odom_rot_scale_error,
        &mut p.heading_drift_rad_per_m,
        &mut p.max_substep_s,
    ];
    *fields.into_iter().nth(i).unwrap() = v;
}

/// Parameters that skipped validation still give a bounded run: one advance takes at most
/// `MAX_SUBSTEPS_PER_ADVANCE` substeps however small `max_substep_s` is.
#[test]
fn an_unvalidated_substep_cannot_hang_the_base() {
    let p = SimParams {
        max_substep_s: 1e-300,
        ..SimParams::default()
    };
    let mut base = SimBase::new(p, 0);
    base.reset(Pose::default());
    base.set_command(0.5, 0.0);
    let s = base.advance(1.0);
    assert!(s.pose.x_m > 0.0 && s.pose.x_m.is_finite(), "{s:?}");
}

#[test]
fn params_files_keep_defaults_for_omitted_fields() {
    let p = SimParams::from_json_str("p.json", r#"{"lag_s": 0.4}"#).unwrap();
    assert_eq!(p.lag_s, 0.4);
    assert_eq!(p.rate_hz, 30.0);
    let text = serde_json::to_string_pretty(&SimParams::default()).unwrap();
    assert_eq!(
        SimParams::from_json_str("d.json", &text).unwrap(),
        SimParams::default()
    );
}

#[test]
fn params_file_diagnostics() {
    let typo = "{\n  \"lag_s\": 0.3,\n  \"max_sped_mps\": 2.0\n}\n";
    let invalid = r#"{"rate_hz": 0}"#;
    let not_json = "{\"lag_s\": fast}";
    let mut out = String::new();
    for (name, text) in [
        ("typo.json", typo),
        ("invalid.json", invalid),
        ("bad.json", not_json),
        // The hostile-input report's cases: each used to run (a 1.4 GB CSV, an out-of-memory
        // abort, a hang, NaN rows that could not be read back).
        ("fast.json", "{\"rate_hz\": 1e6}"),
        (
            "huge.json",
            "{\n  \"lag_s\": 0.3,\n  \"rate_hz\": 1e300\n}\n",
        ),
        (
            "tiny_step.json",
            r#"{"rate_hz": 30, "max_substep_s": 1e-9}"#,
        ),
        ("noise.json", r#"{ "encoder_noise_frac" : 1e308 }"#),
        // An escaped key is still found.
        ("escaped.json", r#"{"tr\u0061ck_width_m": -2}"#),
    ] {
        let err = SimParams::from_json_str(name, text).unwrap_err();
        out.push_str(&format!("----- {name}\n{}\n", render(&err)));
    }
    let missing = SimParams::load(
        &mut advise::diag::SourceMap::new(),
        std::path::Path::new("/nonexistent/sim.json"),
    )
    .unwrap_err();
    out.push_str(&format!("----- missing\n{}\n", render(&missing)));
    insta::assert_snapshot!(out);
}
