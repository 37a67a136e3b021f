"""advise from Python: the advice operator language, the learners and the simulator.

The functions and classes here are bindings over the same Rust code the ``advise`` command line
runs; nothing is recomputed in Python.

- ``check(path_or_text)``: check operator text or a file on top of the standard operators.
- ``Operators(*files)``: the standard operators plus those of ``files``; ``apply`` runs one on
  numpy arrays.
- ``BC``, ``LWR``: the paper's learners; ``fit``, ``predict``, ``critique`` and ``why`` on numpy
  arrays (``Critique``, ``Why``, ``Provenance``: their results).
- ``gym.AdviseEnv``: the simulator as the Gymnasium environments ``advise/Positioning-v0`` and
  ``advise/Interception-v0``, registered on import when gymnasium is installed.
- ``Session(task=..., backend="sim")``: a teaching session; ``execute(statement)`` returns
  the reply as a dict.
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
    check,
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
]
