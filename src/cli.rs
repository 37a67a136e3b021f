//! The command line's arguments: the clap types of every subcommand, over the library's own
//! types (a task is a [`TaskKind`], a learner a [`LearnerKind`](advise::policy::learner::LearnerKind),
//! a study a [`Study`], a platform a [`Platform`]), and the errors that belong to the command line
//! itself. `src/main.rs` parses these and calls the library; the subcommands that are not a
//! session are run by [`tools`].

use std::path::{Path, PathBuf};

use advise::choice::Choice;
use clap::{Args, Parser, Subcommand};
use miette::{Diagnostic, miette};
use thiserror::Error;

use advise::backend::rmp::codec::{Platform, WordOrder};
use advise::backend::sim::SimParams;
use advise::eval::EvalPolicy;
use advise::experiment::study::{Seeds, Study};
use advise::task::TaskKind;

pub mod operators;
pub mod tools;

#[derive(Parser)]
#[command(
    name = "advise",
    version,
    about = "Teach a robot's motion controller by critiquing and advising its executions"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand)]
pub enum Command {
    /// Check advice-operator files (on top of the standard operators); every error of every file
    /// is reported, and the exit code is non-zero if there was any.
    Check {
        /// Files of task declarations the operator files build on (`domain NAME { goal ... }`),
        /// checked first, as `repl`, `eval` and `demo` take them.
        #[arg(long = "tasks", value_name = "FILE")]
        tasks: Vec<PathBuf>,
        /// Operator files (`*.adv`); with none (and no `--tasks`), the standard operators are
        /// checked.
        files: Vec<PathBuf>,
    },
    /// Rewrite operator files in the canonical layout, keeping their comments; `--check` changes
    /// nothing and exits non-zero naming the files that would change.
    Fmt {
        /// Only report the files that are not formatted.
        #[arg(long)]
        check: bool,
        /// Operator files (`*.adv`).
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Run the examples in operator files' doc comments (`/// Example: ...`); with no files, the
    /// standard operators'. Prints `N examples, M failed` and exits non-zero on a failure.
    Test {
        /// Files of task declarations the operator files build on, checked first (with the
        /// standard operators by role), as `check --tasks` takes them; their operators' examples
        /// are run too.
        #[arg(long = "tasks", value_name = "FILE")]
        tasks: Vec<PathBuf>,
        /// Operator files (`*.adv`), checked on top of the standard operators.
        files: Vec<PathBuf>,
    },
    /// A language server for operator files over stdin and stdout, for editors.
    Lsp,
    /// Apply an operator to a range of a trace and print the synthesized points as CSV.
    Apply {
        /// Extra operator files, checked on top of the standard operators (repeatable).
        #[arg(long = "operators", value_name = "FILE")]
        operators: Vec<PathBuf>,
        /// The operator and its arguments: `speed_up`, `speed_up(0.5)`, `speed_up(rate = 0.5)`.
        #[arg(long, value_name = "NAME[(ARGS)]")]
        op: String,
        /// The trace (CSV with a header, or JSON).
        #[arg(long, value_name = "TRACE")]
        trace: PathBuf,
        /// Half-open, 0-based range of points: `A..B`.
        #[arg(long, value_name = "A..B")]
        range: String,
        /// The trace's domain; by default it is recognised from the CSV header or JSON.
        #[arg(long)]
        domain: Option<String>,
        /// For a demonstrations file of many episodes: which one (0-based, in file order).
        #[arg(long, value_name = "K")]
        episode: Option<usize>,
    },
    /// Record teacher demonstrations in the simulator (one file, many episodes).
    Demo(DemoArgs),
    /// Turn a person's recorded driving (ROS 2 bags, or CSV logs `time,x,y,theta,v,w`) into
    /// positioning demonstrations that `load demos` reads.
    Import(ImportArgs),
    /// Write a saved dataset (`save FILE.json`) for other tools: MCAP for Foxglove and ROS 2,
    /// a LeRobot dataset for training other policies.
    Export(ExportArgs),
    /// Run a policy over the task's fixed test set and print the figures.
    Eval(EvalArgs),
    /// Run a session script (the REPL's commands, one per line); stops at the first failing
    /// statement unless `--keep-going`.
    Run {
        /// The script (`*.adv`).
        script: PathBuf,
        /// Report failing statements and go on.
        #[arg(long)]
        keep_going: bool,
        #[command(flatten)]
        session: SessionArgs,
    },
    /// Replay a session journal (the newest one by default) and continue in the REPL.
    Resume {
        /// The journal to replay; by default the newest in the journal folder.
        journal: Option<PathBuf>,
    },
    /// Open the REPL (what `advise` with no arguments does); with `--view`, the web view of the
    /// same session beside it.
    Repl {
        #[command(flatten)]
        session: SessionArgs,
        #[command(flatten)]
        view: ViewArgs,
    },
    /// Serve the session as a web page (the teacher's view in a browser) at the URL it prints;
    /// runs until Ctrl-C.
    Serve {
        #[command(flatten)]
        session: SessionArgs,
        /// The address to listen on; anything but loopback is reachable from other machines
        /// (the token still guards it) and is warned about.
        #[arg(long, default_value = "127.0.0.1:0", value_name = "ADDR:PORT")]
        listen: std::net::SocketAddr,
        /// A host name the page may be opened by besides loopback names, IP addresses and this
        /// machine's own name (a name other machines know it by); repeatable.
        #[arg(long = "allow-host", value_name = "NAME")]
        allow_hosts: Vec<String>,
    },
    /// Reproduce one of the paper's studies with automated teachers and print its figures.
    Experiment(ExperimentArgs),
    /// Fit the constants the paper leaves open to the figures it gives as a study's starting
    /// conditions (never its claims), on held-out practice sets; prints what was fitted to what
    /// and how closely, and with `--write` saves the file the defaults are read from.
    Calibrate(CalibrateArgs),
    /// Emulate a Segway RMP v3 on a UDP port, with the simulator behind it: what `--backend
    /// rmp:HOST:PORT` drives when no robot is at hand. Runs until Ctrl-C.
    RmpEmulator(EmulatorArgs),
    /// The simulator as a ROS 2 robot: subscribes `cmd_vel`, publishes `odom` at 50 Hz, what
    /// `--backend ros2` drives when no robot is at hand. Runs until Ctrl-C.
    Ros2Sim(Ros2SimArgs),
}

/// `advise repl --view`: the web view beside the REPL.
#[derive(Args)]
pub struct ViewArgs {
    /// Serve the session as a web page too, at the URL printed (the same session and journal).
    #[arg(long)]
    pub view: bool,
    /// With `--view`: the address to listen on (loopback unless said otherwise, with a warning).
    #[arg(
        long,
        default_value = "127.0.0.1:0",
        value_name = "ADDR:PORT",
        requires = "view"
    )]
    pub listen: std::net::SocketAddr,
    /// With `--view`: a host name the page may be opened by besides loopback names, IP
    /// addresses and this machine's own name; repeatable.
    #[arg(long = "allow-host", value_name = "NAME", requires = "view")]
    pub allow_hosts: Vec<String>,
}

