//! The BC study (the paper's "Empirical Validation: BC"): ball interception, a BC 1-NN learner
//! derived from 100 teacher demonstrations, 120 critique rounds by the automated [`critic`],
//! test-set evaluation every 20 rounds.
//!
//! Protocol, per seed: the interception teacher demonstrates from the first `demos` practice
//! starts of the seed; the learner is derived; the learner, and the teacher, run the test set.
//! Then each critique round runs the current policy from the next practice start (drawn without
//! replacement, never a test start), the critic judges the execution as a person watching would
//! (misses and detours only), and every flagged chunk becomes a `critique` with `kappa` exactly as
//! a teacher would type it in a session: on the recorded support (which data point drove each
//! step, recorded right after the run, as a session records it). Every `eval_every` rounds the policy runs the test set,
//! which is never critiqued.
//!
//! Table 1's efficiency column compares path lengths only on test starts where the initial
//! policy, the final policy and the teacher all succeeded (the paper compares only runs "in which
//! both learner and teacher are successful"; one common set keeps the three lengths comparable).
//!
//! By default the critique rounds run twice from the same demonstrations and practice starts,
//! each with its own learner: under the paper's rule (`learner_final`, `curve`, `critiques`) and
//! under the paper's proposed improvement, the directional rule ([`CritiqueRule::Directional`];
//! `directional`). The directional row's lengths use its own paired set (the initial policy, the
//! directional final policy and the teacher succeeded), with the initial policy's and the
//! teacher's lengths over that set beside it, so the paper's rows are the same whether or not the
//! directional rule also ran, and each rule's length claim compares like with like.
//!
//! [`critic`]: crate::experiment::critic

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::backend::sim::SimParams;
use crate::eval::{Report, ending_name};
use crate::experiment::critic::{self, CriticRules};
use crate::experiment::protocol::{Revert, reverts};
use crate::experiment::{Progress, eval_seed, evaluate_starts_in, opt_m, pct, practice_seed};
use crate::policy::Policy;
use crate::policy::dataset::{CritiqueRule, Dataset};
use crate::policy::learner::{Learner, LearnerKind};
use crate::task::interception::{StatelessInterceptionTeacher, practice_starts_in};
use crate::task::{
    Controller, Ending, Execution, InterceptionRules, InterceptionTeacher, Outcome, Start,
    TaskKind, record_demos_in, run_sim_in,
};
use crate::trace::{Chunk, Episode};

/// The paper's Table 1.
pub const PAPER: PaperBc = PaperBc {
    learner_initial_success: 0.56,
    learner_initial_length: 2.73,
    learner_final_success: 0.70,
    learner_final_length: 1.96,
    teacher_success: 0.62,
    teacher_length: 2.87,
};

/// The paper's Table 1 figures (their length unit is not stated).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperBc {
    pub learner_initial_success: f64,
    pub learner_initial_length: f64,
    pub learner_final_success: f64,
    pub learner_final_length: f64,
    pub teacher_success: f64,
    pub teacher_length: f64,
}

/// Which critique rules the study runs (`advise experiment bc --critique`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rules {
    /// The paper's rule only.
    Paper,
    /// The directional rule only (the paper's proposed improvement).
    Directional,
    /// Both, each with its own learner, from the same demonstrations and practice starts.
    #[default]
    Both,
}

impl Rules {
    /// The rules to run, the first reported as `learner_final`.
    fn list(self) -> &'static [CritiqueRule] {
        match self {
            Rules::Paper => &[CritiqueRule::Paper],
            Rules::Directional => &[CritiqueRule::Directional],
            Rules::Both => &[CritiqueRule::Paper, CritiqueRule::Directional],
        }
    }
}

impl crate::choice::Choice for Rules {
    fn all() -> &'static [Rules] {
        &[Rules::Paper, Rules::Directional, Rules::Both]
    }

    fn name(self) -> &'static str {
        match self {
            Rules::Paper => "paper",
            Rules::Directional => "directional",
            Rules::Both => "both",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Rules::Paper => "The paper's rule only",
            Rules::Directional => "The directional rule only (the paper's proposed improvement)",
            Rules::Both => {
                "Both, each with its own learner, from the same demonstrations and practice starts"
            }
        }
    }
}

