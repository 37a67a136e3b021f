"""advise from Python: the advice operator language, the learners and the simulator.

The functions and classes here are bindings over the same Rust code the ``advise`` command line
runs; nothing is recomputed in Python.

- ``check(path_or_text)``: check operator text or a file on top of the standard operators.
- ``Operators(*files)``: the standard operators plus those of ``files``; ``apply`` runs one on
  numpy arrays.
- ``BC``, ``LWR``: the paper's learners; ``fit`` and ``predict`` on numpy arrays.
- ``gym.AdviseEnv``: the simulator as the Gymnasium environments ``advise/Positioning-v0`` and
  ``advise/Interception-v0``, registered on import when gymnasium is installed.
- ``Session(task=..., backend="sim")``: a teaching session; ``execute(statement)`` returns
  the reply as a dict.
- ``load_demos(path, task=...)``: a demonstrations file (CSV, JSON, a saved dataset) as numpy
  observations, actions, episode index and names, as ``load demos`` reads it.
- ``fmt(text_or_path)``, ``test(path_or_text)``: ``advise fmt`` and ``advise test`` as
  functions (the formatted text; a ``TestResult`` per doc example).
- ``AdviseError``: every refusal, with ``code`` (``advise::area::name``) and ``diagnostics``.
"""

from ._advise import (
    BC,
    LWR,
    AdviseError,
    Diagnostic,
    Operators,
    Session,
    SimEnv,
    Span,
    TestResult,
    check,
    fmt,
    load_demos,
    test,
)

try:  # The Gymnasium environments, where gymnasium is installed.
    from . import gym as _gym
except ImportError:  # pragma: no cover - gymnasium is optional
    _gym = None
else:
    _gym.register()

__all__ = [
    "AdviseError",
    "BC",
    "Diagnostic",
    "LWR",
    "Operators",
    "Session",
    "SimEnv",
    "Span",
    "TestResult",
    "check",
    "fmt",
    "load_demos",
    "test",
]
