"""advise.load_demos: a demonstrations file as numpy arrays, as `load demos` reads it."""

import json
import os
import subprocess

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