/// Which BC teachers the study runs (`advise experiment bc --teacher`; the second protocol, S1
/// and S2): the paper's hand-written controller (the main arm), the human-like hand (the second
/// arm), or both, each with its own demonstrations, learners and oracles, from the same starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Teachers {
    /// The paper's hand-written deterministic controller only.
    Controller,
    /// The human-like teacher (the first protocol's) only.
    Hand,
    /// Both: the controller's arm reported first, the hand's under `hand`.
    #[default]
    Both,
}

impl crate::choice::Choice for Teachers {
    fn all() -> &'static [Teachers] {
        &[Teachers::Controller, Teachers::Hand, Teachers::Both]
    }

    fn name(self) -> &'static str {
        match self {
            Teachers::Controller => "controller",
            Teachers::Hand => "hand",
            Teachers::Both => "both",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Teachers::Controller => {
                "The paper's hand-written deterministic controller only (the main arm)"
            }
            Teachers::Hand => "The human-like teacher only (the second arm)",
            Teachers::Both => "Both arms, from the same starts, each with its own learners",
        }
    }
}

/// Which teacher an arm's demonstrations and teacher runs came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TeacherKind {
    /// The paper's hand-written deterministic controller (S1).
    #[default]
    Controller,
    /// The human-like teacher (S2).
    Hand,
}

impl TeacherKind {
    pub fn label(self) -> &'static str {
        match self {
            TeacherKind::Controller => "hand-written controller",
            TeacherKind::Hand => "human-like hand",
        }
    }
}

/// The study's configuration. The defaults are the paper's protocol.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcParams {
    /// Teacher demonstrations the learner starts from (paper: 100).
    pub demos: usize,
    /// Critique rounds, one practice execution each (paper: 120).
    pub rounds: usize,
    /// Test-set evaluation every this many rounds (paper: 20).
    pub eval_every: usize,
    /// How many of the fixed test starts to use (paper: all 100).
    pub test_starts: usize,
    /// The critique constant kappa: a flagged point's supporting data point gets
    /// `m += kappa / distance` (the paper leaves it open).
    pub kappa: f64,
    pub critic: CriticRules,
    /// The interception world (arena, capture distance, the ball's starts and friction) and the
    /// teacher's gains: the constants the paper leaves open, calibrated by `advise calibrate bc`.
    pub world: InterceptionRules,
    pub teacher: InterceptionTeacher,
    pub sim: SimParams,
    /// Which critique rules run (default both).
    #[serde(default)]
    pub critique: Rules,
    /// The protocol's choice reverted for the ablation (`--revert`), if any
    /// ([`crate::experiment::ablation`]). An ablation runs the main arm only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub revert: Option<Revert>,
    /// Which teachers' arms run (default both).
    #[serde(default)]
    pub teachers: Teachers,
}

impl Default for BcParams {
    fn default() -> Self {
        BcParams {
            demos: 100,
            rounds: 120,
            eval_every: 20,
            test_starts: crate::task::interception::TEST_STARTS,
            kappa: 0.1,
            critic: CriticRules::default(),
            world: InterceptionRules::default(),
            teacher: InterceptionTeacher::new(SimParams::default().period_s()),
            sim: SimParams::default(),
            critique: Rules::default(),
            revert: None,
            teachers: Teachers::default(),
        }
    }
}

/// One policy's line of Table 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcFigures {
    /// Fraction of test starts intercepted, in [0, 1].
    pub success_rate: f64,
    pub successes: usize,
    pub episodes: usize,
    /// Mean path length over the paired test starts (all three policies succeeded), m; `None`
    /// when there are none.
    pub mean_length_m: Option<f64>,
    /// Mean path length over this policy's own successes, m.
    pub mean_length_own_successes_m: Option<f64>,
    /// How the test episodes ended (captured, ball_out, robot_out, time_limit).
    pub endings: BTreeMap<String, usize>,
}