#[derive(Args)]
pub struct Ros2SimArgs {
    /// The robot's namespace, e.g. `/robot1` for `/robot1/cmd_vel` and `/robot1/odom`; options
    /// as in `--backend ros2:NAMESPACE?cmd=..&odom=..&domain=..`. The domain is ROS_DOMAIN_ID's.
    #[arg(long, default_value = "/", value_name = "NS")]
    pub namespace: String,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    pub sim_params: Option<PathBuf>,
    /// Seeds the simulator's noise.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seconds a command is held with no newer one before the simulated base stops itself, as a
    /// real base's controller does (0.05 to 10).
    #[arg(long, value_name = "SECONDS", default_value_t = advise::backend::ros2::robot::COMMAND_TIMEOUT_S)]
    pub command_timeout: f64,
}

#[derive(Args)]
pub struct ExperimentArgs {
    /// Which study.
    #[arg(value_parser = choice::<Study>())]
    pub study: Study,
    /// Seeds everything: demonstrations, practice starts, simulator noise, LWR tuning.
    #[arg(long, default_value_t = 0, conflicts_with = "seeds")]
    pub seed: u64,
    /// Run several seeds (`0..5`: 0 to 4) and print each figure's mean and spread beside the
    /// paper's, and for how many seeds the paper's shape holds.
    #[arg(long, value_name = "A..B")]
    pub seeds: Option<String>,
    /// Print the result as JSON on stdout (every figure, the seed and the parameters; with
    /// `--seeds`, the summary and every run).
    #[arg(long)]
    pub json: bool,
    /// Write the study's plots as SVG files into this folder (created if needed).
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    pub sim_params: Option<PathBuf>,
    /// `bc` only: which critique rule the rounds use: the paper's, the directional one (the
    /// paper's proposed improvement), or both, each with its own learner from the same
    /// demonstrations and practice starts [default: both].
    #[arg(long, value_name = "RULE", value_parser = choice::<advise::experiment::bc::Rules>())]
    pub critique: Option<advise::experiment::bc::Rules>,
    /// `bc` only: whose demonstrations: the paper's hand-written deterministic controller (the
    /// main arm), the human-like teacher (the second arm), or both, each with its own learners
    /// and oracles from the same starts [default: both; an ablation runs the controller's].
    #[arg(long, value_name = "ARM", value_parser = choice::<advise::experiment::bc::Teachers>())]
    pub teacher: Option<advise::experiment::bc::Teachers>,
    /// The ablation (docs/ablation.md): revert one choice of the studies' protocol (README,
    /// "The protocol") alone to what it replaced, everything else as the protocol has it:
    /// `ball` (1, bc), `teacher` (2, bc and aopi), `chunks` (3, bc), `support` (4, bc),
    /// `advisor` (5, aopi), `stopping` (6, aopi), `rate` (7, aopi).
    #[arg(long, value_name = "CHOICE", value_parser = choice::<advise::experiment::ablation::Revert>())]
    pub revert: Option<advise::experiment::ablation::Revert>,
    /// `aopi` only: at most N practice goals per arm (1 to 1000; default: the calibrated arm
    /// length), for a quick look at the study's machinery; the protocol's figures use the default.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub practice: Option<u32>,
}

