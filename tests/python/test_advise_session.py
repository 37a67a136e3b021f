"""advise.Session: the REPL's statements from Python, replies as dicts, the same text the REPL
prints."""

import os
import re
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
    out = re.sub(r"ready in [0-9.]+ ms", "ready in _ ms", out)
    s = advise.Session(demos=3)
    for st in statements:
        reply = s.execute(st)
        first = re.sub(r"ready in [0-9.]+ ms", "ready in _ ms", reply["text"].splitlines()[0])
        assert first in out, (first, out)


def test_a_failing_statement_raises_its_code():
    s = advise.Session()
    with pytest.raises(advise.AdviseError) as e:
        s.execute("run goal 1 1 0")  # no demonstrations yet
    assert e.value.code.startswith("advise::")
    with pytest.raises(advise.AdviseError) as e:
        advise.Session(task="docking")
    assert e.value.code == "advise::py::unknown_task"
