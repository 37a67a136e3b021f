//! Several seeds of a study at once: each figure's mean and spread across the seeds beside the
//! paper's, and for how many seeds the shape of the paper's result holds, claim by claim.
//!
//! The shape claims are the issue's, checked per seed on the figures the study printed:
//! - BC: the final policy beats the initial one on success and on length (mean path over the
//!   paired runs), and matches or beats the teacher on success; the same three claims again
//!   with the directional rule's final policy when it ran (its lengths over its own paired runs);
//! - A-OPI: the advised and hybrid policies beat the baseline on success, match or beat
//!   teleoperation on success, and end with a smaller dataset than teleoperation.
//!
//! A seed "holds" when every claim of its study holds. Beside each claim's seed count stands the
//! paired difference it reads (per seed, e.g. final minus initial success), its mean and a
//! bootstrap 95% interval over the seeds ([`Interval`]). A-OPI's figures are the halted
//! policies'. Nothing here runs a study.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::eval::ending_name;
use crate::experiment::aopi::{AopiResult, ArmFigures, Arms};
use crate::experiment::bc::{self, BcFigures, BcOracles, BcResult, BcRuleResult, TeacherKind};
use crate::experiment::{mean_sd, pct};
use crate::policy::dataset::CritiqueRule;

/// Mean and sample standard deviation of one figure across seeds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    pub mean: f64,
    pub sd: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Spread {
        let (mean, sd) = mean_sd(values);
        Spread { mean, sd }
    }
}

/// One shape claim and the seeds it held for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Claim {
    pub claim: String,
    pub seeds_held: Vec<u64>,
    /// The paired difference the claim reads (positive: in the claim's direction), its mean over
    /// the seeds and a bootstrap 95% interval of that mean.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub difference: Option<Interval>,
}

/// The mean of a per-seed difference and its bootstrap 95% interval (percentiles of the means of
/// [`BOOTSTRAP_RESAMPLES`] resamples of the seeds, with replacement, from a fixed seed).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub mean: f64,
    pub lo95: f64,
    pub hi95: f64,
    /// Seeds the difference exists for.
    pub seeds: usize,
}

/// Resamples of the seeds behind each [`Interval`].
pub const BOOTSTRAP_RESAMPLES: usize = 10_000;

impl Interval {
    /// The interval of `values`' mean; `None` without values.
    pub fn of(values: &[f64]) -> Option<Interval> {
        use rand::{Rng, SeedableRng};
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xB007_5742);
        let mut means: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
            .map(|_| (0..n).map(|_| values[rng.random_range(0..n)]).sum::<f64>() / n as f64)
            .collect();
        means.sort_by(f64::total_cmp);
        let at = |q: f64| means[((q * BOOTSTRAP_RESAMPLES as f64) as usize).min(means.len() - 1)];
        Some(Interval {
            mean,
            lo95: at(0.025),
            hi95: at(0.975),
            seeds: n,
        })
    }
}

/// The shape claims over all seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Shape {
    pub claims: Vec<Claim>,
    /// Seeds for which every claim held.
    pub seeds_all_held: Vec<u64>,
    pub seeds: usize,
}

impl Shape {
    /// The claims from each seed's checks and, per claim, each seed's paired difference (none
    /// where the seed has no such figure).
    fn from_checks(
        seeds: &[u64],
        names: &[&str],
        checks: &[Vec<bool>],
        diffs: &[Vec<Option<f64>>],
    ) -> Shape {
        let claims = names
            .iter()
            .enumerate()
            .map(|(c, name)| Claim {
                claim: name.to_string(),
                seeds_held: seeds
                    .iter()
                    .zip(checks)
                    .filter(|(_, ok)| ok[c])
                    .map(|(s, _)| *s)
                    .collect(),
                difference: Interval::of(
                    &diffs
                        .iter()
                        .filter_map(|d| d.get(c).copied().flatten())
                        .collect::<Vec<_>>(),
                ),
            })
            .collect();
        Shape {
            claims,
            seeds_all_held: seeds
                .iter()
                .zip(checks)
                .filter(|(_, ok)| ok.iter().all(|&b| b))
                .map(|(s, _)| *s)
                .collect(),
            seeds: seeds.len(),
        }
    }