/// One point of Figure 5: the test set after `round` critique rounds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcCurvePoint {
    pub round: usize,
    pub success_rate: f64,
    /// Mean path length over this evaluation's successes, m.
    pub mean_length_success_m: Option<f64>,
    /// Chunks critiqued so far.
    pub critiques: usize,
}

/// What the critic did over the practice rounds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CritiqueSummary {
    pub rounds: usize,
    /// Rounds in which at least one chunk was flagged.
    pub rounds_flagged: usize,
    pub chunks_flagged: usize,
    pub points_flagged: usize,
    /// Flagged chunks by reason.
    pub flaws: BTreeMap<String, usize>,
    /// Fraction of practice executions that intercepted the ball.
    pub practice_success_rate: f64,
}

/// The study's result: Table 1, Figure 5, and how it came about.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcResult {
    pub experiment: String,
    pub seed: u64,
    pub params: BcParams,
    pub learner_initial: BcFigures,
    /// The final policy under [`BcResult::rule`] (the paper's rule, unless only the directional
    /// one ran).
    pub learner_final: BcFigures,
    pub teacher: BcFigures,
    /// Test starts on which all three succeeded (the length comparison's runs).
    pub paired_runs: usize,
    pub demo_points: usize,
    /// Demonstrations that intercepted the ball.
    pub demo_successes: usize,
    pub curve: Vec<BcCurvePoint>,
    pub critiques: CritiqueSummary,
    /// The rule of `learner_final`, `curve` and `critiques`.
    #[serde(default)]
    pub rule: CritiqueRule,
    /// The directional rule's rounds, when both rules ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub directional: Option<BcRuleResult>,
    /// Whose demonstrations these are (the arm).
    #[serde(default)]
    pub teacher_kind: TeacherKind,
    /// Critique's ceiling on this arm's demonstrations (the second protocol, S6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub oracles: Option<BcOracles>,
    /// The human-like teacher's arm, when both arms ran (this result is then the controller's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hand: Option<Box<BcResult>>,
    pub paper: PaperBc,
}

/// What re-weighting an arm's demonstrations could at best do (the second protocol, S6): 1-NN
/// learners under the paper's rule, never critiqued, on the same test starts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcOracles {
    /// On the teacher's demonstrations that intercepted the ball only.
    pub successful_demos: BcOracle,
    /// On every demonstration without the points the critic flags in it (every flawed stretch
    /// of a demonstration the critic judges poor removed whole: the limit of perfect critique).
    pub perfect_critique: BcOracle,
}

/// One oracle's data and, when it had any, its test-set figures (lengths over the starts where
/// it, the initial policy and the teacher all succeeded).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcOracle {
    /// Demonstrations that kept at least one point.
    pub demos: usize,
    pub points: usize,
    /// `None` when no point was left (the oracle cannot act).
    pub figures: Option<BcFigures>,
    /// The test starts its length is measured over.
    pub paired_runs: usize,
}

/// One critique rule's rounds beside the paper's: its final policy, curve and critiques, and the
/// lengths over its own paired runs (initial, this final policy and the teacher all succeeded).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BcRuleResult {
    pub rule: CritiqueRule,
    /// The final policy; `mean_length_m` over `paired_runs`.
    pub learner_final: BcFigures,
    /// The initial policy's mean length over `paired_runs`, m.
    pub learner_initial_length_m: Option<f64>,
    /// The teacher's mean length over `paired_runs`, m.
    pub teacher_length_m: Option<f64>,
    pub paired_runs: usize,
    pub curve: Vec<BcCurvePoint>,
    pub critiques: CritiqueSummary,
}

/// What one rule's critique rounds ended with.
struct Rounds {
    last: Report,
    curve: Vec<BcCurvePoint>,
    summary: CritiqueSummary,
}

