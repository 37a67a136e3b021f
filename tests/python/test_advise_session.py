"""advise.Session: the REPL's statements from Python, replies as dicts, the same text the REPL
prints; the CLI's journal (written here and resumed by `advise resume`, written by `advise run`
and resumed here), executions as arrays equal to the bit to what the journal holds, and tasks
declared in files as `--tasks FILE --task NAME` starts them."""

import json
import os
import re
import shutil
import subprocess

import pytest

import advise


def test_a_session_runs_advises_and_evaluates(tmp_path):
    s = advise.Session(task="positioning", backend="sim", seed=0, demos=3)
    assert len(s) > 0
    ran = s.execute("run goal 2 -1 0.5")
    assert ran["kind"] == "ran" and ran["execution"] == 0 and ran["points"] > 0
    assert ran["text"].startswith("execution 0: run goal 2 -1 0.5")
    sel = s.execute("select 20..40")
    assert sel["kind"] == "selected" and sel["chunk"] == (20, 40)
    adv = s.execute("advise slow_down(0.3)")
    assert adv["kind"] == "advised" and adv["added"] + adv["skipped"] == 20
    assert adv["invocation"] == "slow_down(rate = 0.3)"
    assert len(s) == adv["dataset"]


def test_replies_match_the_cli_transcript(tmp_path):
    # The same statements through `advise run` print the same text.
    statements = ["run goal 1.5 1 0", "select 10..30", "advise slow_down(0.5)"]
    (tmp_path / "s.adv").write_text("\n".join(statements) + "\n")
    out = subprocess.run(
        [os.environ["ADVISE_BIN"], "run", "s.adv", "--demos", "3", "--no-journal"],
        cwd=tmp_path, check=True, capture_output=True, text=True, timeout=120,
    ).stdout
    # Timings (`ready in 0.1 ms`) differ from run to run.
    out = re.sub(r"ready in [0-9.]+ (?:ms|µs)", "ready in _ ms", out)
    s = advise.Session(demos=3)
    for st in statements:
        reply = s.execute(st)
        first = re.sub(r"ready in [0-9.]+ (?:ms|µs)", "ready in _ ms", reply["text"].splitlines()[0])
        assert first in out, (first, out)


def test_a_failing_statement_raises_its_code():
    s = advise.Session()
    with pytest.raises(advise.AdviseError) as e:
        s.execute("run goal 1 1 0")  # no demonstrations yet
    assert e.value.code.startswith("advise::")
    with pytest.raises(advise.AdviseError) as e:
        advise.Session(task="docking")
    assert e.value.code == "advise::task::unknown_task"


# --- Journals, executions as arrays and declared tasks (the CLI's `advise run`, `advise resume`,
# `--tasks FILE --task NAME`), each compared with the CLI binary itself.

STANDOFF = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "tasks", "standoff.adv")
STANDOFF = os.path.abspath(STANDOFF)

# A script that records, selects, advises and critiques: every kind of effect a run journals.
SCRIPT = [
    "run goal 1.5 1 0",
    "select 10..30",
    "advise slow_down(0.5)",
    "select 40..60",
    "critique",
    "run goal 2 -1 0.5",
]


def cli(args, cwd, home=None, stdin=None):
    """The CLI binary's stdout (it must succeed), with ADVISE_HOME at `home` when given."""
    env = dict(os.environ)
    if home is not None:
        env["ADVISE_HOME"] = str(home)
    done = subprocess.run(
        [os.environ["ADVISE_BIN"], *args], cwd=cwd, env=env, input=stdin,
        capture_output=True, text=True, timeout=180,
    )
    assert done.returncode == 0, (args, done.stdout, done.stderr)
    return done.stdout


def timeless(text):
    """`text` without what varies from run to run (`ready in 0.1 ms`)."""
    return re.sub(r"ready in [0-9.]+ (?:ms|µs)", "ready in _ ms", text)


