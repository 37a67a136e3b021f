"""The simulator as Gymnasium environments: registered on import, passing gymnasium's own
checker, seeded (the same seed gives the same episode)."""

import os
import shutil

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import advise


@pytest.mark.parametrize("env_id", ["advise/Positioning-v0", "advise/Interception-v0"])
def test_env_passes_gymnasiums_checker(env_id):
    env = gymnasium.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", ["advise/Positioning-v0", "advise/Interception-v0"])
def test_same_seed_same_episode(env_id):
    def episode(seed):
        env = gymnasium.make(env_id)
        obs, _ = env.reset(seed=seed, options={"start": 3})
        out = [obs]
        for _ in range(50):
            obs, reward, terminated, truncated, info = env.step(np.array([0.5, 0.2]))
            out.append(obs)
            if terminated or truncated:
                break
        return np.array(out)

    a, b, c = episode(7), episode(7), episode(8)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_bad_actions_and_tasks_raise_coded_errors():
    env = advise.SimEnv("positioning")
    with pytest.raises(advise.AdviseError) as e:
        env.step(np.zeros(2))
    assert e.value.code == "advise::py::not_reset"
    env.reset(0, 0)
    with pytest.raises(advise.AdviseError) as e:
        env.step(np.array([np.nan, 0.0]))
    assert e.value.code == "advise::py::not_finite"
    with pytest.raises(advise.AdviseError) as e:
        env.step(np.zeros(3))
    assert e.value.code == "advise::py::shape"
    with pytest.raises(advise.AdviseError) as e:
        advise.SimEnv("docking")
    assert e.value.code == "advise::task::unknown_task"


@pytest.mark.parametrize("task, env_id", [("interception", "advise/Interception-v0")])
def test_replaying_a_cli_demonstration_gives_its_observations_to_the_bit(tmp_path, task, env_id):
    # `advise demo --seed 5` records demo-i from practice start i on a simulator seeded for
    # episode i; interception keeps every control step, so replaying its actions through the
    # environment reset the same way must reproduce each observation exactly.
    import os
    import subprocess

    out = tmp_path / "demos.csv"
    subprocess.run(
        [os.environ["ADVISE_BIN"], "demo", "--task", task, "--count", "2", "--seed", "5",
         "--out", str(out)],
        check=True, capture_output=True, timeout=120,
    )
    rows = np.genfromtxt(out, delimiter=",", skip_header=1, dtype=str)
    env = gymnasium.make(env_id).unwrapped
    od = env.observation_space.shape[0]
    ad = env.action_space.shape[0]
    for i, name in enumerate(["demo-0", "demo-1"]):
        ep = rows[rows[:, 0] == name]
        z = ep[:, 2 : 2 + od].astype(float)
        a = ep[:, 2 + od : 2 + od + ad].astype(float)
        obs, _ = env.reset(seed=5, options={"start": i})
        assert np.array_equal(obs, z[0])
        for k in range(len(z) - 1):
            obs, _, terminated, truncated, _ = env.step(a[k])
            assert np.array_equal(obs, z[k + 1]), (name, k)
            assert not (terminated or truncated)


STANDOFF = "examples/tasks/standoff.adv"


def test_a_declared_task_is_an_environment_that_passes_the_checker():
    env = advise.make_env(tasks=STANDOFF, task="standoff")
    check_env(env, skip_render_check=True)
    obs, _ = env.reset(seed=3, options={"start": 1})
    again, _ = advise.make_env(tasks=[STANDOFF], task="standoff").reset(
        seed=3, options={"start": 1})
    assert np.array_equal(obs, again)


def test_a_declared_task_starts_as_the_command_lines_demonstration(tmp_path):
    # `advise demo --tasks FILE --task T --seed 5` records demo-i from practice goal i on a
    # simulator seeded for episode i: its first observation is the environment's after reset.
    import os
    import subprocess

    out = tmp_path / "demos.csv"
    subprocess.run(
        [os.environ["ADVISE_BIN"], "demo", "--tasks", STANDOFF, "--task", "standoff",
         "--count", "2", "--seed", "5", "--out", str(out)],
        check=True, capture_output=True, timeout=120,
    )
    rows = np.genfromtxt(out, delimiter=",", skip_header=1, dtype=str)
    env = advise.make_env(tasks=STANDOFF, task="standoff")
    od = env.observation_space.shape[0]
    for i, name in enumerate(["demo-0", "demo-1"]):
        ep = rows[rows[:, 0] == name]
        obs, _ = env.reset(seed=5, options={"start": i})
        assert np.array_equal(obs, ep[0, 2 : 2 + od].astype(float)), name


def test_a_bad_task_file_or_name_raises_its_diagnostics(tmp_path):
    bad = tmp_path / "bad.adv"
    bad.write_text("domain dock {\n  observe d \"m\" = nosuch\n}\n")
    with pytest.raises(advise.AdviseError) as e:
        advise.make_env(tasks=str(bad), task="dock")
    assert e.value.code.startswith("advise::"), e.value.code
    with pytest.raises(advise.AdviseError) as e:
        advise.make_env(tasks=STANDOFF, task="standof")
    assert "standoff" in str(e.value)


DOCK = os.path.join(os.path.dirname(__file__), "..", "common", "dock_io.adv")


def _checked_without_warnings(env):
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    assert [str(w.message) for w in caught] == []


def test_spaces_are_the_declared_ranges_and_the_checker_says_nothing(tmp_path):
    # Issue 49: a declared task's observation ranges and action limits, not Box(-inf, inf).
    dock = tmp_path / "dock.adv"
    shutil.copy(DOCK, dock)
    env = advise.make_env(tasks=str(dock), task="dock")
    assert np.array_equal(env.observation_space.low, [0, -np.pi, 0, -np.pi, -0.1])
    assert np.array_equal(env.observation_space.high, [10, np.pi, 10, np.pi, 0.1])
    # trans in [-0.3, 0.6] is not a box Gymnasium's checker accepts: actions are normalized,
    # -1 and 1 the declared limits.
    assert env.normalize_actions
    assert np.array_equal(env.action_space.low, [-1, -1])
    assert np.array_equal(env.action_space.high, [1, 1])
    assert np.array_equal(env.action_limits[0], [-0.3, -1])
    assert np.array_equal(env.action_limits[1], [0.6, 1])
    assert np.allclose(env.task_action([-1, 0]), [-0.3, 0])
    assert np.allclose(env.task_action([1, 1]), [0.6, 1])
    _checked_without_warnings(env)
    # Positioning's limits are accepted as they are: actions in the task's units.
    pos = gymnasium.make("advise/Positioning-v0").unwrapped
    assert not pos.normalize_actions
    assert np.array_equal(pos.action_space.low, [-1, -1])
    assert np.array_equal(pos.observation_space.high, [100, np.pi, np.pi])
    _checked_without_warnings(pos)
    # Either way on request.
    raw = advise.make_env(tasks=str(dock), task="dock", normalize_actions=False)
    assert np.array_equal(raw.action_space.low, [-0.3, -1])


def test_a_successful_docking_ends_with_reward_one_and_names_its_rule(tmp_path):
    dock = tmp_path / "dock.adv"
    shutil.copy(DOCK, dock)
    env = advise.make_env(tasks=str(dock), task="dock", normalize_actions=False)
    env.reset(seed=1, options={"start": 0})
    # Standing still ends the run by the resting rule, which names itself.
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(np.zeros(2))
        if terminated or truncated:
            break
    assert terminated and not info["success"] and reward == 0.0
    assert info["end_rule"].startswith("end when abs(trans) < 0.01"), info