/// Run the BC study. `progress` draws a bar on a terminal.
pub fn run(seed: u64, params: &BcParams, progress: bool) -> BcResult {
    let mut test: Vec<Start> = crate::task::interception::test_starts_in(&params.world)
        .into_iter()
        .map(Start::Ball)
        .collect();
    test.truncate(params.test_starts.max(1));
    run_on(seed, params, &test, progress)
}

/// Run the BC study with `test` standing in for the test set (to tune the critic on held-out
/// practice starts without ever looking at the real test set): the arms `params.teachers`
/// names (an ablation, `params.revert`, runs the main arm only), each from the same starts.
pub fn run_on(seed: u64, params: &BcParams, test: &[Start], progress: bool) -> BcResult {
    let arm = |kind: TeacherKind| {
        let teacher = match kind {
            TeacherKind::Controller => params.teacher.controller(),
            TeacherKind::Hand => params.teacher.human_like(),
        };
        let p = BcParams {
            teacher,
            ..params.clone()
        };
        run_arm(seed, &p, test, progress, kind)
    };
    let teachers = if params.revert.is_some() {
        Teachers::Controller
    } else {
        params.teachers
    };
    match teachers {
        Teachers::Controller => arm(TeacherKind::Controller),
        Teachers::Hand => arm(TeacherKind::Hand),
        Teachers::Both => {
            let mut main = arm(TeacherKind::Controller);
            main.hand = Some(Box::new(arm(TeacherKind::Hand)));
            main
        }
    }
}

/// One arm of the study: `params.teacher` demonstrates, the learners are critiqued, and the
/// oracles (S6) run beside them.
fn run_arm(
    seed: u64,
    params: &BcParams,
    test: &[Start],
    progress: bool,
    teacher_kind: TeacherKind,
) -> BcResult {
    let kind = TaskKind::Interception;
    let sim = &params.sim;
    let eval_every = params.eval_every.max(1);
    let rules = params.critique.list();
    let per_rule = params.rounds as u64 + params.rounds.div_ceil(eval_every) as u64;
    let bar = Progress::new(
        progress,
        2 + per_rule * rules.len() as u64,
        "bc: demonstrations",
    );

    // Demonstrations and practice: one stream of starts in the study's world, the first
    // `demos` demonstrated, the rest practised, so none repeats.
    let starts: Vec<Start> = practice_starts_in(seed, params.demos + params.rounds, &params.world)
        .into_iter()
        .map(Start::Ball)
        .collect();
    let (demo_starts, practice) = starts.split_at(params.demos);
    let recorded = record_teacher(demo_starts, params, seed);
    let demo_successes = recorded.iter().filter(|(_, o)| o.success).count();
    let oracle_data = oracle_datasets(&recorded, &params.critic);
    let episodes: Vec<Episode> = recorded.into_iter().map(|(e, _)| e).collect();
    let mut ds = Dataset::new(&kind.domain());
    for e in &episodes {
        // Recorded in the task's own domain: this cannot fail.
        let _ = ds.add_demonstration(&e.name, &e.trace);
    }
    let demo_points = ds.len();
    // One learner per rule, from the same demonstrations: the initial policy is theirs alike.
    let learners: Vec<Learner> = rules
        .iter()
        .map(|_| Learner::with_dataset(ds.clone(), LearnerKind::Bc, seed))
        .collect();
    bar.inc(1);

    let eseed = eval_seed(seed);
    let evaluate = |learner: &Learner| -> Report {
        let policy: &dyn Policy = learner.policy();
        evaluate_starts_in(&params.world, kind.clone(), test, || policy, sim, eseed)
    };
    bar.set_message("bc: teacher and initial policy");
    let teacher = evaluate_starts_in(
        &params.world,
        kind.clone(),
        test,
        || params.teacher_driver(sim),
        sim,
        eseed,
    );
    let initial = evaluate(&learners[0]);
    bar.set_message("bc: oracles");
    let oracle_reports = evaluate_oracles(oracle_data, &evaluate, seed);
    bar.inc(1);

    let mut results: Vec<Rounds> = rules
        .iter()
        .zip(learners)
        .map(|(&rule, mut learner)| {
            bar.set_message(&format!("bc: critique rounds ({})", rule.label()));
            critique_rounds(
                seed,
                params,
                rule,
                &mut learner,
                practice,
                &initial,
                &evaluate,
                &bar,
            )
        })
        .collect();
    bar.finish();

    // Each rule's paired runs: the initial policy, its final policy and the teacher succeeded.
    let paired_with = |last: &Report| -> Vec<usize> {
        (0..test.len())
            .filter(|&i| {
                initial.outcomes[i].success
                    && last.outcomes[i].success
                    && teacher.outcomes[i].success
            })
            .collect()
    };
    let mean_over = |paired: &[usize], r: &Report| {
        (!paired.is_empty()).then(|| {
            paired.iter().map(|&i| r.outcomes[i].length_m).sum::<f64>() / paired.len() as f64
        })
    };
    let figures = |paired: &[usize], r: &Report| BcFigures {
        success_rate: r.success_rate,
        successes: r.successes,
        episodes: r.episodes,
        mean_length_m: mean_over(paired, r),
        mean_length_own_successes_m: r.mean_length_success_m,
        endings: r.endings.clone(),
    };
    let directional = (results.len() > 1).then(|| {
        let d = results.remove(1);
        let paired = paired_with(&d.last);
        BcRuleResult {
            rule: CritiqueRule::Directional,
            learner_final: figures(&paired, &d.last),
            learner_initial_length_m: mean_over(&paired, &initial),
            teacher_length_m: mean_over(&paired, &teacher),
            paired_runs: paired.len(),
            curve: d.curve,
            critiques: d.summary,
        }
    });
    let first = results.remove(0);
    let paired = paired_with(&first.last);
    let [successful_demos, perfect_critique] = oracle_reports.map(|(demos, points, report)| {
        let own = report.as_ref().map(&paired_with).unwrap_or_default();
        BcOracle {
            demos,
            points,
            figures: report.as_ref().map(|r| figures(&own, r)),
            paired_runs: own.len(),
        }
    });
    BcResult {
        experiment: "bc".into(),
        seed,
        params: params.clone(),
        learner_initial: figures(&paired, &initial),
        learner_final: figures(&paired, &first.last),
        teacher: figures(&paired, &teacher),
        paired_runs: paired.len(),
        demo_points,
        demo_successes,
        curve: first.curve,
        critiques: first.summary,
        rule: rules[0],
        directional,
        teacher_kind,
        oracles: Some(BcOracles {
            successful_demos,
            perfect_critique,
        }),
        hand: None,
        paper: PAPER,
    }
}