def journal_of(home):
    """The one journal in `home`: its path, and its header and entries parsed."""
    names = [n for n in os.listdir(home) if n.startswith("session-") and n.endswith(".jsonl")]
    assert len(names) == 1, names
    path = os.path.join(home, names[0])
    return path, read_journal(path)


def read_journal(path):
    """A journal's header and entries, parsed (JSON, not bytes: numbers compare as values)."""
    with open(path) as f:
        lines = [json.loads(line) for line in f]
    return lines[0], lines[1:]


def cli_journal(tmp_path, statements, extra_args=(), name="cli"):
    """`advise run` of `statements` with `--demos 3`, journalled into its own ADVISE_HOME:
    stdout, the journal's path, header and entries."""
    d = tmp_path / name
    d.mkdir()
    (d / "s.adv").write_text("\n".join(statements) + "\n")
    out = cli(["run", "s.adv", "--demos", "3", *extra_args], cwd=d, home=d / "home")
    path, (header, entries) = journal_of(d / "home")
    return out, path, header, entries


def cli_out_of(tmp_path, statements, extra_args=()):
    """`advise run` of `statements` with `--demos 3` and no journal: its stdout, timeless."""
    d = tmp_path / "whole"
    d.mkdir(exist_ok=True)
    (d / "s.adv").write_text("\n".join(statements) + "\n")
    out = cli(["run", "s.adv", "--demos", "3", "--no-journal", *extra_args], cwd=d)
    return timeless(out)


def task_args(task, tasks):
    """The CLI's arguments for `task` declared in `tasks`."""
    return ["--task", task] + [a for f in tasks for a in ("--tasks", f)]


# (task, task files, the statements): a positioning goal, an interception start (the ball), a
# declared task's goal values.
RUNS = [
    ("positioning", [], SCRIPT),
    ("interception", [], ["run start 2", "select 5..25", "advise slow_down(0.1)", "run start 3"]),
    ("standoff", [STANDOFF], ["run goal px=2 py=1", "select 5..25", "critique", "run start 1"]),
]


@pytest.mark.parametrize("task,tasks,statements", RUNS, ids=[r[0] for r in RUNS])
def test_the_journal_of_a_python_session_equals_the_clis(tmp_path, task, tasks, statements):
    _, _, cli_header, cli_entries = cli_journal(tmp_path, statements, task_args(task, tasks))
    s = advise.Session(task=task, tasks=tasks, demos=3, journal=str(tmp_path / "py"))
    for st in statements:
        s.execute(st)
    assert os.path.dirname(s.journal_path) == str(tmp_path / "py")
    header, entries = read_journal(s.journal_path)
    # The header differs only in when and by which process the journal was started.
    for h in (header, cli_header):
        assert h.pop("started_unix_s") > 0 and h.pop("pid") > 0
    assert header == cli_header
    # Effect for effect, statement for statement: the start (`--tasks FILE`, `--task NAME`,
    # `--demos N`) the same, the script's lines from `s.adv:N` in the CLI, `<python>` here.
    assert [e["effect"] for e in entries] == [e["effect"] for e in cli_entries]
    assert [e["statement"] for e in entries] == [e["statement"] for e in cli_entries]
    start = ["--tasks"] * len(tasks) + ["--task"] * bool(tasks) + ["--demos"]
    assert [e["origin"] for e in entries] == start + ["<python>"] * len(statements)
    assert [e["origin"] for e in cli_entries] == start + [
        f"s.adv:{i + 1}" for i in range(len(statements))
    ]


