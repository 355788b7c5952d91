#!/usr/bin/env python3
"""Retrieval across a corpus, timed in one run: motionlab's pruned search, motionlab's exhaustive
search (every window matched) and dtaidistance's subsequence search, on the same model, corpus
and candidate windows; prints the times and the speed-ups.

Work (the experiment of record, experiments/yabe_retrieval.toml): model = one jumping jack of
CMU 13_30 (frames 56..180, 124 frames), corpus = every shipped CMU AMC take (data/**/*.amc.gz:
86_01, 86_09, 13_29, 13_30, 13_31, 14_14, 14_20), the skeleton's 31 distinct points, positions
relative to the root every frame; windows of 250 frames every 31 frames; the 5 most similar and
the 5 most dissimilar non-overlapping stretches.

  * ours: `cargo run --release -p motionlab-match --example retrieval_timing` loads the takes,
    times `retrieve` with pruning and without (it fails unless both give the same lists) and
    writes the exact matched numbers (frames x points x 3, f64) for the peer;
  * dtaidistance 2.5.1 (C): `subsequence.subsequencesearch.subsequence_search(model, windows)`
    over the same windows, each a (250, 93) array of the same numbers, `kbest_matches(k)` —
    `use_c=True`, inner_dist='euclidean', early abandoning at the k-th best distance so far
    (its LB_Keogh bound is switched off for multivariate series by dtaidistance itself). It ranks windows by the
    full multidimensional DTW of the model against the whole window (both ends anchored, local
    distance the euclidean distance over all 93 coordinates at once), not by the two-stage
    multistream match (free start and end inside the window, one DTW per marker summed): the
    same job — the k windows closest to the model — with a simpler distance. It has no
    "most dissimilar" query: its time is for the similar list; ours is timed for both lists and
    for the similar list alone (`--k-dissimilar 0`).

Each round runs ours (`--repeats` times each mode) and then the peer `--repeats` times; the
median over all samples per implementation is reported, and the best.

Usage: bench/retrieval_vs_peers.py [--rounds 3] [--repeats 3] [--k 5] [--window 250] [--stride 31]
"""
import argparse
import glob
import json
import os
import statistics
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
from dtaidistance.subsequence.subsequencesearch import subsequence_search  # noqa: E402

MODEL = ("data/mocap6/amc/13_30.amc.gz", 56, 180)


def windows(frames, window, stride):
    """The candidate windows of motionlab_match::retrieval::windows: [start, end)."""
    if frames <= window:
        return [(0, frames)]
    last = frames - window
    out = [(s, s + window) for s in range(0, last + 1, stride)]
    if out[-1][0] != last:
        out.append((last, frames))
    return out