/// Each oracle's demonstrations, points and, when it has data, test-set report.
fn evaluate_oracles(
    data: [(usize, Dataset); 2],
    evaluate: &dyn Fn(&Learner) -> Report,
    seed: u64,
) -> [(usize, usize, Option<Report>); 2] {
    data.map(|(demos, ds)| {
        let points = ds.len();
        let report =
            (points > 0).then(|| evaluate(&Learner::with_dataset(ds, LearnerKind::Bc, seed)));
        (demos, points, report)
    })
}

/// The oracles' datasets (S6), each with the number of demonstrations that kept a point:
/// the successful demonstrations only, and every demonstration without the points the critic
/// flags in it (each flawed stretch of a demonstration it judges poor, removed whole).
fn oracle_datasets(recorded: &[(Episode, Outcome)], rules: &CriticRules) -> [(usize, Dataset); 2] {
    let domain = TaskKind::Interception.domain();
    let mut successful = Dataset::new(&domain);
    let mut n_successful = 0;
    let mut critiqued = Dataset::new(&domain);
    let mut n_critiqued = 0;
    for (e, outcome) in recorded {
        if outcome.success {
            // Recorded in the task's own domain: this cannot fail.
            let _ = successful.add_demonstration(&e.name, &e.trace);
            n_successful += 1;
        }
        let exec = Execution {
            trace: e.trace.clone(),
            true_poses: None,
            ball: None,
            outcome: outcome.clone(),
        };
        let mut flagged = vec![false; e.trace.len()];
        for f in critic::critique_execution(&exec, rules) {
            for t in f.stretch.range() {
                if let Some(x) = flagged.get_mut(t) {
                    *x = true;
                }
            }
        }
        let mut kept_any = false;
        let mut t = 0;
        while t < flagged.len() {
            if flagged[t] {
                t += 1;
                continue;
            }
            let start = t;
            while t < flagged.len() && !flagged[t] {
                t += 1;
            }
            let piece = e.trace.slice(Chunk { start, end: t });
            let _ = critiqued.add_demonstration(&format!("{}/{start}", e.name), &piece);
            kept_any = true;
        }
        n_critiqued += usize::from(kept_any);
    }
    [(n_successful, successful), (n_critiqued, critiqued)]
}

