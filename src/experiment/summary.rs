//! Several seeds of a study at once: each figure's mean and spread across the seeds beside the
//! paper's, and for how many seeds the shape of the paper's result holds, claim by claim.
//!
//! The shape claims are the issue's, checked per seed on the figures the study printed:
//! - BC: the final policy beats the initial one on success and on length (mean path over the
//!   paired runs), and matches or beats the teacher on success;
//! - A-OPI: the advised and hybrid policies beat the baseline on success, match or beat
//!   teleoperation on success, and end with a smaller dataset than teleoperation.
//!
//! A seed "holds" when every claim of its study holds. Nothing here runs a study.

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::experiment::aopi::{AopiResult, ArmFigures};
use crate::experiment::bc::BcResult;
use crate::experiment::{mean_sd, pct};

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
    fn from_checks(seeds: &[u64], names: &[&str], checks: &[Vec<bool>]) -> Shape {
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

    fn render(&self, s: &mut String) {
        let _ = writeln!(s, "  shape of the paper's result, per seed:");
        for c in &self.claims {
            let _ = writeln!(
                s,
                "    {:<52} {} of {} seeds",
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
    pub runs: Vec<BcResult>,
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

pub const BC_CLAIMS: [&str; 3] = [
    "final beats initial on success",
    "final beats initial on length",
    "final matches or beats the teacher on success",
];

pub fn bc(runs: Vec<BcResult>) -> BcSummary {
    let seeds: Vec<u64> = runs.iter().map(|r| r.seed).collect();
    let spread = |f: &dyn Fn(&BcResult) -> Option<f64>| {
        Spread::of(&runs.iter().filter_map(f).collect::<Vec<_>>())
    };
    let checks: Vec<Vec<bool>> = runs.iter().map(bc_checks).collect();
    BcSummary {
        experiment: "bc".into(),
        learner_initial_success: spread(&|r| Some(r.learner_initial.success_rate)),
        learner_initial_length_m: spread(&|r| r.learner_initial.mean_length_m),
        learner_final_success: spread(&|r| Some(r.learner_final.success_rate)),
        learner_final_length_m: spread(&|r| r.learner_final.mean_length_m),
        teacher_success: spread(&|r| Some(r.teacher.success_rate)),
        teacher_length_m: spread(&|r| r.teacher.mean_length_m),
        shape: Shape::from_checks(&seeds, &BC_CLAIMS, &checks),
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
            "BC study (ball interception), seeds {:?}: mean ± sd across seeds\n\n",
            self.seeds
        );
        let _ = writeln!(
            s,
            "  {:<18} {:>11} {:>13}   {:>13} {:>12}",
            "Table 1", "success", "length (m)", "paper success", "paper length"
        );
        for (name, sr, ln, ps, pl) in [
            (
                "learner initial π",
                self.learner_initial_success,
                self.learner_initial_length_m,
                p.learner_initial_success,
                p.learner_initial_length,
            ),
            (
                "learner final π",
                self.learner_final_success,
                self.learner_final_length_m,
                p.learner_final_success,
                p.learner_final_length,
            ),
            (
                "teacher",
                self.teacher_success,
                self.teacher_length_m,
                p.teacher_success,
                p.teacher_length,
            ),
        ] {
            let _ = writeln!(
                s,
                "  {:<18} {:>11} {:>13}   {:>13} {:>12.2}",
                name,
                rate(sr),
                num(ln, 2),
                pct(ps),
                pl
            );
        }
        s.push('\n');
        self.shape.render(&mut s);
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
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AopiSummary {
    pub experiment: String,
    pub seeds: Vec<u64>,
    pub arms: AopiArms,
    pub shape: Shape,
    pub runs: Vec<AopiResult>,
}

pub const AOPI_CLAIMS: [&str; 6] = [
    "advised beats the baseline on success",
    "hybrid beats the baseline on success",
    "advised matches or beats teleoperation on success",
    "hybrid matches or beats teleoperation on success",
    "advised dataset smaller than teleoperation's",
    "hybrid dataset smaller than teleoperation's",
];

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
    };
    let checks: Vec<Vec<bool>> = runs.iter().map(aopi_checks).collect();
    AopiSummary {
        experiment: "aopi".into(),
        arms,
        shape: Shape::from_checks(&seeds, &AOPI_CLAIMS, &checks),
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
        for (name, f, paper, paper_exec) in [
            ("Baseline", &a.baseline, p.baseline_success, None),
            (
                "A-OPI Advised",
                &a.advised,
                p.advised_success,
                Some(p.advised_executions),
            ),
            (
                "A-OPI Hybrid",
                &a.hybrid,
                p.hybrid_success,
                Some(p.hybrid_executions),
            ),
            (
                "Teleoperation",
                &a.teleop,
                p.teleop_success,
                Some(p.teleop_executions),
            ),
        ] {
            let exec = match paper_exec {
                Some(e) => format!("{} ({e})", num(f.executions, 0)),
                None => num(f.executions, 0),
            };
            let _ = writeln!(
                s,
                "  {:<14} {:>10} {:>6}  {:>13} {:>15}  {:>13} {:>14}",
                name,
                rate(f.success_rate),
                pct(paper),
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
        self.shape.render(&mut s);
        s
    }
}
