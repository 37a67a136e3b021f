"""Hostile input, third round (issue 47), from Python: Parquet written by pyarrow in every common
compression, footers that lie (a valid file with its Thrift footer patched), declared sizes that
ask for memory, FIFOs where files are read, the learners and the simulator from other threads,
arrays of the wrong kind, a forked child, Ctrl-C during a long statement, and errors pickled
across processes. Every refusal is an AdviseError with its code; every loop is bounded."""

import concurrent.futures
import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import advise

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

ADVISE = os.environ["ADVISE_BIN"]
DATA = "data/chunk-000/file-000.parquet"


# --- Parquet: every codec, footers that lie, sizes that ask for memory ---------------------


def demos_table(rows=50, episodes=2):
    """A positioning demonstrations table as a CSV file's columns (episode, t, the domain's)."""
    z, a, ep, labels = advise.load_demos(str(demos_csv()), task="positioning")
    z, a, ep = z[:rows], a[:rows], ep[:rows]
    d = advise.BC(task="positioning").fit(z, a, ep.tolist()).dataset()
    cols = {"episode": pa.array([labels[i] for i in ep])}
    cols["t"] = pa.array(np.concatenate([np.arange((ep == e).sum()) * 0.1 for e in np.unique(ep)]))
    for k, n in enumerate(d["observation_names"]):
        cols[n] = pa.array(z[:, k])
    for k, n in enumerate(d["action_names"]):
        cols[n] = pa.array(a[:, k])
    return pa.table(cols), z, a


_DEMOS = {}


def demos_csv():
    if "csv" not in _DEMOS:
        d = os.path.join(os.environ.get("PYTEST_TMP", "/tmp"), f"advise-hostile-{os.getpid()}")
        os.makedirs(d, exist_ok=True)
        subprocess.run(
            [ADVISE, "demo", "--task", "positioning", "--count", "2", "--out", "d.csv"],
            cwd=d, check=True, capture_output=True, timeout=120,
        )
        _DEMOS["csv"] = os.path.join(d, "d.csv")
    return _DEMOS["csv"]


@pytest.mark.parametrize("codec", ["none", "snappy", "gzip", "brotli", "lz4", "zstd"])
def test_parquet_of_every_common_codec_reads_the_same_points(tmp_path, codec):
    table, z, a = demos_table()
    path = tmp_path / f"d-{codec}.parquet"
    pq.write_table(table, path, compression=codec)
    z2, a2, _, names = advise.load_demos(str(path), task="positioning")
    assert np.array_equal(z2, z) and np.array_equal(a2, a)
    assert len(names) >= 1
    # The command line reads it as the Python package does.
    out = run_cli(tmp_path, f"load demos {path}")
    assert out.returncode == 0, out.stderr
    assert f"({len(z)} points)" in out.stdout + out.stderr


def run_cli(d, statement):
    """`advise run` of a one-statement script in `d`: its completed process."""
    (d / "s.adv").write_text(statement + "\n")
    return subprocess.run(
        [ADVISE, "run", "--no-journal", "--demos", "0", "s.adv"],
        capture_output=True, text=True, timeout=120, cwd=d,
    )


def zigzag_varint(v):
    u = (v << 1) ^ (v >> 63)
    u &= (1 << 64) - 1
    out = bytearray()
    while True:
        b = u & 0x7F
        u >>= 7
        if u:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def patch_footer(path, old, new):
    """Replace the bytes `old` by `new` (once) in the Parquet file's Thrift footer, its length
    fixed: a valid file whose footer then says something else."""
    data = path.read_bytes()
    assert data[-4:] == b"PAR1"
    n = int.from_bytes(data[-8:-4], "little")
    start = len(data) - 8 - n
    footer = data[start:-8]
    assert footer.count(old) >= 1, (old, footer[:200])
    footer = footer.replace(old, new, 1)
    path.write_bytes(data[:start] + footer + len(footer).to_bytes(4, "little") + b"PAR1")


