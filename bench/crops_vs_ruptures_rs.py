#!/usr/bin/env python3
"""kernel_cpd's penalty path (CROPS) against ruptures-rs 0.1.1's `Crops`, on TSSB series.

For each series (the shortest TSSB series first, `--series` of them, at least ten), min-max
normalised as the TSSB scripts feed ruptures, and each configuration — cost l2 and rbf (the
bandwidth ours resolved, given to both), Pelt's grid (jump 5, min_size 2) and every sample
(jump 1); cost ar (order 4, min_size 20) on the first few — both libraries return every
segmentation optimal for a penalty in [BIC/20, 50·BIC] (BIC the penalty `kernel_cpd` uses
with `pen = "bic"`, which the bridge gives a job without `pen`) with its penalty interval. The run fails unless the segmentations are identical
(same number, same breakpoints, in the same order) and every interval end agrees within 1e-9
relative; it prints how many series, paths and segmentations it compared, and fails with
fewer than ten series.

--speed: the path of a 100,000-sample series (four channels, five mean and spread changes,
kernel_pelt, cost rbf or l2 with --speed-cost) against one PELT run at the range's lower penalty and at the BIC
penalty, with the peak resident memory of our process, and the machine's load average.

Our side runs through `cargo run --release -p motionlab-changepoint --example changepoint_json`.
Its own venv: bench/.venv-crops from bench/requirements-crops.txt (bench/setup_venv.sh).
--speed-many: the same measure on a path with many segmentations (30 changes of spread heights,
path over [BIC/10, 2·BIC]), with the time per segmentation.

Usage: bench/crops_vs_ruptures_rs.py [--series 12] [--speed | --speed-many] [--speed-cost l2]
"""
import argparse
import glob
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv("requirements-crops.txt")

import numpy as np  # noqa: E402
import ruptures_rs  # noqa: E402

TSSB = os.path.join(ROOT, "data", "tssb", "datasets")
REL = 1e-9