def test_a_python_journal_is_resumed_by_the_cli(tmp_path, monkeypatch):
    home = tmp_path / "home"
    monkeypatch.setenv("ADVISE_HOME", str(home))
    with advise.Session(demos=3, journal=True) as s:
        for st in SCRIPT[:3]:
            s.execute(st)
        path, status = s.journal_path, s.status
        assert os.path.dirname(path) == str(home)
    # Closed, the journal is unlocked: `advise resume` restores it, re-running nothing.
    with pytest.raises(advise.AdviseError) as e:
        s.status
    assert e.value.code == "advise::py::closed"
    out = cli(["resume", path], cwd=tmp_path, home=home, stdin="run goal 2 -1 0.5\nquit\n")
    assert f"resumed {path}: 4 statements restored; {status}\n" in out, out
    # Its next run is the one the session would have made (the run counter seeds it).
    alone = advise.Session(demos=3)
    for st in SCRIPT[:3]:
        alone.execute(st)
    ran = alone.execute("run goal 2 -1 0.5")
    assert timeless(ran["text"]).splitlines()[0] in timeless(out), out


def test_a_session_on_a_declared_task_resumes_both_ways(tmp_path):
    # The task file lives in a folder of its own, apart from the journals and the working folder.
    folder = tmp_path / "lab"
    folder.mkdir()
    task_file = folder / "standoff.adv"
    shutil.copy(STANDOFF, task_file)
    statements = ["run goal px=2 py=1", "select 5..25", "critique"]
    # Python writes it, the CLI resumes it.
    with advise.Session(task="standoff", tasks=str(task_file), demos=3, journal=str(tmp_path / "py")) as s:
        for st in statements:
            s.execute(st)
        path, status = s.journal_path, s.status
    out = cli(["resume", path], cwd=tmp_path, home=tmp_path / "h", stdin="quit\n")
    assert f"resumed {path}: " in out and f"statements restored; {status}\n" in out, out
    # The CLI writes it, Python resumes it.
    _, path, header, entries = cli_journal(tmp_path, statements, task_args("standoff", [str(task_file)]))
    assert header["task"] == "positioning" and entries[1]["effect"] == {"kind": "task", "task": "standoff"}
    r = advise.Session.resume(path, journal_dir=str(tmp_path / "elsewhere"))
    assert r.resumed["notes"] == [] and r.resumed["stopped"] is None
    assert r.status.startswith("task standoff, ") and r.executions == 1
    r.close()
    # A changed task file is named; the journalled text is what is restored.
    task_file.write_text(task_file.read_text() + "// edited\n")
    r = advise.Session.resume(path, journal_dir=str(tmp_path / "elsewhere"))
    assert len(r.resumed["notes"]) == 1 and f"`{task_file}` has changed" in r.resumed["notes"][0]
    assert r.status.startswith("task standoff, ")
    r.close()


def test_a_cli_journal_is_resumed_by_python(tmp_path):
    _, path, _, entries = cli_journal(tmp_path, SCRIPT[:4])
    # The CLI's own resume of a copy says what the state is.
    copy = tmp_path / "copy.jsonl"
    shutil.copy(path, copy)
    resumed_by_cli = cli(["resume", str(copy)], cwd=tmp_path, home=tmp_path / "h2", stdin="quit\n")
    s = advise.Session.resume(path, journal_dir=str(tmp_path / "elsewhere"))
    r = s.resumed
    assert r["path"] == path and r["entries"] == len(entries) == 5
    assert r["notes"] == [] and r["stopped"] is None
    assert r["text"] == f"resumed {path}: 5 statements restored; {s.status}"
    assert r["text"].replace(path, str(copy)) in resumed_by_cli
    assert s.executions == 1 and s.journal_path == path
    # The next statements give the CLI's replies for the whole script, line for line.
    whole = cli_out_of(tmp_path, SCRIPT)
    for st in SCRIPT[4:]:
        first = timeless(s.execute(st)["text"]).splitlines()[0]
        assert first in whole, (first, whole)
    # ...and are journalled into the same file, as `advise resume` journals.
    _, after = read_journal(path)
    assert [e["statement"] for e in after[5:]] == SCRIPT[4:]
    assert all(e["origin"] == "<python>" for e in after[5:])