/// The critique rounds under `rule` on `learner`: each practice start run, judged by the critic,
/// its flagged chunks critiqued; the test set every `eval_every` rounds.
#[allow(clippy::too_many_arguments)]
fn critique_rounds(
    seed: u64,
    params: &BcParams,
    rule: CritiqueRule,
    learner: &mut Learner,
    practice: &[Start],
    initial: &Report,
    evaluate: &dyn Fn(&Learner) -> Report,
    bar: &Progress,
) -> Rounds {
    let sim = &params.sim;
    let eval_every = params.eval_every.max(1);
    let mut curve = vec![point(0, initial, 0)];
    let mut summary = CritiqueSummary {
        rounds: params.rounds,
        rounds_flagged: 0,
        chunks_flagged: 0,
        points_flagged: 0,
        flaws: BTreeMap::new(),
        practice_success_rate: 0.0,
    };
    let mut practice_successes = 0;
    let mut last = initial.clone();
    for (r, start) in practice.iter().enumerate() {
        let exec = {
            let mut policy: &dyn Policy = learner.policy();
            let controller: &mut dyn Controller = &mut policy;
            run_sim_in(
                start,
                &params.world,
                controller,
                sim,
                practice_seed(seed, r as u64),
            )
        };
        practice_successes += usize::from(exec.outcome.success);
        let flags = if reverts(params.revert, Revert::Chunks) {
            critic::critique_execution_fixed(&exec, &params.critic)
        } else {
            critic::critique_execution(&exec, &params.critic)
        };
        if !flags.is_empty() {
            summary.rounds_flagged += 1;
            // Which data point drove each step, recorded before any critique changes the
            // weights, as a session records it: a later chunk penalises what acted, not what
            // would act after the first chunk's penalties.
            // (Reverted for the ablation: no support, the points nearest now.)
            let support = (!reverts(params.revert, Revert::Support))
                .then(|| learner.support_provenance(&exec.trace));
            let id = learner.add_execution(&exec.trace);
            for f in &flags {
                // The learner has data and the chunk lies within the trace: this cannot fail.
                let made = learner
                    .plan_critique(&exec.trace, f.chunk, params.kappa, support.as_deref(), rule)
                    .and_then(|plan| learner.add_critique(id, plan.critique));
                if made.is_ok() {
                    summary.chunks_flagged += 1;
                    summary.points_flagged += f.chunk.len();
                    *summary.flaws.entry(f.flaw.name().to_string()).or_insert(0) += 1;
                }
            }
        }
        bar.inc(1);
        let round = r + 1;
        if round % eval_every == 0 || round == params.rounds {
            last = evaluate(learner);
            curve.push(point(round, &last, summary.chunks_flagged));
            bar.inc(1);
        }
    }
    summary.practice_success_rate = if params.rounds == 0 {
        0.0
    } else {
        practice_successes as f64 / params.rounds as f64
    };
    Rounds {
        last,
        curve,
        summary,
    }
}

impl BcParams {
    /// The study's teacher at the simulator's control period.
    pub fn teacher_for(&self, sim: &SimParams) -> InterceptionTeacher {
        InterceptionTeacher {
            period_s: sim.period_s(),
            ..self.teacher.clone()
        }
    }

