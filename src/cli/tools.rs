//! The subcommands that are not a session: `demo`, `eval`, `experiment`, `rmp-emulator` and
//! `ros2-sim`.
//! Each calls the library and prints what it returns.

use advise::backend::rmp::config::FaultInjection;
use advise::backend::rmp::{Emulator, EmulatorConfig};
use advise::backend::ros2::Ros2Spec;
use advise::backend::{BackendSpec, Connect, StopSignal};
use advise::eval::{self, EvalOptions, EvalPolicy};
use advise::experiment::study;
use advise::task::TaskKind;
use advise::trace::Episode;

use super::{
    CalibrateArgs, CliError, DemoArgs, EmulatorArgs, EvalArgs, ExperimentArgs, ImportArgs,
    Ros2SimArgs, parse_seeds, print_stdout, sim_params,
};

/// `advise demo`: record teacher demonstrations in the simulator into one file.
pub fn demo(args: DemoArgs) -> miette::Result<()> {
    let kind = super::resolve_task(&args.task, &args.tasks)?;
    if !kind.has_teacher() {
        return Err(CliError::NoTeacher {
            task: kind.name().to_string(),
        }
        .into());
    }
    let params = sim_params(args.sim_params.as_deref())?;
    let domain = kind.domain();
    let recorded =
        advise::task::record_demos(kind.clone(), args.count as usize, args.seed, &params);
    // A demonstration stopped on a value that is not a number refuses them all: nothing written.
    advise::task::finite_demos(&kind, &recorded)?;
    let successes = recorded.iter().filter(|(_, o)| o.success).count();
    let episodes: Vec<Episode> = recorded.into_iter().map(|(e, _)| e).collect();
    let points: usize = episodes.iter().map(|e| e.trace.len()).sum();
    let is_json = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let inputs = args.tasks.iter().chain(&args.sim_params);
    advise::files::refuse_overwriting_inputs(&args.out, inputs.map(|p| p.as_path()))?;
    advise::files::write_atomic(&args.out, |out| {
        if is_json {
            serde_json::to_writer(out, &Episode::to_json(&domain, &episodes)).map_err(Into::into)
        } else {
            Episode::write_csv(&domain, &episodes, out)
        }
    })?;
    errln!(
        "recorded {} {kind} demonstrations ({points} points) to {}; the teacher succeeded in {successes}",
        episodes.len(),
        args.out.display(),
    );
    Ok(())
}

/// `advise eval`: run a policy (or the teacher) over the task's test set and print the report.
pub fn eval(args: EvalArgs) -> miette::Result<()> {
    let kind = super::resolve_task(&args.task, &args.tasks)?;
    if matches!(args.policy, EvalPolicy::Teacher) && !kind.has_teacher() {
        return Err(CliError::NoTeacher {
            task: kind.name().to_string(),
        }
        .into());
    }
    let backend: BackendSpec = crate::cli::backend_with_topics(
        &args.backend,
        args.cmd_topic.as_deref(),
        args.odom_topic.as_deref(),
    )?
    .parse()?;
    let opts = EvalOptions {
        seed: args.seed,
        params: sim_params(args.sim_params.as_deref())?,
        progress: !args.json,
    };
    let limit = args.limit.map(|n| n as usize);
    let report = match args.policy {
        EvalPolicy::Teacher if !backend.is_simulator() => {
            let period = opts.params.period_s();
            eval_on_base(kind.clone(), backend.clone(), &opts, limit, || {
                kind.teacher(period)
            })?
        }
        EvalPolicy::Teacher => eval::evaluate_teacher(kind.clone(), &opts),
        EvalPolicy::Learned(learner) => {
            let path = args.dataset.as_deref().ok_or(CliError::NoDataset {
                policy: learner.name(),
            })?;
            let domain = kind.domain();
            let mut files = advise::diag::SourceMap::new();
            let demos = advise::policy::dataset::load_demonstrations(&mut files, &domain, path)
                .map_err(|e| files.attach(e))?;
            let lwr_k = args.lwr_k.map(|k| k as usize);
            let policy = eval::derive_policy_with(learner, &domain, &demos.episodes, lwr_k)?;
            if backend.is_simulator() {
                eval::evaluate(kind.clone(), policy.as_ref(), &opts)
            } else {
                let p: &dyn advise::policy::Policy = policy.as_ref();
                eval_on_base(kind.clone(), backend.clone(), &opts, limit, || p)?
            }
        }
    };
    let report = match (backend.is_simulator(), limit) {
        // The simulator runs the whole test set in parallel; `--limit` keeps the first episodes.
        (true, Some(n)) if n < report.episodes => {
            let outcomes = report.outcomes.into_iter().take(n).collect();
            eval::Report::from_outcomes(kind, args.seed, outcomes)
        }
        _ => report,
    };
    let text = if args.json {
        let mut t = serde_json::to_string_pretty(&report).expect("a report is plain data");
        t.push('\n');
        t
    } else {
        report.render()
    };
    print_stdout(&text)?;
    Ok(())
}

