#!/usr/bin/env python3
"""Maximum one-to-one boundary matching: motionlab-eval against scipy, in one run.

For each size n, draws n found frames and n truth frames uniform over 10·n frames with a
tolerance of 20 frames (the bipartite graph of `|a − r| <= tol`), then
  - times scipy.sparse.csgraph.maximum_bipartite_matching (Hopcroft–Karp, Cython) on the
    prebuilt sparse biadjacency matrix, best of the repeats;
  - runs `cargo run --release -p motionlab-eval --example matching_timing` on the same
    instance, which times motionlab's point–interval sweep and its Hopcroft–Karp;
  - checks that all three matchings have the same size (an independent check of maximality
    at sizes exhaustive search cannot reach) and prints the time ratios.

Run from anywhere: bench/matching_vs_scipy.py  (uses bench/setup_venv.sh's interpreter).
"""
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.sparse import csr_matrix  # noqa: E402
from scipy.sparse.csgraph import maximum_bipartite_matching  # noqa: E402

TOL = 20
REPEATS = 20


def instance(n, seed):
    rng = np.random.default_rng(seed)
    found = rng.integers(0, 10 * n, n)
    truth = rng.integers(0, 10 * n, n)
    return found, truth


def biadjacency(found, truth):
    order = np.argsort(truth, kind="stable")
    s = truth[order]
    lo = np.searchsorted(s, found - TOL, side="left")
    hi = np.searchsorted(s, found + TOL, side="right")
    counts = hi - lo
    rows = np.repeat(np.arange(len(found)), counts)
    cols = np.concatenate([order[a:b] for a, b in zip(lo, hi)]) if counts.sum() else np.array([], int)
    data = np.ones(len(rows), dtype=np.int8)
    return csr_matrix((data, (rows, cols)), shape=(len(found), len(truth)))


def scipy_best(graph):
    best, pairs = float("inf"), 0
    for _ in range(REPEATS):
        t = time.perf_counter()
        m = maximum_bipartite_matching(graph, perm_type="column")
        best = min(best, (time.perf_counter() - t) * 1e6)
        pairs = int((m >= 0).sum())
    return pairs, best


def main():
    env = dict(os.environ)
    subprocess.run(
        ["cargo", "build", "--release", "--quiet", "-p", "motionlab-eval", "--example", "matching_timing"],
        cwd=ROOT, check=True, env=env,
    )
    target = env.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    exe = os.path.join(target, "release", "examples", "matching_timing")
    print(f"scipy {scipy.__version__}, numpy {np.__version__}; tolerance {TOL} frames; best of {REPEATS}")
    print("| n found = n truth | pairs | scipy HK (µs) | motionlab sweep (µs) | motionlab HK (µs) | scipy / sweep | scipy / HK |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    ok = True
    for n in (1_000, 10_000, 100_000):
        found, truth = instance(n, seed=n)
        graph = biadjacency(found, truth)
        pairs_scipy, us_scipy = scipy_best(graph)
        with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
            f.write(f"{TOL}\n{' '.join(map(str, found))}\n{' '.join(map(str, truth))}\n")
            path = f.name
        try:
            out = subprocess.run([exe, path, str(REPEATS)], check=True, capture_output=True, text=True).stdout.split()
        finally:
            os.unlink(path)
        pairs_sweep, pairs_hk, us_sweep, us_hk = int(out[0]), int(out[1]), float(out[2]), float(out[3])
        if not pairs_scipy == pairs_sweep == pairs_hk:
            ok = False
        print(f"| {n} | {pairs_sweep} (scipy {pairs_scipy}, HK {pairs_hk}) | {us_scipy:.1f} | {us_sweep:.1f} | {us_hk:.1f} | "
              f"{us_scipy / us_sweep:.1f}× | {us_scipy / us_hk:.1f}× |")
    if not ok:
        print("MISMATCH: matching sizes differ", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
