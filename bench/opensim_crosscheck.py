#!/usr/bin/env python3
"""OpenSim conformance: motionlab's TRC and MOT/STO readers, and the TRC that
``motionlab convert`` writes, against OpenSim 4.6's own Python API (``opensim`` on PyPI, in
bench/.venv-opensim).

1. Every ``.trc``, ``.mot`` and ``.sto`` under ``data/`` is read by OpenSim
   (``TimeSeriesTableVec3`` for TRC, ``TimeSeriesTable`` for MOT/STO) and by motionlab
   (``motionlab inspect --json --npy`` for TRC positions; ``motionlab convert X.mot X.csv`` for
   the channels), and every frame count, rate, unit, label and value is compared: values to
   1e-12 relative (both parse the same decimal text), missing samples (empty cells) at the
   same places.
2. ``motionlab convert`` writes TRC files from a TRC (mm → m), a C3D with missing samples, a
   Qualisys TSV, a BVH and an ASF/AMC (joint positions); OpenSim reads each back, and its
   values equal motionlab's own reading of the input to within float text rounding (1e-12
   relative; the writer prints shortest round-trip decimals).

The script prints how many files it compared and fails unless it compared exactly the
expected number (so a sample that silently stops being found fails CI).

Run: bench/opensim_crosscheck.py [path/to/motionlab]
"""
import csv
import glob
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

try:
    import numpy as np
    import opensim as osim
except ImportError:
    ensure_venv("requirements-opensim.txt")
    raise

MM_PER = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}
# What the script must compare: the shipped samples, and the files convert writes.
EXPECTED_READ = 11
EXPECTED_WRITTEN = 5
RTOL = 1e-12


def motionlab_binary():
    if len(sys.argv) > 1:
        return sys.argv[1]
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    return os.path.join(target, "debug", "motionlab")


ML = motionlab_binary()


def run(*args):
    return subprocess.run([ML, *args], check=True, capture_output=True, text=True).stdout


def inspect(path, tmp):
    """motionlab's reading: its report and positions (mm, frames × points × 3, NaN missing)."""
    out = os.path.join(tmp, "npy")
    report = json.loads(run("inspect", "--json", "--npy", out, path))[0]
    return report, np.load(os.path.join(out, "0.npy"))


def close(a, b, what):
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        raise SystemExit(f"{what}: shapes differ {a.shape} vs {b.shape}")
    if not np.array_equal(np.isnan(a), np.isnan(b)):
        raise SystemExit(f"{what}: missing samples differ ({int(np.isnan(a).sum())} vs {int(np.isnan(b).sum())})")
    ok = np.isnan(a) | (np.abs(a - b) <= RTOL * np.maximum(np.abs(a), np.abs(b)) + 1e-300)
    if not ok.all():
        i = np.argwhere(~ok)[0]
        raise SystemExit(f"{what}: differs at {tuple(i)}: {a[tuple(i)]!r} vs {b[tuple(i)]!r}")


def opensim_trc(path):
    """OpenSim's TRC reading: labels, rate, units and positions (file units), NaN missing."""
    t = osim.TimeSeriesTableVec3(path)
    rows, cols = t.getNumRows(), t.getNumColumns()
    xyz = np.empty((rows, cols, 3))
    for r in range(rows):
        row = t.getRowAtIndex(r)
        for c in range(cols):
            v = row[c]
            xyz[r, c] = (v[0], v[1], v[2])
    return (list(t.getColumnLabels()), float(t.getTableMetaDataAsString("DataRate")),
            t.getTableMetaDataAsString("Units"), xyz, np.array(list(t.getIndependentColumn())))


def check_trc(path, tmp):
    labels, rate, units, xyz, _ = opensim_trc(path)
    report, mm = inspect(path, tmp)
    if report["points"] != labels:
        raise SystemExit(f"{path}: labels differ")
    if report["frame_rate_hz"] != rate:
        raise SystemExit(f"{path}: rate {report['frame_rate_hz']} vs OpenSim's {rate}")
    if report["length_unit"] is None or not report["length_unit_from"].startswith(f'Units "{units}"'):
        raise SystemExit(f"{path}: unit {report['length_unit_from']!r} vs OpenSim's {units!r}")
    close(mm / MM_PER[units], xyz, path)
    # A sample is missing in motionlab when any coordinate is: OpenSim's NaNs are whole too.
    return f"{os.path.relpath(path, ROOT)}: {xyz.shape[0]} frames × {xyz.shape[1]} markers, {units}, {rate} Hz, {int(np.isnan(xyz[:, :, 0]).sum())} missing"


