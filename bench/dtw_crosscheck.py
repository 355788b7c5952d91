#!/usr/bin/env python3
"""Cross-check of motionlab-match's DP kernels against independent implementations.

On random 3-D series (seeded), compares
  * our full DTW (both ends anchored, local cost = euclidean distance, summed along the path)
    with dtaidistance ``dtw_ndim.distance(..., inner_dist='euclidean', use_c=True)`` and
    ``dtw_ndim.warping_path`` (with ``inner_dist='euclidean'`` dtaidistance sums euclidean
    distances and returns that sum, not its square root: its ``result`` transform is the
    identity for this inner distance), and with tslearn
    ``dtw_path_from_metric(metric='euclidean')``;
  * our free-start/free-end subsequence DP, h(j) for every end j, with a brute force: the
    minimum over every start a <= j of a full DTW (dtaidistance, C) of the model against
    T[a..=j];
  * our backward pass anchored at b, the cost of every start a, with the full DTW of the model
    against T[a..=b].

Our side runs through ``cargo run --release -p motionlab-match --example dtw_json``.
Prints the max relative difference per comparison; exits non-zero if any is >= 1e-9 or a path
is not a valid optimal warping path.

Usage: bench/dtw_crosscheck.py [--cases N] [--seed S]
"""
import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()

import numpy as np  # noqa: E402
from dtaidistance import dtw_ndim  # noqa: E402
from tslearn.metrics import dtw_path_from_metric  # noqa: E402

TOL = 1e-9


def rel(a, b):
    return abs(a - b) / max(abs(b), 1e-300) if a != b else 0.0


def path_cost(s, t, path):
    i = np.array([p[0] for p in path])
    j = np.array([p[1] for p in path])
    return float(np.sqrt(((s[i] - t[j]) ** 2).sum(axis=1)).sum())


def valid_path(path, start, end):
    if [tuple(p) for p in path[:1]] != [start] or [tuple(p) for p in path[-1:]] != [end]:
        return False
    return all((b[0] - a[0], b[1] - a[1]) in ((1, 1), (1, 0), (0, 1)) for a, b in zip(path, path[1:]))


def dtai(s, t):
    return dtw_ndim.distance(s, t, inner_dist="euclidean", use_c=True)


