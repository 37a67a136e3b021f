"""A lab's own task from Python (issue 49): a docking task declared in a file kept in a folder of
its own, outside the repository, taken by the learners, the operators, ``load_demos`` and
``advise_demos`` as ``advise.Session`` and the command line take it (``tasks=``/``task=``), with
the standard operators by role; one resolver (and one code) for an unknown task everywhere."""

import os
import shutil
import subprocess

import numpy as np
import pytest

import advise

ADVISE = os.environ["ADVISE_BIN"]
DOCK = os.path.join(os.path.dirname(__file__), "dock.adv")


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A lab's folder (not the repository): ``dock.adv`` and four teacher demonstrations of it
    recorded by ``advise demo`` as ``demos.csv``. The tests run there."""
    d = tmp_path_factory.mktemp("lab")
    shutil.copy(DOCK, d / "dock.adv")
    subprocess.run(
        [ADVISE, "demo", "--tasks", "dock.adv", "--task", "dock", "--count", "4",
         "--out", "demos.csv"],
        cwd=d, check=True, capture_output=True, timeout=120,
    )
    return d


@pytest.fixture
def in_lab(lab, monkeypatch):
    monkeypatch.chdir(lab)
    return lab


def error_of(call):
    with pytest.raises(advise.AdviseError) as e:
        call()
    return e.value.diagnostics[0]


def test_the_learners_take_a_declared_task(in_lab):
    z, a, episodes, names = advise.load_demos("demos.csv", task="dock", tasks="dock.adv")
    assert z.shape[1] == 5 and a.shape[1] == 2 and len(names) == 4
    for cls in (advise.BC, advise.LWR):
        # `tasks=` as Session takes it: a path, a pathlib.Path, or a list of them.
        for tasks in ("dock.adv", in_lab / "dock.adv", ["dock.adv"]):
            learner = cls(task="dock", tasks=tasks)
            assert learner.domain == "dock"
        from_file = cls(task="dock", tasks="dock.adv").fit_file("demos.csv")
        from_arrays = cls(task="dock", tasks="dock.adv").fit(z, a, episodes)
        assert len(from_file) == len(z)
        np.testing.assert_array_equal(from_file.predict(z[:50]), from_arrays.predict(z[:50]))
    # A domain the task file declares, named as a domain.
    assert advise.BC(domain="dock", tasks="dock.adv").domain == "dock"


def test_the_standard_operators_by_role_reach_a_declared_task(in_lab):
    for ops in (advise.Operators("dock.adv"), advise.Operators(tasks="dock.adv")):
        names = ops.names("dock")
        # Positioning's action-side operators, as `advise check --tasks dock.adv` counts them.
        for name in ("slow_down", "speed_up", "stop", "turn_tighter", "brake_straight"):
            assert name in names, (name, names)
        # Observation-side ones name positioning's observations: they do not carry over.
        assert "start_turning_earlier" not in names
        assert ops.tasks() == ["positioning", "interception", "dock"]
    z, a, _, _ = advise.load_demos("demos.csv", task="dock", tasks="dock.adv")
    ops = advise.Operators(tasks="dock.adv")
    z2, a2, skipped = ops.apply("slow_down", {"rate": 0.5}, z[:20], a[:20], task="dock")
    moving = ~skipped
    np.testing.assert_allclose(a2, a[:20][moving] * 0.5)
    np.testing.assert_array_equal(z2, z[:20][moving])
    # The CLI counts the same operators for the task.
    out = subprocess.run([ADVISE, "check", "--tasks", "dock.adv"], cwd=in_lab,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr


def test_advice_on_a_declared_tasks_demonstrations(in_lab):
    r = advise.advise_demos("demos.csv", "advised.json", episode=0, frames=(5, 25),
                            operator="slow_down", params={"rate": 0.5},
                            task="dock", tasks="dock.adv")
    assert r["synthesized"] + r["skipped"] == 20
    assert r["invocation"].startswith("slow_down(")
    z, _, _, _ = advise.load_demos("advised.json", task="dock", tasks=["dock.adv"])
    assert z.shape[1] == 5


def test_an_unknown_task_is_one_diagnostic_everywhere(in_lab):
    # A misspelling, from every front end: the same code, message and help.
    for call in (lambda: advise.LWR(task="dokc", tasks="dock.adv"),
                 lambda: advise.BC(task="dokc", tasks=["dock.adv"]),
                 lambda: advise.Operators(tasks="dock.adv").apply(
                     "stop", {}, np.zeros((1, 5)), np.zeros((1, 2)), task="dokc"),
                 lambda: advise.load_demos("demos.csv", task="dokc", tasks="dock.adv"),
                 lambda: advise.Session(task="dokc", tasks="dock.adv")):
        d = error_of(call)
        assert (d.code, d.message, d.help) == (
            "advise::task::unknown_task", "unknown task `dokc`", "did you mean `dock`?")
    out = subprocess.run([ADVISE, "demo", "--tasks", "dock.adv", "--task", "dokc", "--count", "1",
                          "--out", "never.csv"], cwd=in_lab, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode != 0 and "advise::task::unknown_task" in out.stdout + out.stderr
    assert "did you mean `dock`?" in out.stdout + out.stderr
    # A declared task without its file: the tasks listed once each, and how to give the file.
    d = error_of(lambda: advise.LWR(task="dock"))
    assert (d.code, d.message) == ("advise::task::unknown_task", "unknown task `dock`")
    assert d.help == ("the tasks are `positioning`, `interception`; a task declared in a file "
                      "needs it: `tasks=\"FILE.adv\"`")
    # A file that is not there is the file's diagnostic, not an unknown task.
    d = error_of(lambda: advise.LWR(task="dock", tasks="nowhere/dock.adv"))
    assert d.code == "advise::file::read"


def test_a_path_that_names_no_file_is_said_so(in_lab):
    # Outside the repository, the standard library's path is no file: said so, not parsed.
    d = error_of(lambda: advise.check("operators/positioning.adv"))
    assert (d.code, d.message) == ("advise::py::no_such_file",
                                   "there is no file `operators/positioning.adv`")
    assert str(in_lab) in d.help and "built in" in d.help
    for path in ("my_ops.adv", "ops/mine", str(in_lab / "missing.adv")):
        d = error_of(lambda: advise.check(path))
        assert (d.code, d.message) == ("advise::py::no_such_file", f"there is no file `{path}`")
        d = error_of(lambda: advise.Operators(path))
        assert d.code == "advise::py::no_such_file"
    # Operator text is still text, on one line (with `/` or `=`) or several.
    assert advise.check("operator halve for positioning on action { trans = trans / 2 }") == []
    assert advise.check("operator halt for positioning on action = stop") == []
    assert advise.check("operator half(rate = 0.5 in [0, 1]) for positioning on action {\n"
                        "  trans *= rate\n}\n") == []
    # A file given by a path relative to here, and the task file itself.
    assert advise.check("dock.adv") == []
    assert advise.check(str(in_lab / "dock.adv")) == []
