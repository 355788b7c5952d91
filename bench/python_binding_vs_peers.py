#!/usr/bin/env python3
"""The Python package (crates/motionlab-py) against what a Python user has otherwise, timed in
one run; prints the ratios that bench/README.md quotes.

1. Loading into NumPy (frames x points x 3, mm):
   * CMU 86_01 (ASF/AMC, 4,579 frames, 31 bones): `motionlab.load` against a pure-Python
     ASF/AMC reader with NumPy forward kinematics written here in the style of the readers
     Python users copy (CalciferZh's amc_parser, pymo): parse the ASF, every AMC line, then
     `C·Rz·Ry·Rx·C⁻¹` down the hierarchy. Its positions are checked against motionlab's
     (largest difference printed, < 1e-6 mm) so both do the same work.
   * A C3D take (data/mct/walk1.c3d.gz, decompressed once into a temporary file that all three
     read; --c3d for another): `motionlab.load` against ezc3d (C++) and py-c3d (pure Python),
     the readers of bench/conformance_crosscheck.py; the largest difference from ezc3d printed.
2. The two-stage multistream DP (Yabe & Tanaka §3.1.3) on NumPy arrays: `motionlab.multistream_match`
   against dtaidistance (C), and against the same DP timed inside Rust by
   `cargo run --release -p motionlab-match --example multistream_timing` — the binding must not
   lose the Rust speed (per-cell time within 1.2x). The data and dtaidistance's implementation
   are bench/multistream_vs_peers.py's.

Runs under bench/.venv (bench/setup_venv.sh), installing the package into it on first use
(`pip install ./crates/motionlab-py`, a release build; reinstall it after changing the crate):
    bench/python_binding_vs_peers.py [--rounds 3] [--repeats 3] [--c3d FILE]
Implementations are interleaved round by round; the best time of each is reported (the
pure-Python readers run once a round).
"""
import argparse
import gzip
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()

import json  # noqa: E402

import numpy as np  # noqa: E402

try:
    import motionlab as ml  # noqa: E402
except ImportError:  # first use: build the wheel (release) into bench/.venv
    import subprocess

    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", os.path.join(ROOT, "crates/motionlab-py")], check=True)
    import motionlab as ml  # noqa: E402

from multistream_vs_peers import dtai_two_stage, make_data, run_ours, timed  # noqa: E402

AMC = os.path.join(ROOT, "data/cmu86/86_01.amc.gz")
ASF = os.path.join(ROOT, "data/cmu86/86.asf")
C3D = os.path.join(ROOT, "data/mct/walk1.c3d.gz")


# --- a pure-Python ASF/AMC reader (amc_parser / pymo style) ------------------------------------