    fn render(&self, s: &mut String, label: &str) {
        let _ = writeln!(s, "  shape of the paper's result{label}, per seed:");
        for c in &self.claims {
            let interval = c.difference.map_or(String::new(), |d| {
                format!(
                    "   difference {:+.3} [{:+.3}, {:+.3}]",
                    d.mean, d.lo95, d.hi95
                )
            });
            let _ = writeln!(
                s,
                "    {:<52} {} of {} seeds{interval}",
                c.claim,
                c.seeds_held.len(),
                self.seeds
            );
        }
        let _ = writeln!(
            s,
            "    {:<52} {} of {} seeds {:?}",
            "all of them",
            self.seeds_all_held.len(),
            self.seeds,
            self.seeds_all_held
        );
    }
}

/// Table 1 across seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcSummary {
    pub experiment: String,
    pub seeds: Vec<u64>,
    pub learner_initial_success: Spread,
    pub learner_initial_length_m: Spread,
    pub learner_final_success: Spread,
    pub learner_final_length_m: Spread,
    pub teacher_success: Spread,
    pub teacher_length_m: Spread,
    pub shape: Shape,
    /// The rule of `learner_final_*` and `shape` (the paper's, unless only the directional rule
    /// ran).
    #[serde(default)]
    pub rule: CritiqueRule,
    /// The directional rule's final policy across the seeds, when both rules ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub directional: Option<BcRuleSummary>,
    /// Whose demonstrations (the arm).
    #[serde(default)]
    pub teacher_kind: TeacherKind,
    /// Critique's ceiling across the seeds (the second protocol, S6), when the runs carry it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub oracles: Option<BcOracleSummary>,
    /// How the test episodes ended, per policy (`teacher`, `initial`, `final`), ending by ending
    /// (`captured`, `ball_out`, `robot_out`, `time_limit`): the count in the test set.
    #[serde(default)]
    pub endings: BTreeMap<String, BTreeMap<String, Spread>>,
    /// The human-like teacher's arm across the same seeds, when both arms ran (its `runs` are
    /// inside each run's `hand`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hand: Option<Box<BcSummary>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub runs: Vec<BcResult>,
}

/// The oracles across seeds: success over every seed; length over the seeds where the oracle had
/// paired runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcOracleSummary {
    pub successful_demos_success: Spread,
    pub successful_demos_length_m: Spread,
    pub successful_demos_points: Spread,
    pub perfect_critique_success: Spread,
    pub perfect_critique_length_m: Spread,
    pub perfect_critique_points: Spread,
    /// The share of the demonstrations' points the critic flags (what perfect critique removes).
    pub perfect_critique_removed_share: Spread,
}

/// One more critique rule across seeds: its final policy, the lengths over its own paired runs,
/// and the shape claims with its final policy.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcRuleSummary {
    pub rule: CritiqueRule,
    pub learner_final_success: Spread,
    pub learner_final_length_m: Spread,
    /// The initial policy's mean length over this rule's paired runs.
    pub learner_initial_length_m: Spread,
    /// The teacher's mean length over this rule's paired runs.
    pub teacher_length_m: Spread,
    pub shape: Shape,
}

/// The BC shape claims of one seed, in the order of [`BC_CLAIMS`].
pub fn bc_checks(r: &BcResult) -> Vec<bool> {
    let (i, f, t) = (&r.learner_initial, &r.learner_final, &r.teacher);
    vec![
        f.success_rate > i.success_rate,
        matches!((f.mean_length_m, i.mean_length_m), (Some(f), Some(i)) if f < i),
        f.success_rate >= t.success_rate,
    ]
}

/// The BC shape claims of one seed with another rule's final policy (lengths over that rule's
/// paired runs), in the order of [`BC_CLAIMS`].
pub fn bc_rule_checks(r: &BcResult, d: &BcRuleResult) -> Vec<bool> {
    let (i, f, t) = (&r.learner_initial, &d.learner_final, &r.teacher);
    vec![
        f.success_rate > i.success_rate,
        matches!((f.mean_length_m, d.learner_initial_length_m), (Some(f), Some(i)) if f < i),
        f.success_rate >= t.success_rate,
    ]
}

