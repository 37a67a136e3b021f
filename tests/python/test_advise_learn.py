"""advise.BC and advise.LWR against the command line: a session's executions record the action
its policy chose at each observation, so the same demonstrations fitted from Python must predict
those actions to the bit (clamped to the domain's limits, as a run clamps them)."""

import numpy as np
import pytest

import advise

SCRIPT = """load demos demos.csv
run goal 2 -1 0.5
learner bc
run goal 1.5 1 0
save out.json
"""


# What `advise run` printed for the module's session.
STDOUT = {}


@pytest.fixture(scope="module")
def session(scripted_session):
    d, out, _, runs = scripted_session(SCRIPT, "session")
    STDOUT["session"] = out
    return d, runs


def clamp(a):
    # The positioning domain's action limits (trans, rot), as the run clamps the policy's action.
    return np.clip(a, -1.0, 1.0)


def test_lwr_predicts_the_session_actions_to_the_bit(session):
    d, runs = session
    z, a = runs[0]  # the first run used the positioning task's default learner, LWR
    lwr = advise.LWR(task="positioning").fit_file(str(d / "demos.csv"))
    assert len(lwr) > 0
    assert np.array_equal(clamp(lwr.predict(z)), a)


def test_lwr_reports_its_kernel_and_a_runs_coverage_as_the_session_does(session):
    import re

    d, runs = session
    z, _ = runs[0]
    lwr = advise.LWR(task="positioning").fit_file(str(d / "demos.csv"))
    k = lwr.kernel()
    # Four demonstrations: four held-out sources, one fold each (issue 48's tuning).
    assert (k["folds"], k["sources"]) == (4, 4)
    assert k["bandwidth"] > 0 and k["query_bandwidth"] == k["bandwidth"]
    assert len(k["scales"]) == 3 and 0 <= k["held_out_coverage"] <= 1
    assert k["held_out_covered"] <= k["held_out_scored"]
    # The run's reply says how many of its steps found data in the kernel: the same count.
    said = re.search(r"LWR: (\d+) of (\d+) steps", STDOUT["session"])
    c = lwr.coverage(z)
    assert (c["covered"], c["steps"]) == (int(said[1]), int(said[2]))
    assert advise.BC(task="positioning").fit_file(str(d / "demos.csv")).coverage(z) is None
    assert advise.BC(task="positioning").fit_file(str(d / "demos.csv")).kernel() is None


def test_bc_predicts_the_session_actions_to_the_bit(session):
    d, runs = session
    z, a = runs[1]  # after `learner bc`
    bc = advise.BC(task="positioning").fit_file(str(d / "demos.csv"))
    assert np.array_equal(bc.predict(z), a)


def test_fit_from_arrays_equals_fit_from_the_file(session):
    d, runs = session
    rows = np.genfromtxt(d / "demos.csv", delimiter=",", skip_header=1, dtype=str)
    labels = np.unique(rows[:, 0], return_inverse=True)[1]
    values = rows[:, 2:7].astype(float)
    z, a = values[:, :3], values[:, 3:5]
    for cls in (advise.BC, advise.LWR):
        from_arrays = cls(task="positioning").fit(z, a, episodes=labels)
        from_file = cls(task="positioning").fit_file(str(d / "demos.csv"))
        q = runs[0][0]
        assert np.array_equal(from_arrays.predict(q), from_file.predict(q))


def test_bad_inputs_raise_coded_errors(session):
    d, runs = session
    bc = advise.BC(task="positioning")
    with pytest.raises(advise.AdviseError) as e:
        bc.predict(np.zeros((1, 3)))
    assert e.value.code == "advise::py::not_fitted"
    bc.fit_file(str(d / "demos.csv"))
    with pytest.raises(advise.AdviseError) as e:
        bc.predict(np.zeros((2, 4)))
    assert e.value.code == "advise::py::shape"
    with pytest.raises(advise.AdviseError) as e:
        bc.predict(np.array([[np.nan, 0.0, 0.0]]))
    assert e.value.code == "advise::py::not_finite"
    with pytest.raises(advise.AdviseError) as e:
        advise.LWR(task="docking")
    assert e.value.code == "advise::task::unknown_task"
    with pytest.raises(advise.AdviseError) as e:
        advise.BC(task="positioning").fit_file(str(d / "missing.csv"))
    assert e.value.code.startswith("advise::file::")


@pytest.mark.parametrize("cls", [advise.BC, advise.LWR])
def test_predict_lets_other_python_threads_run(session, cls):
    # A long batched predict in one thread while this one notes each time it gets to run. Were
    # the GIL held through predict, this thread could not run between its start and its end.
    import threading
    import time

    d, _ = session
    learner = cls(task="positioning").fit_file(str(d / "demos.csv"))
    z, _, _, _ = advise.load_demos(str(d / "demos.csv"))
    started = time.perf_counter()
    learner.predict(np.resize(z, (2000, z.shape[1])))
    per_row = (time.perf_counter() - started) / 2000
    # About half a second of work, at most 4 million rows.
    q = np.resize(z, (int(min(max(0.5 / per_row, 2000), 4e6)), z.shape[1]))
    span = {}

    def work():
        span["start"] = time.perf_counter()
        learner.predict(q)
        span["end"] = time.perf_counter()

    ticks = []
    worker = threading.Thread(target=work)
    worker.start()
    while worker.is_alive() and len(ticks) < 50_000_000:
        ticks.append(time.perf_counter())
    worker.join(timeout=120)
    took = span["end"] - span["start"]
    assert took > 0.1, took
    # The longest stretch of predict during which this thread did not run: a few switch
    # intervals at most when the GIL is free, all of predict but its first moments when held.
    inside = [span["start"]] + [t for t in ticks if span["start"] < t < span["end"]] + [span["end"]]
    longest = max(b - a for a, b in zip(inside, inside[1:]))
    assert longest < 0.5 * took, (longest, took, len(inside))