/// `advise experiment`: one of the paper's studies, its figures on stdout (or JSON), its plots
/// written where asked.
pub fn experiment(args: ExperimentArgs) -> miette::Result<()> {
    let sim = sim_params(args.sim_params.as_deref())?;
    let seeds = parse_seeds(args.seed, args.seeds.as_deref())?;
    let critique = match (args.study, args.critique) {
        (study::Study::Bc, rules) => rules.unwrap_or_default(),
        (study::Study::Aopi, Some(_)) => {
            return Err(CliError::CritiqueWithoutBc {
                study: "aopi".into(),
            }
            .into());
        }
        (study::Study::Aopi, None) => Default::default(),
    };
    let teachers = match (args.study, args.teacher) {
        (study::Study::Bc, arms) => arms.unwrap_or_default(),
        (study::Study::Aopi, Some(_)) => {
            return Err(CliError::TeacherWithoutBc {
                study: "aopi".into(),
            }
            .into());
        }
        (study::Study::Aopi, None) => Default::default(),
    };
    if let Some(choice) = args.revert
        && !choice.affects(args.study)
    {
        let (name, other) = match args.study {
            study::Study::Bc => ("bc", "aopi"),
            study::Study::Aopi => ("aopi", "bc"),
        };
        return Err(CliError::RevertNotInStudy {
            point: choice.point(),
            choice: choice.name(),
            study: name,
            other,
        }
        .into());
    }
    if args.practice.is_some() && args.study == study::Study::Bc {
        return Err(CliError::PracticeWithoutAopi.into());
    }
    let out = study::run(
        args.study,
        &seeds,
        sim,
        study::BcChoices { critique, teachers },
        args.revert,
        args.practice.map(|n| n as usize),
        args.plot.as_deref(),
        true,
    )?;
    print_stdout(if args.json { &out.json } else { &out.text })?;
    for p in out.plots {
        errln!("wrote {}", p.display());
    }
    Ok(())
}

/// `advise calibrate bc|aopi`: fit, report, and write the file when asked.
/// A folder to write into that is missing is refused before the calibration runs (it takes a
/// minute); a write that fails after it prints the calibration's JSON, so the result is not lost.
pub fn calibrate(args: CalibrateArgs) -> miette::Result<()> {
    let sim = sim_params(args.sim_params.as_deref())?;
    if let Some(path) = &args.write {
        let folder = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => std::path::Path::new("."),
        };
        if !folder.is_dir() {
            return Err(CliError::NoFolder {
                path: path.display().to_string(),
                folder: folder.display().to_string(),
            }
            .into());
        }
        advise::files::refuse_overwriting_inputs(path, args.sim_params.as_deref())?;
    }
    let out = advise::experiment::calibrate::run(args.study, sim, args.from_bootstrap, true);
    if let Some(path) = &args.write {
        if let Err(e) = advise::files::write_bytes(path, out.json.as_bytes()) {
            print_stdout(&out.json)?;
            return Err(e.into());
        }
        errln!("wrote {}", path.display());
    }
    print_stdout(if args.json { &out.json } else { &out.text })?;
    Ok(())
}

