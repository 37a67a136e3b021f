"""The simulator as Gymnasium environments: registered on import, passing gymnasium's own
checker, seeded (the same seed gives the same episode)."""

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
    assert e.value.code == "advise::py::unknown_task"
