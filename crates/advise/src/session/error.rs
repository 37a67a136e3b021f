//! Why a statement fails: [`SessionError`], one variant per mistake, each with a stable code.

use miette::Diagnostic;
use thiserror::Error;

use super::journal::JournalError;
use super::plot;
use super::{MAX_GOAL_M, MAX_KAPPA};
use crate::backend::sim::SimError;
use crate::backend::{BackendError, BackendSpecError};
use crate::check::{CheckError, CheckErrors};
use crate::interp::ApplyError;
use crate::policy::learner::LearnerError;
use crate::syntax::ParseError;
use crate::task::{self, TaskKind};
use crate::trace::{ChunkError, TraceError};

/// Why a statement failed. Nothing in the session changes when a statement fails.
#[derive(Debug, Error, Diagnostic)]
pub enum SessionError {
    #[error(transparent)]
    #[diagnostic(transparent)]
    Parse(#[from] ParseError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Check(#[from] CheckErrors),
    /// An invocation that does not bind to an operator of the task.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Bind(#[from] CheckError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Apply(#[from] ApplyError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Chunk(#[from] ChunkError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Learner(#[from] LearnerError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Plot(#[from] plot::PlotError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    ParquetDemos(#[from] crate::recording::parquet_demos::ParquetDemosError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Interrupted(Box<task::Interrupted>),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Sim(#[from] SimError),
    /// A ROS 2 bag or a CSV log that `load demos` could not import.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Import(#[from] crate::recording::ImportError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    Export(#[from] crate::recording::mcap_export::ExportError),
    #[error(transparent)]
    #[diagnostic(transparent)]
    LeRobot(#[from] crate::recording::lerobot::LeRobotError),
    #[error(
        "{path} is a recording of a base's drive, which makes demonstrations of a task that reads its goal from where a recording ends"
    )]
    #[diagnostic(
        code(advise::session::recording_needs_positioning),
        help(
            "`task positioning` first, or a declared task with a `recorded` clause and actions that drive the speeds; interception needs the ball's positions, which a recording of the base does not hold"
        )
    )]
    RecordingNeedsPositioning { path: String },
    #[error("`{path}` is not a ROS 2 bag, so `cmd` and `odom` topics do not apply to it")]
    #[diagnostic(
        code(advise::session::topics_need_a_bag),
        help(
            "name topics only for a bag (a rosbag2 folder or a `.mcap` file): `load demos run1/ cmd /robot1/cmd_vel odom /robot1/odom`"
        )
    )]
    TopicsNeedABag { path: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    PracticeStart(#[from] task::PracticeStartOutOfRange),
    /// `load demos teacher:N` of a task whose teacher's runs stopped on a value that is not a
    /// number.
    #[error(transparent)]
    #[diagnostic(transparent)]
    DemosStopped(#[from] task::DemosStopped),
    #[error(transparent)]
    #[diagnostic(transparent)]
    UnknownTask(#[from] task::UnknownTask),
    #[error("{path} was recorded for the task `{found}`, not `{task}`")]
    #[diagnostic(
        code(advise::session::demos_of_another_task),
        help(
            "its columns are `{found}`'s observations and actions: load it on that task (`task {found}` then `load demos {path}`), or record demonstrations for `{task}` with `load demos teacher:N`"
        )
    )]
    DemosOfAnotherTask {
        path: String,
        found: String,
        task: String,
    },
    #[error("{path} declares no task")]
    #[diagnostic(
        code(advise::session::no_tasks),
        help(
            "a task is a domain with a goal, observations' definitions, drives, success and end rules (see `operators/README.md`, Tasks); for operators alone use `operators FILE`"
        )
    )]
    NoTasksInFile { path: String },
    #[error("there is no execution yet")]
    #[diagnostic(
        code(advise::session::no_execution),
        help("run the policy first (`run goal 2 -1 0` or `run start 0`), or `load trace FILE`")
    )]
    NoExecution,
    #[error("task {task} declares no flaws, so `suggest` has nothing to look for")]
    #[diagnostic(
        code(advise::session::no_flaws),
        help(
            "a task declared in the language says what a poor run looks like with `flaw NAME when CONDITION [for SECONDS]` (see `operators/positioning.adv` and the README's Suggestions); the interception task is not declared in the language yet: select and critique its chunks yourself"
        )
    )]
    NoFlaws { task: TaskKind },
    #[error("execution {n} ({label}) has {why}, so its flaws cannot be looked for")]
    #[diagnostic(
        code(advise::session::flaws_unreadable),
        help(
            "`suggest` rebuilds the task's values from the run's poses and goal: suggest on a run of this session (`run start N`, `run goal ...`)"
        )
    )]
    FlawsUnreadable {
        n: usize,
        label: String,
        why: &'static str,
    },
    #[error("there is no suggestion to accept: {why}")]
    #[diagnostic(
        code(advise::session::no_suggestions),
        help(
            "`suggest` (or `suggest N` for execution N) lists suggestions; `accept K` applies the K-th"
        )
    )]
    NoSuggestions { why: &'static str },
    #[error("there is no suggestion {k}: the last `suggest` made {count}")]
    #[diagnostic(
        code(advise::session::no_such_suggestion),
        help("suggestions are numbered from 1 in the order `suggest` listed them")
    )]
    NoSuchSuggestion { k: usize, count: usize },
    #[error("there is no execution {n}: this task has {count}")]
    #[diagnostic(
        code(advise::session::no_such_execution),
        help(
            "executions are numbered from 0 in the order they were recorded; `history` and `show` name them"
        )
    )]
    NoSuchExecution { n: usize, count: usize },
    #[error("unknown learner `{name}`")]
    #[diagnostic(
        code(advise::session::unknown_learner),
        help(
            "the learners are `bc` (1-NN with critique weights, the paper's BC) and `lwr` (locally weighted regression, the paper's A-OPI){hint}"
        )
    )]
    UnknownLearner { name: String, hint: String },
    #[error("execution {n} has no poses: there is no path to plot")]
    #[diagnostic(
        code(advise::session::no_poses),
        help(
            "a trace loaded without `x`, `y`, `theta` columns has no path; `plot actions FILE.svg` plots its actions"
        )
    )]
    NoPoses { n: usize },
    #[error("nothing is selected")]
    #[diagnostic(
        code(advise::session::no_selection),
        help("select the points to critique or advise first: `select 40..70`")
    )]
    NoSelection,
    #[error("point {t} is outside the execution, which has {len} points")]
    #[diagnostic(
        code(advise::session::point_out_of_range),
        help("points are numbered 0..{len}")
    )]
    PointOutOfRange { t: usize, len: usize },
    #[error("the {task} task has no goal to name: its runs start from a ball's position and speed")]
    #[diagnostic(
        code(advise::session::goal_for_wrong_task),
        help("run it from its practice starts: `run start N`")
    )]
    GoalForWrongTask { task: TaskKind },
    #[error("the goal of {task} has {expected} values, and {given} were given")]
    #[diagnostic(
        code(advise::session::goal_count),
        help("its goal is {params}, in that order or by name: {example}")
    )]
    GoalCount {
        task: String,
        given: usize,
        expected: usize,
        params: String,
        example: String,
    },
    #[error("the goal of {task} has no value `{name}`")]
    #[diagnostic(code(advise::session::unknown_goal_value), help("{help}"))]
    UnknownGoalParam {
        name: String,
        task: String,
        help: String,
    },
    #[error("the goal value `{name}` is given twice")]
    #[diagnostic(
        code(advise::session::goal_value_twice),
        help("give each once, in order or by name: {params}")
    )]
    GoalParamTwice { name: String, params: String },
    #[error("the goal of {task} needs {missing} too")]
    #[diagnostic(
        code(advise::session::goal_missing),
        help("its goal is {params}, in that order or by name: {example}")
    )]
    GoalMissing {
        task: String,
        missing: String,
        params: String,
        example: String,
    },
    #[error("{name} = {value} is outside the goal range of {task}")]
    #[diagnostic(
        code(advise::session::goal_out_of_range),
        help("its goal is {params}: the ranges its rules were written for")
    )]
    GoalOutOfRange {
        task: String,
        name: String,
        value: String,
        params: String,
    },
    #[error("the goal ({goal}) is not a pose a run can reach")]
    #[diagnostic(
        code(advise::session::bad_goal),
        help(
            "x and y are metres from where the base stands, within ±{MAX_GOAL_M}; theta is radians within ±2π (±6.2832)"
        )
    )]
    BadGoal { goal: String },
    #[error("kappa must be a positive number up to {MAX_KAPPA}, not {kappa}")]
    #[diagnostic(
        code(advise::session::bad_kappa),
        help(
            "the paper's kappa is a small positive constant, e.g. 0.5 (`critique 0.5` at the prompt, `kappa=0.5` in Python)"
        )
    )]
    BadKappa { kappa: String },
    #[error("the {task} dataset is empty: there is no policy to run")]
    #[diagnostic(
        code(advise::session::empty_policy),
        help(
            "add demonstrations first: `load demos teacher:9` records nine teacher runs in the simulator, `load demos FILE` loads yours"
        )
    )]
    EmptyPolicy { task: TaskKind },
    #[error(transparent)]
    #[diagnostic(transparent)]
    JournalRead(#[from] JournalError),
    #[error("run number {number} has no successor")]
    #[diagnostic(
        code(advise::session::run_number),
        help("a session numbers its runs from 0; a journal line with this number was edited")
    )]
    RunNumber { number: u64 },
    #[error("nothing to undo")]
    #[diagnostic(code(advise::session::nothing_to_undo))]
    NothingToUndo,
    #[error("nothing to redo")]
    #[diagnostic(
        code(advise::session::nothing_to_redo),
        help("redo puts back what `undo` took, until new advice is given")
    )]
    NothingToRedo,
    #[error(transparent)]
    #[diagnostic(transparent)]
    Backend(#[from] BackendSpecError),
    #[error("cannot drive `{spec}`")]
    #[diagnostic(
        code(advise::session::backend_unavailable),
        help("the session stays on `{current}`; `backend sim` drives the simulator")
    )]
    BackendUnavailable {
        spec: String,
        current: String,
        #[source]
        #[diagnostic_source]
        error: BackendError,
    },
    /// A statement stopped (Ctrl-C, the page's Stop) after its work and before its effect:
    /// nothing changed and nothing was journalled.
    #[error("`{statement}` was interrupted; nothing was changed")]
    #[diagnostic(
        code(advise::session::interrupted),
        help("run it again to finish it; the session is as it was before it")
    )]
    Stopped { statement: String },
    /// The one failure that changes the session: what the base recorded before it failed is kept
    /// as an execution, as on a real robot it cannot be had again.
    #[error(
        "execution {index} ({label}) was interrupted after {steps} steps; what was recorded is kept{took_over}"
    )]
    #[diagnostic(
        code(advise::session::run_interrupted),
        help(
            "`show` it, and select, critique or advise it like any other; `run` again when the base is ready"
        )
    )]
    RunInterrupted {
        index: usize,
        label: String,
        steps: usize,
        /// What the teacher drove before it, as the run's reply says it (empty: nothing).
        took_over: String,
        #[source]
        #[diagnostic_source]
        error: BackendError,
    },
    #[error("the task `{task}` has no teacher to take over a run")]
    #[diagnostic(
        code(advise::session::takeover_no_teacher),
        help(
            "`takeover A..B` lets the task's own teacher drive (a declared task names one with `teacher {{ ... }}`); a person takes over a run live from the terminal's keys, the web view's pad or a ROS 2 topic (`ros2?takeover=/TOPIC`)"
        )
    )]
    TakeoverNoTeacher { task: TaskKind },
    #[error("`takeover {window}` is not a window of a run")]
    #[diagnostic(
        code(advise::session::bad_takeover),
        help(
            "the teacher drives from A to B seconds into the run: A before B, B at most {max_s} s (`takeover 2..4`)"
        )
    )]
    BadTakeover { window: String, max_s: String },
    /// A run that stopped on a value of the task that is not a number: like an interrupted
    /// one, what was recorded before it is kept as an execution.
    #[error(
        "execution {index} ({label}) stopped after {steps} steps on a value that is not a number; what was recorded is kept{took_over}"
    )]
    #[diagnostic(
        code(advise::session::run_stopped),
        help(
            "`show` it; the task's declaration needs fixing before its runs can be trusted (`advise check FILE` warns where a value may not be a number)"
        )
    )]
    RunStopped {
        index: usize,
        label: String,
        steps: usize,
        /// What the teacher drove before it (empty: nothing).
        took_over: String,
        #[source]
        #[diagnostic_source]
        reason: task::NonFinite,
    },
    #[error("`record demo` listens to a ROS 2 base; this session drives `{backend}`")]
    #[diagnostic(
        code(advise::session::record_needs_ros2),
        help(
            "connect the base with `backend ros2` (or `ros2:/NAMESPACE`) first; on any base, `teleop` records you driving it from this terminal's keys"
        )
    )]
    RecordNeedsRos2 { backend: String },
    #[error("a recorded drive cannot be a demonstration of the task {task}")]
    #[diagnostic(
        code(advise::session::record_task),
        help(
            "`task positioning` first, or a declared task whose goal is read from where a drive ends (`recorded`, and `goal X Y THETA` is positioning's); an interception demonstration needs the ball, which odometry does not see"
        )
    )]
    RecordTask { task: TaskKind },
    #[error("`for {seconds}` is not a recording time")]
    #[diagnostic(
        code(advise::session::record_time),
        help("give the longest recording in seconds, more than 0 and at most 3600: `for 120`")
    )]
    RecordTime { seconds: String },
    #[error("nothing to record: {heard} command(s) heard on `{topic}` from {ty}; {seen}")]
    #[diagnostic(
        code(advise::session::record_empty),
        help(
            "drive the base with your teleoperation while recording (geometry_msgs Twist or TwistStamped commands that reach `{topic}`; `from TOPIC` names another), and end it after some driving"
        )
    )]
    RecordEmpty {
        topic: String,
        heard: u64,
        /// The command type subscribed to, in words.
        ty: String,
        /// What discovery saw on the topic from other participants.
        seen: String,
    },
    #[error("`teleop` reads keys from a terminal; this session has none")]
    #[diagnostic(
        code(advise::session::teleop_needs_terminal),
        help(
            "run it in the REPL (`advise` or `advise repl`); a script can load demonstrations with `load demos FILE`, or record a person driving a ROS 2 base with `record demo`"
        )
    )]
    TeleopNeedsTerminal,
    #[error("the drive never moved the base: nothing to keep")]
    #[diagnostic(
        code(advise::session::teleop_empty),
        help("up/w starts driving, left/a and right/d turn; Enter ends")
    )]
    TeleopEmpty,
    #[error("recording from the ROS 2 base failed")]
    #[diagnostic(code(advise::session::record_failed))]
    RecordFailed {
        #[source]
        #[diagnostic_source]
        error: BackendError,
    },
    #[error("nothing is known as `{topic}`")]
    #[diagnostic(code(advise::session::unknown_help), help("{help}"))]
    UnknownHelp { topic: String, help: String },
    #[error("cannot read `{path}`")]
    #[diagnostic(code(advise::session::io))]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write the journal `{path}`: the session stops recording")]
    #[diagnostic(
        code(advise::journal::write),
        help(
            "check the disk and the folder's permissions; `save FILE.json` keeps the dataset, and a session started with ADVISE_HOME set to a writable folder journals there"
        )
    )]
    Journal {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    #[diagnostic(transparent)]
    Sidecar(#[from] super::sidecar::SidecarError),
    #[error("the goal ({goal}) is not a goal of {task}")]
    #[diagnostic(
        code(advise::session::bad_goal_values),
        help("a goal of {task} is one finite value for each of its goal parameters: {params}")
    )]
    BadGoalValues {
        goal: String,
        task: TaskKind,
        params: String,
    },
}