/// The paired differences the BC claims read, in the order of [`BC_CLAIMS`] (positive: in the
/// claim's direction): final minus initial success, initial minus final length, final minus
/// teacher success.
pub fn bc_diffs(r: &BcResult) -> Vec<Option<f64>> {
    let (i, f, t) = (&r.learner_initial, &r.learner_final, &r.teacher);
    vec![
        Some(f.success_rate - i.success_rate),
        i.mean_length_m.zip(f.mean_length_m).map(|(i, f)| i - f),
        Some(f.success_rate - t.success_rate),
    ]
}

/// [`bc_diffs`] with another rule's final policy (lengths over its own paired runs).
pub fn bc_rule_diffs(r: &BcResult, d: &BcRuleResult) -> Vec<Option<f64>> {
    let (i, f, t) = (&r.learner_initial, &d.learner_final, &r.teacher);
    vec![
        Some(f.success_rate - i.success_rate),
        d.learner_initial_length_m
            .zip(f.mean_length_m)
            .map(|(i, f)| i - f),
        Some(f.success_rate - t.success_rate),
    ]
}

pub const BC_CLAIMS: [&str; 3] = [
    "final beats initial on success",
    "final beats initial on length",
    "final matches or beats the teacher on success",
];

pub fn bc(runs: Vec<BcResult>) -> BcSummary {
    let hand_runs: Vec<BcResult> = runs
        .iter()
        .filter_map(|r| r.hand.as_deref().cloned())
        .collect();
    let hand = (!hand_runs.is_empty() && hand_runs.len() == runs.len()).then(|| {
        let mut h = bc(hand_runs);
        h.runs.clear();
        Box::new(h)
    });
    let mut summary = bc_arm(runs);
    summary.hand = hand;
    summary
}

fn oracle_summary(runs: &[BcResult]) -> Option<BcOracleSummary> {
    let all: Vec<(&BcResult, &BcOracles)> = runs
        .iter()
        .filter_map(|r| r.oracles.as_ref().map(|o| (r, o)))
        .collect();
    if all.is_empty() || all.len() != runs.len() {
        return None;
    }
    let spread = |f: &dyn Fn(&BcResult, &BcOracles) -> Option<f64>| {
        Spread::of(&all.iter().filter_map(|(r, o)| f(r, o)).collect::<Vec<_>>())
    };
    // An oracle with no data catches nothing.
    let success = |o: &crate::experiment::bc::BcOracle| {
        Some(o.figures.as_ref().map_or(0.0, |f| f.success_rate))
    };
    let length =
        |o: &crate::experiment::bc::BcOracle| o.figures.as_ref().and_then(|f| f.mean_length_m);
    Some(BcOracleSummary {
        successful_demos_success: spread(&|_, o| success(&o.successful_demos)),
        successful_demos_length_m: spread(&|_, o| length(&o.successful_demos)),
        successful_demos_points: spread(&|_, o| Some(o.successful_demos.points as f64)),
        perfect_critique_success: spread(&|_, o| success(&o.perfect_critique)),
        perfect_critique_length_m: spread(&|_, o| length(&o.perfect_critique)),
        perfect_critique_points: spread(&|_, o| Some(o.perfect_critique.points as f64)),
        perfect_critique_removed_share: spread(&|r, o| {
            (r.demo_points > 0)
                .then(|| 1.0 - o.perfect_critique.points as f64 / r.demo_points as f64)
        }),
    })
}

/// Which of a run's policies.
type FiguresOf = fn(&BcResult) -> &BcFigures;

/// Each policy's endings across seeds (see [`BcSummary::endings`]).
fn endings_summary(runs: &[BcResult]) -> BTreeMap<String, BTreeMap<String, Spread>> {
    let policies: [(&str, FiguresOf); 3] = [
        ("teacher", |r| &r.teacher),
        ("initial", |r| &r.learner_initial),
        ("final", |r| &r.learner_final),
    ];
    policies
        .iter()
        .map(|(name, of)| {
            let each = bc::ENDINGS
                .iter()
                .map(|&e| {
                    let k = ending_name(e);
                    let v: Vec<f64> = runs
                        .iter()
                        .map(|r| of(r).endings.get(k).copied().unwrap_or(0) as f64)
                        .collect();
                    (k.to_string(), Spread::of(&v))
                })
                .collect();
            (name.to_string(), each)
        })
        .collect()
}

