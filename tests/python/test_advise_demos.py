"""advise.load_demos: a demonstrations file as numpy arrays, as `load demos` reads it."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import advise

ADVISE = os.environ["ADVISE_BIN"]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("demos")
    for out in ["d.csv", "d.json"]:
        subprocess.run(
            [ADVISE, "demo", "--task", "positioning", "--count", "3", "--out", out],
            cwd=d, check=True, capture_output=True, timeout=120,
        )
    return d


def test_csv_and_json_give_the_files_points(files):
    z, a, ep, names = advise.load_demos(str(files / "d.csv"), task="positioning")
    doc = json.loads((files / "d.json").read_text())
    assert names == [e["name"] for e in doc["episodes"]] == ["demo-0", "demo-1", "demo-2"]
    zj = np.array([p["z"] for e in doc["episodes"] for p in e["points"]])
    aj = np.array([p["a"] for e in doc["episodes"] for p in e["points"]])
    counts = [len(e["points"]) for e in doc["episodes"]]
    assert z.shape == zj.shape and a.shape == aj.shape and ep.dtype == np.int64
    assert np.array_equal(z, zj) and np.array_equal(a, aj)
    assert np.array_equal(np.bincount(ep), counts)
    z2, a2, ep2, names2 = advise.load_demos(str(files / "d.json"))
    assert np.array_equal(z, z2) and np.array_equal(a, a2) and np.array_equal(ep, ep2)
    assert names2 == names


def test_learners_fit_on_the_arrays_as_on_the_file(files):
    # What a session's `load demos` gives the learner: fit_file reads the file that way.
    z, a, ep, _ = advise.load_demos(str(files / "d.csv"))
    q = z[::7]
    for cls in (advise.BC, advise.LWR):
        from_file = cls(task="positioning").fit_file(str(files / "d.csv"))
        from_arrays = cls(task="positioning").fit(z, a, ep.tolist())
        assert len(from_file) == len(from_arrays) == len(z)
        assert np.array_equal(from_file.predict(q), from_arrays.predict(q))


def test_bad_files_and_names_raise_coded_errors(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("episode,t,dist2\nx,0,1\n")
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(bad))
    assert e.value.code.startswith("advise::"), e.value.code
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(tmp_path / "missing.csv"))
    assert e.value.code.startswith("advise::")
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(bad), domain="nowhere")
    assert e.value.code == "advise::py::unknown_domain"


BAGS = os.path.join(os.path.dirname(__file__), "bags.py")


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    """A rosbag2 folder written by `rosbags` (a library advise did not write), with what
    `advise import` makes of it."""
    d = tmp_path_factory.mktemp("bag")
    out = d / "rosbags-messy"
    subprocess.run([sys.executable, BAGS, "rosbags", "messy", str(out)],
                   check=True, capture_output=True, timeout=120)
    subprocess.run([ADVISE, "import", str(out), "--out", "imported.csv"],
                   cwd=d, check=True, capture_output=True, timeout=120)
    return out, d / "imported.csv"


def test_a_bag_loads_as_advise_import_makes_it(bag):
    folder, imported = bag
    z, a, ep, names = advise.load_demos(str(folder))
    zi, ai, epi, namesi = advise.load_demos(str(imported))
    assert len(z) > 20 and np.array_equal(z, zi) and np.array_equal(a, ai)
    assert np.array_equal(ep, epi) and names == namesi
    # The learners read the bag the same way.
    q = zi[::5]
    assert np.array_equal(advise.BC(task="positioning").fit_file(str(folder)).predict(q),
                          advise.BC(task="positioning").fit_file(str(imported)).predict(q))
    # The idle points kept: at least as many, the trimmed ones among them.
    zk, _, _, _ = advise.load_demos(str(folder), keep_idle=True)
    assert len(zk) >= len(z)


def test_a_bags_topics_and_task_are_checked(bag):
    folder, imported = bag
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(folder), cmd_topic="/robot1/cmd_vel")
    assert e.value.code.startswith("advise::import::"), e.value.code
    assert "/robot1/cmd_vel" in str(e.value)
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(imported), cmd_topic="/cmd_vel")
    assert e.value.code == "advise::session::topics_need_a_bag"
    # A domain alone does not say how a recording's goal is read; interception cannot be.
    for kw in ({"domain": "positioning"}, {"task": "interception"}):
        with pytest.raises(advise.AdviseError) as e:
            advise.load_demos(str(folder), **kw)
        assert e.value.code == "advise::session::recording_needs_positioning", kw
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(folder), domain="positioning", task="positioning")
    assert e.value.code == "advise::py::domain_or_task"


def test_parquet_demonstrations_load_as_their_csv(files, tmp_path):
    import pandas as pd

    pd.read_csv(files / "d.csv", float_precision="round_trip").to_parquet(tmp_path / "d.parquet", index=False)
    z, a, ep, names = advise.load_demos(str(files / "d.csv"))
    zp, ap, epp, namesp = advise.load_demos(str(tmp_path / "d.parquet"))
    assert np.array_equal(z, zp) and np.array_equal(a, ap)
    assert np.array_equal(ep, epp) and names == namesp


def test_a_declared_tasks_demonstrations_load_from_its_file(tmp_path):
    tasks = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "tasks", "standoff.adv")
    subprocess.run(
        [ADVISE, "demo", "--tasks", tasks, "--task", "standoff", "--count", "2", "--out", "s.csv"],
        cwd=tmp_path, check=True, capture_output=True, timeout=120,
    )
    z, a, ep, names = advise.load_demos(str(tmp_path / "s.csv"), task="standoff", tasks=[tasks])
    # The file's columns: episode, t, the observations, the actions, then the pose.
    rows = [r.split(",") for r in (tmp_path / "s.csv").read_text().splitlines()[1:]]
    want = np.array([[float(v) for v in r[2:7]] for r in rows])
    assert np.array_equal(np.hstack([z, a]), want)
    assert names == ["demo-0", "demo-1"] and np.array_equal(np.unique(ep), [0, 1])
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(tmp_path / "s.csv"), task="standof", tasks=[tasks])
    assert "standoff" in str(e.value) or "standoff" in str(e.value.diagnostics[0].help)