def run_ours(cases):
    payload = json.dumps([{"model": c["model"].tolist(), "target": c["target"].tolist(), "end": c["end"]} for c in cases])
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "motionlab-match", "--example", "dtw_json"]
    out = subprocess.run(cmd, input=payload, capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        sys.exit(f"dtw_json failed:\n{out.stderr}")
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=300)
    ap.add_argument("--seed", type=int, default=20240601)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    cases = []
    for k in range(args.cases):
        # Small sizes for the brute force; the first cases cover the 1-frame edges.
        n = [1, 1, 4, 1][k] if k < 4 else int(rng.integers(1, 16))
        m = [1, 5, 1, 9][k] if k < 4 else int(rng.integers(1, 31))
        scale = 10.0 ** rng.uniform(-1, 3)  # 0.1 mm .. 1 m
        s = rng.normal(size=(n, 3)) * scale
        t = rng.normal(size=(m, 3)) * scale
        cases.append({"model": s, "target": t, "end": int(rng.integers(0, m))})
    ours = run_ours(cases)

    worst = {k: 0.0 for k in ("full vs dtaidistance", "full vs tslearn", "full path cost", "subsequence h(j) vs brute force",
                              "subsequence path cost", "anchored cost(a) vs full DTW on T[a..=b]")}
    same_path = {"dtaidistance (use_c=False)": 0, "tslearn": 0}
    c_path_off = c_path_is_sq = c_path_costlier = 0
    failures = []
    for k, (c, o) in enumerate(zip(cases, ours)):
        s, t, b = c["model"], c["target"], c["end"]
        n, m = len(s), len(t)
        ref = dtai(s, t)
        worst["full vs dtaidistance"] = max(worst["full vs dtaidistance"], rel(o["full_cost"], ref))
        tl_path, tl_cost = dtw_path_from_metric(s, t, metric="euclidean")
        worst["full vs tslearn"] = max(worst["full vs tslearn"], rel(o["full_cost"], float(tl_cost)))
        ours_path = [tuple(p) for p in o["full_path"]]
        if not valid_path(ours_path, (0, 0), (n - 1, m - 1)):
            failures.append(f"case {k}: full path is not a warping path")
        worst["full path cost"] = max(worst["full path cost"], rel(path_cost(s, t, ours_path), ref))
        # dtaidistance's Python path honours inner_dist; its C path (use_c=True) does not in
        # 2.5.1: it returns the squared-euclidean path (see the count printed below).
        dt_path = [tuple(p) for p in dtw_ndim.warping_path(s, t, inner_dist="euclidean", use_c=False)]
        same_path["dtaidistance (use_c=False)"] += ours_path == dt_path
        same_path["tslearn"] += ours_path == [tuple(p) for p in tl_path]
        dt_c_path = [tuple(p) for p in dtw_ndim.warping_path(s, t, inner_dist="euclidean", use_c=True)]
        if dt_c_path != ours_path:
            c_path_off += 1
            sq_path = [tuple(p) for p in dtw_ndim.warping_path(s, t, use_c=False)]
            c_path_is_sq += dt_c_path == sq_path
            c_path_costlier += path_cost(s, t, dt_c_path) > ref * (1 + TOL)

        # h(j) = min over a <= j of DTW(S, T[a..=j]).
        brute = [min(dtai(s, t[a:j + 1]) for a in range(j + 1)) for j in range(m)]
        worst["subsequence h(j) vs brute force"] = max(
            worst["subsequence h(j) vs brute force"], max(rel(x, y) for x, y in zip(o["end_costs"], brute)))
        if o["sub_end"] != int(np.argmin(brute)) and rel(brute[o["sub_end"]], min(brute)) >= TOL:
            failures.append(f"case {k}: subsequence end {o['sub_end']} is not a minimiser of h")
        sub_path = [tuple(p) for p in o["sub_path"]]
        if not valid_path(sub_path, (0, o["sub_start"]), (n - 1, o["sub_end"])):
            failures.append(f"case {k}: subsequence path is not a warping path from (0, a) to (n-1, b)")
        worst["subsequence path cost"] = max(worst["subsequence path cost"], rel(path_cost(s, t, sub_path), min(brute)))

        starts = [dtai(s, t[a:b + 1]) for a in range(b + 1)]
        worst["anchored cost(a) vs full DTW on T[a..=b]"] = max(
            worst["anchored cost(a) vs full DTW on T[a..=b]"], max(rel(x, y) for x, y in zip(o["start_costs"], starts)))

    print(f"{len(cases)} random cases (n = 1..15 model frames, m = 1..30 target frames, 3-D, scales 0.1..1000 mm)")
    for name, v in worst.items():
        flag = "ok" if v < TOL else "FAIL"
        print(f"  max relative difference, {name:<42} {v:.3e}  {flag}")
        if v >= TOL:
            failures.append(f"{name}: {v:.3e} >= {TOL}")
    for peer, count in same_path.items():
        print(f"  identical full-DTW warping path to {peer:<27} {count}/{len(cases)}")
        if count != len(cases):
            failures.append(f"paths differ from {peer} in {len(cases) - count} cases")
    print(f"  peer note: dtaidistance's C warping_path (use_c=True, inner_dist='euclidean') differs from ours in "
          f"{c_path_off} cases; in {c_path_is_sq} of them it is the squared-euclidean path, and in {c_path_costlier} "
          f"its summed euclidean cost exceeds the DTW distance dtaidistance itself returns (not counted as a failure)")
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print(f"all differences < {TOL}")


if __name__ == "__main__":
    main()
