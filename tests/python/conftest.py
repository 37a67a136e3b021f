"""Shared fixtures of the package's pytest files (tests/python_pkg.rs runs them). Other pytest
runs load this file too (tests/lsp.rs's, in a venv without numpy): import only the standard
library and pytest at the top."""

import json
import os
import subprocess

import pytest


@pytest.fixture(scope="session")
def scripted_session(tmp_path_factory):
    """``run(script, name)``: in a new folder, four teacher demonstrations recorded by
    ``advise demo`` as ``demos.csv``, then ``script`` (which saves ``out.json``) run by
    ``advise run``. Gives the folder, the run's stdout, the saved dataset, and each execution's
    observations and actions as arrays."""
    import numpy as np

    advise_bin = os.environ["ADVISE_BIN"]

    def run(script, name):
        d = tmp_path_factory.mktemp(name)
        subprocess.run(
            [advise_bin, "demo", "--task", "positioning", "--count", "4", "--out", "demos.csv"],
            cwd=d, check=True, capture_output=True, timeout=120,
        )
        (d / "s.adv").write_text(script)
        out = subprocess.run(
            [advise_bin, "run", "s.adv", "--demos", "0", "--no-journal"],
            cwd=d, check=True, capture_output=True, text=True, timeout=120,
        ).stdout
        saved = json.loads((d / "out.json").read_text())
        runs = [
            (np.array([p["z"] for p in e["points"]]), np.array([p["a"] for p in e["points"]]))
            for e in saved["executions"]
        ]
        return d, out, saved, runs

    return run


@pytest.fixture(scope="session")
def experiment_cli():
    """``experiment_cli(*args)``: what ``advise experiment ARGS --json`` prints, parsed."""
    advise_bin = os.environ["ADVISE_BIN"]

    def run(*args):
        out = subprocess.run([advise_bin, "experiment", *args, "--json"], check=True,
                             capture_output=True, timeout=600)
        return json.loads(out.stdout)

    return run