def _rot(axis, deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _euler(values, order="XYZ"):
    """Rotation of angles applied in `order` (first letter first): XYZ -> Rz·Ry·Rx."""
    m = np.eye(3)
    for axis, v in zip(order.lower(), values):
        m = _rot(axis, v) @ m
    return m


def read_asf(path):
    lines = [ln.strip() for ln in open(path) if ln.strip() and not ln.startswith("#")]
    mm = 25.4 / 0.45
    bones, hierarchy, section, bone = {}, {}, None, None
    for ln in lines:
        if ln.startswith(":"):
            section = ln.split()[0]
            continue
        parts = ln.split()
        if section == ":units" and parts[0] == "length":
            mm = 25.4 / float(parts[1])
        elif section == ":bonedata":
            if parts[0] == "begin":
                bone = {"dof": []}
            elif parts[0] == "end":
                bones[bone["name"]] = bone
            elif parts[0] == "name":
                bone["name"] = parts[1]
            elif parts[0] == "direction":
                bone["direction"] = np.array([float(x) for x in parts[1:4]])
            elif parts[0] == "length":
                bone["length"] = float(parts[1]) * mm
            elif parts[0] == "axis":
                bone["C"] = _euler([float(x) for x in parts[1:4]], parts[4])
            elif parts[0] == "dof":
                bone["dof"] = parts[1:]
        elif section == ":hierarchy" and parts[0] not in ("begin", "end"):
            hierarchy[parts[0]] = parts[1:]
    return bones, hierarchy, mm


def read_amc(path):
    frames, frame = [], None
    with gzip.open(path, "rt") as f:
        for ln in f:
            if ln[0] in "#:":
                continue
            parts = ln.split()
            if len(parts) == 1 and parts[0].isdigit():
                frame = {}
                frames.append(frame)
            else:
                frame[parts[0]] = [float(x) for x in parts[1:]]
    return frames


def pure_python_amc(asf, amc):
    """Positions (frames x points x 3, mm) of the root, every bone's start and every leaf's end
    (motionlab's joints: a bone's joint sits where its parent bone ends)."""
    bones, hierarchy, mm = read_asf(asf)
    frames = read_amc(amc)
    order, names = [], ["root"]
    queue = ["root"]
    while queue:  # breadth-first: a parent before its children
        parent = queue.pop(0)
        for child in hierarchy.get(parent, []):
            order.append((child, parent))
            queue.append(child)
    for child, _ in order:
        names.append(child)
    leaves = [b for b in bones if b not in hierarchy]
    names += [f"{b}_end" for b in leaves]
    out = np.empty((len(frames), len(names), 3))
    for i, fr in enumerate(frames):
        r = fr["root"]
        ends = {"root": (np.array(r[:3]) * mm, _euler(r[3:6]))}
        for child, parent in order:
            b = bones[child]
            angles = dict.fromkeys("xyz", 0.0)
            for dof, v in zip(b["dof"], fr.get(child, [])):
                angles[dof[1]] = v
            local = b["C"] @ _euler([angles["x"], angles["y"], angles["z"]]) @ b["C"].T
            p_pos, p_rot = ends[parent]
            rot = p_rot @ local
            ends[child] = (p_pos + b["length"] * rot @ b["direction"], rot)
        starts = {"root": ends["root"][0]}
        for child, parent in order:
            starts[child] = ends[parent][0]
        for k, n in enumerate(names):
            out[i, k] = ends[n[:-4]][0] if n.endswith("_end") else starts[n]
    return names, out


# --- timing -------------------------------------------------------------------------------------


def best(fn, repeats):
    times, result = timed(fn, repeats)
    return min(times), result


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--c3d", default=C3D)
    args = ap.parse_args()
    import tempfile

    if args.c3d.endswith(".gz"):
        plain = os.path.join(tempfile.mkdtemp(), os.path.basename(args.c3d)[:-3])
        with gzip.open(args.c3d, "rb") as src, open(plain, "wb") as dst:
            dst.write(src.read())
        label, args.c3d = os.path.relpath(args.c3d, ROOT), plain
    else:
        label = args.c3d

    # 1. Loading.
    import c3d as pyc3d
    import ezc3d

    def ours_amc():
        return np.asarray(ml.load(AMC).positions)

    def ours_c3d():
        return np.asarray(ml.load(args.c3d).positions)

    def ezc3d_c3d():
        pts = ezc3d.c3d(args.c3d)["data"]["points"]  # 4 x points x frames, w = 1
        return np.ascontiguousarray(pts[:3].transpose(2, 1, 0))

    def pyc3d_c3d():
        import warnings

        warnings.filterwarnings("ignore", message="No analog data found")  # walk1 has none
        with open(args.c3d, "rb") as f:
            r = pyc3d.Reader(f)
            return np.array([p[:, :3] for _, p, _ in r.read_frames()])

    m = ml.load(AMC)
    names, pure = pure_python_amc(ASF, AMC)
    ours_by_name = np.asarray(m.positions)[:, [m.point_names.index(n) for n in names], :]
    amc_diff = float(np.nanmax(np.abs(ours_by_name - pure)))
    c3d_ours, c3d_ez = ours_c3d(), ezc3d_c3d()
    c3d_diff = float(np.nanmax(np.abs(c3d_ours - c3d_ez)))

    load_impls = {
        "86_01 motionlab": ours_amc,
        "86_01 pure Python": lambda: pure_python_amc(ASF, AMC),
        "c3d motionlab": ours_c3d,
        "c3d ezc3d": ezc3d_c3d,
        "c3d py-c3d": pyc3d_c3d,
    }
    load_times = {k: [] for k in load_impls}

    # 2. DP.
    L, n, mw = 31, 120, 600
    model, target = make_data(L, n, mw)
    model_arr = np.ascontiguousarray(np.stack(model, axis=1))  # n x L x 3
    target_arr = np.ascontiguousarray(np.stack(target, axis=1))
    payload = json.dumps({"model": [s.tolist() for s in model], "target": [t.tolist() for t in target],
                          "repeats": args.repeats, "keep_paths": True})
    ms = ml.multistream_match(model_arr, target_arr, keep_paths=True, k=None)
    a, b = ms.a, ms.b
    da, db, dH, _ = dai = dtai_two_stage(model, target)
    cells = L * n * (mw + (b + 1) + (b - a + 1))
    dp_times = {"binding": [], "rust": [], "dtaidistance": []}

    for _ in range(args.rounds):
        for k, fn in load_impls.items():
            # The pure-Python readers take seconds: once a round.
            load_times[k].append(best(fn, 1 if "py" in k.lower() else args.repeats)[0])
        dp_times["binding"].append(best(lambda: ml.multistream_match(model_arr, target_arr, keep_paths=True, k=None), args.repeats)[0])
        dp_times["rust"].append(min(run_ours(payload)["times_s"]))
        dp_times["dtaidistance"].append(best(lambda: dtai_two_stage(model, target), args.repeats)[0])

    print(f"loading into NumPy ({args.rounds} rounds x {args.repeats}, best):")
    print(f"  86_01 ({m.n_frames} frames, {m.n_points} joints): pure Python vs motionlab positions differ by at most {amc_diff:.2e} mm")
    print(f"  {label} ({c3d_ours.shape[0]} frames, {c3d_ours.shape[1]} markers): ezc3d vs motionlab positions differ by at most {c3d_diff:.2e} mm")
    t = {k: min(v) for k, v in load_times.items()}
    for k, v in t.items():
        base = t["86_01 motionlab"] if k.startswith("86_01") else t["c3d motionlab"]
        print(f"  {k:20s} {v * 1e3:9.1f} ms   {v / base:6.1f}x motionlab's time")
    rel = abs(dH - ms.H) / ms.H
    print(f"\ntwo-stage multistream DP, {L} points, model {n}, window {mw}, {cells:,} cells: [a, b] = [{a}, {b}], H = {ms.H:.6f} mm")
    print(f"  dtaidistance [a, b] = [{da}, {db}], H relative difference {rel:.1e}")
    d = {k: min(v) for k, v in dp_times.items()}
    for k, v in d.items():
        print(f"  {k:14s} {v * 1e3:8.2f} ms  {v / cells * 1e9:6.3f} ns/cell  {v / d['rust']:5.2f}x the Rust example's time")
    ratio = d["binding"] / d["rust"]
    ok = (da, db) == (a, b) and rel < 1e-9 and amc_diff < 1e-6
    print(f"\nbinding / Rust per cell: {ratio:.2f} ({'within' if ratio <= 1.2 else 'NOT within'} 1.2x); dtaidistance / binding: {d['dtaidistance'] / d['binding']:.1f}")
    if not ok:
        sys.exit("MISMATCH: the implementations disagree (see above)")


if __name__ == "__main__":
    main()
