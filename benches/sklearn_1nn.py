#!/usr/bin/env python3
"""scikit-learn's single-query 1-NN rate on the policy bench's data, for the README's comparison.

Run from the repository root:

    ADVISE_BENCH_CSV=1 cargo bench --bench policy -- 'policy/bc'   # writes target/bench-data/
    python3 benches/sklearn_1nn.py

The points (100,000 6-D interception observations) and the 1,000 queries are the ones
`policy/bc_query_100k` uses, range-scaled as the learner scales them (each dimension divided by its
range over the points). Each query is `KDTree.query(x.reshape(1, -1), k=1)`, one at a time, as a
robot loop would ask. scikit-learn and numpy are installed, at pinned versions, into a venv under
target/ on the first run and reused afterwards. No weights: this is plain 1-NN, the work the BC
query does when its nearest point is unpenalised.
"""

import os
import subprocess
import sys
import time
import venv

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VENV = os.path.join(ROOT, "target", "sklearn-venv")
DATA = os.path.join(ROOT, "target", "bench-data")
PINS = ["numpy==2.2.6", "scikit-learn==1.6.1"]


def in_venv():
    """Re-run this script under the venv's interpreter, creating the venv first if needed."""
    py = os.path.join(VENV, "bin", "python")
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        return
    if not os.path.exists(py):
        venv.create(VENV, with_pip=True)
        subprocess.check_call([py, "-m", "pip", "install", "--quiet", *PINS])
    os.execv(py, [py, os.path.abspath(__file__), *sys.argv[1:]])


def main():
    in_venv()
    import numpy as np
    import sklearn
    from sklearn.neighbors import KDTree

    points_csv = os.path.join(DATA, "policy_points.csv")
    queries_csv = os.path.join(DATA, "policy_queries.csv")
    if not os.path.exists(points_csv):
        sys.exit(
            f"{points_csv} is missing: run `ADVISE_BENCH_CSV=1 cargo bench --bench policy -- 'policy/bc'` first"
        )
    points = np.loadtxt(points_csv, delimiter=",", ndmin=2)
    queries = np.loadtxt(queries_csv, delimiter=",", ndmin=2)
    span = points.max(axis=0) - points.min(axis=0)
    scale = np.where(span > 1e-12, 1.0 / np.where(span > 1e-12, span, 1.0), 1.0)
    points *= scale
    queries *= scale

    tree = KDTree(points)  # leaf_size 40, scikit-learn's default
    for x in queries[:100]:  # warm up
        tree.query(x.reshape(1, -1), k=1)
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        for x in queries:
            tree.query(x.reshape(1, -1), k=1)
        best = min(best, time.perf_counter() - start)
    rate = len(queries) / best
    print(
        f"scikit-learn {sklearn.__version__} (numpy {np.__version__}) KDTree, "
        f"{len(points)} points, {points.shape[1]}-D: {rate:,.0f} single 1-NN queries/s "
        f"(best of 5 passes over {len(queries)} queries)"
    )


if __name__ == "__main__":
    main()