/// Evaluate on one real (or emulated) base, with Ctrl-C stopping it; an interrupted evaluation
/// prints the figures so far before its diagnostic.
fn eval_on_base<C, F>(
    kind: TaskKind,
    spec: BackendSpec,
    opts: &EvalOptions,
    limit: Option<usize>,
    make: F,
) -> miette::Result<eval::Report>
where
    C: eval::ControllerBox,
    F: Fn() -> C,
{
    let mut base = spec.connect(&Connect {
        sim: &opts.params,
        seed: opts.seed,
    })?;
    let signal = StopSignal::new();
    // Ctrl-C stops the base at once from the signal thread (as in a session), not only at the
    // evaluation's next control step.
    signal.set_base(base.remote_stop());
    let mut guarded = advise::backend::Interruptible::new(base.as_mut(), signal.clone());
    crate::repl::install_ctrl_c(&signal);
    errln!("evaluating {kind} on {spec} in real time; Ctrl-C stops the base");
    match eval::evaluate_on(kind, make, &mut guarded, opts, limit) {
        Ok(r) => Ok(r),
        Err(e) => {
            err!("{}", e.report.render());
            Err((*e).into())
        }
    }
}

/// `advise import`: bags and CSV logs of a person's driving to a demonstrations file.
pub fn import(args: ImportArgs) -> miette::Result<()> {
    use advise::recording::{ImportOptions, write_demonstrations};
    let kind = super::resolve_task(&args.task, &args.tasks)?;
    if let Some(dir) = &args.lerobot {
        return import_lerobot(dir, &kind.domain(), &args);
    }
    let def = match kind.def() {
        Some(d) if d.recorded.is_some() || args.goal.is_some() => d,
        Some(d) if d.goal.is_empty() => d,
        _ => {
            return Err(miette::miette!(
                code = "advise::import::task",
                help = "import for `positioning`, or for a task whose declaration says how a recording's goal is read from where it ends (`recorded NAME = ...`)",
                "`advise import` cannot make `{kind}` demonstrations: {}",
                if kind == TaskKind::Interception {
                    "interception needs the ball's positions, which a log of the base does not hold"
                        .to_string()
                } else {
                    format!(
                        "the task `{kind}` does not say how a recording's goal is read (no `recorded` clause); give it with `--goal`"
                    )
                }
            ));
        }
    };
    if [&def.speed, &def.turn]
        .iter()
        .any(|d| d.as_ref().is_some_and(|d| d.integrate.is_some()))
    {
        return Err(miette::miette!(
            code = "advise::import::task",
            help = "import for a task whose actions drive the base's speeds directly (`drives speed`, `drives turn`)",
            "the task `{kind}`'s actions are changes of speed; a log holds the speeds commanded, not how they were reached"
        ));
    }
    if let Some(g) = args.goal.as_deref() {
        let want = def.goal.len();
        if g.len() != want || g.iter().any(|v| !v.is_finite()) {
            let names: Vec<&str> = def.goal.iter().map(|p| p.name.as_str()).collect();
            return Err(miette::miette!(
                code = "advise::import::goal",
                help = format!(
                    "give the goal as {want} finite number{}: `--goal {}`",
                    if want == 1 { "" } else { "s" },
                    names
                        .iter()
                        .map(|n| n.to_uppercase())
                        .collect::<Vec<_>>()
                        .join(" ")
                ),
                "the goal {g:?} is not a goal of `{kind}` ({})",
                names.join(", ")
            ));
        }
    }
    let options = ImportOptions {
        goal: None,
        task: Some(def.clone()),
        goal_values: args.goal.clone(),
        split_gap_s: args.split_gap,
        cmd_topic: Some(args.cmd_topic),
        odom_topic: Some(args.odom_topic),
        keep_idle: args.keep_idle,
    };
    // Before reading anything: `--out` naming a log (or a bag's file) would replace it.
    let mut inputs: Vec<std::path::PathBuf> = args.tasks.clone();
    for log in &args.logs {
        inputs.push(log.clone());
        if let Ok(entries) = std::fs::read_dir(log) {
            inputs.extend(entries.flatten().take(10_000).map(|e| e.path()));
        }
    }
    advise::files::refuse_overwriting_inputs(&args.out, inputs.iter().map(|p| p.as_path()))?;
    let mut episodes = Vec::new();
    for log in &args.logs {
        let mut imported = advise::recording::import_recording(log, &options)?;
        for w in &imported.warnings {
            errln!("warning: {}: {w}", log.display());
        }
        for note in imported.notes("--keep-idle") {
            errln!("{}: {note}", log.display());
        }
        episodes.append(&mut imported.episodes);
    }
    write_demonstrations(&args.out, &def.domain, &episodes)?;
    let points: usize = episodes.iter().map(|e| e.trace.len()).sum();
    errln!(
        "wrote {} demonstration{} ({points} points) to {}; `load demos {}` adds them to a session",
        episodes.len(),
        if episodes.len() == 1 { "" } else { "s" },
        args.out.display(),
        args.out.display()
    );
    Ok(())
}