    /// The person driving the study's demonstrations and the teacher's test runs: the
    /// calibrated teacher's driver, or, with choice 2 reverted for the ablation, the stateless
    /// teacher the protocol replaced.
    pub fn teacher_driver(&self, sim: &SimParams) -> Box<dyn Controller + Send> {
        if reverts(self.revert, Revert::Teacher) {
            Box::new(StatelessInterceptionTeacher::pre_protocol(sim.period_s()))
        } else {
            Box::new(self.teacher_for(sim).driver())
        }
    }
}

/// The teacher's demonstrations from `starts` in the study's world, in parallel: demonstration
/// `i` on the simulator noise [`crate::task::record_demos`] would give it.
pub(crate) fn record_teacher(
    starts: &[Start],
    params: &BcParams,
    seed: u64,
) -> Vec<(Episode, Outcome)> {
    record_demos_in(
        starts,
        &params.world,
        || params.teacher_driver(&params.sim),
        &params.sim,
        seed,
    )
}

fn point(round: usize, r: &Report, critiques: usize) -> BcCurvePoint {
    BcCurvePoint {
        round,
        success_rate: r.success_rate,
        mean_length_success_m: r.mean_length_success_m,
        critiques,
    }
}

impl BcResult {
    /// Table 1 and Figure 5 as text.
    pub fn render(&self) -> String {
        let p = &self.params;
        let mut s = format!(
            "BC study (ball interception), seed {}, teacher: {}: {} demonstrations ({} points, {} intercepted), {} critique rounds, test set of {} starts\n\n",
            self.seed,
            self.teacher_kind.label(),
            p.demos,
            self.demo_points,
            self.demo_successes,
            p.rounds,
            self.learner_initial.episodes
        );
        let _ = writeln!(
            s,
            "  {:<29} {:>8} {:>11}   {:>14} {:>13}",
            "Table 1", "success", "length (m)", "paper success", "paper length"
        );
        let row = |s: &mut String, name: &str, f: &BcFigures, paper: Option<(f64, f64)>| {
            let (ps, pl) = paper.map_or(("-".to_string(), "-".to_string()), |(ps, pl)| {
                (pct(ps), format!("{pl:.2}"))
            });
            let _ = writeln!(
                s,
                "  {:<29} {:>8} {:>11}   {:>14} {:>13}",
                name,
                pct(f.success_rate),
                opt_m(f.mean_length_m),
                ps,
                pl
            );
        };
        row(
            &mut s,
            "learner initial π",
            &self.learner_initial,
            Some((PAPER.learner_initial_success, PAPER.learner_initial_length)),
        );
        let final_paper = Some((PAPER.learner_final_success, PAPER.learner_final_length));
        match self.rule {
            CritiqueRule::Paper => row(&mut s, "learner final π", &self.learner_final, final_paper),
            CritiqueRule::Directional => row(
                &mut s,
                "learner final π (directional)",
                &self.learner_final,
                None,
            ),
        }
        if let Some(d) = &self.directional {
            row(
                &mut s,
                "learner final π (directional)",
                &d.learner_final,
                None,
            );
        }
        row(
            &mut s,
            "teacher",
            &self.teacher,
            Some((PAPER.teacher_success, PAPER.teacher_length)),
        );
        let _ = writeln!(
            s,
            "  lengths: mean path over the {} test starts where all three succeeded",
            self.paired_runs
        );
        if let Some(d) = &self.directional {
            let _ = writeln!(
                s,
                "  the directional row's: over its own {} (initial π {}, teacher {} there)",
                d.paired_runs,
                opt_m(d.learner_initial_length_m),
                opt_m(d.teacher_length_m)
            );
        }
        if let Some(o) = &self.oracles {
            render_oracles(&mut s, o);
        }
        let _ = writeln!(
            s,
            "  {}",
            endings_line("teacher", &self.teacher.endings, p.world.time_limit_s)
        );
        s.push('\n');
        // The paper's rule goes unnamed; another rule's blocks say which.
        let named = |rule: CritiqueRule| match rule {
            CritiqueRule::Paper => String::new(),
            _ => format!(" ({})", rule.label()),
        };
        let label = named(self.rule);
        render_curve(&mut s, &label, &self.curve, self.teacher.success_rate);
        if let Some(d) = &self.directional {
            s.push('\n');
            render_curve(&mut s, &named(d.rule), &d.curve, self.teacher.success_rate);
        }
        s.push('\n');
        render_critic(&mut s, &label, &self.critiques);
        if let Some(d) = &self.directional {
            render_critic(&mut s, &named(d.rule), &d.critiques);
        }
        if let Some(h) = &self.hand {
            s.push('\n');
            s.push_str(&h.render());
        }
        s
    }
}