/// One arm's Table 1 across seeds.
fn bc_arm(runs: Vec<BcResult>) -> BcSummary {
    let seeds: Vec<u64> = runs.iter().map(|r| r.seed).collect();
    let spread = |f: &dyn Fn(&BcResult) -> Option<f64>| {
        Spread::of(&runs.iter().filter_map(f).collect::<Vec<_>>())
    };
    let checks: Vec<Vec<bool>> = runs.iter().map(bc_checks).collect();
    // The directional rule over the seeds that ran it (all of them, with `--critique both`).
    let with_dir: Vec<(&BcResult, &BcRuleResult)> = runs
        .iter()
        .filter_map(|r| r.directional.as_ref().map(|d| (r, d)))
        .collect();
    let directional = (!with_dir.is_empty()).then(|| {
        let spread = |f: &dyn Fn(&BcRuleResult) -> Option<f64>| {
            Spread::of(
                &with_dir
                    .iter()
                    .filter_map(|(_, d)| f(d))
                    .collect::<Vec<_>>(),
            )
        };
        let dir_seeds: Vec<u64> = with_dir.iter().map(|(r, _)| r.seed).collect();
        let dir_checks: Vec<Vec<bool>> =
            with_dir.iter().map(|(r, d)| bc_rule_checks(r, d)).collect();
        let dir_diffs: Vec<Vec<Option<f64>>> =
            with_dir.iter().map(|(r, d)| bc_rule_diffs(r, d)).collect();
        BcRuleSummary {
            rule: CritiqueRule::Directional,
            learner_final_success: spread(&|d| Some(d.learner_final.success_rate)),
            learner_final_length_m: spread(&|d| d.learner_final.mean_length_m),
            learner_initial_length_m: spread(&|d| d.learner_initial_length_m),
            teacher_length_m: spread(&|d| d.teacher_length_m),
            shape: Shape::from_checks(&dir_seeds, &BC_CLAIMS, &dir_checks, &dir_diffs),
        }
    });
    BcSummary {
        experiment: "bc".into(),
        rule: runs.first().map_or(CritiqueRule::Paper, |r| r.rule),
        directional,
        teacher_kind: runs
            .first()
            .map_or_else(TeacherKind::default, |r| r.teacher_kind),
        oracles: oracle_summary(&runs),
        endings: endings_summary(&runs),
        hand: None,
        learner_initial_success: spread(&|r| Some(r.learner_initial.success_rate)),
        learner_initial_length_m: spread(&|r| r.learner_initial.mean_length_m),
        learner_final_success: spread(&|r| Some(r.learner_final.success_rate)),
        learner_final_length_m: spread(&|r| r.learner_final.mean_length_m),
        teacher_success: spread(&|r| Some(r.teacher.success_rate)),
        teacher_length_m: spread(&|r| r.teacher.mean_length_m),
        shape: Shape::from_checks(
            &seeds,
            &BC_CLAIMS,
            &checks,
            &runs.iter().map(bc_diffs).collect::<Vec<_>>(),
        ),
        seeds,
        runs,
    }
}

fn rate(s: Spread) -> String {
    format!("{} ± {:.0}", pct(s.mean), 100.0 * s.sd)
}

fn num(s: Spread, digits: usize) -> String {
    format!("{:.*} ± {:.*}", digits, s.mean, digits, s.sd)
}