#[derive(Args)]
pub struct CalibrateArgs {
    /// Which study's constants.
    #[arg(value_parser = choice::<Study>())]
    pub study: Study,
    /// Write the calibration (values and record) to this file: `calibration/bc.json` or
    /// `calibration/aopi.json` in a checkout, which the defaults are built from.
    #[arg(long, value_name = "FILE")]
    pub write: Option<PathBuf>,
    /// Print the calibration file's JSON instead of the report.
    #[arg(long)]
    pub json: bool,
    /// Start from the first guesses in the code instead of the shipped constants: this is how
    /// the shipped file was made, and it reproduces it byte for byte.
    #[arg(long)]
    pub from_bootstrap: bool,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    pub sim_params: Option<PathBuf>,
}

#[derive(Args)]
pub struct EmulatorArgs {
    /// Address to listen on (port 0 picks a free port; the real RMP listens on 8080).
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "HOST:PORT")]
    pub bind: std::net::SocketAddr,
    /// Fraction of datagrams (either way) silently dropped, 0..1.
    #[arg(long, default_value_t = 0.0, value_name = "FRACTION")]
    pub drop: f64,
    /// Fraction of datagrams with one byte changed (the CRC catches every one), 0..1.
    #[arg(long, default_value_t = 0.0, value_name = "FRACTION")]
    pub corrupt: f64,
    /// Fraction of datagrams held back by `--delay-ms` (so they also arrive out of order), 0..1.
    #[arg(long, default_value_t = 0.0, value_name = "FRACTION")]
    pub delay: f64,
    /// How long a delayed datagram is held, ms.
    #[arg(long, default_value_t = 30)]
    pub delay_ms: u64,
    /// Seeds the fault injection and the simulator's noise.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Byte order of the feedback words (the driver detects it; the real firmware is little).
    #[arg(long, default_value = "little", value_parser = word_order())]
    pub word_order: WordOrder,
    /// The platform it reports (balance mode needs an RMP 220).
    #[arg(long, default_value = "rmp220", value_parser = platform())]
    pub platform: Platform,
    /// Simulator parameters of the base behind it (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    pub sim_params: Option<PathBuf>,
    /// Enter balance mode at once, without waiting for an operator to tip the base back.
    #[arg(long)]
    pub no_tip_back: bool,
}

#[derive(Args)]
pub struct DemoArgs {
    /// The task to demonstrate: `positioning`, `interception`, or a task of `--tasks FILE`.
    #[arg(long, value_name = "TASK")]
    pub task: String,
    /// Files of task declarations (`domain NAME { goal ... success when ... }`) whose tasks
    /// `--task` may name.
    #[arg(long = "tasks", value_name = "FILE")]
    pub tasks: Vec<PathBuf>,
    /// How many demonstrations (episodes) to record.
    #[arg(long, default_value_t = 9, value_parser = clap::value_parser!(u64).range(1..=100_000))]
    pub count: u64,
    /// Seeds the practice starts, the simulator noise and the teacher.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output file: `.json` writes JSON episodes, anything else CSV with an `episode` column.
    #[arg(long)]
    pub out: PathBuf,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    pub sim_params: Option<PathBuf>,
}