def lying_files(tmp_path):
    """pyarrow-written demonstrations with one footer field each made a lie."""
    table, _, _ = demos_table()
    out = {}
    for name in ["compressed", "dictionary", "children", "num_values"]:
        p = tmp_path / f"{name}.parquet"
        pq.write_table(table, p, compression="none", use_dictionary=(name == "dictionary"))
        col = pq.ParquetFile(p).metadata.row_group(0).column(0)
        if name == "compressed":
            # Fields 6 and 7 of ColumnMetaData, each after the one before (delta 1, i64): 0x16.
            old = b"\x16" + zigzag_varint(col.total_uncompressed_size) + b"\x16" + zigzag_varint(col.total_compressed_size)
            new = b"\x16" + zigzag_varint(col.total_uncompressed_size) + b"\x16" + zigzag_varint(-1)
        elif name == "dictionary":
            # data_page_offset (9) then dictionary_page_offset (11): delta 2, i64: 0x26.
            assert col.dictionary_page_offset is not None
            old = b"\x26" + zigzag_varint(col.data_page_offset) + b"\x26" + zigzag_varint(col.dictionary_page_offset)
            new = b"\x26" + zigzag_varint(col.data_page_offset) + b"\x26" + zigzag_varint(-1)
        elif name == "children":
            # The root's num_children (field 5, i32, right after its name "schema").
            n = len(table.schema)
            old = b"schema\x15" + zigzag_varint(n)
            new = b"schema\x15" + zigzag_varint(2**31 - 1)
        else:
            # num_values (field 5, after codec 4: 0x16) of the first column: more than its rows.
            old = b"\x16" + zigzag_varint(col.num_values) + b"\x16" + zigzag_varint(col.total_uncompressed_size)
            new = b"\x16" + zigzag_varint(10**8) + b"\x16" + zigzag_varint(col.total_uncompressed_size)
        patch_footer(p, old, new)
        out[name] = p
    return out


def test_footers_that_lie_are_refused_with_a_code_before_the_reader_sees_them(tmp_path):
    files = lying_files(tmp_path)
    for name, p in files.items():
        with pytest.raises(advise.AdviseError) as e:
            advise.load_demos(str(p), task="positioning")
        assert e.value.code in ("advise::parquet::footer",), (name, str(e.value))
        assert str(p) in str(e.value)
        with pytest.raises(advise.AdviseError) as e:
            advise.BC(task="positioning").fit_file(str(p))
        assert e.value.code == "advise::parquet::footer"
        # The command line: a coded refusal, not a panic (exit 101) or an abort.
        out = run_cli(tmp_path, f"load demos {p}")
        assert "advise::parquet::footer" in out.stderr + out.stdout, (name, out.stderr)
        assert "panicked" not in out.stderr


def test_a_long_dictionary_label_on_every_row_is_refused_not_copied(tmp_path):
    # A 20 MB episode name, dictionary-encoded, on every row: a small file that would be 8 GB
    # of copied labels.
    table, _, _ = demos_table(rows=400)
    big = "x" * (20 << 20)
    i = table.schema.get_field_index("episode")
    # Made as a dictionary directly: `pa.array([big] * rows).dictionary_encode()` made the same
    # column from 8 GB of strings first (17 s here).
    indices = pa.array([0] * table.num_rows, type=pa.int32())
    column = pa.DictionaryArray.from_arrays(indices, pa.array([big]))
    table = table.set_column(i, "episode", column)
    p = tmp_path / "label.parquet"
    pq.write_table(table, p, compression="zstd")
    assert p.stat().st_size < 4 << 20
    with pytest.raises(advise.AdviseError) as e:
        advise.load_demos(str(p), task="positioning")
    assert e.value.code == "advise::parquet::bad_value"
    assert "episode" in str(e.value) and "row 0" in str(e.value)


# --- LeRobot: FIFOs, lists where scalars are, the demonstration rules ----------------------


@pytest.fixture(scope="module")
def lerobot(tmp_path_factory):
    d = tmp_path_factory.mktemp("lerobot")
    (d / "s.adv").write_text("run start 0\nsave s.json\n")
    for args in (
        ["run", "--demos", "2", "--no-journal", "s.adv"],
        ["export", "s.json", "--lerobot", "lr", "--fps", "10"],
    ):
        subprocess.run([ADVISE, *args], cwd=d, check=True, capture_output=True, timeout=120)
    return d / "lr"


def copy_with(lerobot, tmp_path, name, table):
    d = tmp_path / name
    shutil.copytree(lerobot, d)
    pq.write_table(table, d / DATA)
    return d