/// `advise import --lerobot DIR`: a LeRobot v3.0 dataset's episodes to a demonstrations file.
fn import_lerobot(
    dir: &std::path::Path,
    domain: &advise::domain::Domain,
    args: &ImportArgs,
) -> miette::Result<()> {
    use advise::recording::lerobot_in::{LeRobotReadOptions, read_lerobot};
    let mut inputs: Vec<std::path::PathBuf> = args.tasks.clone();
    inputs.push(dir.join("meta/info.json"));
    advise::files::refuse_overwriting_inputs(&args.out, inputs.iter().map(|p| p.as_path()))?;
    if args.out.starts_with(dir) {
        return Err(miette::miette!(
            code = "advise::import::out_in_dataset",
            help = "write the demonstrations outside the dataset's directory",
            "`{}` is inside the LeRobot dataset {}",
            args.out.display(),
            dir.display()
        ));
    }
    let options = LeRobotReadOptions {
        by_position: args.by_position,
    };
    let read = read_lerobot(dir, domain, &options)?;
    advise::recording::write_demonstrations(&args.out, domain, &read.episodes)?;
    let points = read.episode_index.len();
    errln!(
        "read {}: {}; wrote {} demonstration{} ({points} points) to {}; `load demos {}` adds them to a session",
        dir.display(),
        read.mapping.join(", "),
        read.episodes.len(),
        if read.episodes.len() == 1 { "" } else { "s" },
        args.out.display(),
        args.out.display()
    );
    Ok(())
}

/// `advise export`: a saved dataset as MCAP.
pub fn export(args: super::ExportArgs) -> miette::Result<()> {
    // Before reading anything: an output naming the dataset would replace it.
    for out in args.mcap.iter().chain(&args.lerobot) {
        advise::files::refuse_overwriting_inputs(out, [args.dataset.as_path()])?;
    }
    let mut files = advise::diag::SourceMap::new();
    let dataset = advise::policy::dataset::Dataset::load(&mut files, &args.dataset)
        .map_err(|e| files.attach(e))?;
    if let Some(out) = &args.mcap {
        use advise::recording::mcap_export::{McapOptions, export_mcap};
        // The timeline starts at the file's modification time, when the session saved it (the
        // session's wall clock, as near as a saved dataset tells).
        let saved = std::fs::metadata(&args.dataset)
            .and_then(|m| m.modified())
            .unwrap_or_else(|_| std::time::SystemTime::now());
        let summary = export_mcap(&dataset, out, &McapOptions::starting_at(saved))?;
        let shown = out.display().to_string();
        errln!(
            "{}",
            advise::recording::mcap_export::describe(&summary, &shown)
        );
    }
    if let Some(dir) = &args.lerobot {
        use advise::recording::lerobot;
        let options = lerobot::LeRobotOptions {
            fps: args.fps.unwrap_or_else(lerobot::default_fps),
            with_executions: args.with_executions,
        };
        let parts = lerobot::export_lerobot_with(&dataset, dir, &options)?;
        errln!(
            "{}",
            lerobot::describe_parts(&parts, &dir.display().to_string())
        );
    }
    Ok(())
}

