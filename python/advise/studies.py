"""The paper's studies as plain functions of a seed and parameters, returning the data
``advise experiment STUDY --seed SEED --json`` prints (the same Rust function runs them). Map
them over seeds with any engine::

    import ray, advise.studies
    run = ray.remote(advise.studies.aopi)
    results = ray.get([run.remote(seed) for seed in range(20)])
"""

from __future__ import annotations

from typing import Any

from ._advise import study


def bc(seed: int, *, revert: str | None = None, critique: str | None = None,
       teacher: str | None = None, sim_params: str | None = None) -> dict[str, Any]:
    """The Binary Critiquing study (Table 1, Figure 5) for ``seed``: ``advise experiment bc``
    (``teacher``: ``"controller"``, ``"hand"`` or ``"both"``, ``--teacher``)."""
    return study("bc", seed, revert=revert, critique=critique, teacher=teacher,
                 sim_params=sim_params)


def aopi(seed: int, *, revert: str | None = None,
         sim_params: str | None = None, practice: int | None = None) -> dict[str, Any]:
    """The A-OPI study (Figures 8, 9, 11) for ``seed``: ``advise experiment aopi``
    (``practice`` caps each arm's practice goals, ``--practice``)."""
    return study("aopi", seed, revert=revert, sim_params=sim_params, practice=practice)


__all__ = ["aopi", "bc", "study"]
