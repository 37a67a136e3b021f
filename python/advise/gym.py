"""The simulator as Gymnasium environments: ``advise/Positioning-v0`` and
``advise/Interception-v0`` (registered when ``advise`` is imported and gymnasium is installed).

The dynamics are the command line's simulator (``advise._advise.SimEnv``): the same tasks, the
same noise, the same control period. ``reset(seed=S, options={"start": I})`` starts the task's
practice start ``I`` of seed ``S`` on a simulator seeded as ``advise demo --seed S`` seeds its
``demo-I``. The reward is 1 at the end of a successful episode, else 0.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from ._advise import SimEnv


class AdviseEnv(gymnasium.Env):
    """One of advise's simulated tasks as a Gymnasium environment."""

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(self, task: str = "positioning", tasks: list[str] | None = None) -> None:
        self._sim = SimEnv(task, tasks)
        self.task = task
        lo, hi = zip(*self._sim.action_limits())
        self.action_space = spaces.Box(
            np.array(lo, dtype=np.float64), np.array(hi, dtype=np.float64), dtype=np.float64
        )
        self.observation_space = spaces.Box(
            -np.inf, np.inf, shape=(self._sim.obs_dim,), dtype=np.float64
        )

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        base = seed if seed is not None else int(self.np_random.integers(0, 2**63 - 1))
        start = int((options or {}).get("start", 0))
        obs = self._sim.reset(base, start)
        return obs, {}

    def step(self, action):
        return self._sim.step(np.asarray(action, dtype=np.float64))


def register() -> None:
    """Register ``advise/Positioning-v0`` and ``advise/Interception-v0`` (idempotent)."""
    for name, task in (("Positioning-v0", "positioning"), ("Interception-v0", "interception")):
        env_id = f"advise/{name}"
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=AdviseEnv, kwargs={"task": task})


def make_env(tasks: str | list[str], task: str) -> AdviseEnv:
    """The simulator on ``task``, declared in the task file(s) ``tasks`` (checked on top of the
    standard operators, as ``advise run --tasks FILE`` checks them; a mistake raises
    ``advise.AdviseError`` with its diagnostics), as a Gymnasium environment with the dynamics
    of ``advise run --tasks FILE --task TASK``: ``reset(seed=S, options={"start": I})`` starts
    practice goal ``I`` of seed ``S`` as ``advise demo --tasks FILE --task TASK --seed S`` does."""
    files = [tasks] if isinstance(tasks, str) else list(tasks)
    return AdviseEnv(task, files)
