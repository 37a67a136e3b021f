"""advise from Python: the advice operator language, the learners and the simulator.

The functions and classes here are bindings over the same Rust code the ``advise`` command line
runs; nothing is recomputed in Python.

- ``check(path_or_text)``: check operator text or a file on top of the standard operators.
- ``Operators(*files)``: the standard operators plus those of ``files``; ``apply`` runs one on
  numpy arrays.
- ``BC``, ``LWR``: the paper's learners; ``fit``, ``predict``, ``critique`` and ``why`` on numpy
  arrays (``Critique``, ``Why``, ``Provenance``: their results).
- ``gym.AdviseEnv``: the simulator as the Gymnasium environments ``advise/Positioning-v0`` and
  ``advise/Interception-v0``, registered on import when gymnasium is installed;
  ``make_env(tasks="dock.adv", task="dock")`` for a task declared in the language.
- ``Session(task=..., backend="sim", journal=True)``: a teaching session; ``execute(statement)``
  returns the reply as a dict, ``execution(i)`` an execution as arrays; its journal is the
  CLI's (``Session.resume(path)`` restores one as ``advise resume`` does).
- ``load_lerobot(dir, task=...)``: a LeRobot v3.0 dataset's frames as numpy arrays;
  ``to_arrow(data)`` as a pyarrow table with provenance columns; ``advise_lerobot(src, out,
  episode=..., frames=(a, b), operator=..., params=...)`` writes a chunk of an episode corrected
  by an operator as a new LeRobot dataset.
- ``load_demos(path, task=...)``: a demonstrations file (CSV, JSON, a saved dataset, Parquet, a
  ROS 2 bag or CSV log) as numpy observations, actions, episode index and names, as ``load
  demos`` reads it; ``advise_demos(src, out, episode=..., frames=(a, b), operator=...,
  params=...)`` advises a chunk of one of its episodes and writes the result next to it as a
  saved dataset with provenance; ``BC.dataset()``/``LWR.dataset()``: the points with their
  provenance (``to_arrow`` makes a table of them).
- ``fmt(text_or_path)``, ``test(path_or_text)``: ``advise fmt`` and ``advise test`` as
  functions (the formatted text; a ``TestResult`` per doc example).
- ``study(name, seed, ...)`` and ``studies.bc``/``studies.aopi``: the paper's studies as
  functions of a seed, returning ``advise experiment --json``'s data.
- ``AdviseError``: every refusal, with ``code`` (``advise::area::name``) and ``diagnostics``.
"""

from ._advise import (
    BC,
    LWR,
    AdviseError,
    Critique,
    Diagnostic,
    Operators,
    Provenance,
    Session,
    SimEnv,
    Span,
    Why,
    TestResult,
    check,
    fmt,
    load_demos,
    test,
)
from ._advise import advise_demos, advise_lerobot, load_lerobot
from .lerobot import to_arrow
from ._advise import study
from . import studies

try:  # The Gymnasium environments, where gymnasium is installed.
    from . import gym as _gym
except ImportError:  # pragma: no cover - gymnasium is optional
    _gym = None

    def make_env(tasks, task):  # type: ignore[no-redef]
        """A declared task as a Gymnasium environment: needs gymnasium (``pip install
        'advise[gym]'``)."""
        raise ImportError("advise.make_env needs gymnasium: pip install 'advise[gym]'")
else:
    _gym.register()
    make_env = _gym.make_env

__all__ = [
    "AdviseError",
    "BC",
    "Critique",
    "Diagnostic",
    "LWR",
    "Operators",
    "Provenance",
    "Session",
    "SimEnv",
    "Span",
    "Why",
    "check",
    "advise_demos",
    "advise_lerobot",
    "load_lerobot",
    "to_arrow",
    "TestResult",
    "fmt",
    "load_demos",
    "study",
    "studies",
    "make_env",
    "test",
]
