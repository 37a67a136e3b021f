"""advise from Python: the advice operator language, the learners and the simulator.

The functions and classes here are bindings over the same Rust code the ``advise`` command line
runs; nothing is recomputed in Python.

- ``check(path_or_text)``: check operator text or a file on top of the standard operators.
- ``Operators(*files)``: the standard operators plus those of ``files``; ``apply`` runs one on
  numpy arrays.
- ``BC``, ``LWR``: the paper's learners; ``fit`` and ``predict`` on numpy arrays.
- ``AdviseError``: every refusal, with ``code`` (``advise::area::name``) and ``diagnostics``.
"""

from ._advise import (
    BC,
    LWR,
    AdviseError,
    Diagnostic,
    Operators,
    Span,
    check,
)

__all__ = [
    "AdviseError",
    "BC",
    "Diagnostic",
    "LWR",
    "Operators",
    "Span",
    "check",
]