/// Critique's ceiling (S6) under Table 1.
fn render_oracles(s: &mut String, o: &BcOracles) {
    let _ = writeln!(
        s,
        "  critique's ceiling (1-NN, no critique; lengths over the starts where it, initial π and the teacher succeeded):"
    );
    for (name, oracle) in [
        ("successful demonstrations", &o.successful_demos),
        ("perfect critique", &o.perfect_critique),
    ] {
        match &oracle.figures {
            Some(f) => {
                let _ = writeln!(
                    s,
                    "  {:<29} {:>8} {:>11}   ({} demonstrations, {} points; {} paired starts)",
                    name,
                    pct(f.success_rate),
                    opt_m(f.mean_length_m),
                    oracle.demos,
                    oracle.points,
                    oracle.paired_runs
                );
            }
            None => {
                let _ = writeln!(s, "  {name:<29} no data left: not evaluated");
            }
        }
    }
}

/// The endings of an interception episode, the paper's (and the robot leaving the arena) first,
/// the safety limit last (the second protocol, S3).
pub const ENDINGS: [Ending; 4] = [
    Ending::Captured,
    Ending::BallOut,
    Ending::RobotOut,
    Ending::TimeLimit,
];

/// How a policy's test episodes ended, the paper's endings first and the safety limit apart.
pub(crate) fn endings_line(who: &str, endings: &BTreeMap<String, usize>, limit_s: f64) -> String {
    let [captured, ball_out, robot_out, limit] =
        ENDINGS.map(|e| endings.get(ending_name(e)).copied().unwrap_or(0));
    format!(
        "{who}'s endings: captured {captured}, ball out {ball_out}, robot out {robot_out}; at the {limit_s:.0} s safety limit {limit} (not an ending the paper has)"
    )
}

fn render_curve(s: &mut String, label: &str, curve: &[BcCurvePoint], teacher: f64) {
    let _ = writeln!(
        s,
        "  Figure 5{label}: test-set success against critique rounds"
    );
    for c in curve {
        let _ = writeln!(
            s,
            "  round {:>4}  {:>5}  {}  ({} chunks critiqued)",
            c.round,
            pct(c.success_rate),
            bar(c.success_rate, 40),
            c.critiques
        );
    }
    let _ = writeln!(s, "  {:<11} {:>5}", "teacher", pct(teacher));
}

fn render_critic(s: &mut String, label: &str, c: &CritiqueSummary) {
    let flaws: Vec<String> = c.flaws.iter().map(|(k, v)| format!("{k} {v}")).collect();
    let _ = writeln!(
        s,
        "  critic{label}: {} chunks ({} points) flagged in {} of {} rounds ({}); practice success {}",
        c.chunks_flagged,
        c.points_flagged,
        c.rounds_flagged,
        c.rounds,
        if flaws.is_empty() {
            "none".to_string()
        } else {
            flaws.join(", ")
        },
        pct(c.practice_success_rate)
    );
}

/// A bar of `width` characters for a rate in [0, 1].
pub(crate) fn bar(rate: f64, width: usize) -> String {
    let full = (rate.clamp(0.0, 1.0) * width as f64).round() as usize;
    format!("{}{}", "█".repeat(full), "·".repeat(width - full))
}