def bits(x):
    """The float64 values of `x` as their bit patterns: equal only when equal to the bit."""
    import numpy as np

    return np.ascontiguousarray(np.asarray(x, dtype=np.float64)).view(np.uint64)


def assert_bits(a, b):
    assert a.shape == b.shape and (bits(a) == bits(b)).all()


def pose_rows(poses):
    import numpy as np

    return np.array([[p["x_m"], p["y_m"], p["theta_rad"]] for p in poses])


def provenance_json(p):
    """An advise.Provenance (or None) as the journal writes it."""
    if p is None:
        return None
    if p.kind == "demonstration":
        return {"demonstration": {"demo": p.id, "index": p.index}}
    return {"advice": {"advice": p.id, "index": p.index, "source": p.source}}


@pytest.mark.parametrize("task,tasks,statements", RUNS, ids=[r[0] for r in RUNS])
def test_executions_as_arrays_equal_the_clis_journal(tmp_path, task, tasks, statements):
    import numpy as np

    _, _, _, entries = cli_journal(tmp_path, statements, task_args(task, tasks))
    s = advise.Session(task=task, tasks=tasks, demos=3)
    for st in statements:
        s.execute(st)
    runs = [e["effect"] for e in entries if e["effect"]["kind"] == "execution"]
    assert s.executions == len(runs) == 2
    for i, want in enumerate(runs):
        got = s.execution(i)
        points = want["trace"]["points"]
        assert got["index"] == i and got["label"] == want["label"]
        assert_bits(got["observations"], np.array([p["z"] for p in points]))
        assert_bits(got["actions"], np.array([p["a"] for p in points]))
        assert_bits(got["t"], np.array([p["t"] for p in points]))
        assert_bits(got["pose"], np.array([p["pose"] for p in points]))
        run = want["run"]
        assert_bits(got["true_pose"], pose_rows(run["true_poses"]))
        if task == "interception":
            assert_bits(got["ball"], np.array(run["ball"]))
        else:
            assert got["ball"] is None and "ball" not in run
        assert got["outcome"] == run["outcome"]
        assert [provenance_json(p) for p in got["support"]] == run["support"]
        # Each step's supporting point, by its position in the dataset.
        assert got["support_points"].shape == (len(points),)
        assert (got["support_points"] >= 0).all() and (got["support_points"] < len(s)).all()
        goal = want.get("goal")
        assert got["goal"] == (None if goal is None else (goal["x_m"], goal["y_m"], goal["theta_rad"]))
        assert got["goal_values"] == want.get("goal_values")
        assert got["observations"].shape[1] == len(got["observation_names"])
        assert got["actions"].shape[1] == len(got["action_names"])
    # The chunks advised and critiqued, on the execution they were given on.
    first = s.execution(0)
    edits = [e["effect"] for e in entries if e["effect"]["kind"] in ("advice", "critique")]
    for e in edits:
        chunk = (e["applied"]["chunk"] if e["kind"] == "advice" else e["chunk"])
        listed = first["advised"] if e["kind"] == "advice" else first["flagged"]
        assert listed == [(chunk["start"], chunk["end"])]
    assert s.execution(-1)["label"] == s.execution(1)["label"] == runs[1]["label"]


def test_a_declared_task_session_replies_as_the_cli(tmp_path):
    statements = ["run goal px=2 py=1", "select 5..25", "advise creep(0.1)"]
    out = cli_out_of(tmp_path, statements, ["--tasks", STANDOFF, "--task", "standoff"])
    s = advise.Session(task="standoff", tasks=STANDOFF, demos=3)
    assert s.status.startswith("task standoff, backend sim, ")
    for st in statements:
        first = timeless(s.execute(st)["text"]).splitlines()[0]
        assert first in out, (first, out)
    assert s.execution(0)["observation_names"] == ["range", "bearing", "closing"]