def test_lerobot_import_holds_the_demonstration_rules(lerobot, tmp_path):
    t = pq.read_table(lerobot / DATA)
    ts = t.column("timestamp").to_numpy().copy()
    nan = ts.copy()
    nan[3] = np.nan
    back = ts.copy()
    back[4] = back[2]
    i = t.schema.get_field_index("timestamp")
    cases = [
        (copy_with(lerobot, tmp_path, "nan", t.set_column(i, "timestamp", pa.array(nan))), "advise::lerobot::not_finite"),
        (copy_with(lerobot, tmp_path, "back", t.set_column(i, "timestamp", pa.array(back))), "advise::lerobot::time_order"),
        (copy_with(lerobot, tmp_path, "empty", t.slice(0, 0)), "advise::lerobot::no_frames"),
    ]
    # A frame_index that is a list (of many values): refused before any row is built.
    one = pa.array(np.zeros(1, dtype=np.int64))
    frames = pa.ListArray.from_arrays(pa.array([0, 1_000_000], pa.int32()), pa.array(np.zeros(1_000_000, dtype=np.int64)))
    listed = pa.table({
        "observation.state": t.column("observation.state").slice(0, 1),
        "action": t.column("action").slice(0, 1),
        "episode_index": one,
        "frame_index": frames,
    })
    cases.append((copy_with(lerobot, tmp_path, "list", listed), "advise::lerobot::column_type"))
    for d, code in cases:
        with pytest.raises(advise.AdviseError) as e:
            advise.load_lerobot(str(d))
        assert e.value.code == code, str(e.value)
        out_csv = tmp_path / f"{d.name}.csv"
        r = subprocess.run(
            [ADVISE, "import", "--lerobot", str(d), "--out", str(out_csv)],
            capture_output=True, text=True, timeout=120,
        )
        assert r.returncode != 0 and code in r.stderr, r.stderr
        assert not out_csv.exists()


def test_a_fifo_where_a_file_is_read_is_refused_not_waited_on(lerobot, tmp_path):
    d = tmp_path / "fifo"
    shutil.copytree(lerobot, d)
    os.remove(d / DATA)
    os.mkfifo(d / DATA)
    with pytest.raises(advise.AdviseError) as e:
        advise.load_lerobot(str(d))
    assert e.value.code == "advise::file::not_regular"
    r = subprocess.run(
        [ADVISE, "import", "--lerobot", str(d), "--out", str(tmp_path / "o.csv")],
        capture_output=True, text=True, timeout=60,
    )
    assert "advise::file::not_regular" in r.stderr
    # A journal's sidecar replaced by a FIFO.
    table, _, _ = demos_table()
    pq.write_table(table, tmp_path / "d.parquet")
    jdir = tmp_path / "journals"
    with advise.Session(task="positioning", journal=str(jdir)) as s:
        s.execute(f"load demos {tmp_path / 'd.parquet'}")
        journal = s.journal_path
    sidecars = [p for p in os.listdir(jdir) if p.startswith("demos-") and p.endswith(".parquet")]
    assert len(sidecars) == 1
    os.remove(jdir / sidecars[0])
    os.mkfifo(jdir / sidecars[0])
    s = advise.Session.resume(journal, journal_dir=str(jdir / "new"))
    assert s.resumed["stopped"] is not None
    assert "not_regular" in str(s.resumed["stopped"]) + s.resumed["text"], s.resumed
    s.close()
    r = subprocess.run(
        [ADVISE, "resume", journal],
        input="quit\n", capture_output=True, text=True, timeout=60,
        env={**os.environ, "ADVISE_HOME": str(jdir / "cli")},
    )
    assert "not_regular" in r.stdout + r.stderr, r.stderr


# --- Threads, signals, fork, pickling ------------------------------------------------------