#[derive(Args)]
pub struct ImportArgs {
    /// The recordings, each one demonstration (or several with `--split-gap`): ROS 2 bags (a
    /// rosbag2 directory or an `.mcap` file) or CSV logs `time,x,y,theta,v,w`.
    #[arg(required_unless_present = "lerobot", value_name = "BAG|LOG")]
    pub logs: Vec<PathBuf>,
    /// A LeRobot v3.0 dataset directory: its episodes as demonstrations of `--task`, its
    /// `observation.state` and `action` mapped to the task's dimensions by their names.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["logs", "goal", "split_gap", "keep_idle"])]
    pub lerobot: Option<PathBuf>,
    /// With `--lerobot`: map `observation.state` and `action` position by position where their
    /// names are not the task's dimensions (the widths must agree).
    #[arg(long, requires = "lerobot")]
    pub by_position: bool,
    /// A bag's command topic (geometry_msgs Twist or TwistStamped).
    #[arg(long, value_name = "TOPIC", default_value = "/cmd_vel")]
    pub cmd_topic: String,
    /// A bag's odometry topic (nav_msgs Odometry).
    #[arg(long, value_name = "TOPIC", default_value = "/odom")]
    pub odom_topic: String,
    /// The task the demonstrations are for: `positioning`, or a task of `--tasks FILE` that
    /// reads its goal from a recording (a `recorded` clause).
    #[arg(long, default_value = "positioning", value_name = "TASK")]
    pub task: String,
    /// Files of task declarations (`domain NAME { goal ... success when ... }`) whose tasks
    /// `--task` may name.
    #[arg(long = "tasks", value_name = "FILE")]
    pub tasks: Vec<PathBuf>,
    /// The goal of every demonstration, in the log's frame (positioning: X Y THETA; a declared
    /// task: a value for each goal parameter); default: read from where each one ends.
    #[arg(long, num_args = 1.., value_name = "VALUE", allow_negative_numbers = true)]
    pub goal: Option<Vec<f64>>,
    /// Split a recording where consecutive commands are more than this many seconds apart.
    #[arg(long, value_name = "SECONDS")]
    pub split_gap: Option<f64>,
    /// Keep the standing-still points before the first moving command and after the base came
    /// to rest (trimmed by default; the reply counts them).
    #[arg(long)]
    pub keep_idle: bool,
    /// Output file: `.json` writes JSON episodes, anything else CSV with an `episode` column.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
#[group(id = "format", required = true, multiple = true, args = ["mcap", "lerobot"])]
pub struct ExportArgs {
    /// A dataset saved by a session (`save FILE.json`).
    #[arg(value_name = "DATASET.json")]
    pub dataset: PathBuf,
    /// Write MCAP (profile ros2, ROS 2 message types in CDR): each execution on /cmd_vel and
    /// /odom, advice and critiques on /advise/advice and /advise/critique.
    #[arg(long, value_name = "OUT.mcap")]
    pub mcap: Option<PathBuf>,
    /// Write a LeRobot v3.0 dataset into this new directory: every point a frame, each
    /// demonstration and each piece of advice an episode.
    #[arg(long, value_name = "DIR")]
    pub lerobot: Option<PathBuf>,
    /// The frames per second of demonstrations without times (a dataset saved before datasets
    /// kept them); every other source is written at its own rate, one dataset per rate. Default:
    /// the simulator's control rate.
    #[arg(long, value_name = "HZ", requires = "lerobot")]
    pub fps: Option<u32>,
    /// Export each execution as a LeRobot episode too (`advise.source` = `execution`,
    /// `advise.weight` 0), besides the demonstrations and advice.
    #[arg(long, requires = "lerobot")]
    pub with_executions: bool,
}

#[derive(Args)]
pub struct EvalArgs {
    /// The task whose test set to run: `positioning`, `interception`, or a task of
    /// `--tasks FILE`.
    #[arg(long, value_name = "TASK")]
    pub task: String,
    /// Files of task declarations (`domain NAME { goal ... success when ... }`) whose tasks
    /// `--task` may name.
    #[arg(long = "tasks", value_name = "FILE")]
    pub tasks: Vec<PathBuf>,
    /// Demonstrations to derive the policy from (a file written by `advise demo`).
    #[arg(long, value_name = "FILE")]
    pub dataset: Option<PathBuf>,
    /// Which policy to derive (or `teacher` to evaluate the teacher itself).
    #[arg(long, default_value = "bc", value_parser = choice::<EvalPolicy>())]
    pub policy: EvalPolicy,
    /// LWR's kernel limited to its N nearest points (default: no limit up to 20,000 points,
    /// beyond it the tuned kernel's mean neighbours; docs/protocol.md).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub lwr_k: Option<u64>,
    /// Seeds the simulator noise; the test set itself is fixed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Simulator parameters (JSON; omitted fields keep their defaults).
    #[arg(long, value_name = "FILE")]
    pub sim_params: Option<PathBuf>,
    /// The base: `sim` (the test set in parallel on fresh simulators) or `rmp:HOST:PORT` (a Segway
    /// RMP or `advise rmp-emulator`, episode after episode in real time).
    #[arg(
        long,
        default_value = "sim",
        value_name = backend_syntaxes()
    )]
    pub backend: String,
    /// A ROS 2 base's command topic (as `?cmd=` in the spec): `--cmd-topic teleop/cmd_vel`.
    #[arg(long, value_name = "TOPIC")]
    pub cmd_topic: Option<String>,
    /// A ROS 2 base's odometry topic (as `?odom=` in the spec): `--odom-topic /robot1/odom`.
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    /// Run only the first N starts of the test set (a quick check on a real base).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub limit: Option<u64>,
}

