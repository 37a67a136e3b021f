"""Type stubs of the extension module ``advise._advise`` (crates/advise-py)."""

import os
from typing import Any, Mapping, Sequence

from typing_extensions import Self

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]

class AdviseError(Exception):
    """A refusal of advise: ``code`` is the first diagnostic's ``advise::`` code."""

    code: str
    diagnostics: list[Diagnostic]

class Span:
    """Where a diagnostic points: source name, 1-based line and column, byte range."""

    @property
    def file(self) -> str: ...
    @property
    def line(self) -> int: ...
    @property
    def column(self) -> int: ...
    @property
    def start(self) -> int: ...
    @property
    def end(self) -> int: ...

class Diagnostic:
    """One diagnostic: code, message, span, help, severity and the text the CLI prints."""

    @property
    def code(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def span(self) -> Span | None: ...
    @property
    def help(self) -> str | None: ...
    @property
    def severity(self) -> str: ...
    @property
    def rendered(self) -> str: ...

def check(path_or_text: str) -> list[Diagnostic]:
    """Check an operator file or text on top of the standard operators; the warnings, or
    AdviseError with every error. A one-line string ending in ``.adv`` or holding a path
    separator (and no ``{`` or ``=``) is a path: no such file is ``advise::py::no_such_file``."""

def load_demos(
    path: str,
    *,
    task: str | None = None,
    domain: str | None = None,
    tasks: str | os.PathLike[str] | Sequence[str | os.PathLike[str]] | None = None,
    cmd_topic: str | None = None,
    odom_topic: str | None = None,
    keep_idle: bool = False,
) -> tuple[Array, Array, npt.NDArray[np.int64], list[str]]:
    """The demonstrations of a file as ``load demos`` reads them: CSV, JSON, a saved dataset,
    Parquet, or a ROS 2 bag (rosbag2 folder or ``.mcap``) or CSV log of a base's drive, made into
    demonstrations as ``advise import`` makes them (``cmd_topic``/``odom_topic``: a bag's topics;
    idle points trimmed unless ``keep_idle``). Returns observations, actions, each row's episode
    index and the episodes' names (default task positioning; ``tasks``: files declaring
    ``task``); AdviseError when the file cannot be read."""

def fmt(text_or_path: str) -> str:
    """The canonical layout of an operator file or text, as ``advise fmt`` writes it (the file
    is not changed); AdviseError when it does not parse."""

class TestResult:
    """One doc example run by ``test``: operator ``domain/name``, the example line, where it is,
    whether it held, and why not (``message``, ``diagnostic``)."""

    @property
    def name(self) -> str: ...
    @property
    def example(self) -> str: ...
    @property
    def file(self) -> str: ...
    @property
    def line(self) -> int: ...
    @property
    def passed(self) -> bool: ...
    @property
    def message(self) -> str | None: ...
    @property
    def diagnostic(self) -> Diagnostic | None: ...
    def __bool__(self) -> bool: ...

def test(path_or_text: str | None = None) -> list[TestResult]:
    """Run the doc examples of an operator file or text (checked on top of the standard
    operators), or of the standard operators, as ``advise test`` does."""

class Operators:
    """The standard advice operators plus those of ``tasks`` (task files) and ``files`` (paths or
    operator text), each declared task with the standard operators by role (``advise check
    --tasks``)."""

    def __init__(
        self, *files: str, tasks: str | os.PathLike[str] | Sequence[str | os.PathLike[str]] | None = None
    ) -> None: ...
    @property
    def warnings(self) -> list[Diagnostic]: ...
    def domains(self) -> list[str]: ...
    def tasks(self) -> list[str]: ...
    def names(self, domain: str) -> list[str]: ...
    def apply(
        self,
        name: str,
        args: Mapping[str, float | int | bool],
        observations: npt.ArrayLike,
        actions: npt.ArrayLike,
        *,
        domain: str | None = None,
        task: str | None = None,
        chunk: tuple[int, int] | None = None,
        times: npt.ArrayLike | None = None,
    ) -> tuple[Array, Array, npt.NDArray[np.bool_]]:
        """The synthesized observations and actions, and the mask of chunk points skipped."""

class _Learner:
    """What BC and LWR share (in these stubs only: the runtime classes are separate)."""

    def __init__(
        self,
        *,
        task: str | None = None,
        domain: str | None = None,
        tasks: str | os.PathLike[str] | Sequence[str | os.PathLike[str]] | None = None,
        seed: int = 0,
        k: int | None = None,
    ) -> None:
        """``task`` (built in, or declared in ``tasks`` files) or ``domain``; ``k`` (LWR only): its
        kernel limited to the k nearest points."""
    def fit(
        self, observations: npt.ArrayLike, actions: npt.ArrayLike, episodes: Sequence[int] | None = None
    ) -> Self:
        """Derive the policy from demonstrations (rows with one episode label form an episode)."""
    def fit_file(self, path: str) -> Self:
        """Derive the policy from a demonstrations file, read as `load demos FILE` reads it."""
    def predict(self, observations: npt.ArrayLike) -> Array:
        """The action for each row of observations; the GIL is released while it computes."""
    def critique(
        self,
        observations: npt.ArrayLike,
        *,
        chunk: tuple[int, int] | None = None,
        kappa: float = 1.0,
        rule: str = "paper",
        actions: npt.ArrayLike | None = None,
    ) -> Critique:
        """The REPL's ``critique KAPPA`` on ``chunk`` of a trace of ``observations``: the data
        points that supported those steps get their weight raised; the trace is recorded."""
    def why(self, observation: npt.ArrayLike) -> Why:
        """The REPL's ``why`` at one observation: BC's nearest point, LWR's neighbourhood."""
    def weights(self) -> Array:
        """Every data point's weight m (the paper's rule), in dataset order."""
    def dataset(self) -> dict[str, Any]:
        """The data points with their provenance: ``observations``, ``actions``, ``weights``,
        ``source`` (``demonstration``/``advice``), ``source_id``, ``index``,
        ``execution_index`` (numpy arrays, dataset order), ``demonstrations``, ``advice``,
        ``domain``, ``observation_names``, ``action_names``."""
    def kernel(self) -> dict[str, Any] | None:
        """LWR's kernel as its last tuning chose it: ``bandwidth``, ``query_bandwidth``,
        ``scales``, ``folds``, ``sources``, ``loss``, ``standard_error``, ``held_out_scored``,
        ``held_out_covered``, ``held_out_coverage``, ``mean_neighbours``; None before LWR was
        tuned (a BC learner)."""
    def coverage(self, observations: npt.ArrayLike) -> dict[str, Any] | None:
        """How many rows of ``observations`` find data in LWR's kernel: ``steps``, ``covered``,
        ``share``; None for a BC learner."""
    def __len__(self) -> int: ...
    @property
    def domain(self) -> str: ...

class Provenance:
    """Where a data point came from: ``kind`` ``demonstration`` (point ``index`` of demonstration
    ``id`` named ``name``) or ``advice`` (synthesized point ``index`` of advice ``id``, from
    execution point ``source``)."""

    @property
    def kind(self) -> str: ...
    @property
    def id(self) -> int: ...
    @property
    def name(self) -> str | None: ...
    @property
    def index(self) -> int: ...
    @property
    def source(self) -> int | None: ...

class Critique:
    """What a critique did: per increment the dataset point raised, by how much, its weight
    after; ``summary`` is the REPL's reply."""

    @property
    def chunk(self) -> tuple[int, int]: ...
    @property
    def kappa(self) -> float: ...
    @property
    def rule(self) -> str: ...
    @property
    def summary(self) -> str: ...
    @property
    def provenance(self) -> list[Provenance]: ...
    @property
    def points(self) -> npt.NDArray[np.int64]: ...
    @property
    def increments(self) -> Array: ...
    @property
    def weights(self) -> Array: ...

class Why:
    """Why a learner acts as it does at one observation (the REPL's ``why``)."""

    @property
    def point(self) -> int | None: ...
    @property
    def distance(self) -> float | None: ...
    @property
    def m(self) -> float | None: ...
    @property
    def weighted(self) -> float | None: ...
    @property
    def bc_action(self) -> list[float] | None: ...
    @property
    def provenance(self) -> Provenance | None: ...
    @property
    def lwr_neighbours(self) -> int: ...
    @property
    def lwr_total_weight(self) -> float: ...
    @property
    def lwr_action(self) -> list[float]: ...
    @property
    def lwr_tuned(self) -> bool: ...
    @property
    def action(self) -> list[float]: ...
    @property
    def text(self) -> str: ...

class BC(_Learner):
    """Binary Critiquing's learner: weighted 1-NN over range-scaled observations."""

class LWR(_Learner):
    """A-OPI's learner: locally weighted regression, kernel tuned by cross-validation."""

class SimEnv:
    """One simulated episode of a task, stepped from Python (see advise.gym): a built-in one, or
    one declared in the task files ``tasks``."""

    def __init__(self, task: str, tasks: list[str] | None = None) -> None: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def period_s(self) -> float: ...
    def action_limits(self) -> list[tuple[float, float]]: ...
    def observation_limits(self) -> list[tuple[float, float]]: ...
    def reset(self, seed: int, index: int) -> Array: ...
    def step(self, action: npt.ArrayLike) -> tuple[Array, float, bool, bool, dict[str, Any]]: ...

class Session:
    """A teaching session (the REPL's statements) on a built-in task or one declared in ``tasks``
    files, as ``advise --tasks FILE --task NAME --demos N`` starts one; journalled as the CLI
    journals when ``journal`` says so. Any thread may use it, one statement at a time (the GIL
    is released while one runs; another thread's call meanwhile raises ``advise::py::busy``)."""

    def __init__(
        self,
        *,
        task: str = "positioning",
        tasks: str | Sequence[str] | None = None,
        backend: str = "sim",
        seed: int = 0,
        demos: int = 0,
        journal: bool | str | os.PathLike[str] | None = None,
    ) -> None:
        """``journal``: None (or False) keeps none, True journals where ``advise resume`` looks
        ($ADVISE_HOME, else ~/.advise), a folder journals there."""
    @staticmethod
    def resume(
        path: str | os.PathLike[str] | None = None,
        journal_dir: str | os.PathLike[str] | None = None,
    ) -> Session:
        """Restore a journal as ``advise resume PATH`` does: nothing re-run, no robot connected
        or driven; the newest journal of ``journal_dir`` without ``path``. What the restore said
        is ``resumed``."""
    def execute(self, statement: str) -> dict[str, Any]:
        """Run one statement; the reply as a dict with ``kind``, ``text`` and its fields."""
    def suggest(
        self, execution: int | None = None, budget_s: float | None = None
    ) -> dict[str, Any]:
        """``suggest [N]`` as data: flawed chunks, candidate advice ranked by a re-run."""
    def take_over(self, speed: float, turn: float) -> None:
        """Take over the robot's run another thread is executing: fractions of the base's
        limits (-1 to 1), given again at least every 0.3 s; the window is kept as a takeover."""
    def hand_back(self) -> None:
        """Let go of ``take_over``: the learner drives from the run's next step."""
    @property
    def journal_path(self) -> str | None:
        """The journal this session writes, or None."""
    @property
    def resumed(self) -> dict[str, Any] | None:
        """For a resumed session: ``path``, ``entries``, ``notes`` (list[str]), ``stopped``
        (Diagnostic | None) and ``text`` (the line ``advise resume`` prints)."""
    @property
    def status(self) -> str:
        """The one-line summary the REPL's banner prints."""
    @property
    def executions(self) -> int:
        """How many executions the current task holds."""
    def execution(self, index: int) -> dict[str, Any]:
        """Execution ``index`` (negative from the end) as arrays: ``observations``, ``actions``,
        ``t``, ``pose``, ``true_pose``, ``ball``, ``support`` (list[Provenance | None]),
        ``support_points`` (int64, -1 for none), ``outcome``, ``label``, ``goal``,
        ``goal_values``, ``flagged``, ``advised``, ``teacher`` (the windows a takeover drove),
        ``observation_names``, ``action_names``."""
    def close(self) -> None:
        """End the session, closing and unlocking its journal."""
    def __enter__(self) -> Self: ...
    def __exit__(self, _kind: object, _value: object, _traceback: object) -> bool: ...
    def dataset(self) -> dict[str, Any]:
        """The current task's data points with their provenance (as ``BC.dataset()``)."""
    def __len__(self) -> int: ...

def load_lerobot(
    path: str, task: str = "positioning", *, by_position: bool = False, tasks: Sequence[str] = ()
) -> dict[str, Any]:
    """A LeRobot v3.0 dataset's frames as numpy arrays: ``observations``, ``actions``,
    ``episode_index``, ``frame_index``, ``timestamp``; and ``fps``, ``domain``,
    ``observation_names``, ``action_names``, ``mapping``, ``path``."""
    ...

def advise_demos(
    src: str,
    out: str,
    *,
    episode: int | str,
    frames: tuple[int, int],
    operator: str,
    params: Mapping[str, float | bool],
    task: str = "positioning",
    tasks: str | os.PathLike[str] | Sequence[str | os.PathLike[str]] | None = None,
    operators: Sequence[str] = (),
    cmd_topic: str | None = None,
    odom_topic: str | None = None,
) -> dict[str, Any]:
    """Apply ``operator`` to ``frames`` of ``episode`` (index or name) of any demonstrations
    file ``load_demos`` reads, and write it next to the original as a saved dataset ``out``
    (``.json`` with provenance; ``load demos``/``open`` read it): the file's episodes as
    demonstrations, the advised episode as the execution, the synthesized points as the advice.
    Returns ``path``, ``episode``, ``demonstrations``, ``synthesized``, ``skipped``,
    ``invocation`` and the corrected episode (``observations``, ``actions``, ``source``)."""
    ...

def advise_lerobot(
    src: str,
    out: str,
    *,
    episode: int,
    frames: tuple[int, int],
    operator: str,
    params: Mapping[str, float | bool],
    task: str = "positioning",
    operators: Sequence[str] = (),
    by_position: bool = False,
    fps: int | None = None,
    tasks: Sequence[str] = (),
) -> dict[str, Any]:
    """Apply ``operator`` to ``frames`` of ``episode`` of the LeRobot dataset ``src`` and write
    the corrected episode as a new LeRobot v3.0 dataset in ``out``, with its provenance."""
    ...


def study(
    study: str,
    seed: int,
    *,
    revert: str | None = None,
    critique: str | None = None,
    teacher: str | None = None,
    sim_params: str | None = None,
    practice: int | None = None,
) -> dict[str, Any]:
    """Run one seed of ``study`` (``"bc"`` or ``"aopi"``) on the simulator: the data
    ``advise experiment STUDY --seed SEED --json`` prints. Runs without the GIL."""
    ...