def ours(jobs):
    payload = json.dumps({"jobs": jobs})
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "motionlab-changepoint", "--example", "changepoint_json"]
    out = subprocess.run(cmd, input=payload, capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        sys.exit(f"our example failed: {out.stderr}")
    reply = json.loads(out.stdout)
    for r in reply["results"]:
        if "error" in r:
            sys.exit(f"our kernel_cpd failed: {r['error']}")
    return reply["results"], reply["peak_rss_kib"]


def job(x, params, **extra):
    x2 = np.asarray(x, dtype=float).reshape(len(x), -1)
    hexed = np.ascontiguousarray(x2, dtype="<f8").tobytes().hex()
    return {"segmenter": "kernel_cpd", "params": params, "values_hex": hexed, "n_channels": x2.shape[1], **extra}


def series(count):
    files = sorted(glob.glob(os.path.join(TSSB, "[A-Z]*.txt")), key=lambda f: (os.path.getsize(f), f))
    out = []
    for f in files[:count]:
        x = np.loadtxt(f)
        x = (x - x.min()) / (x.max() - x.min())
        out.append((os.path.basename(f)[:-4], x))
    return out


def close(a, b):
    return abs(a - b) <= REL * max(abs(a), abs(b))


def check(args):
    data = series(args.series)
    configs = [
        ("l2", {"cost": "l2", "search": "pelt", "jump": 5, "min_size": 2}),
        ("l2 jump 1", {"cost": "l2", "search": "pelt", "jump": 1, "min_size": 2}),
        ("rbf", {"cost": "rbf", "search": "pelt", "jump": 5, "min_size": 2}),
    ]
    ar = ("ar", {"cost": "ar", "search": "pelt", "jump": 5, "min_size": 20, "ar_order": 4})
    plan = []
    for i, (name, x) in enumerate(data):
        for label, params in configs + ([ar] if i < 4 else []):
            plan.append((name, x, label, params))
    # First pass: BIC and the bandwidth ours resolves (the path's range and rbf's gamma).
    first, _ = ours([job(x, p) for _, x, _, p in plan])
    jobs = []
    for (name, x, label, params), r in zip(plan, first):
        bic = r["pen"]
        p = {**params, "penalty": {"path": [bic / 20, bic * 50]}}
        if params["cost"] == "rbf":
            p["gamma"] = r["gamma"]
        jobs.append(p)
    results, _ = ours([job(x, p) for (_, x, _, _), p in zip(plan, jobs)])
    n_paths = n_segs = 0
    compared = set()
    bad = []
    for (name, x, label, params), p, r in zip(plan, jobs, results):
        lo, hi = p["penalty"]["path"]
        kw = {"gamma": p["gamma"]} if "gamma" in p else ({"order": 4} if params["cost"] == "ar" else None)
        algo = ruptures_rs.Crops(model=params["cost"], min_size=params["min_size"], jump=params["jump"], params=kw)
        theirs = algo.fit_predict(x.reshape(len(x), -1), lo, hi)
        mine = r["path"]
        same = len(mine) == len(theirs) and all(
            m["breakpoints"] == list(t.bkps) and close(m["pen_min"], t.pen_min) and close(m["pen_max"], t.pen_max)
            for m, t in zip(mine, theirs)
        )
        if not same:
            bad.append((name, label, lo, hi, [(m["pen_min"], m["pen_max"], len(m["breakpoints"]) - 1) for m in mine], [(t.pen_min, t.pen_max, t.n_bkps) for t in theirs]))
        compared.add(name)
        n_paths += 1
        n_segs += len(theirs)
        print(f"{name:32s} {label:10s} n={len(x):5d} range [{lo:.4g}, {hi:.4g}]: {len(mine)} segmentations ({'identical' if same else 'DIFFERENT'})")
    for b in bad:
        print("DIFFERENT:", b[0], b[1], "range", b[2], b[3], "\n  ours  ", b[4], "\n  theirs", b[5])
    print(f"compared {len(compared)} TSSB series, {n_paths} paths, {n_segs} segmentations")
    if bad:
        sys.exit(f"{len(bad)} path(s) differ from ruptures-rs Crops")
    if len(compared) < 10:
        sys.exit(f"only {len(compared)} series compared; expected at least 10")
    print("every path identical to ruptures-rs Crops")


def speed(cost):
    rng = np.random.default_rng(5)
    n, d = 100_000, 4
    bounds = [0, 14_000, 31_000, 50_000, 66_000, 83_000, n]
    x = np.empty((n, d))
    for a, b in zip(bounds, bounds[1:]):
        x[a:b] = rng.normal(rng.normal(0, 1.5, d), rng.choice([0.5, 1.0, 2.0], d), (b - a, d))
    base = {"cost": cost, "search": "kernel_pelt"}
    [first], _ = ours([job(x, base)])
    bic = first["pen"]
    extra = {"gamma": first["gamma"]} if cost == "rbf" else {}
    lo, hi = bic, 100 * bic
    one_lo, _ = ours([job(x, {**base, **extra, "pen": lo}, repeats=1)])
    one_bic, _ = ours([job(x, {**base, **extra, "pen": bic * 10}, repeats=1)])
    [path], rss = ours([job(x, {**base, **extra, "penalty": {"path": [lo, hi]}})])
    [single], rss_single = ours([job(x, {**base, **extra, "pen": lo})])
    t_path = path["cpu_seconds"][0]
    t_lo = one_lo[0]["cpu_seconds"][0]
    t_mid = one_bic[0]["cpu_seconds"][0]
    print(f"load average: {os.getloadavg()}")
    print(f"n = {n}, {d} channels, {cost} kernel_pelt, path over [{lo:.4g}, {hi:.4g}]: "
          f"{len(path['path'])} segmentations ({[len(p['breakpoints']) - 1 for p in path['path']]} change points)")
    print(f"CPU seconds: path {t_path:.2f}; one PELT at pen {lo:.4g}: {t_lo:.2f} (x{t_path / t_lo:.1f}); at pen {10 * bic:.4g}: {t_mid:.2f} (x{t_path / t_mid:.1f})")
    print(f"peak RSS: path {rss} KiB, one PELT {rss_single} KiB")


def speed_many(cost):
    """A path with many segmentations: 100,000 samples, four channels, 30 mean changes whose
    heights are spread log-uniformly (0.25 to 3 noise standard deviations, one channel each),
    so that segmentations with from a few up to all 30 changes are each optimal somewhere in
    [BIC/10, 2·BIC]. CROPS runs PELT about twice per segmentation on its path: the ratio to one
    PELT run grows with the path's length, and this measures it where that length is real."""
    rng = np.random.default_rng(35)
    n, d, k = 100_000, 4, 30
    bounds = np.sort(rng.choice(np.arange(2_000, n - 2_000, 500), k, replace=False))
    heights = np.exp(rng.uniform(np.log(0.25), np.log(3.0), k))
    x = rng.normal(0.0, 1.0, (n, d))
    level = np.zeros(d)
    edges = [0, *bounds.tolist(), n]
    for i, (a, b) in enumerate(zip(edges, edges[1:])):
        if i > 0:
            level[rng.integers(d)] += heights[i - 1] * rng.choice([-1.0, 1.0])
        x[a:b] += level
    base = {"cost": cost, "search": "kernel_pelt"}
    [first], _ = ours([job(x, base)])
    bic = first["pen"]
    extra = {"gamma": first["gamma"]} if cost == "rbf" else {}
    # BIC here counts the level shifts in the variance (log n · Σ var): the small steps pay
    # below it, the large ones up to a few times it; a range where PELT finds no change would
    # time a run without pruning (O(n²)), not the path.
    lo, hi = bic / 10, 2 * bic
    [one_lo], rss_single = ours([job(x, {**base, **extra, "pen": lo})])
    [one_hi], _ = ours([job(x, {**base, **extra, "pen": hi})])
    [path], rss = ours([job(x, {**base, **extra, "penalty": {"path": [lo, hi]}})])
    t_path, t_lo, t_hi = path["cpu_seconds"][0], one_lo["cpu_seconds"][0], one_hi["cpu_seconds"][0]
    counts = [len(p["breakpoints"]) - 1 for p in path["path"]]
    print(f"load average: {os.getloadavg()}")
    print(f"n = {n}, {d} channels, {k} true changes, {cost} kernel_pelt, path over [{lo:.4g}, {hi:.4g}]: "
          f"{len(counts)} segmentations (change points {counts})")
    print(f"CPU seconds: path {t_path:.2f}; one PELT at pen {lo:.4g} (BIC/10): {t_lo:.2f} (path x{t_path / t_lo:.1f}); "
          f"at pen {hi:.4g}: {t_hi:.2f} (path x{t_path / t_hi:.1f}); per segmentation {t_path / len(counts):.2f} "
          f"(x{t_path / len(counts) / t_lo:.1f} one PELT at BIC/10)")
    print(f"peak RSS: path {rss} KiB, one PELT {rss_single} KiB")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--series", type=int, default=12)
    ap.add_argument("--speed", action="store_true")
    ap.add_argument("--speed-many", action="store_true", help="the 100,000-sample path with many segmentations")
    ap.add_argument("--speed-cost", default="rbf", choices=["rbf", "l2"])
    args = ap.parse_args()
    if args.speed_many:
        speed_many(args.speed_cost)
    elif args.speed:
        speed(args.speed_cost)
    else:
        check(args)


if __name__ == "__main__":
    main()