/// The command line, parsed; or, when clap refuses it, clap's text printed as a coded diagnostic
/// and the exit code to end with (clap's: 2). `--help` and `--version` print as clap prints them
/// and exit 0.
pub fn parse_args() -> Result<Cli, std::process::ExitCode> {
    Cli::try_parse().map_err(|e| {
        use clap::error::ErrorKind;
        if matches!(
            e.kind(),
            ErrorKind::DisplayHelp
                | ErrorKind::DisplayVersion
                | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
        ) {
            e.exit()
        }
        print_report(&advise::diag::SourceMap::new(), &ArgumentError::from(&e));
        std::process::ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2))
    })
}

/// An argument clap refused, in clap's words: the first line is what is wrong, the rest (a tip,
/// the usage, where to read more) is the help. The code says which kind of mistake it is.
#[derive(Debug)]
pub struct ArgumentError {
    code: &'static str,
    message: String,
    help: String,
}

impl From<&clap::Error> for ArgumentError {
    fn from(e: &clap::Error) -> ArgumentError {
        use clap::error::ErrorKind as K;
        let code = match e.kind() {
            K::InvalidValue | K::ValueValidation | K::InvalidUtf8 => "advise::cli::invalid_value",
            K::UnknownArgument => "advise::cli::unknown_argument",
            K::InvalidSubcommand => "advise::cli::unknown_command",
            K::MissingRequiredArgument | K::MissingSubcommand => "advise::cli::missing_argument",
            K::ArgumentConflict => "advise::cli::argument_conflict",
            K::NoEquals | K::TooManyValues | K::TooFewValues | K::WrongNumberOfValues => {
                "advise::cli::value_count"
            }
            _ => "advise::cli::arguments",
        };
        // `render` is clap's text without colour.
        let text = e.render().to_string();
        let text = text.trim().strip_prefix("error: ").unwrap_or(text.trim());
        let (message, help) = text.split_once('\n').unwrap_or((text, ""));
        ArgumentError {
            code,
            message: message.trim().to_string(),
            help: help.trim().to_string(),
        }
    }
}

impl std::fmt::Display for ArgumentError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for ArgumentError {}

impl Diagnostic for ArgumentError {
    fn code<'a>(&'a self) -> Option<Box<dyn std::fmt::Display + 'a>> {
        Some(Box::new(self.code))
    }

    fn help<'a>(&'a self) -> Option<Box<dyn std::fmt::Display + 'a>> {
        (!self.help.is_empty()).then(|| Box::new(&self.help) as Box<dyn std::fmt::Display>)
    }
}