impl BcSummary {
    pub fn render(&self) -> String {
        let p = crate::experiment::bc::PAPER;
        let mut s = format!(
            "BC study (ball interception), seeds {:?}, teacher: {}: mean ± sd across seeds\n\n",
            self.seeds,
            self.teacher_kind.label()
        );
        let _ = writeln!(
            s,
            "  {:<29} {:>11} {:>13}   {:>13} {:>12}",
            "Table 1", "success", "length (m)", "paper success", "paper length"
        );
        let row =
            |s: &mut String, name: &str, sr: Spread, ln: Spread, paper: Option<(f64, f64)>| {
                let (ps, pl) = paper.map_or(("-".to_string(), "-".to_string()), |(ps, pl)| {
                    (pct(ps), format!("{pl:.2}"))
                });
                let _ = writeln!(
                    s,
                    "  {:<29} {:>11} {:>13}   {:>13} {:>12}",
                    name,
                    rate(sr),
                    num(ln, 2),
                    ps,
                    pl
                );
            };
        row(
            &mut s,
            "learner initial π",
            self.learner_initial_success,
            self.learner_initial_length_m,
            Some((p.learner_initial_success, p.learner_initial_length)),
        );
        match self.rule {
            CritiqueRule::Paper => row(
                &mut s,
                "learner final π",
                self.learner_final_success,
                self.learner_final_length_m,
                Some((p.learner_final_success, p.learner_final_length)),
            ),
            CritiqueRule::Directional => row(
                &mut s,
                "learner final π (directional)",
                self.learner_final_success,
                self.learner_final_length_m,
                None,
            ),
        }
        if let Some(d) = &self.directional {
            row(
                &mut s,
                "learner final π (directional)",
                d.learner_final_success,
                d.learner_final_length_m,
                None,
            );
        }
        row(
            &mut s,
            "teacher",
            self.teacher_success,
            self.teacher_length_m,
            Some((p.teacher_success, p.teacher_length)),
        );
        if let Some(d) = &self.directional {
            let _ = writeln!(
                s,
                "  the directional row's lengths: over its own paired runs (initial π {}, teacher {} there)",
                num(d.learner_initial_length_m, 2),
                num(d.teacher_length_m, 2)
            );
        }
        if let Some(o) = &self.oracles {
            let _ = writeln!(
                s,
                "  critique's ceiling (1-NN, no critique; lengths over each oracle's own paired runs):"
            );
            row(
                &mut s,
                "successful demonstrations",
                o.successful_demos_success,
                o.successful_demos_length_m,
                None,
            );
            row(
                &mut s,
                "perfect critique",
                o.perfect_critique_success,
                o.perfect_critique_length_m,
                None,
            );
            let _ = writeln!(
                s,
                "  perfect critique removes {} of the demonstrations' points",
                rate(o.perfect_critique_removed_share)
            );
        }
        for (who, e) in &self.endings {
            let [captured, ball_out, robot_out, limit] =
                bc::ENDINGS.map(|k| e.get(ending_name(k)).map_or(0.0, |v| v.mean));
            let _ = writeln!(
                s,
                "  {who}'s endings per test set (mean): captured {captured:.1}, ball out {ball_out:.1}, robot out {robot_out:.1}; safety limit {limit:.1}"
            );
        }
        s.push('\n');
        self.shape.render(&mut s, "");
        if let Some(d) = &self.directional {
            d.shape
                .render(&mut s, " with the directional rule's final π");
        }
        if let Some(h) = &self.hand {
            s.push('\n');
            s.push_str(&h.render());
        }
        s
    }
}

/// Figures 8, 9 and 11 across seeds, one row per arm.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ArmSpread {
    pub success_rate: Spread,
    pub mean_position_error_m: Spread,
    pub mean_heading_error_rad: Spread,
    pub dataset_size: Spread,
    pub executions: Spread,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AopiArms {
    pub baseline: ArmSpread,
    pub advised: ArmSpread,
    pub hybrid: ArmSpread,
    pub teleop: ArmSpread,
    /// The takeover arm (issue 53), when every run has it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub takeover: Option<ArmSpread>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AopiSummary {
    pub experiment: String,
    pub seeds: Vec<u64>,
    pub arms: AopiArms,
    pub shape: Shape,
    /// The takeover arm's pre-registered claims (docs/protocol.md, T6), when every run has it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub takeover: Option<TakeoverClaims>,
    pub runs: Vec<AopiResult>,
}

/// The takeover arm's claims ([`TAKEOVER_CLAIMS`]) and, as figures beside them, its success
/// minus the advised and the hybrid arms' (paired by seed, bootstrap 95% intervals).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TakeoverClaims {
    pub shape: Shape,
    pub minus_advised: Option<Interval>,
    pub minus_hybrid: Option<Interval>,
}

pub const TAKEOVER_CLAIMS: [&str; 3] = [
    "takeover beats the baseline on success",
    "takeover matches or beats teleoperation on success",
    "takeover dataset smaller than teleoperation's",
];

/// The paired differences the takeover claims read, in the order of [`TAKEOVER_CLAIMS`]
/// (positive: in the claim's direction); `None` for a run without the arm.
pub fn takeover_diffs(r: &AopiResult) -> Option<Vec<Option<f64>>> {
    let a = &r.arms;
    let t = a.takeover.as_ref()?;
    Some(vec![
        Some(t.success_rate - a.baseline.success_rate),
        Some(t.success_rate - a.teleop.success_rate),
        Some(a.teleop.dataset_size as f64 - t.dataset_size as f64),
    ])
}

