#!/usr/bin/env python3
"""The built-in `speed_minima` segmenter, re-implemented in Python (numpy only) as a motionlab
external segmenter (protocol 1: `motionlab describe external`).

    python3 speed_minima.py EXCHANGE_DIR      # prints {"candidates": [...], "traces": [...], ...}

It follows crates/motionlab-segment/src/speed_minima.rs and the functions it calls operation by
operation, so that its candidates (and its V trace, bit for bit) equal the built-in's:

- smoothing (`params.smoothing = {frames = n}` or `{seconds = s}`, default {seconds = 0.2} as
  the built-in's; {seconds = 0.0} for none): rounded half away
  from zero to whole frames at the motion's rate (TimeSpan::whole_frames_at); a window > 1 is a
  centred moving average per marker, shrunk at the ends, skipping missing samples, summed in
  frame order (features/src/smoothing.rs);
- v[i][k] = sqrt((dx*dx + dy*dy) + dz*dz) * fps for i < F-1, NaN at the last frame and where a
  marker is missing at i or i+1; V[i] = the largest valid v[i][k], NaN when none (speed.rs);
- v_low (`params.v_low`, default {fraction_of_p90 = 0.3}, the built-in's): mm/s, or a fraction of the 90th
  percentile of V's finite values, linear interpolation between order statistics computed as
  lo + (hi - lo) * (rank - floor(rank)) (signal.rs percentile, thresholds.rs);
- candidate i when V[i-1] > V[i] < V[i+1] (strict; any NaN fails) and V[i] <= v_low.
"""
import json
import math
import os
import sys

import numpy as np


def whole_frames(span, rate_hz):
    """TimeSpan::whole_frames_at: Rust's f64::round (half away from zero), 0 unless finite > 0."""
    if span is None:
        return 0
    if set(span) == {"frames"}:
        frames = float(span["frames"])
    elif set(span) == {"seconds"}:
        frames = float(span["seconds"]) * rate_hz
    else:
        raise ValueError(f"smoothing must be {{frames = n}} or {{seconds = s}}, found {span!r}")
    if not math.isfinite(frames):
        return 0
    whole = math.floor(frames)
    if frames - whole >= 0.5:  # exact for doubles: the fractional part is representable
        whole += 1
    return int(whole) if whole > 0 else 0


def moving_average(p, window):
    """Centred moving average over `window` frames, shrunk at the ends; missing stays missing."""
    n_frames = p.shape[0]
    half = window // 2
    valid = ~np.isnan(p).any(axis=2)  # (F, M)
    acc = np.zeros_like(p)
    count = np.zeros(valid.shape)
    # Frame j = i + d in ascending order, as the Rust loop adds them.
    for d in range(-half, half + 1):
        lo, hi = max(0, -d), min(n_frames, n_frames - d)
        if lo >= hi:
            continue
        src_valid = valid[lo + d:hi + d]
        acc[lo:hi] += np.where(src_valid[:, :, None], p[lo + d:hi + d], 0.0)
        count[lo:hi] += src_valid
    out = acc / np.where(count == 0, 1.0, count)[:, :, None]
    out[~valid] = np.nan
    return out


def fastest_speed(p, fps):
    """V[i] = max_k |p[i+1][k] - p[i][k]| * fps over markers valid at both frames; NaN at the end."""
    d = p[1:] - p[:-1]
    v = np.sqrt((d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]) * fps
    all_nan = np.isnan(v).all(axis=1)
    top = np.max(np.where(np.isnan(v), -np.inf, v), axis=1)
    top[all_nan] = np.nan
    return np.concatenate([top, [np.nan]])


def percentile(x, p):
    finite = np.sort(x[np.isfinite(x)])
    if finite.size == 0:
        raise ValueError("the fastest-marker speed has no finite value to take a percentile of")
    rank = (min(max(p, 0.0), 100.0) / 100.0) * float(finite.size - 1)
    lo, hi = math.floor(rank), math.ceil(rank)
    a, b = float(finite[lo]), float(finite[hi])
    return a + (b - a) * (rank - lo)


def v_low_of(spec, v):
    if set(spec) == {"mm_per_s"}:
        return float(spec["mm_per_s"])
    if set(spec) == {"fraction_of_p90"}:
        return float(spec["fraction_of_p90"]) * percentile(v, 90.0)
    raise ValueError(f"v_low must be {{mm_per_s = x}} or {{fraction_of_p90 = f}}, found {spec!r}")


def main():
    folder = sys.argv[-1]
    with open(os.path.join(folder, "meta.json"), encoding="utf-8") as f:
        meta = json.load(f)
    if meta["protocol"] != 1:
        sys.exit(f"speed_minima.py speaks protocol 1, motionlab sent {meta['protocol']}")
    params = meta["params"]
    unknown = set(params) - {"v_low", "smoothing"}
    if unknown:
        sys.exit(f"speed_minima.py: unknown params {sorted(unknown)} (expected v_low, smoothing)")
    rate = float(meta["motion"]["rate_hz"])
    p = np.load(os.path.join(folder, meta["positions"]["file"]))
    if p.shape[0] < 3:
        sys.exit(f"speed_minima needs at least 3 frames, found {p.shape[0]}")
    window = whole_frames(params.get("smoothing", {"seconds": 0.2}), rate)
    if window > 1:
        p = moving_average(p, window)
    v = fastest_speed(p, rate)
    v_low = v_low_of(params.get("v_low", {"fraction_of_p90": 0.3}), v)
    with np.errstate(invalid="ignore"):  # comparisons with NaN are False, as in Rust
        is_min = (v[:-2] > v[1:-1]) & (v[1:-1] < v[2:]) & (v[1:-1] <= v_low)
    candidates = (np.flatnonzero(is_min) + 1).tolist()
    values = [None if math.isnan(x) else float(x) for x in v]
    json.dump({
        "candidates": candidates,
        "traces": [{"name": "V_mm_per_s", "unit": "mm/s", "values": values}],
        "thresholds": [{"name": "v_low", "trace": "V_mm_per_s", "value": v_low}],
    }, sys.stdout, allow_nan=False)


if __name__ == "__main__":
    main()