def test_a_resumed_session_is_on_the_simulator_whatever_it_was_on(tmp_path):
    # A journal whose session connected to a robot (its `backend` line added as the CLI writes
    # it): the restore connects to nothing and says so; only `backend SPEC` would connect.
    with advise.Session(demos=2, journal=str(tmp_path)) as s:
        s.execute("run goal 1 1 0")
        path = s.journal_path
    line = {"statement": "backend rmp:127.0.0.1:9", "origin": "--backend",
            "effect": {"kind": "backend", "spec": "rmp:127.0.0.1:9"}}
    with open(path, "a") as f:
        f.write(json.dumps(line) + "\n")
    r = advise.Session.resume(path, journal_dir=str(tmp_path))
    assert r.status.startswith("task positioning, backend sim, ")
    assert r.resumed["entries"] == 3
    assert r.resumed["notes"] == [
        "the session was on `rmp:127.0.0.1:9`; it is on `sim` now, and nothing was driven: "
        "`backend rmp:127.0.0.1:9` connects again"
    ]


def test_a_damaged_journal_resumes_up_to_the_damage_in_a_new_journal(tmp_path):
    with advise.Session(demos=2, journal=tmp_path / "j") as s:  # a pathlib.Path too
        s.execute("run goal 1 1 0")
        s.execute("select 5..25")
        path = s.journal_path
    with open(path) as f:
        lines = f.readlines()
    lines[2] = lines[2].replace('"kind":"execution"', '"kind":"executed"')
    with open(path, "w") as f:
        f.writelines(lines)
    r = advise.Session.resume(path, journal_dir=str(tmp_path / "new"))
    assert r.resumed["entries"] == 1 and r.executions == 0
    assert r.resumed["stopped"].code == "advise::journal::damaged_line"
    assert r.resumed["stopped"].severity == "warning"
    assert r.journal_path != path and os.path.dirname(r.journal_path) == str(tmp_path / "new")
    assert r.resumed["notes"] == [f"this session continues in a new journal: {r.journal_path}"]


def error_of(call):
    """The AdviseError `call` raises: its first diagnostic."""
    with pytest.raises(advise.AdviseError) as e:
        call()
    assert e.value.code == e.value.diagnostics[0].code
    return e.value.diagnostics[0]


def test_what_a_session_refuses(tmp_path):
    d = error_of(lambda: advise.Session(task="standof", tasks=[STANDOFF]))
    assert (d.code, d.message, d.help) == (
        "advise::task::unknown_task", "unknown task `standof`", "did you mean `standoff`?"
    )
    missing = str(tmp_path / "missing.adv")
    d = error_of(lambda: advise.Session(task="standoff", tasks=[missing]))
    assert (d.code, d.message) == ("advise::file::read", f"cannot read `{missing}`")
    # A mistake in a file: every error of the check, each with its place.
    bad = tmp_path / "bad.adv"
    bad.write_text("operator zz(rate = 0.2 in [0, 1]) for standoff on action {\n  nope *= 2\n}\n")
    d = error_of(lambda: advise.Session(task="standoff", tasks=[STANDOFF, str(bad)]))
    assert (d.code, d.message) == (
        "advise::check::unknown_dimension", "`nope` is not a dimension of the `standoff` domain"
    )
    assert (d.span.file, d.span.line, d.span.column) == (str(bad), 2, 3)
    d = error_of(lambda: advise.Session(task="docking"))
    assert (d.code, d.message) == ("advise::task::unknown_task", "unknown task `docking`")
    d = error_of(lambda: advise.Session(task="standoff", tasks=3))
    assert (d.code, d.message) == ("advise::py::tasks", "`tasks` is 3, not a task file or a list of them")
    d = error_of(lambda: advise.Session(journal=42))
    assert (d.code, d.message) == ("advise::py::journal", "`journal` is 42, not a folder, True or None")
    (tmp_path / "a-file").write_text("")
    d = error_of(lambda: advise.Session(journal=str(tmp_path / "a-file")))
    assert (d.code, d.message) == (
        "advise::journal::create", f"cannot create a session journal in `{tmp_path / 'a-file'}`"
    )
    assert sorted(os.listdir(tmp_path)) == ["a-file", "bad.adv"]

    s = advise.Session(demos=2)
    s.execute("run goal 1 1 0")
    for i in (1, -2):
        d = error_of(lambda: s.execution(i))
        assert (d.code, d.message) == (
            "advise::py::no_execution",
            f"there is no execution {i}: the session holds 1 (task positioning)",
        )
    assert s.journal_path is None and s.resumed is None
    s.close()
    s.close()
    for use in (lambda: s.execute("show"), lambda: s.execution(0), lambda: len(s)):
        d = error_of(use)
        assert (d.code, d.message) == ("advise::py::closed", "the session is closed")


