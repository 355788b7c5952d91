#!/usr/bin/env python3
"""The `butterworth` preprocessor against scipy.signal.butter + filtfilt on real motions:
every filtered sample must agree within 1e-9 relative (to the run's largest value).

motionlab's side: `cargo run -p motionlab-features --example butterworth_dump` (raw and
filtered samples of real files, null where missing). scipy's side, per point and coordinate:
each contiguous run of present samples filtered separately with
`filtfilt(*butter(order, cutoff / (rate / 2)))` (scipy's default padding, padtype='odd',
padlen = 3 * (order + 1)); runs not longer than padlen must be left as captured; missing samples
must stay missing.

Data: MoCap Toolbox walk1 (60 Hz, 28 markers, 27 real gaps) at 6 Hz, order 2 and order 4, and
CMU 86_01 (120 Hz, the first 12 joints) at 6 and 10 Hz.
Run: bench/butterworth_vs_scipy.py
"""
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_modules  # noqa: E402

ensure_modules("numpy", "scipy")

import numpy as np  # noqa: E402
from scipy.signal import butter, filtfilt  # noqa: E402

REL_TOL = 1e-9


def dump(order, cutoff, max_points, files):
    cmd = ["cargo", "run", "-q", "-p", "motionlab-features", "--example", "butterworth_dump", "--", str(order), str(cutoff),
           str(max_points)] + files
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=dict(os.environ, CARGO_TERM_COLOR="never"))
    if out.returncode != 0:
        sys.exit(f"butterworth_dump failed:\n{out.stderr}")
    return json.loads(out.stdout)


def runs(present):
    i, n = 0, len(present)
    while i < n:
        if not present[i]:
            i += 1
            continue
        j = i
        while j < n and present[j]:
            j += 1
        yield i, j
        i = j


def main():
    failures = 0
    print("| data | order | cutoff (Hz) | runs filtered | runs left (short) | samples | max relative difference |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for order, cutoff, max_points, files in [(2, 6.0, 1000, ["mct/walk1.tsv.gz"]), (4, 6.0, 1000, ["mct/walk1.tsv.gz"]),
                                             (2, 6.0, 12, ["cmu86/86_01.amc.gz"]), (2, 10.0, 12, ["cmu86/86_01.amc.gz"])]:
        data = dump(order, cutoff, max_points, files)
        for motion in data["motions"]:
            b, a = butter(order, cutoff / (motion["rate_hz"] / 2))
            padlen = 3 * max(len(a), len(b))
            worst, filtered_runs, short_runs, samples = 0.0, 0, 0, 0
            for s in motion["series"]:
                raw = [np.nan if v is None else v for v in s["raw"]]
                ours = [np.nan if v is None else v for v in s["filtered"]]
                present = [v is not None for v in s["raw"]]
                if [v is not None for v in s["filtered"]] != present:
                    print("MISSING MASK CHANGED", motion["file"], s["point"], s["coordinate"])
                    failures += 1
                for i, j in runs(present):
                    x = np.array(raw[i:j])
                    y = np.array(ours[i:j])
                    if j - i <= padlen:
                        short_runs += 1
                        want = x
                    else:
                        filtered_runs += 1
                        want = filtfilt(b, a, x)
                    samples += j - i
                    rel = np.max(np.abs(y - want)) / max(np.max(np.abs(want)), 1e-300)
                    worst = max(worst, rel)
                    if not rel <= REL_TOL:
                        failures += 1
                        print("MISMATCH", motion["file"], s["point"], s["coordinate"], i, j, rel)
            print(f"| {motion['file']} | {order} | {cutoff} | {filtered_runs} | {short_runs} | {samples} | {worst:.2g} |")
    if failures:
        sys.exit(f"{failures} mismatches")
    print("butterworth agrees with scipy.signal.butter + filtfilt within 1e-9 relative")


if __name__ == "__main__":
    main()
