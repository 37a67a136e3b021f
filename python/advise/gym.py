"""The simulator as Gymnasium environments: ``advise/Positioning-v0`` and
``advise/Interception-v0`` (registered when ``advise`` is imported and gymnasium is installed).

The dynamics are the command line's simulator (``advise._advise.SimEnv``): the same tasks, the
same noise, the same control period. ``reset(seed=S, options={"start": I})`` starts the task's
practice start ``I`` of seed ``S`` on a simulator seeded as ``advise demo --seed S`` seeds its
``demo-I``.

The spaces come from the task's declarations. ``observation_space`` is each observation's
declared range (``observe NAME "UNIT" in [LO, HI]``; unbounded where a task declares none). The
observations are the task's own, not clipped: a robot far from its goal can leave a range.
``action_space`` is the declared action limits (``act NAME "UNIT" in [LO, HI]``) when they are a
box Gymnasium's checker accepts as it is (each dimension symmetric about 0 within [-1, 1], or
[0, HI] with HI at most 1: positioning's and interception's), and an action is in the task's
units. Otherwise (a declared task's ``trans in [-0.3, 0.6]``) the action space is [-1, 1] in
every dimension, mapped linearly onto the declared limits (-1 the low limit, 1 the high);
``normalize_actions=True`` or ``False`` chooses either way for any task. ``env.action_limits``
holds the declared limits and ``env.task_action(a)`` the action in the task's units.

The reward is 1 at the end of a successful episode (the task's ``success when`` holds when an
``end`` rule or its time limit ends the run), else 0; ``info`` at the end holds ``ending``,
``end_rule`` (for a declared task's ``end when`` rule, its text), ``success`` and
``position_error_m``.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from ._advise import SimEnv


def _accepted_as_is(lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether Gymnasium's checker takes the box [lo, hi] without a warning."""
    symmetric = (lo == 0) | (np.abs(lo) == np.abs(hi))
    return bool(np.all(symmetric) and np.all(lo >= -1) and np.all(hi <= 1))


class AdviseEnv(gymnasium.Env):
    """One of advise's simulated tasks as a Gymnasium environment."""

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        task: str = "positioning",
        tasks: list[str] | None = None,
        normalize_actions: bool | None = None,
    ) -> None:
        self._sim = SimEnv(task, tasks)
        self.task = task
        lo, hi = (np.array(v, dtype=np.float64) for v in zip(*self._sim.action_limits()))
        self.action_limits = (lo, hi)
        bounded = bool(np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))
                       and np.all(lo < hi) and np.all(hi - lo < 1e300))
        if normalize_actions is None:
            normalize_actions = bounded and not _accepted_as_is(lo, hi)
        self.normalize_actions = bool(normalize_actions) and bounded
        if self.normalize_actions:
            ones = np.ones(len(lo), dtype=np.float64)
            self.action_space = spaces.Box(-ones, ones, dtype=np.float64)
        else:
            self.action_space = spaces.Box(lo, hi, dtype=np.float64)
        olo, ohi = (np.array(v, dtype=np.float64) for v in zip(*self._sim.observation_limits()))
        self.observation_space = spaces.Box(olo, ohi, dtype=np.float64)

    def task_action(self, action) -> np.ndarray:
        """``action`` (in ``action_space``) in the task's units, as the simulator takes it."""
        a = np.asarray(action, dtype=np.float64)
        if not self.normalize_actions:
            return a
        lo, hi = self.action_limits
        return lo + (np.clip(a, -1.0, 1.0) + 1.0) * 0.5 * (hi - lo)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        base = seed if seed is not None else int(self.np_random.integers(0, 2**63 - 1))
        start = int((options or {}).get("start", 0))
        obs = self._sim.reset(base, start)
        return obs, {}

    def step(self, action):
        return self._sim.step(self.task_action(action))


def register() -> None:
    """Register ``advise/Positioning-v0`` and ``advise/Interception-v0`` (idempotent)."""
    for name, task in (("Positioning-v0", "positioning"), ("Interception-v0", "interception")):
        env_id = f"advise/{name}"
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=AdviseEnv, kwargs={"task": task})


def make_env(
    tasks: str | list[str], task: str, normalize_actions: bool | None = None
) -> AdviseEnv:
    """The simulator on ``task``, declared in the task file(s) ``tasks`` (checked on top of the
    standard operators, as ``advise run --tasks FILE`` checks them; a mistake raises
    ``advise.AdviseError`` with its diagnostics), as a Gymnasium environment with the dynamics
    of ``advise run --tasks FILE --task TASK``: ``reset(seed=S, options={"start": I})`` starts
    practice goal ``I`` of seed ``S`` as ``advise demo --tasks FILE --task TASK --seed S`` does.
    Its spaces come from the task's declared ranges and limits (see the module's docs)."""
    files = [tasks] if isinstance(tasks, str) else list(tasks)
    return AdviseEnv(task, files, normalize_actions)