/// Errors that belong to the command line itself.
#[derive(Debug, Error, Diagnostic)]
pub enum CliError {
    #[error("cannot write `{path}`")]
    #[diagnostic(
        code(advise::cli::write),
        help("check that the directory exists and is writable")
    )]
    Write {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write `{path}`: the folder `{folder}` does not exist")]
    #[diagnostic(
        code(advise::cli::no_folder),
        help("create the folder first, or name a file in an existing one")
    )]
    NoFolder { path: String, folder: String },
    #[error("`--policy {policy}` needs demonstrations to learn from")]
    #[diagnostic(
        code(advise::cli::no_dataset),
        help(
            "pass `--dataset FILE` (record one with `advise demo --task TASK --out FILE`), or use `--policy teacher`"
        )
    )]
    NoDataset { policy: &'static str },
    #[error("the task `{task}` has no teacher to demonstrate it")]
    #[diagnostic(
        code(advise::cli::no_teacher),
        help(
            "declare one in the task (`teacher {{ trans = ...  rot = ... }}`), or record demonstrations on a base and `advise import` them"
        )
    )]
    NoTeacher { task: String },
    #[error("`--{flag}` names a ROS 2 topic, but the backend is `{backend}`")]
    #[diagnostic(
        code(advise::cli::topic_without_ros2),
        help("topics belong to a ROS 2 base: `--backend ros2` (or `ros2:/NAMESPACE`) with it")
    )]
    TopicWithoutRos2 { flag: &'static str, backend: String },
    #[error("`--{flag} {flag_topic}` and the spec's `{key}={spec_topic}` disagree")]
    #[diagnostic(
        code(advise::cli::topic_conflict),
        help("name the topic once: in the flag or in the spec")
    )]
    TopicConflict {
        flag: &'static str,
        flag_topic: String,
        key: &'static str,
        spec_topic: String,
    },
    #[error("`{topic}` is not a topic name")]
    #[diagnostic(
        code(advise::cli::bad_topic),
        help("a ROS 2 topic has no spaces, `?` or `&`: `cmd_vel`, `/robot1/odom`")
    )]
    BadTopic { topic: String },
    #[error(
        "`--critique` chooses the BC study's critique rule; the `{study}` study has no critiques"
    )]
    #[diagnostic(
        code(advise::cli::critique_without_bc),
        help("use it with `advise experiment bc`, or leave it out")
    )]
    CritiqueWithoutBc { study: String },
    #[error("`--teacher` chooses the BC study's teacher arms; the `{study}` study has none")]
    #[diagnostic(
        code(advise::cli::teacher_without_bc),
        help("use it with `advise experiment bc`, or leave it out")
    )]
    TeacherWithoutBc { study: String },
    #[error("`--practice` caps the A-OPI study's arms; the `bc` study has no arms")]
    #[diagnostic(
        code(advise::cli::practice_without_aopi),
        help("use it with `advise experiment aopi`, or leave it out")
    )]
    PracticeWithoutAopi,
    #[error("protocol choice {point} (`{choice}`) is not part of the `{study}` study")]
    #[diagnostic(
        code(advise::cli::revert_not_in_study),
        help("`{choice}` is reverted in `advise experiment {other} --revert {choice}`")
    )]
    RevertNotInStudy {
        point: usize,
        choice: &'static str,
        study: &'static str,
        other: &'static str,
    },
}

