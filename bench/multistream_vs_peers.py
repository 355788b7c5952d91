#!/usr/bin/env python3
"""The two-stage multistream DP (Yabe & Tanaka §3.1.3) done by motionlab-match, dtaidistance (C)
and tslearn on the same data, timed in one run; prints the time per DP cell and the ratios.

Work (31 markers, model n = 120 frames, window m = 600 frames, 3-D, euclidean local distance):
  1. forward subsequence pass per marker (free start and end) -> h_l(j) for every j; G = sum;
     b = argmin G (earliest);
  2. backward pass per marker anchored at b (free start) -> cost of every start a; a = argmin of
     the sum (latest); h_l at a; H = sum;
  3. each marker's warping path over [a, b].
DP cells: L*n*m + L*n*(b+1) + L*n*(b-a+1).

How each library does it:
  * ours: `cargo run --release -p motionlab-match --example multistream_timing` (times itself
    in-process, so process start and JSON parsing are not counted; eight markers per SIMD
    register, the paths walked from decisions recorded in the backward pass);
  * dtaidistance 2.5.1, C (use_c=True), inner_dist='euclidean': forward = warping_paths with
    psi=(0, 0, m, m) (free start/end in the window) and psi_neg=False, last row; backward = warping_paths of the
    reversed model against the reversed window T[b], T[b-1], ..., T[0], last row; paths =
    warping_paths (C) over [a, b] + dtw.best_path. (dtaidistance's C `warping_path` ignores
    inner_dist='euclidean' and returns the squared-euclidean path, see dtw_crosscheck.py.)
    Its a, b and H are checked against ours (relative difference < 1e-9).
  * tslearn 0.10 (numba): forward = subsequence_cost_matrix, backward = dtw_accumulated_matrix
    on the reversed sequences, paths = dtw_path_from_metric(metric='euclidean'). Its subsequence
    and accumulated-matrix kernels use the *squared* euclidean local cost (no public option for
    euclidean), so its a, b can differ from ours; it does the same number of cells, one sqrt
    per cell fewer in the two passes.

Each implementation runs `--rounds` rounds of `--repeats` repetitions, interleaved (ours, dtai,
tslearn, ours, ...) so load on the machine hits all alike; the best time per implementation is
reported, and the median of the round medians.

Usage: bench/multistream_vs_peers.py [--rounds 5] [--repeats 5] [--markers 31] [--model 120] [--window 600]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()

import numpy as np  # noqa: E402
from dtaidistance import dtw, dtw_ndim  # noqa: E402
from tslearn.metrics import dtw_accumulated_matrix, dtw_path_from_metric, subsequence_cost_matrix  # noqa: E402


def position(j, l):
    """Marker l at (fractional) frame j, mm — the formula of crates/motionlab-match/benches/multistream.rs."""
    return np.stack([300.0 * np.sin(0.05 * j + 0.3 * l) + 20.0 * l,
                     200.0 * np.cos(0.037 * j + 0.7 * l),
                     150.0 * np.sin(0.021 * j - l) + 900.0], axis=-1)


def make_data(markers, n, m):
    model = [np.ascontiguousarray(position(240.0 + 1.1 * np.arange(n), l)) for l in range(markers)]
    target = [np.ascontiguousarray(position(np.arange(m, dtype=float), l)) for l in range(markers)]
    return model, target


def argmin_last(v):
    v = np.asarray(v)
    return int(len(v) - 1 - np.argmin(v[::-1]))


def dtai_two_stage(model, target):
    n, m = len(model[0]), len(target[0])
    G = np.zeros(m)
    for s, t in zip(model, target):
        # psi_neg=False: by default the cells past the best end are overwritten with -1.
        _, P = dtw_ndim.warping_paths(s, t, psi=(0, 0, m, m), psi_neg=False, inner_dist="euclidean", use_c=True)
        G += P[n, 1:]
    b = int(np.argmin(G))
    per = []
    for s, t in zip(model, target):
        _, P = dtw_ndim.warping_paths(np.ascontiguousarray(s[::-1]), np.ascontiguousarray(t[b::-1]),
                                      inner_dist="euclidean", use_c=True)
        per.append(P[n, 1:][::-1])  # index a: cost of starting at a (reversed end b - a)
    per = np.array(per)
    a = argmin_last(per.sum(axis=0))
    h = per[:, a]
    paths = []
    for s, t in zip(model, target):
        _, P = dtw_ndim.warping_paths(s, np.ascontiguousarray(t[a:b + 1]), inner_dist="euclidean", use_c=True)
        paths.append(dtw.best_path(P))
    return a, b, float(h.sum()), paths


def tslearn_two_stage(model, target):
    n, m = len(model[0]), len(target[0])
    G = np.zeros(m)
    for s, t in zip(model, target):
        G += subsequence_cost_matrix(s, t)[n - 1]
    b = int(np.argmin(G))
    mask = np.ones((n, b + 1), dtype=bool)
    per = np.array([dtw_accumulated_matrix(s[::-1], t[b::-1], mask)[n - 1][::-1] for s, t in zip(model, target)])
    a = argmin_last(per.sum(axis=0))
    paths = [dtw_path_from_metric(s, t[a:b + 1], metric="euclidean")[0] for s, t in zip(model, target)]
    return a, b, float(per[:, a].sum()), paths


def dtai_forward(model, target):
    n, m = len(model[0]), len(target[0])
    G = np.zeros(m)
    for s, t in zip(model, target):
        _, P = dtw_ndim.warping_paths(s, t, psi=(0, 0, m, m), psi_neg=False, inner_dist="euclidean", use_c=True)
        G += P[n, 1:]
    return G


def tslearn_forward(model, target):
    n, m = len(model[0]), len(target[0])
    G = np.zeros(m)
    for s, t in zip(model, target):
        G += subsequence_cost_matrix(s, t)[n - 1]
    return G


def run_ours(payload):
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "motionlab-match", "--example", "multistream_timing"]
    out = subprocess.run(cmd, input=payload, capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        sys.exit(f"multistream_timing failed:\n{out.stderr}")
    return json.loads(out.stdout)


def timed(fn, repeats):
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return times, result


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--markers", type=int, default=31)
    ap.add_argument("--model", type=int, default=120)
    ap.add_argument("--window", type=int, default=600)
    args = ap.parse_args()
    L, n, m = args.markers, args.model, args.window
    model, target = make_data(L, n, m)
    payload = json.dumps({"model": [s.tolist() for s in model], "target": [t.tolist() for t in target],
                          "repeats": args.repeats, "keep_paths": True})
    # Warm-up: builds our example, compiles tslearn's numba kernels.
    ours = run_ours(json.dumps({**json.loads(payload), "repeats": 1}))
    tslearn_two_stage([model[0]], [target[0]])

    names = ["motionlab-match", "dtaidistance (C)", "tslearn (numba)"]
    times = {k: [] for k in names}
    medians = {k: [] for k in names}
    ftimes = {k: [] for k in names}
    fmedians = {k: [] for k in names}

    def record(k, t, ft):
        times[k] += t
        medians[k].append(statistics.median(t))
        ftimes[k] += ft
        fmedians[k].append(statistics.median(ft))

    for _ in range(args.rounds):
        ours = run_ours(payload)
        record("motionlab-match", ours["times_s"], ours["forward_times_s"])
        t, dt = timed(lambda: dtai_two_stage(model, target), args.repeats)
        ft, dG = timed(lambda: dtai_forward(model, target), args.repeats)
        record("dtaidistance (C)", t, ft)
        t, tl = timed(lambda: tslearn_two_stage(model, target), args.repeats)
        ft, _ = timed(lambda: tslearn_forward(model, target), args.repeats)
        record("tslearn (numba)", t, ft)

    a, b = ours["start"], ours["end"]
    da, db, dH, _ = dt
    ta, tb, _, _ = tl
    rel = abs(dH - ours["total_distance"]) / ours["total_distance"]
    print(f"two-stage multistream DP: {L} markers, model {n} frames, window {m} frames")
    print(f"  ours:         [a, b] = [{a}, {b}], H = {ours['total_distance']:.6f} mm")
    print(f"  dtaidistance: [a, b] = [{da}, {db}], H = {dH:.6f} mm (relative difference {rel:.1e})")
    print(f"  tslearn:      [a, b] = [{ta}, {tb}] (squared-euclidean local cost in the two passes)")
    ok = (da, db) == (a, b) and rel < 1e-9
    if not ok:
        print("  MISMATCH between ours and dtaidistance")

    def cells(a, b):
        return L * n * (m + (b + 1) + (b - a + 1))

    cell_count = {"motionlab-match": cells(a, b), "dtaidistance (C)": cells(da, db), "tslearn (numba)": cells(ta, tb)}
    print(f"  DP cells: ours/dtaidistance {cells(a, b):,}, tslearn {cells(ta, tb):,}; "
          f"{args.rounds} interleaved rounds x {args.repeats} repetitions each")

    def table(title, times, medians, cell_count):
        print(title)
        print(f"  {'implementation':<18} {'best ms':>9} {'median ms':>10} {'best ns/cell':>13} {'median ns/cell':>15} "
              f"{'ours faster (best)':>19} {'(median)':>9}")
        best = {k: min(v) for k, v in times.items()}
        med = {k: statistics.median(v) for k, v in medians.items()}
        ns = {k: best[k] / cell_count[k] * 1e9 for k in times}
        ns_med = {k: med[k] / cell_count[k] * 1e9 for k in times}
        for k in times:
            print(f"  {k:<18} {best[k] * 1e3:9.2f} {med[k] * 1e3:10.2f} {ns[k]:13.2f} {ns_med[k]:15.2f} "
                  f"{ns[k] / ns['motionlab-match']:18.2f}x {ns_med[k] / ns_med['motionlab-match']:8.2f}x")
        return ns_med["dtaidistance (C)"] / ns_med["motionlab-match"]

    whole = table("whole two-stage match (forward + backward + 31 paths):", times, medians, cell_count)
    forward_cells = {k: L * n * m for k in names}
    forward = table(f"stage 1 alone (31 forward passes and G, {L * n * m:,} cells; kernel against kernel, no path extraction):",
                    ftimes, fmedians, forward_cells)
    print(f"per-cell ratio vs dtaidistance (medians): whole match {whole:.2f}x, stage 1 {forward:.2f}x "
          f"(target whole match >= 10x: {'met' if whole >= 10 else 'NOT met'})")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
