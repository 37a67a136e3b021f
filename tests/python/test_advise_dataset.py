"""advise.advise_demos (advice on a chunk of any demonstrations file's episode, written next to it
with provenance) and the learners' dataset with its provenance as numpy arrays and pyarrow."""

import json
import os
import subprocess

import numpy as np
import pytest

import advise

ADVISE = os.environ["ADVISE_BIN"]


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    d = tmp_path_factory.mktemp("dataset")
    subprocess.run([ADVISE, "demo", "--task", "positioning", "--count", "3", "--out", "d.csv"],
                   cwd=d, check=True, capture_output=True, timeout=120)
    return d


def session(d, statements):
    (d / "s.adv").write_text("\n".join(statements) + "\n")
    return subprocess.run([ADVISE, "run", "s.adv", "--no-journal", "--demos", "0"],
                          cwd=d, check=True, capture_output=True, text=True, timeout=120).stdout


def test_advice_on_an_episode_is_the_sessions_saved_dataset(demos):
    d = demos
    r = advise.advise_demos(str(d / "d.csv"), str(d / "py.json"), episode="demo-1",
                            frames=(10, 30), operator="slow_down", params={"rate": 0.3})
    assert r["episode"] == "demo-1" and r["demonstrations"] == 3
    assert r["synthesized"] + r["skipped"] == 20 and r["invocation"] == "slow_down(rate = 0.3)"
    # The same advice given in a session on that episode loaded as an execution, then saved.
    lines = (d / "d.csv").read_text().splitlines()
    (d / "ep1.csv").write_text("\n".join([lines[0]] + [x for x in lines if x.startswith("demo-1,")]) + "\n")
    session(d, ["load demos d.csv", "load trace ep1.csv", "select 10..30",
                "advise slow_down(0.3)", "save cli.json"])
    assert json.loads((d / "py.json").read_text()) == json.loads((d / "cli.json").read_text())
    # An index names the same episode; the corrected episode is the operator's on the chunk.
    r2 = advise.advise_demos(str(d / "d.csv"), str(d / "py2.json"), episode=1,
                             frames=(10, 30), operator="slow_down", params={"rate": 0.3})
    assert (d / "py2.json").read_bytes() == (d / "py.json").read_bytes()
    z, a, ep, _ = advise.load_demos(str(d / "d.csv"))
    z1, a1 = z[ep == 1], a[ep == 1]
    zs, as_, skipped = advise.Operators().apply("slow_down", {"rate": 0.3}, z1, a1,
                                                task="positioning", chunk=(10, 30))
    keep = ~skipped
    assert np.array_equal(r2["observations"], np.vstack([z1[:10], zs, z1[30:]]))
    assert np.array_equal(r2["actions"], np.vstack([a1[:10], as_, a1[30:]]))
    assert list(r2["source"]) == ["demonstration"] * 10 + ["advice"] * int(keep.sum()) + \
        ["demonstration"] * (len(z1) - 30)
    # The session reads it back: the file's demonstrations and the advice.
    out = session(d, ["load demos py.json", "open py.json"])
    assert "a saved dataset's 3 demonstrations and 1 piece of advice" in out, out


def test_advice_refuses_what_it_cannot_do(demos):
    d = demos
    kw = dict(frames=(10, 30), operator="slow_down", params={"rate": 0.3})
    cases = [
        ({"episode": 7}, "advise::py::no_such_episode"),
        ({"episode": "demo-9"}, "advise::py::no_such_episode"),
        ({"episode": 0.5}, "advise::py::bad_argument"),
        ({"episode": 0, "frames": (30, 10)}, "advise::"),
        ({"episode": 0, "operator": "slow_dwn"}, "advise::"),
        ({"episode": 0, "params": {"rate": float("nan")}}, "advise::py::not_finite"),
    ]
    for change, code in cases:
        args = {**kw, **change}
        with pytest.raises(advise.AdviseError) as e:
            advise.advise_demos(str(d / "d.csv"), str(d / "x.json"), **args)
        assert e.value.code.startswith(code), (change, e.value.code)
    assert not (d / "x.json").exists()
    before = (d / "d.csv").read_bytes()
    with pytest.raises(advise.AdviseError) as e:
        advise.advise_demos(str(d / "d.csv"), str(d / "d.csv"), episode=0, **kw)
    assert e.value.code.startswith("advise::"), e.value.code
    assert (d / "d.csv").read_bytes() == before
    with pytest.raises(advise.AdviseError) as e:
        advise.advise_demos(str(d / "d.csv"), str(d / "x.txt"), episode=0, **kw)
    assert e.value.code.startswith("advise::"), e.value.code


def test_a_learners_dataset_carries_provenance_and_weights(demos):
    pa = pytest.importorskip("pyarrow")
    d = demos
    bc = advise.BC(task="positioning").fit_file(str(d / "d.csv"))
    z, a, ep, names = advise.load_demos(str(d / "d.csv"))
    bc.critique(z[:40], chunk=(0, 20), kappa=2.0)
    ds = bc.dataset()
    assert np.array_equal(ds["observations"], z) and np.array_equal(ds["actions"], a)
    assert np.array_equal(ds["weights"], bc.weights()) and ds["weights"].max() > 1.0
    ids = np.array([x["id"] for x in ds["demonstrations"]])
    assert set(ds["source"].tolist()) == {"demonstration"} and np.array_equal(ds["source_id"], ids[ep])
    assert [x["name"] for x in ds["demonstrations"]] == names
    assert np.array_equal(ds["index"], np.concatenate([np.arange(c) for c in np.bincount(ep)]))
    assert (ds["execution_index"] == -1).all()
    t = advise.to_arrow(ds)
    assert t.num_rows == len(z) and t.column("weight").to_pylist() == list(ds["weights"])
    assert np.array_equal(np.array(t.column("observation").to_pylist()), z)
    assert json.loads(t.schema.metadata[b"advise.demonstrations"])[0]["name"] == names[0]
    assert t.schema.metadata[b"advise.domain"] == b"positioning"


def test_a_sessions_dataset_says_which_points_are_advice(demos):
    pa = pytest.importorskip("pyarrow")
    s = advise.Session(task="positioning", demos=0)
    s.execute(f"load demos {demos / 'd.csv'}")
    s.execute("run goal 2 -1 0.5")
    s.execute("select 10..30")
    adv = s.execute("advise slow_down(0.3)")
    ds = s.dataset()
    is_advice = ds["source"] == "advice"
    assert is_advice.sum() == adv["added"] and len(ds["weights"]) == len(s)
    assert ds["advice"][0]["invocation"] == "slow_down(rate = 0.3)"
    assert ds["advice"][0]["chunk"] == (10, 30)
    # Each advice point came from an execution point in the chunk, in order.
    src = ds["execution_index"][is_advice]
    assert ((src >= 10) & (src < 30)).all() and (np.diff(src) > 0).all()
    assert (ds["execution_index"][~is_advice] == -1).all()
    # The run's own arrays: the advice points are synthesized from its observations.
    run = s.execution(0)
    assert run["observations"].shape[1] == ds["observations"].shape[1]
    t = advise.to_arrow(ds)
    assert t.column("advise.source").to_pylist().count("advice") == adv["added"]
