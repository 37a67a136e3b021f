"""LeRobot v3.0 datasets from Python: ``advise.load_lerobot``, ``advise.to_arrow`` and
``advise.advise_lerobot``, checked against pyarrow and pandas reading the files as LeRobot v3.0's
loader does (LeRobot's own ``LeRobotDataset`` needs torch, which the test venv does not install).
"""

import json
import os
import subprocess

import numpy as np
import pytest

import advise

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")
pd = pytest.importorskip("pandas")

ADVISE = os.environ["ADVISE_BIN"]
DATA = "data/chunk-000/file-000.parquet"


@pytest.fixture(scope="module")
def lerobot(tmp_path_factory):
    """A LeRobot dataset exported by advise: 3 demonstrations at their recorded 15 fps (the
    advice on a 30 Hz execution goes to a dataset of its own: one dataset per rate)."""
    d = tmp_path_factory.mktemp("lerobot")
    (d / "s.adv").write_text("run start 0\nselect 5..20\nadvise speed_up(0.2)\nsave s.json\n")
    for args in (
        ["run", "--demos", "3", "--no-journal", "s.adv"],
        ["export", "s.json", "--lerobot", "lr", "--fps", "10"],
    ):
        subprocess.run([ADVISE, *args], cwd=d, check=True, capture_output=True, timeout=120)
    assert (d / "lr" / "30fps" / "meta" / "info.json").exists()
    return d / "lr" / "15fps"


def frames(d):
    """The frames of a LeRobot dataset as LeRobot v3.0's loader reads them: the data parquet,
    each frame's task text `tasks.iloc[task_index].name`."""
    t = pq.read_table(d / DATA).to_pandas()
    tasks = pd.read_parquet(d / "meta/tasks.parquet")
    t["task"] = [tasks.iloc[int(i)].name for i in t["task_index"]]
    return t


def test_load_lerobot_reads_the_frames_pyarrow_reads(lerobot):
    data = advise.load_lerobot(str(lerobot), task="positioning")
    t = frames(lerobot).sort_values(["episode_index", "frame_index"], kind="stable")
    np.testing.assert_array_equal(
        data["observations"], np.stack(t["observation.state"]).astype(np.float64)
    )
    np.testing.assert_array_equal(data["actions"], np.stack(t["action"]).astype(np.float64))
    np.testing.assert_array_equal(data["episode_index"], t["episode_index"].to_numpy())
    np.testing.assert_array_equal(data["frame_index"], t["frame_index"].to_numpy())
    assert data["episode_index"].dtype == np.int64
    assert data["fps"] == 15.0
    assert data["observation_names"] == ["dist2", "bearing", "dheading"]
    assert data["mapping"][1] == "`action` by name: `trans`, `rot`"


def test_to_arrow_is_a_pyarrow_table_with_provenance(lerobot):
    data = advise.load_lerobot(str(lerobot))
    table = advise.to_arrow(data)
    n = len(data["episode_index"])
    assert table.num_rows == n
    assert table.schema.field("observation.state").type == pa.list_(pa.float64(), 3)
    assert table.schema.field("action").type == pa.list_(pa.float64(), 2)
    state = table.column("observation.state").combine_chunks().flatten().to_numpy()
    np.testing.assert_array_equal(state.reshape(-1, 3), data["observations"])
    assert table.column("advise.source").to_pylist() == ["demonstration"] * n
    assert table.column("advise.dataset").to_pylist() == [str(lerobot)] * n
    assert table.schema.metadata[b"advise.domain"] == b"positioning"
    # The table round-trips through parquet as any pyarrow table does.
    assert table.to_pandas()["episode_index"].tolist() == data["episode_index"].tolist()