/// `--backend` with `--cmd-topic` and `--odom-topic` folded into a ROS 2 spec's options
/// (`ros2:/r1` and `--cmd-topic teleop/cmd_vel` give `ros2:/r1?cmd=teleop/cmd_vel`). A flag that
/// repeats the spec's own option is accepted; one that contradicts it, or a topic flag with a
/// backend that is not ROS 2, is refused.
pub fn backend_with_topics(
    backend: &str,
    cmd_topic: Option<&str>,
    odom_topic: Option<&str>,
) -> Result<String, CliError> {
    let backend = backend.trim();
    let flags = [
        ("cmd-topic", "cmd", cmd_topic),
        ("odom-topic", "odom", odom_topic),
    ];
    let ros2 = backend == "ros2" || backend.starts_with("ros2:") || backend.starts_with("ros2?");
    let mut spec = backend.to_string();
    for (flag, key, topic) in flags {
        let Some(topic) = topic else { continue };
        if !ros2 {
            return Err(CliError::TopicWithoutRos2 {
                flag,
                backend: backend.to_string(),
            });
        }
        if topic.is_empty() || topic.contains(|c: char| c.is_whitespace() || c == '?' || c == '&') {
            return Err(CliError::BadTopic {
                topic: topic.to_string(),
            });
        }
        let query = spec.split_once('?').map_or("", |(_, q)| q);
        let given = query
            .split('&')
            .find_map(|kv| kv.strip_prefix(key).and_then(|r| r.strip_prefix('=')));
        match given {
            Some(same) if same == topic => {}
            Some(other) => {
                return Err(CliError::TopicConflict {
                    flag,
                    flag_topic: topic.to_string(),
                    key,
                    spec_topic: other.to_string(),
                });
            }
            None => {
                spec.push(if spec.contains('?') { '&' } else { '?' });
                spec.push_str(&format!("{key}={topic}"));
            }
        }
    }
    Ok(spec)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topic_flags_fold_into_a_ros2_spec() {
        let f = |b: &str, c: Option<&str>, o: Option<&str>| backend_with_topics(b, c, o);
        assert_eq!(
            f("ros2", Some("teleop/cmd_vel"), None).unwrap(),
            "ros2?cmd=teleop/cmd_vel"
        );
        assert_eq!(
            f("ros2:/r1?domain=3", None, Some("/r1/odom")).unwrap(),
            "ros2:/r1?domain=3&odom=/r1/odom"
        );
        assert_eq!(f("ros2?cmd=a", Some("a"), None).unwrap(), "ros2?cmd=a");
        assert_eq!(f("sim", None, None).unwrap(), "sim");
        assert!(matches!(
            f("ros2?cmd=a", Some("b"), None),
            Err(CliError::TopicConflict { .. })
        ));
        assert!(matches!(
            f("sim", Some("a"), None),
            Err(CliError::TopicWithoutRos2 { .. })
        ));
        assert!(matches!(
            f("ros2", None, Some("a b")),
            Err(CliError::BadTopic { .. })
        ));
        // The folded spec is one the backend parser reads, with the topics in place.
        let spec: advise::backend::BackendSpec = f("ros2:/r1", Some("teleop/cmd_vel"), Some("/o"))
            .unwrap()
            .parse()
            .unwrap();
        let Some(r) = spec.get::<advise::backend::ros2::Ros2Spec>() else {
            panic!("{spec:?}")
        };
        assert_eq!(
            (r.cmd().as_str(), r.odom().as_str()),
            ("/r1/teleop/cmd_vel", "/o")
        );
    }
}

/// How a session starts.
#[derive(Args, Clone)]
pub struct SessionArgs {
    /// The task to start on: `positioning`, `interception`, or a task of `--tasks FILE`.
    #[arg(long, default_value = "positioning", value_name = "TASK")]
    pub task: String,
    /// Files of task declarations (`domain NAME { goal ... success when ... }`) whose tasks
    /// `--task` may name.
    #[arg(long = "tasks", value_name = "FILE")]
    pub tasks: Vec<PathBuf>,
    /// Seeds the simulator, the practice starts and LWR tuning.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Teacher demonstrations recorded at start (0: start with an empty dataset).
    #[arg(long, default_value_t = 9)]
    pub demos: usize,
    /// Do not keep a journal.
    #[arg(long)]
    pub no_journal: bool,
    /// The base to drive: `sim`, `rmp:HOST:PORT` for a Segway RMP (or `advise rmp-emulator`), or
    /// `ros2[:NS][?options]` for a ROS 2 base; the same as the session command `backend`.
    #[arg(
        long,
        default_value = "sim",
        value_name = backend_syntaxes()
    )]
    pub backend: String,
    /// A ROS 2 base's command topic (as `?cmd=` in the spec): `--cmd-topic teleop/cmd_vel`.
    #[arg(long, value_name = "TOPIC")]
    pub cmd_topic: Option<String>,
    /// A ROS 2 base's odometry topic (as `?odom=` in the spec): `--odom-topic /robot1/odom`.
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
}

impl Default for SessionArgs {
    fn default() -> Self {
        SessionArgs {
            task: "positioning".into(),
            tasks: Vec::new(),
            seed: 0,
            demos: 9,
            no_journal: false,
            backend: "sim".into(),
            cmd_topic: None,
            odom_topic: None,
        }
    }
}

/// The task `name`: one of the paper's, or one declared in `files` (checked on top of the
/// standard operators, every mistake reported), by the library's one resolver
/// ([`advise::task::resolve_in_files`]); its errors bring the files along.
pub fn resolve_task(name: &str, files: &[PathBuf]) -> miette::Result<TaskKind> {
    let mut map = advise::diag::SourceMap::new();
    advise::task::resolve_in_files(&mut map, name, files, advise::task::Front::CommandLine)
        .map(|(kind, _)| kind)
        .map_err(|e| map.attach(e).into())
}

