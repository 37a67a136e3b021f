"""Every ```python block of README.md runs as written (issue 49: a document's example is one a test
runs). The blocks run in order in one namespace, as a reader pastes them into one Python, in a
fresh Python process whose working directory is a new folder holding what they name: an operator
file of one's own (``my_ops.adv``), the docking task (``dock.adv``), teacher demonstrations
(``demos.csv``), a rosbag2 bag of a namespaced robot (``run1/``), a LeRobot dataset
(``path/to/dataset``), and ``$ADVISE_HOME`` for the journal. A traceback names the README's line."""

import json
import os
import re
import shutil
import subprocess
import sys

ADVISE = os.environ["ADVISE_BIN"]
HERE = os.path.dirname(os.path.abspath(__file__))
README = os.path.join(HERE, "..", "..", "README.md")

# The blocks run in order in one namespace; each is compiled under the README's name at its own
# line, so a failure points at the README.
RUNNER = r"""
import json, re, sys
text = open(sys.argv[1]).read()
namespace = {"__name__": "__main__"}
for m in re.finditer(r"^```python\n(.*?)^```", text, re.M | re.S):
    line = text.count("\n", 0, m.start(1))
    code = compile("\n" * line + m.group(1), "README.md", "exec")
    print(f"README.md:{line + 1}: running", flush=True)
    exec(code, namespace)
# What the README's Ray example mapped over seeds, for the test to hold against the command line.
with open("ray_results.json", "w") as f:
    json.dump(namespace.get("results"), f)
print("all blocks ran", flush=True)
"""

MY_OPS = """\
/// Ease off the speed only, keeping the turn rate.
/// Example: ease_off(0.5) on {trans: 0.4, rot: 0.2} gives {trans: 0.2, rot: 0.2}
operator ease_off(rate = 0.25 in [0, 1]) for positioning on action where trans != 0 {
  trans *= 1 - rate
}
"""


def python_blocks(text):
    return re.findall(r"^```python\n(.*?)^```", text, re.M | re.S)


def folder(d):
    """What the README's blocks name, made in `d`."""
    run = lambda *args, **kw: subprocess.run(args, cwd=d, check=True, capture_output=True,
                                              timeout=300, **kw)
    shutil.copy(os.path.join(HERE, "dock.adv"), d / "dock.adv")
    (d / "my_ops.adv").write_text(MY_OPS)
    run(ADVISE, "demo", "--task", "positioning", "--count", "4", "--out", "demos.csv")
    run(sys.executable, os.path.join(HERE, "bags.py"), "rosbags", "namespaced", str(d / "run1"))
    (d / "s.adv").write_text("save s.json\n")
    run(ADVISE, "run", "--demos", "2", "--no-journal", "s.adv")
    (d / "path" / "to").mkdir(parents=True)
    run(ADVISE, "export", "s.json", "--lerobot", "path/to/dataset")
    (d / "home").mkdir()


def test_the_readme_has_python_blocks():
    with open(README) as f:
        blocks = python_blocks(f.read())
    assert len(blocks) >= 4
    assert any("tasks=" in b and "LWR(" in b for b in blocks), "the declared task from Python"


def test_every_python_block_of_the_readme_runs_as_written(tmp_path, experiment_cli):
    folder(tmp_path)
    env = dict(os.environ, ADVISE_HOME=str(tmp_path / "home"), MPLBACKEND="Agg")
    env.pop("PYTHONPATH", None)
    out = subprocess.run([sys.executable, "-c", RUNNER, os.path.abspath(README)], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-6000:]
    assert out.stdout.rstrip().endswith("all blocks ran")
    # The journal went where the block's `journal=True` and $ADVISE_HOME say.
    assert any(p.suffix == ".jsonl" for p in (tmp_path / "home").rglob("*"))
    # The Ray example (a local cluster on loopback) mapped the A-OPI study over seeds 0 and 1:
    # what `advise experiment aopi --seed N --practice 3 --json` prints, to the bit.
    with open(tmp_path / "ray_results.json") as f:
        results = json.load(f)
    assert results == [experiment_cli("aopi", "--seed", str(seed), "--practice", "3")
                       for seed in range(2)]