def test_advice_on_a_chunk_writes_the_corrected_episode_as_a_lerobot_dataset(lerobot, tmp_path):
    data = advise.load_lerobot(str(lerobot))
    ep = data["episode_index"] == 1
    z, a, ts = data["observations"][ep], data["actions"][ep], data["timestamp"][ep]
    out = tmp_path / "lr-advised"
    summary = advise.advise_lerobot(
        str(lerobot), str(out), episode=1, frames=(10, 30),
        operator="slow_down", params={"rate": 0.3},
    )
    want_z, want_a, skipped = advise.Operators().apply(
        "slow_down", {"rate": 0.3}, z, a, task="positioning", chunk=(10, 30), times=ts
    )
    k = len(want_z)
    assert summary["synthesized"] == k and summary["skipped"] == int(skipped.sum())
    assert summary["frames"] == len(z) - 20 + k
    assert summary["invocation"].startswith("slow_down(")

    # Read back as LeRobot's loader reads it.
    t = frames(out)
    assert (t["episode_index"] == 0).all()
    assert t["frame_index"].tolist() == list(range(summary["frames"]))
    assert t["index"].tolist() == list(range(summary["frames"]))
    assert set(t["task"]) == {"drive the base to the goal pose"}
    state, action = np.stack(t["observation.state"]), np.stack(t["action"])
    f32 = lambda x: np.asarray(x, dtype=np.float32)  # noqa: E731
    # The untouched frames unchanged, the chunk the operator's points.
    np.testing.assert_array_equal(state[:10], f32(z[:10]))
    np.testing.assert_array_equal(action[:10], f32(a[:10]))
    np.testing.assert_array_equal(state[10 + k:], f32(z[30:]))
    np.testing.assert_array_equal(action[10 + k:], f32(a[30:]))
    np.testing.assert_array_equal(state[10:10 + k], f32(want_z))
    np.testing.assert_array_equal(action[10:10 + k], f32(want_a))
    assert not np.array_equal(action[10:10 + k], f32(a[10:30])[~skipped])
    sources = ["demonstration"] * 10 + ["advice"] * k + ["demonstration"] * (len(z) - 30)
    assert t["advise.source"].tolist() == sources

    episodes = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pandas()
    assert episodes["length"].tolist() == [summary["frames"]]
    assert episodes["advise.name"][0].startswith("episode 1, frames 10..30: slow_down(")
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["total_frames"] == summary["frames"]
    p = info["advise"]["provenance"]
    assert (p["source"], p["episode_index"], p["frames"]) == (str(lerobot), 1, [10, 30])
    assert (p["operator"], p["params"]) == ("slow_down", {"rate": 0.3})

    # And advise reads it back: the dataset in, advice on a chunk, a dataset out, in again.
    back = advise.load_lerobot(str(out))
    np.testing.assert_array_equal(back["observations"], state.astype(np.float64))
    # The output directory is new: advice never mixes into an existing dataset.
    with pytest.raises(advise.AdviseError) as e:
        advise.advise_lerobot(
            str(lerobot), str(out), episode=1, frames=(10, 30),
            operator="slow_down", params={"rate": 0.3},
        )
    assert e.value.code == "advise::export::lerobot_exists"


def rewritten(lerobot, tmp_path, column, values):
    """A copy of the dataset whose data parquet has `column` replaced by `values`."""
    import shutil

    d = tmp_path / "bad"
    shutil.copytree(lerobot, d)
    t = pq.read_table(d / DATA)
    i = t.schema.get_field_index(column)
    pq.write_table(t.set_column(i, column, values), d / DATA)
    return d