/// `advise ros2-sim`: run the simulator as a ROS 2 robot until Ctrl-C.
pub fn ros2_sim(args: Ros2SimArgs) -> miette::Result<()> {
    let params = sim_params(args.sim_params.as_deref())?;
    let parsed = format!("ros2:{}", args.namespace).parse::<BackendSpec>()?;
    let Some(spec) = parsed.get::<Ros2Spec>().cloned() else {
        return Err(miette::miette!(
            code = "advise::cli::ros2_namespace",
            "`{}` is not a ROS 2 namespace",
            args.namespace
        ));
    };
    if !(args.command_timeout.is_finite() && (0.05..=10.0).contains(&args.command_timeout)) {
        return Err(miette::miette!(
            code = "advise::cli::command_timeout",
            help = "a base stops itself within about half a second (the default, 0.5)",
            "--command-timeout {} is outside 0.05 to 10 seconds",
            args.command_timeout
        ));
    }
    let stop = StopSignal::new();
    crate::repl::install_ctrl_c(&stop);
    let counts = advise::backend::ros2::robot::run_robot(
        &spec,
        params,
        args.seed,
        args.command_timeout,
        &stop,
        |cmd, odom, domain| {
            errln!(
                "ros2-sim: commands on {cmd}, odometry on {odom} at 50 Hz, domain {domain}; a command is held for {} s; drive it with `--backend {}`; Ctrl-C stops it",
                args.command_timeout,
                spec
            )
        },
    )?;
    errln!(
        "ros2-sim: {} commands received, {} odometry messages published, {} command timeouts",
        counts.commands,
        counts.odometry,
        counts.timeouts
    );
    Ok(())
}

/// `advise rmp-emulator`: run the RMP emulator until Ctrl-C, printing its state changes.
pub fn rmp_emulator(args: EmulatorArgs) -> miette::Result<()> {
    let params = sim_params(args.sim_params.as_deref())?;
    let cfg = EmulatorConfig {
        order: args.word_order,
        faults: FaultInjection {
            drop: args.drop,
            corrupt: args.corrupt,
            delay: args.delay,
            delay_ms: args.delay_ms,
        },
        seed: args.seed,
        balance_needs_tip_back: !args.no_tip_back,
        ..EmulatorConfig::for_platform(args.platform)
    };
    let emu = Emulator::bind_sim(args.bind, cfg.clone(), params, args.seed)?;
    let stop = StopSignal::new();
    crate::repl::install_ctrl_c(&stop);
    outln!(
        "RMP emulator: an {} with {} feedback on {}, the simulator behind it{}",
        cfg.platform.name(),
        cfg.order.name(),
        emu.addr(),
        if cfg.faults.drop + cfg.faults.corrupt + cfg.faults.delay == 0.0 {
            String::new()
        } else {
            format!(
                "; dropping {}, corrupting {}, delaying {} ({} ms) of datagrams",
                cfg.faults.drop, cfg.faults.corrupt, cfg.faults.delay, cfg.faults.delay_ms
            )
        }
    );
    outln!(
        "drive it with `--backend rmp:{}` (or `backend rmp:{}` in the REPL); Ctrl-C stops it",
        emu.addr(),
        emu.addr()
    );
    let mut last = None;
    while !stop.is_raised() {
        let s = emu.snapshot();
        if last != Some(s.state) {
            outln!("state: {}", s.state.name());
            last = Some(s.state);
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let s = emu.snapshot();
    emu.shutdown();
    let c = s.counts;
    outln!(
        "stopped in {}: {} datagrams received, {} accepted, {} bad CRC, {} bad length, {} unknown id, {} sent; injected {} drops, {} corruptions, {} delays",
        s.state.name(),
        c.received,
        c.accepted,
        c.bad_crc,
        c.bad_length,
        c.unknown_id,
        c.sent,
        c.injected_drops,
        c.injected_corruptions,
        c.injected_delays
    );
    Ok(())
}
