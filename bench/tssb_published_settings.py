#!/usr/bin/env python3
"""The TSSB competitors in the settings of the benchmark authors' scripts, run by motionlab on
all 75 TSSB series and scored against the published per-series Covering
(data/tssb/published_covering_unknown.csv).

Settings (`--variant raw`, the default):
  * PELT, BinSeg — ruptures Pelt / Binseg(model="ar", min_size=5·w, jump=5), predict(pen=10);
  * Window — ruptures Window(width=10·w, model="ar", min_size=5·w), predict(pen=10);
  * BOCD — the bocd 0.1.2 package: min-max normalised series, ConstantHazard(100), StudentT(),
    change points where the most probable run length falls by >= 250;
  * FLOSS — stumpy's corrected arc curve of the matrix profile with width w, change points at
    its minima while <= 0.45, 5·w excluded around each;
w being the series' window size in desc.txt. `--variant min_max` runs the ClaSP authors' later
evaluation script instead: PELT, BinSeg and Window on the min-max normalised series with
min_size = 5 % of n and pen 0.2; FLOSS with n_regimes = the true count + 1, keeping the regimes
whose CAC is <= 0.45 (BOCD as above). `--variant bocd_raw_series` and `--variant bocd_murphy`
try two other readings of BOCD (the package on the series as given; Murphy's update).

Each runs through motionlab's own segmenters (the example binaries of motionlab-changepoint
and motionlab-profile, which bench/changepoint_vs_peers.py and bench/profile_vs_peers.py check
against ruptures, the bocd package and stumpy), and Covering is TCPDBench's (the formula of
bench/metrics_crosscheck.py, which CI checks against motionlab_eval::cpd_metrics), rounded to
3 decimals as the published sheet is.

Prints per method: our mean Covering beside the published mean, how many series are within
0.01 of the published value, and the others with both values, the Covering of no change point
and our change points; --table FILE writes every series (CSV). Results: bench/README.md.

Usage: bench/tssb_published_settings.py [--variant raw|min_max|bocd_raw_series|bocd_murphy] [--methods PELT,BinSeg,...] [--table out.csv]
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()

import numpy as np  # noqa: E402
from metrics_crosscheck import tcpd_covering  # noqa: E402

TSSB = os.path.join(ROOT, "data", "tssb")
METHODS = ("PELT", "BinSeg", "Window", "BOCD", "FLOSS")


def series():
    out = []
    with open(os.path.join(TSSB, "datasets", "desc.txt")) as f:
        for line in f:
            parts = line.strip().split(",")
            out.append((parts[0], int(parts[1]), [int(c) for c in parts[2:]]))
    return out


def published():
    with open(os.path.join(TSSB, "published_covering_unknown.csv")) as f:
        return {r["dataset"]: r for r in csv.DictReader(f)}


def run_example(crate, example, payload):
    cmd = ["cargo", "run", "--quiet", "--release", "-p", crate, "--example", example]
    out = subprocess.run(cmd, input=json.dumps(payload), capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        sys.exit(f"{example} failed: {out.stderr}")
    return json.loads(out.stdout)


def changepoint_jobs(method, name, w, n, variant):
    path = os.path.join(TSSB, "datasets", name + ".txt")
    if variant == "min_max" and method in ("PELT", "BinSeg", "Window"):
        common = {"cost": "ar", "min_size": int(n * 0.05), "pen": 0.2, "normalize": "min_max"}
        if method == "Window":
            return {"segmenter": "window", "params": {**common, "width": 10 * w}, "values_file": path}
        return {"segmenter": "kernel_cpd", "params": {**common, "search": method.lower()}, "values_file": path}
    if method in ("PELT", "BinSeg"):
        search = "pelt" if method == "PELT" else "binseg"
        return {"segmenter": "kernel_cpd", "params": {"search": search, "cost": "ar", "min_size": 5 * w, "jump": 5, "pen": 10.0}, "values_file": path}
    if method == "Window":
        return {"segmenter": "window", "params": {"cost": "ar", "width": 10 * w, "min_size": 5 * w, "pen": 10.0}, "values_file": path}
    params = {"model": "bocd_package", "normalize": "min_max", "lambda": 100.0, "change_points": "run_length_drop", "drop_threshold": 250.0}
    if variant == "bocd_raw_series":
        params["normalize"] = "none"
    elif variant == "bocd_murphy":
        params.update(model="normal_gamma", prior_mean=0.0, prior_kappa=1.0, prior_alpha=1.0, prior_beta=1.0)
    return {"segmenter": "bocpd", "params": params, "values_file": path}


def found_change_points(method, rows, lengths, variant):
    t0 = time.time()
    if method == "FLOSS":
        tasks = []
        for name, w, cps in rows:
            values = np.loadtxt(os.path.join(TSSB, "datasets", name + ".txt")).tolist()
            if variant == "min_max":
                # fluss(n_regimes = true count + 1), then the regimes whose CAC is <= 0.45.
                params = {"window": w, "n_regimes": len(cps) + 1, "excl_factor": 5}
            else:
                params = {"window": w, "cac_threshold": 0.45, "excl_factor": 5}
            tasks.append({"op": "floss_segment", "values": values, "params": params})
        results = run_example("motionlab-profile", "profile_json", {"tasks": tasks})["results"]
        if variant == "min_max":
            for r in results:
                if "error" not in r:
                    r["candidates"] = [c for c in r["candidates"] if r["trace"][c] <= 0.45]
    else:
        jobs = [changepoint_jobs(method, name, w, n, variant) for (name, w, _), n in zip(rows, lengths)]
        results = run_example("motionlab-changepoint", "changepoint_json", {"jobs": jobs})["results"]
    for (name, _, _), r in zip(rows, results):
        if "error" in r:
            sys.exit(f"{method} on {name}: {r['error']}")
    return [sorted(r["candidates"]) for r in results], time.time() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--table", help="write every series' Covering (ours, published) to this CSV")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--variant", choices=("raw", "min_max", "bocd_raw_series", "bocd_murphy"), default="raw",
                    help="raw: the settings above; min_max: the later script's (series min-max normalised, pen 0.2, "
                         "min_size 5 %% of n; FLOSS with n_regimes = true count + 1, then CAC <= 0.45); "
                         "bocd_raw_series: BOCD as the package on the series not normalised; bocd_murphy: BOCD with "
                         "Murphy's update (bocpd's default model) and the package's prior, min-max normalised")
    args = ap.parse_args()
    rows = series()
    pub = published()
    lengths = [sum(1 for _ in open(os.path.join(TSSB, "datasets", name + ".txt"))) for name, _, _ in rows]
    table = []
    for method in args.methods.split(","):
        found, seconds = found_change_points(method, rows, lengths, args.variant)
        ours, theirs, off = [], [], []
        for (name, w, cps), f, n in zip(rows, found, lengths):
            c = round(tcpd_covering([cps], f, n), 3)
            p = float(pub[name][method])
            ours.append(c)
            theirs.append(p)
            no_change = round(tcpd_covering([cps], [], n), 3)
            table.append({"method": method, "series": name, "n": n, "ours": c, "published": round(p, 3), "no_change": no_change, "found": " ".join(map(str, f))})
            if abs(c - p) > 0.01:
                off.append((name, n, c, p, no_change, f))
        print(f"\n{method}: mean Covering ours {100 * np.mean(ours):.2f} %, published {100 * np.mean(theirs):.2f} %, "
              f"difference {100 * (np.mean(ours) - np.mean(theirs)):+.2f} points; {len(rows) - len(off)}/{len(rows)} series within 0.01 ({seconds:.1f} s)")
        for name, n, c, p, nc, f in off:
            print(f"  {name:<32} n={n:>6}  ours {c:.3f}  published {p:.3f}  (no change point: {nc:.3f})  ours found {f[:10]}{' …' if len(f) > 10 else ''}")
    if args.table:
        with open(args.table, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(table[0]))
            w.writeheader()
            w.writerows(table)


if __name__ == "__main__":
    main()