def test_what_a_resume_refuses(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    d = error_of(lambda: advise.Session.resume(journal_dir=str(empty)))
    assert (d.code, d.message) == (
        "advise::resume::no_journal", f"there is no session journal in {empty}"
    )
    none = tmp_path / "none.jsonl"
    d = error_of(lambda: advise.Session.resume(str(none), journal_dir=str(empty)))
    assert (d.code, d.message) == ("advise::file::read", f"cannot read `{none}`")
    notes = tmp_path / "notes.jsonl"
    notes.write_text("hello\n")
    d = error_of(lambda: advise.Session.resume(str(notes), journal_dir=str(empty)))
    assert (d.code, d.message) == (
        "advise::journal::header",
        f"`{notes}` does not start with a journal header: expected value at line 1 column 1",
    )
    # A journal a live session holds is refused, naming its owner (this process).
    live = advise.Session(journal=str(tmp_path / "held"))
    d = error_of(lambda: advise.Session.resume(live.journal_path, journal_dir=str(empty)))
    assert d.code == "advise::journal::locked" and f"process {os.getpid()}" in d.message
    # Without a path, the newest journal of the folder: this one, once its session is closed.
    live.close()
    again = advise.Session.resume(journal_dir=str(tmp_path / "held"))
    assert again.resumed["entries"] == 0 and again.journal_path == live_path(tmp_path / "held")


def live_path(folder):
    (name,) = [n for n in os.listdir(folder) if n.endswith(".jsonl")]
    return str(folder / name)


def test_demonstrations_from_a_file_resume_from_the_journals_sidecar(tmp_path):
    # `load demos FILE` in a journalled session writes its points beside the journal (a sidecar):
    # the file may change or go; the resumed session, here and in the CLI, has the same points.
    cli(["demo", "--task", "positioning", "--count", "3", "--out", "demos.csv"], cwd=tmp_path)
    with advise.Session(journal=str(tmp_path / "j")) as s:
        s.execute(f"load demos {tmp_path / 'demos.csv'}")
        s.execute("run goal 1 1 0")
        path, status, points = s.journal_path, s.status, len(s)
        run = s.execution(0)
    os.remove(tmp_path / "demos.csv")
    out = cli(["resume", path], cwd=tmp_path, home=tmp_path / "j", stdin="quit\n")
    assert f"resumed {path}: 2 statements restored; {status}\n" in out, out
    r = advise.Session.resume(path, journal_dir=str(tmp_path / "j"))
    assert r.resumed["entries"] == 2 and len(r) == points and r.status == status
    again = r.execution(0)
    for k in ("observations", "actions", "t", "pose", "true_pose"):
        assert_bits(again[k], run[k])


def test_a_statement_lets_other_python_threads_run():
    # A statement of some 0.3 s (teacher demonstrations recorded in the simulator, as many as
    # take that long here) in another thread while this one notes each time it gets to run: were
    # the GIL held through the statement, this thread could not run between its start and its
    # end. Meanwhile the session refuses this thread rather than make it wait.
    import threading
    import time

    s = advise.Session(demos=0)
    started = time.perf_counter()
    s.execute("load demos teacher:10")
    per_demo = (time.perf_counter() - started) / 10
    count = int(min(max(0.3 / per_demo, 10), 10_000))
    span = {}

    def work():
        span["start"] = time.perf_counter()
        span["reply"] = s.execute(f"load demos teacher:{count}")
        span["end"] = time.perf_counter()

    ticks, busy = [], []
    worker = threading.Thread(target=work)
    worker.start()
    while worker.is_alive() and len(ticks) < 50_000_000:
        ticks.append(time.perf_counter())
        if not busy and "start" in span:
            try:
                s.status
            except advise.AdviseError as e:
                busy.append(e.diagnostics[0])
    worker.join(timeout=120)
    assert span["reply"]["text"].startswith(f"loaded {count} demonstrations"), span["reply"]
    took = span["end"] - span["start"]
    assert took > 0.05, took
    inside = [span["start"]] + [t for t in ticks if span["start"] < t < span["end"]] + [span["end"]]
    longest = max(b - a for a, b in zip(inside, inside[1:]))
    assert longest < 0.5 * took, (longest, took, len(inside))
    assert [(d.code, d.message) for d in busy] == [
        ("advise::py::busy", "the session is running a statement in another thread")
    ]
    # Free again once the statement is done.
    assert s.status.startswith("task positioning, backend sim, ")


def test_an_opened_datasets_runs_keep_their_goals(tmp_path):
    # Positioning's goal pose and a declared task's goal values are saved with the run, and
    # `open` gives the runs back with them (plots draw them); a goal edited out of range is
    # refused as a run's goal is.
    s = advise.Session(demos=3)
    s.execute("run goal 2 -1 0.5")
    s.execute("select 10..30")
    s.execute("advise slow_down(0.3)")
    s.execute(f"save {tmp_path / 'p.json'}")
    saved = json.loads((tmp_path / "p.json").read_text())
    assert saved["executions"][0]["goal"] == [2, -1, 0.5]
    o = advise.Session()
    o.execute(f"open {tmp_path / 'p.json'}")
    assert o.execution(0)["goal"] == (2.0, -1.0, 0.5) and o.execution(0)["goal_values"] is None
    tasks = os.path.abspath("examples/tasks/standoff.adv")
    st = advise.Session(task="standoff", tasks=tasks, demos=2)
    ran = st.execute("run start 0")
    st.execute(f"save {tmp_path / 's.json'}")
    values = st.execution(0)["goal_values"]
    assert values and json.loads((tmp_path / "s.json").read_text())["executions"][0]["goal"] == values
    so = advise.Session(task="standoff", tasks=tasks)
    so.execute(f"open {tmp_path / 's.json'}")
    assert so.execution(0)["goal_values"] == values and so.execution(0)["goal"] is None
    saved["executions"][0]["goal"] = [2, -1]
    (tmp_path / "bad.json").write_text(json.dumps(saved))
    with pytest.raises(advise.AdviseError) as e:
        advise.Session().execute(f"open {tmp_path / 'bad.json'}")
    assert e.value.code == "advise::session::bad_goal"
    saved["executions"][0]["goal"] = [2, -1, 99]
    (tmp_path / "bad.json").write_text(json.dumps(saved))
    with pytest.raises(advise.AdviseError) as e:
        advise.Session().execute(f"open {tmp_path / 'bad.json'}")
    assert e.value.code == "advise::session::bad_goal"


def test_ctrl_c_stops_a_run_on_a_real_base_and_keeps_the_execution():
    # A run on `advise rmp-emulator` (a Segway RMP on the loopback address, driven in real time),
    # interrupted by SIGINT after 1.5 s: the statement ends within moments with the signal's
    # exception, and the run so far is kept, marked interrupted, as at the REPL.
    import signal
    import threading
    import time

    emu = subprocess.Popen([os.environ["ADVISE_BIN"], "rmp-emulator", "--bind", "127.0.0.1:0"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        addr = re.search(r" on (127\.0\.0\.1:\d+)", emu.stdout.readline()).group(1)
        s = advise.Session(backend=f"rmp:{addr}", demos=9)

        class Interrupted(Exception):
            pass

        def handler(signum, frame):
            raise Interrupted()

        old = signal.signal(signal.SIGINT, handler)
        timer = threading.Timer(1.5, lambda: os.kill(os.getpid(), signal.SIGINT))
        try:
            started = time.perf_counter()
            timer.start()
            with pytest.raises(Interrupted):
                s.execute("run goal 3 1 0")
            took = time.perf_counter() - started
        finally:
            timer.cancel()
            signal.signal(signal.SIGINT, old)
        assert 1.4 < took < 3.5, took
        run = s.execution(-1)
        assert run["label"] == "run goal 3 1 0 (interrupted)", run["label"]
        # Some 1.5 s of 50 Hz control steps, not the whole run.
        assert 30 < len(run["t"]) < 150, len(run["t"])
        s.close()
    finally:
        emu.terminate()
        emu.wait(timeout=10)


def test_suggest_returns_structured_suggestions_that_accept_gives():
    s = advise.Session(demos=9)
    s.execute("run start 2")
    sug = s.suggest(budget_s=600)
    assert sug["execution"] == 0
    assert sug["trial"]["kind"] == "simulated"
    assert sug["flawed"] and all(f["flaws"] for f in sug["flawed"])
    first = sug["suggestions"][0]
    assert first["number"] == 1
    assert first["after"]["error"] < sug["trial"]["before"]["error"] or first["after"]["success"]
    assert first["invocation"] in sug["text"]
    reply = s.execute("accept 1")
    assert reply["kind"] == "advised"
    assert reply["invocation"] == first["invocation"]
    assert reply["chunk"] == (first["chunk"]["start"], first["chunk"]["end"])
    assert reply["conflict"] is None


def test_suggest_on_a_task_without_flaws_raises_its_code():
    s = advise.Session(task="interception", demos=3)
    s.execute("run start 0")
    with pytest.raises(advise.AdviseError) as e:
        s.suggest()
    assert e.value.code == "advise::session::no_flaws"
def test_a_takeover_from_python_is_a_linked_demonstration_and_resumes(tmp_path):
    """Issue 53: `run ... takeover A..B` from Python; the reply lists the window, the execution
    marks it, `why` names the takeover, and a resumed session has it back without driving."""
    s = advise.Session(demos=9, journal=str(tmp_path))
    r = s.execute("run goal 2 -1 0.5 takeover 2..4")
    assert r["kind"] == "ran"
    assert r["takeovers"] == [
        {"steps": (60, 120), "from_s": 2.0, "to_s": 4.0, "points": 30, "number": 1}
    ]
    assert "the teacher drove from 2.00 s to 4.00 s" in r["text"]
    e = s.execution(-1)
    assert e["teacher"] == [(60, 120)]
    assert "from takeover #1" in s.execute("why 64")["text"]
    n = len(s)
    path = s.journal_path
    s.close()
    back = advise.Session.resume(path, journal_dir=str(tmp_path))
    assert len(back) == n
    assert back.execution(-1)["teacher"] == [(60, 120)]
    assert "#1 takeover of execution 0" in back.execute("history")["text"]
    assert back.execute("undo")["text"].startswith("undid: #1 takeover")
    assert len(back) == n - 30
    # Holding the pad needs a robot's run to act on; values off the pad are refused at once.
    back.take_over(0.5, 0.0)
    back.hand_back()
    with pytest.raises(advise.AdviseError) as err:
        back.take_over(2.0, 0.0)
    assert err.value.code == "advise::py::takeover"
    back.close()