// The command line's spelling of library types that have no `clap` derive of their own (their
// modules know nothing of the command line): one table each, read by clap for parsing, help and
// completion.

/// `--backend`'s value name: the registry's spellings (`sim|rmp:HOST:PORT|ros2[:NAMESPACE]`),
/// so a new kind of base shows here without an edit.
fn backend_syntaxes() -> &'static str {
    static SYNTAXES: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    SYNTAXES.get_or_init(|| advise::backend::Registry::standard().syntaxes())
}

/// A library [`Choice`]'s words as an argument's possible values: listed in help, with clap's
/// "did you mean" on a typo, spelled once in the library.
fn choice<T: Choice>() -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(
        T::all()
            .iter()
            .map(|v| PossibleValue::new(v.name()).help(v.help())),
    )
    .try_map(|word| T::parse(&word).ok_or_else(|| format!("`{word}` names nothing")))
}

/// `--platform`'s words.
fn platform() -> impl clap::builder::TypedValueParser<Value = Platform> {
    words(&[
        ("rmp220", Platform::Rmp220),
        ("rmp210", Platform::Rmp210),
        ("rmp440", Platform::Rmp440),
        ("omni", Platform::RmpOmni),
        ("rmp110", Platform::Rmp110),
    ])
}

/// `--word-order`'s words.
fn word_order() -> impl clap::builder::TypedValueParser<Value = WordOrder> {
    words(&[("little", WordOrder::Little), ("big", WordOrder::Big)])
}

/// An argument that takes one of `table`'s words, for a library type that is not a [`Choice`].
fn words<T: Copy + Send + Sync + 'static>(
    table: &'static [(&'static str, T)],
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(table.iter().map(|(word, _)| *word)).try_map(move |word| {
        table
            .iter()
            .find(|(w, _)| *w == word)
            .map(|(_, v)| *v)
            .ok_or_else(|| format!("`{word}` names nothing"))
    })
}

/// `A..B` as two indices.
pub fn parse_range(s: &str) -> miette::Result<(usize, usize)> {
    let bad = || {
        miette!(
            code = "advise::cli::bad_range",
            help = "write a half-open, 0-based range of points such as `0..20`",
            "`{s}` is not a range"
        )
    };
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let a = a.trim().parse().map_err(|_| bad())?;
    let b = b.trim().parse().map_err(|_| bad())?;
    Ok((a, b))
}

/// `--seed` alone, or `--seeds A..B` as a non-empty half-open range of seeds.
pub fn parse_seeds(seed: u64, range: Option<&str>) -> miette::Result<Seeds> {
    let Some(s) = range else {
        return Ok(Seeds::One(seed));
    };
    let bad = || {
        miette!(
            code = "advise::cli::bad_seeds",
            help = "write a half-open range of seeds such as `0..5` (seeds 0 to 4)",
            "`{s}` is not a range of seeds"
        )
    };
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let a: u64 = a.trim().parse().map_err(|_| bad())?;
    let b: u64 = b.trim().parse().map_err(|_| bad())?;
    if b <= a {
        return Err(bad());
    }
    Ok(Seeds::Range(a..b))
}

/// `--sim-params FILE`, or the defaults.
pub fn sim_params(path: Option<&Path>) -> miette::Result<SimParams> {
    let mut files = advise::diag::SourceMap::new();
    advise::experiment::sim_params(&mut files, path).map_err(|e| files.attach(e).into())
}

/// Print to stdout; a closed pipe (`advise eval --json | head`) is not an error.
pub fn print_stdout(text: &str) -> miette::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(CliError::Write {
            path: "standard output".into(),
            source: e,
        }
        .into()),
        _ => Ok(()),
    }
}

/// Print a diagnostic on stderr, showing a bounded window of its source (never a whole file).
/// An error that points into a source map brings it along ([`advise::diag::Sourced`]).
pub fn print_report(sources: &advise::diag::SourceMap, diag: &dyn Diagnostic) {
    let colour = std::io::IsTerminal::is_terminal(&std::io::stderr());
    errln!(
        "{}",
        advise::diag::render_with_width(sources, diag, colour, 80)
    );
}
