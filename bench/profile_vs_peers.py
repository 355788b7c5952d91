#!/usr/bin/env python3
"""motionlab-profile's `clasp` and `floss` against their reference implementations, on TSSB
series (data/tssb) and random series, in one run: equality and speed.

Checks (the script exits non-zero when one fails):
  * ClaSP profile: ours (`Clasp::profile`) vs claspy 0.2.8 `ClaSP(window_size=w).fit(ts).profile`
    with w the series' suggested width (desc.txt), every value within 1e-9 and −∞ at the same
    split points — unless the series has twin windows (another window at z-normalised distance
    < 1e-4: TSSB series concatenate UCR instances, some repeated exactly or to 1e-11): their
    distances tie to rounding, claspy breaks the tie by the rounding noise of its FFT dot
    products and ours by its recurrence's (the earlier window on exact ties), so neighbours and
    profile can differ there; such a difference is reported, not failed;
  * ClaSP change points: ours (`clasp` at its defaults) vs claspy
    `BinaryClaSPSegmentation().fit_predict(ts)`; with `--min-agree N` at least N series must
    agree exactly (default: all chosen);
  * two channels (a series and its first difference, `--multichannel NAME…`): profile
    within 1e-9 and change points identical;
  * matrix profile index: ours vs `stumpy.stump(ts, m)[:, 1]`, identical (ties go to the nearer
    diagonal, then the earlier window: the order of stumpy's traversal and thread merge);
  * corrected arc curve: ours (`floss`) vs `stumpy.fluss(I, L=m, n_regimes, custom_iac=the
    paper's parabola)`, within 1e-9, and identical regime locations; stumpy's default
    idealised arc curve (a beta fit to random draws) is reported beside it.

Speed: claspy's `fit_predict` per series (after a warm-up that compiles numba's functions) vs
ours (`segment_values`, timed in-process by the example), summed over the chosen series; both
use all cores (claspy's n_jobs=-1, rayon).

Ours runs through the example `profile_json` of motionlab-profile (built with `cargo build
--release`), called on each series right before the peer.

Usage:
  bench/profile_vs_peers.py --ci                 # the CI subset (a few minutes on 2 cores)
  bench/profile_vs_peers.py --all [--json out]   # all 75 series: the numbers of bench/README.md
  bench/profile_vs_peers.py --series ArrowHead Beef
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv("requirements-profile.txt")

import warnings  # noqa: E402

import numpy as np  # noqa: E402

warnings.filterwarnings("ignore")

TSSB = os.path.join(ROOT, "data", "tssb", "datasets")
# Short to medium series spread over the benchmark's kinds of data: the CI subset.
CI_SERIES = ["Adiac", "ArrowHead", "Beef", "BeetleFly", "Car", "Chinatown", "Coffee", "DistalPhalanxTW",
             "ECG200", "GunPoint", "Ham", "Herring", "ItalyPowerDemand", "Lightning2", "OliveOil",
             "SonyAIBORobotSurface2", "ToeSegmentation2", "TwoLeadECG"]


def load_tssb():
    series = {}
    for line in open(os.path.join(TSSB, "desc.txt")):
        parts = line.strip().split(",")
        if len(parts) < 2:
            continue
        name, window, cps = parts[0], int(parts[1]), [int(c) for c in parts[2:]]
        series[name] = (np.loadtxt(os.path.join(TSSB, name + ".txt")), window, cps)
    return series


def build_ours():
    subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "motionlab-profile", "--example", "profile_json"], cwd=ROOT, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    return os.path.join(target, "release", "examples", "profile_json")


def ours(binary, tasks):
    out = subprocess.run([binary], input=json.dumps({"tasks": tasks}), capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"profile_json failed: {out.stderr}")
    results = json.loads(out.stdout)["results"]
    for r in results:
        if "error" in r:
            sys.exit(f"profile_json: {r['error']}")
    return results


def as_array(values):
    return np.array([-np.inf if v is None else v for v in values], dtype=float)


def profiles_equal(a, b, tol=1e-9):
    """Max |a - b| over finite entries, and whether the −∞ entries coincide."""
    fa, fb = np.isfinite(a), np.isfinite(b)
    if a.shape != b.shape or not np.array_equal(fa, fb):
        return np.inf, False
    diff = float(np.max(np.abs(a[fa] - b[fa]))) if fa.any() else 0.0
    return diff, diff <= tol


def twin_windows(ts, w):
    """Windows whose nearest other window (stumpy's matrix profile) is at z-normalised
    distance < 1e-4: ties to rounding for any nearest-neighbour search."""
    import stumpy
    return int(np.sum(stumpy.stump(ts, m=w)[:, 0].astype(float) < 1e-4))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ci", action="store_true", help="the CI subset of TSSB series")
    ap.add_argument("--all", action="store_true", help="all 75 TSSB series")
    ap.add_argument("--series", nargs="*", default=None)
    ap.add_argument("--min-agree", type=int, default=None, help="series whose change points must agree (default: all)")
    ap.add_argument("--multichannel", nargs="*", default=["ArrowHead"], help="series also compared as two channels (with their differences)")
    ap.add_argument("--random", type=int, default=4, help="random series for the matrix profile / FLUSS checks")
    ap.add_argument("--json", default=None, help="write per-series results here")
    args = ap.parse_args()

    data = load_tssb()
    names = sorted(data) if args.all else (args.series or CI_SERIES)
    min_agree = len(names) if args.min_agree is None else args.min_agree

    from claspy.clasp import ClaSP
    from claspy.segmentation import BinaryClaSPSegmentation
    import stumpy

    t0 = time.time()
    warm = np.sin(np.arange(600) / 5.0) + (np.arange(600) > 300)
    BinaryClaSPSegmentation().fit_predict(warm)
    ClaSP(window_size=10).fit(warm)
    stumpy.fluss(stumpy.stump(warm, m=10)[:, 1], L=10, n_regimes=2)
    print(f"peers warmed up (numba compilation) in {time.time() - t0:.0f} s", flush=True)

    binary = build_ours()
    rng = np.random.default_rng(20240601)
    floss_cases = []
    for name in names[:6]:
        ts, window, cps = data[name]
        floss_cases.append((name, ts, window, len(cps) + 1))
    for i in range(args.random):
        n = int(rng.integers(300, 1500))
        floss_cases.append((f"random{i}", rng.standard_normal(n).cumsum(), int(rng.integers(5, 40)), 3))

    rows, failures = [], []
    agree = 0
    claspy_seconds = ours_seconds = 0.0
    for name in names:
        ts, window, true_cps = data[name]
        # Ours and claspy back to back on each series, so load on the machine hits both alike.
        prof_ours, seg_ours = ours(binary, [{"op": "clasp_profile", "values": ts.tolist(), "window": window},
                                            {"op": "clasp_segment", "values": ts.tolist()}])
        ref = ClaSP(window_size=window).fit(ts).profile
        diff, prof_ok = profiles_equal(as_array(prof_ours["profile"]), ref)
        t = time.perf_counter()
        bcs = BinaryClaSPSegmentation()
        cps_ref = [int(c) for c in bcs.fit_predict(ts)]
        dt = time.perf_counter() - t
        claspy_seconds += dt
        ours_seconds += seg_ours["seconds"]
        same = cps_ref == seg_ours["candidates"]
        agree += same
        dup = 0 if prof_ok else twin_windows(ts, window)
        row = {"series": name, "n": len(ts), "window_ours": seg_ours["window"], "window_claspy": int(bcs.window_size),
               "profile_max_diff": diff, "profile_ok": prof_ok, "twin_windows": dup, "cps_ours": seg_ours["candidates"], "cps_claspy": cps_ref,
               "cps_equal": same, "seconds_claspy": dt, "seconds_ours": seg_ours["seconds"]}
        rows.append(row)
        print(f"{name:32s} n={len(ts):6d} w={row['window_claspy']:4d}/{row['window_ours']:4d} profile Δ={diff:.1e} "
              f"{'' if prof_ok else f'({dup} twin windows) '}"
              f"cps {'=' if same else '≠'} {cps_ref} {'' if same else seg_ours['candidates']} "
              f"claspy {dt:7.2f} s ours {seg_ours['seconds']:6.3f} s", flush=True)
        if not prof_ok and dup == 0:
            failures.append(f"{name}: ClaSP profile differs by {diff} (no twin windows to explain it)")

    # Multichannel input (claspy 1.x semantics of 0.2.8: per-channel z-normalised distances
    # averaged, the smallest SuSS width, threshold 1e-30): each series with its first difference.
    multi_rows = []
    for name in args.multichannel:
        ts, window, _ = data[name]
        X = np.stack([ts, np.diff(ts, prepend=ts[0])], axis=1)
        flat = X.reshape(-1).tolist()
        prof_ours, seg_ours = ours(binary, [{"op": "clasp_profile", "values": flat, "n_channels": 2, "window": window},
                                            {"op": "clasp_segment", "values": flat, "n_channels": 2}])
        ref = ClaSP(window_size=window).fit(X).profile
        diff, prof_ok = profiles_equal(as_array(prof_ours["profile"]), ref)
        cps_ref = [int(c) for c in BinaryClaSPSegmentation().fit_predict(X)]
        same = cps_ref == seg_ours["candidates"]
        multi_rows.append({"series": name, "profile_max_diff": diff, "cps_equal": same, "cps_claspy": cps_ref, "cps_ours": seg_ours["candidates"]})
        print(f"2 channels {name:21s} profile Δ={diff:.1e} cps {'=' if same else '≠'} {cps_ref} {'' if same else seg_ours['candidates']}", flush=True)
        if not prof_ok or not same:
            failures.append(f"{name} with 2 channels: profile Δ={diff}, change points {seg_ours['candidates']} vs claspy {cps_ref}")

    floss_rows = []
    for name, ts, m, regimes in floss_cases:
        mp_ours, fl_ours = ours(binary, [{"op": "matrix_profile", "values": ts.tolist(), "window": m},
                                         {"op": "floss_segment", "values": ts.tolist(), "params": {"window": m, "n_regimes": regimes}}])
        mp = stumpy.stump(ts, m=m)
        index_ref = mp[:, 1].astype(np.int64)
        same_index = np.array_equal(index_ref, np.array(mp_ours["index"]))
        k = len(index_ref)
        iac = 2.0 * np.arange(k) * (k - np.arange(k)) / k
        cac_ref, locs_ref = stumpy.fluss(index_ref, L=m, n_regimes=regimes, custom_iac=iac.copy())
        cac_ours = np.array(fl_ours["trace"][:k], dtype=float)
        cac_diff = float(np.max(np.abs(cac_ours - cac_ref)))
        locs_ref = sorted(int(x) for x in locs_ref if 0 < x < len(ts))
        same_locs = locs_ref == fl_ours["candidates"]
        cac_default, _ = stumpy.fluss(index_ref, L=m, n_regimes=regimes)
        vs_default = float(np.max(np.abs(cac_ours - cac_default)))
        n_index_diff = int(np.sum(index_ref != np.array(mp_ours["index"])))
        floss_rows.append({"series": name, "n": len(ts), "window": m, "index_equal": same_index, "index_differences": n_index_diff,
                           "cac_max_diff": cac_diff, "regimes_equal": same_locs, "cac_diff_vs_stumpy_default_iac": vs_default})
        print(f"floss {name:26s} n={len(ts):6d} m={m:4d} index {'=' if same_index else f'≠ ({n_index_diff})'} "
              f"CAC Δ={cac_diff:.1e} regimes {'=' if same_locs else '≠'} {locs_ref} (vs stumpy's own IAC: Δ={vs_default:.2f})", flush=True)
        if not same_index:
            failures.append(f"floss {name}: matrix profile index differs at {n_index_diff} windows")
        if cac_diff > 1e-9 or not same_locs:
            failures.append(f"floss {name}: CAC differs by {cac_diff} or regimes {fl_ours['candidates']} vs {locs_ref}")

    explained = sum(1 for r in rows if not r["profile_ok"] and r["twin_windows"] > 0)
    print(f"\nClaSP profiles within 1e-9: {sum(r['profile_ok'] for r in rows)}/{len(rows)} "
          f"(the other {explained} on series with twin windows); "
          f"change points identical: {agree}/{len(rows)}")
    print(f"BinaryClaSPSegmentation: claspy {claspy_seconds:.1f} s, ours {ours_seconds:.2f} s over {len(rows)} series: "
          f"{claspy_seconds / max(ours_seconds, 1e-9):.1f}x")
    if agree < min_agree:
        failures.append(f"change points identical on {agree} series, expected at least {min_agree}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"clasp": rows, "clasp_2_channels": multi_rows, "floss": floss_rows, "claspy_seconds": claspy_seconds, "ours_seconds": ours_seconds}, f, indent=1)
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("all checks passed")


if __name__ == "__main__":
    main()
