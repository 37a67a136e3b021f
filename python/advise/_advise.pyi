"""Type stubs of the extension module ``advise._advise`` (crates/advise-py)."""

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
    AdviseError with every error."""

def load_demos(
    path: str, *, task: str | None = None, domain: str | None = None
) -> tuple[Array, Array, npt.NDArray[np.int64], list[str]]:
    """The demonstrations of a file (CSV, JSON, a saved dataset) as ``load demos`` reads them:
    observations, actions, each row's episode index and the episodes' names (default task
    positioning); AdviseError when the file cannot be read."""

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
    """The standard advice operators plus those of ``files`` (paths or operator text)."""

    def __init__(self, *files: str) -> None: ...
    @property
    def warnings(self) -> list[Diagnostic]: ...
    def domains(self) -> list[str]: ...
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

    def __init__(self, *, task: str | None = None, domain: str | None = None, seed: int = 0) -> None: ...
    def fit(
        self, observations: npt.ArrayLike, actions: npt.ArrayLike, episodes: Sequence[int] | None = None
    ) -> Self:
        """Derive the policy from demonstrations (rows with one episode label form an episode)."""
    def fit_file(self, path: str) -> Self:
        """Derive the policy from a demonstrations file, read as `load demos FILE` reads it."""
    def predict(self, observations: npt.ArrayLike) -> Array:
        """The action for each row of observations; the GIL is released while it computes."""
    def __len__(self) -> int: ...
    @property
    def domain(self) -> str: ...

class BC(_Learner):
    """Binary Critiquing's learner: weighted 1-NN over range-scaled observations."""

class LWR(_Learner):
    """A-OPI's learner: locally weighted regression, kernel tuned by cross-validation."""

class SimEnv:
    """One simulated episode of a built-in task, stepped from Python (see advise.gym)."""

    def __init__(self, task: str) -> None: ...
    @property
    def obs_dim(self) -> int: ...
    @property
    def period_s(self) -> float: ...
    def action_limits(self) -> list[tuple[float, float]]: ...
    def reset(self, seed: int, index: int) -> Array: ...
    def step(self, action: npt.ArrayLike) -> tuple[Array, float, bool, bool, dict[str, Any]]: ...

class Session:
    """A teaching session on a built-in task (the REPL's statements), without a journal."""

    def __init__(
        self, *, task: str = "positioning", backend: str = "sim", seed: int = 0, demos: int = 0
    ) -> None: ...
    def execute(self, statement: str) -> dict[str, Any]:
        """Run one statement; the reply as a dict with ``kind``, ``text`` and its fields."""
    def __len__(self) -> int: ...