def test_bad_datasets_raise_coded_errors(lerobot, tmp_path):
    t = pq.read_table(lerobot / DATA)
    state = np.stack(t.column("observation.state").to_pylist()).astype(np.float32)
    state[7, 1] = np.nan
    nan = pa.FixedSizeListArray.from_arrays(pa.array(state.reshape(-1)), 3)
    cases = [
        (rewritten(lerobot, tmp_path / "nan", "observation.state", nan), "advise::lerobot::not_finite", "row 7"),
        (
            rewritten(lerobot, tmp_path / "str", "action", pa.array(["x"] * t.num_rows)),
            "advise::lerobot::column_type",
            "a string",
        ),
        (tmp_path / "nowhere", "advise::lerobot::missing_file", "meta/info.json"),
    ]
    # More frames than advise reads: refused from the file's row count, before reading them.
    big = tmp_path / "big"
    import shutil

    shutil.copytree(lerobot, big)
    n = 1_000_001
    zeros = lambda k: pa.FixedSizeListArray.from_arrays(  # noqa: E731
        pa.array(np.zeros(n * k, dtype=np.float32)), k
    )
    ints = pa.array(np.zeros(n, dtype=np.int64))
    pq.write_table(
        pa.table({"observation.state": zeros(3), "action": zeros(2), "episode_index": ints, "frame_index": ints}),
        big / DATA,
    )
    cases.append((big, "advise::lerobot::too_large", "1000001 frames"))
    # One frame whose state is a list of 10M zeros (a few KB on disk): refused from the
    # column's count of values, before a row is built.
    huge = tmp_path / "huge"
    shutil.copytree(lerobot, huge)
    one = pa.array(np.zeros(1, dtype=np.int64))
    long_list = pa.ListArray.from_arrays(
        pa.array([0, 10_000_000], pa.int32()), pa.array(np.zeros(10_000_000, dtype=np.float32))
    )
    pq.write_table(
        pa.table({"observation.state": long_list, "action": zeros(2)[:1], "episode_index": one, "frame_index": one}),
        huge / DATA,
    )
    cases.append((huge, "advise::lerobot::list_too_long", "10000000 values in 1 rows"))
    # Every frame numbered 0: refused, not read as one episode of repeated frames.
    cases.append(
        (
            rewritten(lerobot, tmp_path / "zero", "frame_index", pa.array(np.zeros(t.num_rows, dtype=np.int64))),
            "advise::lerobot::frame_order",
            "row 1: episode 0's frame_index 0 does not follow its frame 0",
        )
    )
    for d, code, where in cases:
        with pytest.raises(advise.AdviseError) as e:
            advise.load_lerobot(str(d))
        assert e.value.code == code, str(e.value)
        assert where in str(e.value)
    with pytest.raises(advise.AdviseError) as e:
        advise.load_lerobot(str(lerobot), task="interception")
    assert e.value.code == "advise::lerobot::names"
    with pytest.raises(advise.AdviseError) as e:
        advise.advise_lerobot(
            str(lerobot), str(tmp_path / "o"), episode=99, frames=(0, 5),
            operator="slow_down", params={"rate": 0.3},
        )
    assert e.value.code == "advise::lerobot::no_episode"
    with pytest.raises(advise.AdviseError) as e:
        advise.advise_lerobot(
            str(lerobot), str(tmp_path / "o"), episode=1, frames=(0, 5),
            operator="no_such_operator", params={},
        )
    assert e.value.code.startswith("advise::")
    assert not (tmp_path / "o").exists()


def test_a_declared_tasks_dataset_reads_and_advises_with_its_task_file(tmp_path):
    tasks = os.path.abspath("examples/tasks/standoff.adv")
    (tmp_path / "s.adv").write_text("save s.json\n")
    for args in (
        ["run", "--tasks", tasks, "--task", "standoff", "--demos", "2", "--no-journal", "s.adv"],
        ["export", "s.json", "--lerobot", "lr", "--fps", "10"],
    ):
        subprocess.run([ADVISE, *args], cwd=tmp_path, check=True, capture_output=True, timeout=120)
    with pytest.raises(advise.AdviseError) as e:
        advise.load_lerobot(str(tmp_path / "lr"), "standoff")
    assert e.value.code == "advise::task::unknown_task"
    data = advise.load_lerobot(str(tmp_path / "lr"), "standoff", tasks=[tasks])
    z, a, ep, _ = advise.load_demos(str(tmp_path / "s.json"), task="standoff", tasks=[tasks])
    assert data["domain"] == "standoff"
    assert np.allclose(data["observations"], z) and np.allclose(data["actions"], a)
    r = advise.advise_lerobot(str(tmp_path / "lr"), str(tmp_path / "out"), episode=0,
                              frames=(5, 15), operator="creep", params={"gain": 0.1},
                              task="standoff", tasks=[tasks])
    assert r["synthesized"] + r["skipped"] == 10