def check_storage(path, tmp):
    t = osim.TimeSeriesTable(path)
    labels = list(t.getColumnLabels())
    rows, cols = t.getNumRows(), t.getNumColumns()
    values = np.array([[t.getRowAtIndex(r)[c] for c in range(cols)] for r in range(rows)])
    times = np.array(list(t.getIndependentColumn()))
    out = os.path.join(tmp, "channels.csv")
    run("convert", path, out)
    with open(out) as f:
        reader = csv.reader(f)
        header = next(reader)
        ml = np.array([[float(v) if v else np.nan for v in row[1:]] for row in reader])
    names = [h.split("#")[0] for h in header[1:]]
    if names != labels:
        raise SystemExit(f"{path}: labels differ from OpenSim's")
    close(ml, values, path)
    report = json.loads(run("inspect", "--json", path))[0]
    mean_hz = (rows - 1) / (times[-1] - times[0])
    if abs(report["frame_rate_hz"] - mean_hz) > 1e-9 * mean_hz:
        raise SystemExit(f"{path}: rate {report['frame_rate_hz']} vs OpenSim's times' mean step {mean_hz}")
    return f"{os.path.relpath(path, ROOT)}: {rows} rows × {cols} columns, {mean_hz:.6g} Hz"


def check_written(source, units, tmp):
    """convert SOURCE → TRC in UNITS; OpenSim reads it to motionlab's own values."""
    report, mm = inspect(source, tmp)
    out = os.path.join(tmp, "written.trc")
    run("convert", "--units", units, source, out)
    labels, rate, file_units, xyz, times = opensim_trc(out)
    if labels != report["points"] or file_units != units:
        raise SystemExit(f"{source}: the written TRC's labels or units differ")
    if abs(rate - report["frame_rate_hz"]) > 1e-12 * rate:
        raise SystemExit(f"{source}: written rate {rate} vs {report['frame_rate_hz']}")
    close(xyz, mm / MM_PER[units], f"{source} → TRC ({units})")
    close(times, np.arange(len(times)) / report["frame_rate_hz"], f"{source} → TRC times")
    return f"{os.path.relpath(source, ROOT)} → TRC in {units}: {xyz.shape[0]} frames × {xyz.shape[1]} points, {int(np.isnan(xyz[:, :, 0]).sum())} missing"


def main():
    read = sorted(p for ext in ("trc", "mot", "sto") for p in glob.glob(os.path.join(ROOT, "data", "**", f"*.{ext}"), recursive=True))
    written = [
        (os.path.join(ROOT, "data/formats/opensim-core/dataWithBlanksForMissingMarkers.trc"), "m"),
        (os.path.join(ROOT, "data/mct/walk1.c3d.gz"), "mm"),
        (os.path.join(ROOT, "data/mct/dance1.tsv.gz"), "m"),
        (os.path.join(ROOT, "data/cmu131/131_03.bvh.gz"), "mm"),
        (os.path.join(ROOT, "data/mocap6/amc/13_29.amc.gz"), "m"),
    ]
    n_read = n_written = 0
    with tempfile.TemporaryDirectory() as tmp:
        for p in read:
            print(check_trc(p, tmp) if p.endswith(".trc") else check_storage(p, tmp))
            n_read += 1
        for source, units in written:
            print(check_written(source, units, tmp))
            n_written += 1
    print(f"compared {n_read} TRC/MOT/STO files read by OpenSim {osim.__version__} and motionlab, "
          f"and {n_written} TRC files written by motionlab convert and read by OpenSim")
    if (n_read, n_written) != (EXPECTED_READ, EXPECTED_WRITTEN):
        raise SystemExit(f"expected {EXPECTED_READ} and {EXPECTED_WRITTEN} files")
    print("every TRC/MOT/STO agrees with OpenSim")


if __name__ == "__main__":
    main()