def test_learners_from_several_threads_refuse_with_a_code_or_work():
    z, a, ep, _ = advise.load_demos(demos_csv(), task="positioning")
    big = np.repeat(z, max(1, 400_000 // len(z)), axis=0)
    for cls in (advise.BC, advise.LWR):
        learner = cls(task="positioning").fit(z, a, ep.tolist())
        errors = []

        def predict():
            try:
                learner.predict(big)
            except Exception as e:  # noqa: BLE001
                errors.append(e)

        seen_busy = False
        for _ in range(20):
            t = threading.Thread(target=predict)
            t.start()
            while t.is_alive():
                try:
                    learner.fit(z, a, ep.tolist())
                except advise.AdviseError as e:
                    assert e.code == "advise::py::busy"
                    seen_busy = True
                t.join(0.001)
            t.join()
            if seen_busy:
                break
        assert not errors, errors
        assert len(learner) == len(z)


def test_the_simulator_steps_from_another_thread():
    env = advise.SimEnv("positioning")
    env.reset(0, 0)
    out = []

    def step():
        try:
            out.append(env.step(np.zeros(2)))
        except Exception as e:  # noqa: BLE001
            out.append(e)

    t = threading.Thread(target=step)
    t.start()
    t.join(60)
    assert len(out) == 1 and isinstance(out[0], tuple), out
    gymnasium = pytest.importorskip("gymnasium")
    genv = gymnasium.make("advise/Positioning-v0")
    genv.reset(seed=1)
    t = threading.Thread(target=lambda: out.append(genv.step(np.zeros(2))))
    t.start()
    t.join(60)
    assert isinstance(out[-1], tuple)


def test_arrays_of_the_wrong_kind_are_refused_not_converted(tmp_path):
    z, a, ep, _ = advise.load_demos(demos_csv(), task="positioning")
    bc = advise.BC(task="positioning").fit(z, a, ep.tolist())
    masked = np.ma.masked_array(z, mask=np.zeros_like(z, dtype=bool))
    masked.mask[2, 1] = True
    cases = [
        (z.astype(complex) + 1j, "advise::py::dtype"),
        (masked, "advise::py::masked"),
        (np.zeros(z.shape, dtype="datetime64[s]"), "advise::py::dtype"),
        (z.astype(str), "advise::py::dtype"),
        (z > 0, "advise::py::dtype"),
    ]
    for bad, code in cases:
        with pytest.raises(advise.AdviseError) as e:
            bc.predict(bad)
        assert e.value.code == code, (bad.dtype, str(e.value))
        with pytest.raises(advise.AdviseError) as e:
            advise.BC(task="positioning").fit(bad, a)
        assert e.value.code in (code, "advise::py::shape"), str(e.value)
    # An unmasked masked array and integers are numbers.
    assert bc.predict(np.ma.masked_array(z)).shape == a.shape
    for fps in (0, -3, 2.5, True):
        with pytest.raises(advise.AdviseError) as e:
            advise.advise_lerobot(
                "nowhere", str(tmp_path / "o"), episode=0, frames=(0, 1),
                operator="slow_down", params={"rate": 0.3}, fps=fps,
            )
        assert e.value.code == "advise::py::fps", (fps, str(e.value))


def test_an_array_memory_cannot_copy_raises_instead_of_aborting(tmp_path):
    # In a child with its address space capped: an array that fits once, not twice.
    script = """
import resource, sys
import numpy as np
import advise
bc = advise.BC(task="positioning").fit(np.zeros((3, 7)) + np.arange(3)[:, None], np.zeros((3, 2)))
z = np.ones((60_000_000, 7))
soft, hard = resource.getrlimit(resource.RLIMIT_AS)
used = int(open("/proc/self/statm").read().split()[0]) * resource.getpagesize()
resource.setrlimit(resource.RLIMIT_AS, (used + (1 << 30), hard))
try:
    bc.predict(z)
except advise.AdviseError as e:
    print("CODE", e.code)
except MemoryError:
    print("CODE MemoryError")
"""
    obs_dim = len(advise.BC(task="positioning").fit(*advise.load_demos(demos_csv())[:2]).dataset()["observation_names"])
    script = script.replace("7", str(obs_dim))
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "CODE advise::py::memory" in r.stdout or "CODE MemoryError" in r.stdout, r.stdout


def test_a_forked_child_cannot_write_its_parents_journal(tmp_path):
    s = advise.Session(task="positioning", demos=1, journal=str(tmp_path))
    before = open(s.journal_path).read()
    rd, wr = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: report and leave without running Python's exit handlers
        code = "none"
        try:
            s.execute("select 0..1 in 0")
        except advise.AdviseError as e:
            code = e.code
        except BaseException as e:  # noqa: BLE001
            code = repr(e)
        try:
            s.close()  # the child's copy, put away without touching the parent's journal
        except BaseException as e:  # noqa: BLE001
            code += f" close: {e!r}"
        os.write(wr, code.encode())
        os._exit(0)
    os.close(wr)
    _, status = os.waitpid(pid, 0)
    code = os.read(rd, 1000).decode()
    os.close(rd)
    assert code == "advise::py::forked", code
    assert open(s.journal_path).read() == before
    assert os.path.exists(s.journal_path + ".lock"), "the child removed the parent's owner file"
    # The parent goes on, journalling, its journal still its own (locked).
    with pytest.raises(advise.AdviseError) as e:
        advise.Session.resume(s.journal_path, journal_dir=str(tmp_path))
    assert e.value.code == "advise::journal::locked", e.value.code
    s.execute("eval")
    assert len(open(s.journal_path).read()) > len(before)
    s.close()


def test_advise_errors_pickle_with_their_code_across_processes():
    with pytest.raises(advise.AdviseError) as e:
        advise.check("operator broken(")
    back = pickle.loads(pickle.dumps(e.value))
    assert type(back) is advise.AdviseError
    assert back.code == e.value.code and str(back) == str(e.value)
    assert [d.code for d in back.diagnostics] == [d.code for d in e.value.diagnostics]
    assert [d.span and (d.span.line, d.span.column) for d in back.diagnostics] == [
        d.span and (d.span.line, d.span.column) for d in e.value.diagnostics
    ]
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=ctx) as pool:
        future = pool.submit(advise.check, "operator broken(")
        with pytest.raises(advise.AdviseError) as remote:
            future.result(timeout=120)
    assert remote.value.code == e.value.code


def test_ctrl_c_during_a_long_statement_leaves_no_effect_or_keeps_its_reply(tmp_path):
    s = advise.Session(task="positioning", journal=str(tmp_path))
    before = len(s)
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    reply = None
    timer.start()
    try:
        reply = s.execute("load demos teacher:6000")
        time.sleep(2)  # the interrupt raised again after a finished statement comes here
    except KeyboardInterrupt:
        pass
    finally:
        timer.cancel()
    journal = open(s.journal_path).read()
    if reply is None:
        # Stopped: nothing changed, nothing journalled.
        assert len(s) == before
        assert "teacher:6000" not in journal
    else:
        # Finished before it saw the stop: kept, journalled, and its reply returned.
        assert len(s) > before and "teacher:6000" in journal
    s.close()


def crc64_xz(data):
    """CRC-64/XZ (what a journal names its sidecar by)."""
    table = []
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ 0xC96C5795D7870F42 if c & 1 else c >> 1
        table.append(c)
    crc = 0xFFFFFFFFFFFFFFFF
    for b in data:
        crc = table[(crc ^ b) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFFFFFFFFFF


def test_a_sidecar_whose_footer_lies_behind_a_matching_crc_is_refused_on_resume(tmp_path):
    table, _, _ = demos_table()
    pq.write_table(table, tmp_path / "d.parquet")
    jdir = tmp_path / "journals"
    with advise.Session(task="positioning", journal=str(jdir)) as s:
        s.execute(f"load demos {tmp_path / 'd.parquet'}")
        journal = s.journal_path
    lines = open(journal).read().splitlines()
    k = next(i for i, line in enumerate(lines) if '"demos_file"' in line)
    entry = json.loads(lines[k])
    side = jdir / entry["effect"]["sidecar"]["file"]
    meta = pq.ParquetFile(side).metadata.row_group(0).column(0)
    unc, comp = meta.total_uncompressed_size, meta.total_compressed_size
    patch_footer(
        side,
        b"\x16" + zigzag_varint(unc) + b"\x16" + zigzag_varint(comp),
        b"\x16" + zigzag_varint(unc) + b"\x16" + zigzag_varint(-1),
    )
    data = side.read_bytes()
    entry["effect"]["sidecar"]["bytes"] = len(data)
    entry["effect"]["sidecar"]["crc64"] = f"{crc64_xz(data):016x}"
    lines[k] = json.dumps(entry, separators=(",", ":"))
    open(journal, "w").write("\n".join(lines) + "\n")
    s = advise.Session.resume(journal, journal_dir=str(jdir / "new"))
    assert "advise::parquet::footer" in str(s.resumed["stopped"]) + s.resumed["text"], s.resumed
    s.close()
    r = subprocess.run(
        [ADVISE, "resume", journal], input="quit\n", capture_output=True, text=True, timeout=60,
        env={**os.environ, "ADVISE_HOME": str(jdir / "cli")},
    )
    assert "advise::parquet::footer" in r.stdout + r.stderr, r.stderr
    assert "panicked" not in r.stderr
