#!/usr/bin/env python3
"""Per-frame 3-D convex-hull volume: motionlab-features against scipy.spatial.ConvexHull (qhull),
on the same real frames, both timed in one run.

For each take (default: data/mct/dance1.tsv.gz, 28 markers, and data/cmu86/86_01.amc.gz,
38 joints and end sites),
  - runs `cargo run --release -p motionlab-features --example hull_timing -- <take> <points> <vols>`,
    which loads the take, times our hull per frame (the from-scratch quickhull and the coherent
    tracker `hull_volume` uses; median of repeated passes, thread CPU time) and writes the exact
    input points and our volumes;
  - times `ConvexHull(frame).volume` on every frame of those very points (missing samples
    dropped as ours does), median of repeated passes, thread CPU time (time.thread_time);
  - checks every frame's volume agrees to 1e-9 relative, and prints µs/frame and the ratios.

Exits non-zero when a volume disagrees. The target is >= 10x scipy (printed, not enforced: the
ratio depends on the machine's load).

Run from anywhere: bench/hull_vs_scipy.py [take ...]  (uses bench/setup_venv.sh's interpreter).
"""
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
from scipy.spatial import ConvexHull  # noqa: E402

DEFAULT_TAKES = ["data/mct/dance1.tsv.gz", "data/cmu86/86_01.amc.gz"]


def ours(take, workdir):
    points_path = os.path.join(workdir, "points.f64")
    volumes_path = os.path.join(workdir, "volumes.f64")
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "motionlab-features", "--example", "hull_timing", "--",
           os.path.join(ROOT, take), points_path, volumes_path]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    timing = json.loads(out.strip().splitlines()[-1])
    raw = np.fromfile(points_path, dtype="<f8")
    frames, points = int(raw[0]), int(raw[1])
    xyz = raw[2:].reshape(frames, points, 3)
    volumes = np.fromfile(volumes_path, dtype="<f8")
    return timing, xyz, volumes


def scipy_pass(valid):
    return [ConvexHull(f).volume for f in valid]


def time_scipy(valid, budget_s=4.0):
    """Median thread-CPU time per frame (µs) of repeated passes over every frame."""
    samples = []
    start = time.perf_counter()
    while len(samples) < 3 or (time.perf_counter() - start < budget_s and len(samples) < 50):
        t = time.thread_time()
        scipy_pass(valid)
        samples.append((time.thread_time() - t) * 1e6 / len(valid))
    return statistics.median(samples)


def main():
    takes = sys.argv[1:] or DEFAULT_TAKES
    failed = False
    print(f"{'take':28} {'frames':>6} {'pts':>4} {'scipy µs':>9} {'ours µs':>8} {'ratio':>6} "
          f"{'rebuild µs':>10} {'ratio':>6} {'reused':>7} {'max rel diff':>12}")
    with tempfile.TemporaryDirectory() as work:
        for take in takes:
            timing, xyz, volumes = ours(take, work)
            valid = [f[np.isfinite(f).all(axis=1)] for f in xyz]
            ref = np.array(scipy_pass(valid))
            rel = np.abs(ref - volumes) / np.maximum(np.abs(ref), 1e-300)
            worst = float(rel.max())
            if worst >= 1e-9:
                failed = True
                bad = int(rel.argmax())
                print(f"  {take}: frame {bad}: scipy {ref[bad]!r} ours {volumes[bad]!r}", file=sys.stderr)
            scipy_us = time_scipy(valid)
            t, s = timing["tracker_us_per_frame"], timing["scratch_us_per_frame"]
            reused = timing["reused"] / timing["frames"]
            print(f"{os.path.basename(take):28} {timing['frames']:6d} {timing['points']:4d} {scipy_us:9.2f} {t:8.3f} "
                  f"{scipy_us / t:6.1f} {s:10.3f} {scipy_us / s:6.1f} {reused:7.0%} {worst:12.1e}")
    print("ours = HullTracker (what hull_volume uses); rebuild = quickhull from scratch every frame;"
          " ratio = scipy / ours; times are thread CPU time per frame, medians of repeated passes.")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