/// The takeover claims of one seed, in the order of [`TAKEOVER_CLAIMS`].
pub fn takeover_checks(r: &AopiResult) -> Option<Vec<bool>> {
    let a = &r.arms;
    let t = a.takeover.as_ref()?;
    Some(vec![
        t.success_rate > a.baseline.success_rate,
        t.success_rate >= a.teleop.success_rate,
        t.dataset_size < a.teleop.dataset_size,
    ])
}

fn takeover_claims(seeds: &[u64], runs: &[AopiResult]) -> Option<TakeoverClaims> {
    let checks: Option<Vec<Vec<bool>>> = runs.iter().map(takeover_checks).collect();
    let diffs: Option<Vec<Vec<Option<f64>>>> = runs.iter().map(takeover_diffs).collect();
    let (checks, diffs) = (checks?, diffs?);
    if runs.is_empty() {
        return None;
    }
    let minus = |other: &dyn Fn(&Arms) -> &ArmFigures| {
        Interval::of(
            &runs
                .iter()
                .filter_map(|r| {
                    let t = r.arms.takeover.as_ref()?;
                    Some(t.success_rate - other(&r.arms).success_rate)
                })
                .collect::<Vec<_>>(),
        )
    };
    Some(TakeoverClaims {
        shape: Shape::from_checks(seeds, &TAKEOVER_CLAIMS, &checks, &diffs),
        minus_advised: minus(&|a| &a.advised),
        minus_hybrid: minus(&|a| &a.hybrid),
    })
}

pub const AOPI_CLAIMS: [&str; 6] = [
    "advised beats the baseline on success",
    "hybrid beats the baseline on success",
    "advised matches or beats teleoperation on success",
    "hybrid matches or beats teleoperation on success",
    "advised dataset smaller than teleoperation's",
    "hybrid dataset smaller than teleoperation's",
];

/// The paired differences the A-OPI claims read, in the order of [`AOPI_CLAIMS`] (positive: in
/// the claim's direction): success differences, then teleoperation's dataset minus the arm's.
pub fn aopi_diffs(r: &AopiResult) -> Vec<Option<f64>> {
    let a = &r.arms;
    let size = |f: &ArmFigures| f.dataset_size as f64;
    vec![
        Some(a.advised.success_rate - a.baseline.success_rate),
        Some(a.hybrid.success_rate - a.baseline.success_rate),
        Some(a.advised.success_rate - a.teleop.success_rate),
        Some(a.hybrid.success_rate - a.teleop.success_rate),
        Some(size(&a.teleop) - size(&a.advised)),
        Some(size(&a.teleop) - size(&a.hybrid)),
    ]
}

/// The A-OPI shape claims of one seed, in the order of [`AOPI_CLAIMS`].
pub fn aopi_checks(r: &AopiResult) -> Vec<bool> {
    let a = &r.arms;
    vec![
        a.advised.success_rate > a.baseline.success_rate,
        a.hybrid.success_rate > a.baseline.success_rate,
        a.advised.success_rate >= a.teleop.success_rate,
        a.hybrid.success_rate >= a.teleop.success_rate,
        a.advised.dataset_size < a.teleop.dataset_size,
        a.hybrid.dataset_size < a.teleop.dataset_size,
    ]
}

pub fn aopi(runs: Vec<AopiResult>) -> AopiSummary {
    let seeds: Vec<u64> = runs.iter().map(|r| r.seed).collect();
    let arm = |pick: &dyn Fn(&AopiResult) -> &ArmFigures| {
        let v = |f: &dyn Fn(&ArmFigures) -> f64| {
            Spread::of(&runs.iter().map(|r| f(pick(r))).collect::<Vec<_>>())
        };
        ArmSpread {
            success_rate: v(&|a| a.success_rate),
            mean_position_error_m: v(&|a| a.mean_position_error_m),
            mean_heading_error_rad: v(&|a| a.mean_heading_error_rad),
            dataset_size: v(&|a| a.dataset_size as f64),
            executions: v(&|a| a.executions as f64),
        }
    };
    let arms = AopiArms {
        baseline: arm(&|r| &r.arms.baseline),
        advised: arm(&|r| &r.arms.advised),
        hybrid: arm(&|r| &r.arms.hybrid),
        teleop: arm(&|r| &r.arms.teleop),
        takeover: (!runs.is_empty() && runs.iter().all(|r| r.arms.takeover.is_some()))
            .then(|| arm(&|r| r.arms.takeover.as_ref().unwrap_or(&r.arms.teleop))),
    };
    let takeover = takeover_claims(&seeds, &runs);
    let checks: Vec<Vec<bool>> = runs.iter().map(aopi_checks).collect();
    AopiSummary {
        experiment: "aopi".into(),
        arms,
        shape: Shape::from_checks(
            &seeds,
            &AOPI_CLAIMS,
            &checks,
            &runs.iter().map(aopi_diffs).collect::<Vec<_>>(),
        ),
        takeover,
        seeds,
        runs,
    }
}