def run_ours(args, takes, export, k_dissimilar=None):
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "motionlab-match", "--example", "retrieval_timing", "--",
           MODEL[0], str(MODEL[1]), str(MODEL[2]), "--repeats", str(args.repeats), "--window", str(args.window),
           "--stride", str(args.stride), "--k", str(args.k)]
    if export:
        cmd += ["--export", export]
    if k_dissimilar is not None:
        cmd += ["--k-dissimilar", str(k_dissimilar)]
    out = subprocess.run(cmd + takes, capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        sys.exit(f"retrieval_timing failed:\n{out.stderr}")
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--k", type=int, default=5)
    ap.add_argument("--window", type=int, default=250)
    ap.add_argument("--stride", type=int, default=31)
    args = ap.parse_args()
    takes = sorted(os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, "data", "**", "*.amc.gz"), recursive=True))
    with tempfile.TemporaryDirectory() as tmp:
        first = run_ours(argparse.Namespace(**{**vars(args), "repeats": 1}), takes, tmp)  # builds the example, exports
        meta = json.load(open(os.path.join(tmp, "meta.json")))
        L = len(meta["points"])
        model = np.fromfile(os.path.join(tmp, "model.f64"), dtype="<f8").reshape(meta["model_frames"], 3 * L)
        data = [np.fromfile(os.path.join(tmp, f"take_{i}.f64"), dtype="<f8").reshape(f, 3 * L)
                for i, f in enumerate(meta["take_frames"])]
    index = [(t, s, e) for t, d in enumerate(data) for (s, e) in windows(len(d), args.window, args.stride)]
    series = [np.ascontiguousarray(data[t][s:e]) for (t, s, e) in index]
    assert len(series) == first["candidates"], (len(series), first["candidates"])

    def peer():
        search = subsequence_search(model, series, dists_options={"inner_dist": "euclidean"}, use_c=True)
        return search.kbest_matches(k=args.k)

    peer()  # warm-up
    ours_p, ours_e, ours_s, ours_se, dtai = [], [], [], [], []
    for _ in range(args.rounds):
        r = run_ours(args, takes, None)
        ours_p += r["pruned_times_s"]
        ours_e += r["exhaustive_times_s"]
        s = run_ours(args, takes, None, k_dissimilar=0)
        ours_s += s["pruned_times_s"]
        ours_se += s["exhaustive_times_s"]
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            best = peer()
            dtai.append(time.perf_counter() - t0)

    name = [os.path.basename(t).split(".")[0] for t in takes]
    print(f"retrieval across {len(takes)} takes ({r['frames']:,} frames, {L} points): model {meta['model_frames']} frames, "
          f"{len(series)} windows of {args.window} frames every {args.stride}, k = {args.k}; {r['threads']} threads")
    print(f"  ours, pruned:     matched {r['pruned_matched']} of {r['candidates']} windows; lists identical to the exhaustive search's")
    for lst in ("similar", "dissimilar"):
        print(f"    most {lst}: " + "; ".join(f"{name[h['take']]} {h['start']}-{h['end']} H {h['h_mm']:,.0f}" for h in r[lst]))
    print("  dtaidistance:     k best windows (full multidimensional DTW): " +
          "; ".join(f"{name[index[m.idx][0]]} {index[m.idx][1]}-{index[m.idx][2] - 1} d {m.distance:,.0f}" for m in best))
    runs = [("pruned", ours_p), ("exhaustive", ours_e), ("similar", ours_s), ("similar_exhaustive", ours_se), ("dtai", dtai)]
    med = {k: statistics.median(v) for k, v in runs}
    lo = {k: min(v) for k, v in runs}
    print(f"  similar list alone, pruned: matched {s['pruned_matched']} of {s['candidates']} windows")
    print(f"  {args.rounds} rounds x {args.repeats} repetitions; median (best) wall time:")
    print(f"    motionlab pruned, both lists:            {med['pruned'] * 1e3:8.1f} ms ({lo['pruned'] * 1e3:.1f})")
    print(f"    motionlab exhaustive, both lists:        {med['exhaustive'] * 1e3:8.1f} ms ({lo['exhaustive'] * 1e3:.1f})")
    print(f"    motionlab pruned, similar list alone:    {med['similar'] * 1e3:8.1f} ms ({lo['similar'] * 1e3:.1f})")
    print(f"    motionlab exhaustive, similar alone:     {med['similar_exhaustive'] * 1e3:8.1f} ms ({lo['similar_exhaustive'] * 1e3:.1f})")
    print(f"    dtaidistance subsequence_search (C):     {med['dtai'] * 1e3:8.1f} ms ({lo['dtai'] * 1e3:.1f})  (similar list only)")
    print(f"  speed-up of pruning over exhaustive, both lists:   {med['exhaustive'] / med['pruned']:.1f}x (best {lo['exhaustive'] / lo['pruned']:.1f}x)")
    print(f"  speed-up of pruning over exhaustive, similar list: {med['similar_exhaustive'] / med['similar']:.1f}x (best {lo['similar_exhaustive'] / lo['similar']:.1f}x)")
    print(f"  speed-up over dtaidistance, similar list:          {med['dtai'] / med['similar']:.1f}x (best {lo['dtai'] / lo['similar']:.1f}x)")
    print(f"  speed-up over dtaidistance, ours with both lists:  {med['dtai'] / med['pruned']:.1f}x (best {lo['dtai'] / lo['pruned']:.1f}x)")

if __name__ == "__main__":
    main()
