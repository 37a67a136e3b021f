"""advise.fmt and advise.test against `advise fmt` and `advise test` on the same files."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

import advise

ADVISE = os.environ["ADVISE_BIN"]
FILES = ["operators/positioning.adv", "operators/interception.adv", "examples/tasks/standoff.adv",
         "examples/sessions/positioning.adv", "examples/sessions/interception.adv"]
MESSY = """///   Creep forward.
///   Example: creep(0.2) on {trans: 0.5} gives {trans: 0.2}
operator   creep(speed=0.1 in [0,1]) for positioning on action {trans=speed}
/// Example: creep on {trans: 0.5} gives {trans: 0.3}
operator still for positioning on action { trans = 0  rot = 0 }
"""


def cli(*args, cwd=None):
    return subprocess.run([ADVISE, *args], cwd=cwd, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("path", FILES + ["messy"])
def test_fmt_equals_what_advise_fmt_writes(path, tmp_path):
    copy = tmp_path / "f.adv"
    if path == "messy":
        copy.write_text(MESSY)
    else:
        shutil.copy(path, copy)
    before = copy.read_text()
    ours = advise.fmt(str(copy))
    assert copy.read_text() == before  # fmt does not write
    assert advise.fmt(before) == ours  # text and path alike
    cli("fmt", str(copy)).check_returncode()
    assert ours == copy.read_text()
    if path == "messy":
        assert ours != before


def test_fmt_refuses_what_is_not_operators_nor_a_script():
    with pytest.raises(advise.AdviseError) as e:
        advise.fmt("operator x for positioning on action {\n")
    assert e.value.code.startswith("advise::"), e.value.code
    assert e.value.diagnostics[0].span is not None


def counts(stdout):
    m = re.search(r"(\d+) examples?, (\d+) failed", stdout)
    assert m, stdout
    return int(m.group(1)), int(m.group(2))


@pytest.mark.parametrize("path", [None, "operators/positioning.adv", "operators/interception.adv"])
def test_test_counts_equal_advise_test(path):
    results = advise.test(path) if path else advise.test()
    out = cli("test", *([path] if path else []))
    assert counts(out.stdout) == (len(results), sum(not r.passed for r in results))
    assert results and all(isinstance(r, advise.TestResult) for r in results)
    assert all(r.passed and r.message is None for r in results)
    assert all(r.example.startswith("Example:") for r in results)


def test_test_reports_a_failing_example_as_the_cli_does(tmp_path):
    f = tmp_path / "ops.adv"
    f.write_text(MESSY)
    results = advise.test(str(f))
    out = cli("test", str(f))
    assert out.returncode != 0
    assert counts(out.stdout) == (2, 1)
    ok, bad = results
    assert ok.passed and ok.name == "positioning/creep" and ok.line == 2 and bool(ok)
    assert not bad.passed and bad.name == "positioning/still" and bad.line == 4
    assert bad.diagnostic.code == "advise::test::failed"
    assert bad.file == str(f)
    # The CLI prints the same diagnostic (modulo colour and layout).
    assert "advise::test::failed" in out.stdout + out.stderr
    assert bad.diagnostic.message in (out.stdout + out.stderr).replace("\n", " ") or \
        "does not hold" in bad.message
    assert advise.test(MESSY)[1].file == "<text>"


def test_test_raises_when_the_operators_do_not_check():
    with pytest.raises(advise.AdviseError) as e:
        advise.test("operator x for positioning on action { trans = nope }")
    assert e.value.code == "advise::check::unknown_name"