impl AopiSummary {
    pub fn render(&self) -> String {
        let p = crate::experiment::aopi::PAPER;
        let mut s = format!(
            "A-OPI study (spatial positioning), seeds {:?}: mean ± sd across seeds\n\n",
            self.seeds
        );
        let _ = writeln!(
            s,
            "  {:<14} {:>10} {:>6}  {:>13} {:>15}  {:>13} {:>14}",
            "policy",
            "success",
            "paper",
            "pos. err (m)",
            "head. err (rad)",
            "dataset",
            "executions"
        );
        let a = &self.arms;
        let mut rows = vec![
            ("Baseline", &a.baseline, Some(p.baseline_success), None),
            (
                "A-OPI Advised",
                &a.advised,
                Some(p.advised_success),
                Some(p.advised_executions),
            ),
            (
                "A-OPI Hybrid",
                &a.hybrid,
                Some(p.hybrid_success),
                Some(p.hybrid_executions),
            ),
            (
                "Teleoperation",
                &a.teleop,
                Some(p.teleop_success),
                Some(p.teleop_executions),
            ),
        ];
        // The takeover arm is ours: no paper figure beside it.
        if let Some(t) = &a.takeover {
            rows.push(("Takeover", t, None, None));
        }
        for (name, f, paper, paper_exec) in rows {
            let exec = match paper_exec {
                Some(e) => format!("{} ({e})", num(f.executions, 0)),
                None => num(f.executions, 0),
            };
            let _ = writeln!(
                s,
                "  {:<14} {:>10} {:>6}  {:>13} {:>15}  {:>13} {:>14}",
                name,
                rate(f.success_rate),
                paper.map_or_else(|| "-".to_string(), pct),
                num(f.mean_position_error_m, 2),
                num(f.mean_heading_error_rad, 2),
                num(f.dataset_size, 0),
                exec
            );
        }
        let _ = writeln!(
            s,
            "  (executions in the final dataset; the paper's in brackets)\n"
        );
        self.shape.render(&mut s, "");
        if let Some(t) = &self.takeover {
            t.render(&mut s);
        }
        s
    }
}

impl TakeoverClaims {
    fn render(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "\n  the takeover arm (issue 53, pre-registered in docs/protocol.md T6), per seed:"
        );
        let mut claims = String::new();
        self.shape.render(&mut claims, "");
        // The shape's own heading names the paper's result; these claims are ours.
        for line in claims.lines().skip(1) {
            let _ = writeln!(s, "{line}");
        }
        for (name, d) in [
            ("takeover minus advised, success", &self.minus_advised),
            ("takeover minus hybrid, success", &self.minus_hybrid),
        ] {
            if let Some(d) = d {
                let _ = writeln!(
                    s,
                    "    {name:<52} (a figure, not a claim)   {:+.3} [{:+.3}, {:+.3}]",
                    d.mean, d.lo95, d.hi95
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interval_brackets_the_mean_and_is_reproducible() {
        let v = [0.1, -0.05, 0.2, 0.0, 0.15, 0.05, 0.1, -0.1];
        let i = Interval::of(&v).unwrap();
        assert!((i.mean - 0.05625).abs() < 1e-12);
        assert!(i.lo95 < i.mean && i.mean < i.hi95, "{i:?}");
        assert!(i.lo95 > -0.1 && i.hi95 < 0.2);
        assert_eq!(Interval::of(&v), Some(i));
        assert_eq!(i.seeds, 8);
        assert_eq!(Interval::of(&[]), None);
        // One value: no spread.
        let one = Interval::of(&[0.3]).unwrap();
        assert_eq!((one.lo95, one.hi95), (0.3, 0.3));
    }
}
