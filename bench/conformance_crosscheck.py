#!/usr/bin/env python3
"""Reader conformance: motionlab's C3D and BVH positions against other readers.

Two commands share the readers below.

``check [MOTIONLAB]`` (CI): reads every C3D in the repository (``data/`` and
``tests/fixtures/``) with motionlab (``motionlab inspect --json --npy DIR``, the debug build by
default) and with ezc3d and py-c3d (PyPI), and fails on any position, missing sample, label,
rate or frame count that differs beyond float32 rounding. Where ezc3d is known to be wrong or
cannot read a file, the table ``EXPECTED`` says so and the file is checked against the readers
that are right instead (py-c3d, or the raw reading below), and the script prints which; every
file motionlab refuses must be one ``EXPECTED`` lists as refused by every reader.

``reference`` (run once, output committed): writes ``tests/fixtures/conformance/reference.json``,
per-point checksums of the positions of every file in ``tests/fixtures/conformance/`` as the
designated reader gives them (ezc3d where it reads the file right; else py-c3d or the raw
reading; for BVH an independent NumPy forward kinematics with position channels replacing the
OFFSET, per axis, as Blender and bvhio read them). ``crates/motionlab-io/tests/conformance.rs``
compares motionlab's loads with them to 1e-9 relative.

The raw reading is a NumPy reader of the C3D layout written from the C3D User Guide: the header
or the parameters' account of the data section (``account`` below), 16-bit integers times the
scale factor or 32-bit floats (Intel, DEC, MIPS), a negative residual word = missing.

Analog channels (EMG, force plates, …): ``check`` also compares every C3D's analog channels as
motionlab loads them (an analog-only file's channels; a marker file's with the loader's
``analog = true``, which ``inspect --npy`` writes to ``<n>.analog.npy``) with ezc3d's
``data/analogs``: labels, units, rate and every sample, to float32 rounding. Where ezc3d departs
from the C3D letter (it subtracts |ANALOG:OFFSET| and reads "UNSIGNED" words as signed), the
channels concerned are compared with py-c3d instead, and the script says so; so are the files
``EXPECTED`` lists ezc3d as wrong on (their data layout shifts the analog words too).

Run: bench/conformance_crosscheck.py check [path/to/motionlab]
     bench/conformance_crosscheck.py self-test [path/to/motionlab]   # broken inputs must fail
     bench/conformance_crosscheck.py reference
"""
import gzip
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import warnings

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_modules  # noqa: E402

ensure_modules("numpy", "ezc3d", "c3d")

import c3d as pyc3d  # noqa: E402
import ezc3d  # noqa: E402
import numpy as np  # noqa: E402

FIXTURES = os.path.join(ROOT, "tests", "fixtures", "conformance")
BLOCK = 512
MM_PER = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}
UNIT_NAMES = {"mm": "mm", "millimetre": "mm", "millimeter": "mm", "cm": "cm", "centimetre": "cm", "centimeter": "cm",
              "m": "m", "metre": "m", "meter": "m", "in": "in", "inch": "in"}

# How each reader fares on the files that need saying (every other file: all three agree).
# reference: the reader the committed checksums come from; account: the data-section account
# the raw reading uses; ezc3d / pyc3d: "ok", "wrong" (reads other numbers) or "refuses".
EXPECTED = {
    "examples_simple.c3d": dict(reference=None, ezc3d="refuses", pyc3d="refuses", raw="refuses",
                                why="processor type 0 and no points: every reader refuses it"),
    "sample_00_Motion_Analysis_Corporation_Walk1.c3d": dict(reference="ezc3d", why="label RKNE twice"),
    "sample_02_sgi_int.c3d": dict(reference="raw", ezc3d="refuses",
                                  why="MIPS: ezc3d does not read big-endian files; py-c3d gives float32"),
    "sample_02_sgi_real.c3d": dict(reference="raw", ezc3d="refuses",
                                   why="MIPS floats: ezc3d does not read big-endian files; py-c3d gives float32"),
    "sample_11_evart.c3d": dict(reference="raw", account="header", ezc3d="wrong", pyc3d="refuses",
                                why="17 analog samples per frame (header) while ANALOG:RATE / POINT:RATE = 16.67: "
                                    "ezc3d reads 16 and every later frame shifts"),
    "sample_20_phasespace_sample.c3d": dict(reference="raw", ezc3d="wrong", pyc3d="refuses",
                                            why="no parameters at all: the header alone describes the data; ezc3d reads "
                                                "no point"),
    "sample_24_MotionMonitorC3D.c3d": dict(reference="ezc3d", account="parameters", pyc3d="refuses",
                                           why="header: 16 analog words per frame; ANALOG:USED 16 x 7 samples fill the file"),
    "sample_27_kyowadengyo.c3d": dict(reference="raw", account="header", ezc3d="wrong", pyc3d="refuses",
                                      why="POINT:USED 12, header 11: the header fits the file, ezc3d reads 12 points"),
    "sample_33_bigparlove.c3d": dict(reference="ezc3d", pyc3d="refuses", why="parameters defined twice"),
    "sample_15_FP1.C3D": dict(reference="ezc3d", pyc3d="refuses", why="POINT:UNITS \"mete\""),
    "c3d_parameters_account_fits.c3d": dict(account="parameters", ezc3d="refuses", pyc3d="refuses",
                                            why="malformed fixture: 4 analog words per frame the header does not count "
                                                "(ezc3d crashes, py-c3d refuses)"),
    "sample_28_type1.C3D": dict(reference="pyc3d", account="header", ezc3d="wrong",
                                why="ANALOG:USED 6 and no ANALOG:RATE: ezc3d takes 0 analog channels and reads each "
                                    "frame 24 bytes short; the header's 6 analog words per frame fit the file"),
}


# --- the raw reading ---------------------------------------------------------------------------
def read_bytes(path):
    with open(path, "rb") as f:
        data = f.read()
    return gzip.decompress(data) if path.endswith(".gz") else data


def dec_to_ieee(raw):
    """VAX F_floating (two little-endian words, exponent bias 128) to IEEE: swap the words, / 4."""
    words = np.frombuffer(raw, dtype="<u2").reshape(-1, 2)
    swapped = (words[:, 0].astype(np.uint32) << 16) | words[:, 1]
    values = swapped.view("<f4").astype(np.float64) / 4.0
    values[(words[:, 0] & 0x7F80) == 0] = 0.0
    return values


class RawC3d:
    """Header, parameters and data section of a C3D file, read independently of motionlab."""

    def __init__(self, path):
        b = self.b = read_bytes(path)
        self.param_start = (b[0] - 1) * BLOCK
        self.processor = b[self.param_start + 3]
        if self.processor not in (84, 85, 86):
            raise ValueError(f"processor type {self.processor}")
        self.end = ">" if self.processor == 86 else "<"
        self.header = dict(points=self.u16(2), analog=self.u16(4), first=self.u16(6), last=self.u16(8),
                           scale=self.f32(12), start=self.u16(16), rate=self.f32(20))
        self.params = self._parameters()

    def u16(self, at):
        return struct.unpack_from(self.end + "H", self.b, at)[0]

    def f32(self, at):
        raw = self.b[at:at + 4]
        return float(dec_to_ieee(raw)[0]) if self.processor == 85 else struct.unpack(self.end + "f", raw)[0]

    def _parameters(self):
        """{(GROUP, NAME): values}: records chained by their offsets, the first of two
        same-named parameters kept, the chain ended at the parameter section's last block."""
        b, pos = self.b, self.param_start + 4
        section_end = self.param_start + b[self.param_start + 2] * BLOCK if b[self.param_start + 2] else len(b)
        groups, records = {}, []
        while pos + 2 <= len(b):
            name_len = abs(struct.unpack_from("b", b, pos)[0])
            gid = struct.unpack_from("b", b, pos + 1)[0]
            if name_len == 0:
                break
            name = b[pos + 2:pos + 2 + name_len].decode("ascii").upper()
            nxt = struct.unpack_from(self.end + "h", b, pos + 2 + name_len)[0]
            body = pos + 4 + name_len
            if gid < 0:
                groups[-gid] = name
            else:
                kind = struct.unpack_from("b", b, body)[0]
                dims = list(b[body + 2:body + 2 + b[body + 1]])
                size = abs(kind) * int(np.prod(dims)) if dims else abs(kind)
                records.append((gid, name, kind, dims, b[body + 2 + len(dims):body + 2 + len(dims) + size]))
            if nxt == 0 or pos + 2 + name_len + nxt >= section_end:
                break
            pos = pos + 2 + name_len + nxt
        params = {}
        for gid, name, kind, dims, data in records:
            key = (groups.get(gid, f"GROUP{gid}"), name)
            if key in params:
                continue
            if kind == -1:
                width = dims[0] if dims else 1
                params[key] = [data[i:i + width].decode("latin-1").strip(" \0") for i in range(0, len(data), max(width, 1))]
            elif kind == 1:
                params[key] = list(data)
            elif kind == 2:
                params[key] = list(struct.unpack(self.end + f"{len(data) // 2}H", data))
            elif kind == 4:
                params[key] = [float(v) for v in (dec_to_ieee(data) if self.processor == 85 else np.frombuffer(data, self.end + "f4"))]
        return params

    def param(self, group, name):
        return self.params.get((group, name))

    def account(self, which):
        """(points, analog words per frame, data start byte) of the header or the parameters."""
        h = self.header
        if which == "header":
            return h["points"], h["analog"], (h["start"] - 1) * BLOCK
        used = (self.param("POINT", "USED") or [h["points"]])[0]
        analog = h["analog"]
        channels = self.param("ANALOG", "USED")
        if channels is not None:
            if channels[0] == 0:
                analog = 0
            else:
                per_frame = (self.param("ANALOG", "RATE") or [0.0])[0] / (self.param("POINT", "RATE") or [h["rate"]])[0]
                analog = channels[0] * round(per_frame)
        start = (self.param("POINT", "DATA_START") or [h["start"]])[0]
        return used, analog, (start - 1) * BLOCK

    def frames(self):
        start = self.param("TRIAL", "ACTUAL_START_FIELD")
        end = self.param("TRIAL", "ACTUAL_END_FIELD")
        if start and end:
            first, last = start[0] + (start[1] << 16), end[0] + (end[1] << 16)
        else:
            first, last = self.header["first"], self.header["last"]
        return last - first + 1

    def units_mm(self):
        label = (self.param("POINT", "UNITS") or ["mm"])[0].strip().lower() or "mm"
        full = [u for n, u in UNIT_NAMES.items() if n.startswith(label)]
        return MM_PER[UNIT_NAMES.get(label) or full[0]]

    def positions(self, which="header"):
        """(frames, points, 3) in mm, NaN where the residual is negative."""
        points, analog, start = self.account(which)
        scale = (self.param("POINT", "SCALE") or [self.header["scale"]])[0]
        word = 4 if scale < 0 else 2
        n = self.frames()
        frame_words = 4 * points + analog
        raw = self.b[start:start + n * frame_words * word]
        if len(raw) != n * frame_words * word:
            raise ValueError("file shorter than its frames")
        if word == 4:
            values = dec_to_ieee(raw) if self.processor == 85 else np.frombuffer(raw, self.end + "f4").astype(np.float64)
        else:
            values = np.frombuffer(raw, self.end + "i2").astype(np.float64)
        values = values.reshape(n, frame_words)[:, :4 * points].reshape(n, points, 4)
        xyz = values[:, :, :3] * (1.0 if word == 4 else scale)
        xyz = xyz * self.units_mm()
        xyz[values[:, :, 3] < 0] = np.nan
        return xyz

    def analog(self, which="header"):
        """(samples, channels) by the C3D letter: the words after each frame's points, sample-
        major, (word - OFFSET) x SCALE x GEN_SCALE; words and OFFSET unsigned when ANALOG:FORMAT
        is "UNSIGNED"."""
        points, analog, start = self.account(which)
        channels = (self.param("ANALOG", "USED") or [0])[0]
        scale = (self.param("POINT", "SCALE") or [self.header["scale"]])[0]
        word = 4 if scale < 0 else 2
        n = self.frames()
        frame_words = 4 * points + analog
        raw = self.b[start:start + n * frame_words * word]
        unsigned = (self.param("ANALOG", "FORMAT") or [""])[0].strip().upper() == "UNSIGNED"
        if word == 4:
            values = dec_to_ieee(raw) if self.processor == 85 else np.frombuffer(raw, self.end + "f4").astype(np.float64)
        else:
            values = np.frombuffer(raw, self.end + ("u2" if unsigned else "i2")).astype(np.float64)
        values = values.reshape(n, frame_words)[:, 4 * points:].reshape(n * (analog // channels), channels)

        def per_channel(name, default):
            v = list(self.param("ANALOG", name) or [default])
            return np.array([v[k] if k < len(v) else v[0] for k in range(channels)], dtype=np.float64)
        offsets = per_channel("OFFSET", 0)  # int16 parameters are unpacked unsigned above
        if not unsigned:
            offsets = np.where(offsets > 32767, offsets - 65536, offsets)
        gen = (self.param("ANALOG", "GEN_SCALE") or [1.0])[0]
        return (values - offsets) * per_channel("SCALE", 1.0) * gen

    def labels(self, n):
        labels = list(self.param("POINT", "LABELS") or [])
        k = 2
        while len(labels) < n and self.param("POINT", f"LABELS{k}") is not None:
            labels += self.param("POINT", f"LABELS{k}")
            k += 1
        return labels[:n]


# --- the peers ---------------------------------------------------------------------------------
def with_plain_file(path, fn):
    """Runs fn on a path to the uncompressed file (the peers do not read .gz)."""
    if not path.endswith(".gz"):
        return fn(path)
    with tempfile.NamedTemporaryFile(suffix=".c3d") as t:
        t.write(read_bytes(path))
        t.flush()
        return fn(t.name)


def ezc3d_read(path):
    def go(p):
        e = ezc3d.c3d(p)
        units = e["parameters"]["POINT"].get("UNITS", {}).get("value", ["mm"])
        label = (units[0] if len(units) else "mm").strip().lower() or "mm"
        full = [u for n, u in UNIT_NAMES.items() if n.startswith(label)]
        mm = MM_PER[UNIT_NAMES.get(label) or full[0]]
        xyz = np.transpose(e["data"]["points"][:3], (2, 1, 0)) * mm
        labels = list(e["parameters"]["POINT"].get("LABELS", {}).get("value", []))
        return dict(positions=xyz, labels=labels[:xyz.shape[1]], rate=float(e["header"]["points"]["frame_rate"]))
    return with_plain_file(path, go)


def pyc3d_read(path):
    def go(p):
        with open(p, "rb") as h, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = pyc3d.Reader(h)
            frames = [pts for _, pts, _ in r.read_frames()]
            a = np.array(frames, dtype=np.float64)
            xyz = a[:, :, :3].copy()
            xyz[a[:, :, 3] < 0] = np.nan
            units = (r.get("POINT:UNITS").string_value.strip().lower() if r.get("POINT:UNITS") else "mm") or "mm"
            full = [u for n, u in UNIT_NAMES.items() if n.startswith(units)]
            return dict(positions=xyz * MM_PER[UNIT_NAMES.get(units) or full[0]],
                        labels=[s.strip() for s in r.point_labels], rate=float(r.point_rate))
    return with_plain_file(path, go)


def raw_read(path, account):
    r = RawC3d(path)
    xyz = r.positions(account)
    labels = r.labels(xyz.shape[1])
    rate = (r.param("POINT", "RATE") or [r.header["rate"]])[0]
    return dict(positions=xyz, labels=labels, rate=float(rate))


def isolated(fn, *args):
    """fn(*args) in a forked child, so that a reader crashing on a file (ezc3d segfaults on
    some inconsistent headers) is a refusal, not the end of the check."""
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)

    def run():
        try:
            child.send(("ok", fn(*args)))
        except Exception as e:  # the peer's refusal, reported to the parent
            child.send(("error", f"{type(e).__name__}: {str(e)[:80]}"))

    p = ctx.Process(target=run)
    p.start()
    child.close()
    try:
        status, value = parent.recv()
    except EOFError:
        status, value = "error", "crashed"
    p.join()
    if p.exitcode and status == "ok":
        status, value = "error", f"crashed (exit {p.exitcode})"
    if status == "error":
        raise RuntimeError(value)
    return value


def read_with(reader, path, account="header"):
    if reader == "ezc3d":
        return ezc3d_read(path)
    if reader == "pyc3d":
        return pyc3d_read(path)
    return raw_read(path, account)


# --- BVH: NumPy forward kinematics, position channels replacing the OFFSET -------------------
def bvh_parse(path):
    tokens = open(path).read().split()
    assert tokens[0] == "HIERARCHY"
    joints, stack, i = [], [], 1
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            joints.append(dict(name=tokens[i + 1], parent=stack[-1] if stack else None, ends=[]))
            i += 2
        elif t == "End":
            i += 2
            assert tokens[i] == "{" and tokens[i + 1] == "OFFSET"
            joints[stack[-1]]["ends"].append([float(v) for v in tokens[i + 2:i + 5]])
            i += 6
        elif t == "{":
            stack.append(len(joints) - 1)
            i += 1
        elif t == "}":
            stack.pop()
            i += 1
        elif t == "OFFSET":
            joints[stack[-1]]["offset"] = np.array([float(v) for v in tokens[i + 1:i + 4]])
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            joints[stack[-1]]["channels"] = tokens[i + 2:i + 2 + n]
            i += 2 + n
        else:
            raise ValueError(t)
    n_frames = int(tokens[i + 2])
    frame_time = float(tokens[i + 5])
    values = np.array(tokens[i + 6:], dtype=np.float64).reshape(n_frames, -1)
    return joints, values, frame_time


def rotation(axis, degrees):
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return {"X": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
            "Y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "Z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def bvh_positions(path):
    """(frames, points, 3) in file units: joints in file order, then one end site per End Site."""
    joints, values, _ = bvh_parse(path)
    n_points = len(joints) + sum(len(j["ends"]) for j in joints)
    out = np.zeros((len(values), n_points, 3))
    for f, row in enumerate(values):
        k, glob, pos = 0, [], []
        for j in joints:
            translation = j["offset"].copy()
            local = np.eye(3)
            for c in j["channels"]:
                if c.endswith("position"):
                    translation["XYZ".index(c[0])] = row[k]
                else:
                    local = local @ rotation(c[0], row[k])
                k += 1
            if j["parent"] is None:
                pos.append(translation)
                glob.append(local)
            else:
                g = glob[j["parent"]]
                pos.append(pos[j["parent"]] + g @ translation)
                glob.append(g @ local)
        ends = [pos[i] + glob[i] @ np.array(e) for i, j in enumerate(joints) for e in j["ends"]]
        out[f] = np.array(pos + ends)
    return out


# --- checksums ---------------------------------------------------------------------------------
def checksums(xyz):
    """Per point: valid count, missing frames' index sum, and over valid samples the sums of
    x, y, z (with the sums of |x|, … they are compared relative to), of (frame + 1)·x, …
    (a shifted or reordered frame changes them) and of x², …; and every point of the first
    and last frames (null = missing)."""
    n, m, _ = xyz.shape
    valid = ~np.isnan(xyz[:, :, 0])
    w = np.arange(1, n + 1, dtype=np.float64)[:, None, None]
    v = np.where(valid[:, :, None], xyz, 0.0)
    return dict(
        valid=valid.sum(axis=0).tolist(),
        missing_frame_sum=[int(np.flatnonzero(~valid[:, p]).sum()) for p in range(m)],
        sum=v.sum(axis=0).tolist(),
        abs_sum=np.abs(v).sum(axis=0).tolist(),
        weighted_sum=(v * w).sum(axis=0).tolist(),
        square_sum=(v * v).sum(axis=0).tolist(),
        frames={str(f): [None if np.isnan(p[0]) else p.tolist() for p in xyz[f]] for f in sorted({0, n - 1})},
    )


def reference():
    out = {"generated_by": "bench/conformance_crosscheck.py reference",
           "readers": {"ezc3d": ezc3d.__version__ if hasattr(ezc3d, "__version__") else "ezc3d",
                       "pyc3d": pyc3d.__version__, "numpy": np.__version__},
           "c3d": {}, "bvh": {}}
    for name in sorted(os.listdir(os.path.join(FIXTURES, "c3d"))):
        if not name.lower().endswith(".c3d"):
            continue
        path = os.path.join(FIXTURES, "c3d", name)
        exp = EXPECTED.get(name, {})
        reader = exp.get("reference", "ezc3d")
        if reader is None:
            out["c3d"][name] = dict(reference=None, why=exp["why"])
            continue
        got = read_with(reader, path, exp.get("account", "header"))
        xyz = got["positions"]
        out["c3d"][name] = dict(reference=reader, why=exp.get("why", ""), n_frames=xyz.shape[0], n_points=xyz.shape[1],
                                rate_hz=got["rate"], labels=got["labels"], **checksums(xyz))
        print(f"{name}: {xyz.shape[0]} frames x {xyz.shape[1]} points from {reader}")
    for name in sorted(os.listdir(os.path.join(FIXTURES, "bvh"))):
        if name.endswith(".bvh"):
            xyz = bvh_positions(os.path.join(FIXTURES, "bvh", name))
            out["bvh"][name] = dict(reference="numpy forward kinematics, position channels replace OFFSET (file units)",
                                    n_frames=xyz.shape[0], n_points=xyz.shape[1], **checksums(xyz))
            print(f"{name}: {xyz.shape[0]} frames x {xyz.shape[1]} points")
    # One line per file, so a regenerated reference diffs file by file.
    with open(os.path.join(FIXTURES, "reference.json"), "w") as f:
        f.write("{\n")
        f.write(f'"generated_by": {json.dumps(out["generated_by"])},\n"readers": {json.dumps(out["readers"], sort_keys=True)},\n')
        for kind in ("bvh", "c3d"):
            entries = [f"{json.dumps(k)}: {json.dumps(v, sort_keys=True, separators=(',', ':'))}" for k, v in sorted(out[kind].items())]
            f.write(f'"{kind}": {{\n' + ",\n".join(entries) + "\n}" + (",\n" if kind == "bvh" else "\n"))
        f.write("}\n")


# --- check: motionlab against the peers, every C3D in the repository --------------------------
F32 = 2.0 ** -22  # two float32 ulps, relative


def repository_c3d_files():
    out = []
    for top in ("data", os.path.join("tests", "fixtures")):
        for folder, _, names in os.walk(os.path.join(ROOT, top)):
            out += [os.path.join(folder, n) for n in names if n.lower().endswith((".c3d", ".c3d.gz"))]
    return sorted(out)


def motionlab_read(binary, files):
    """{path: dict(positions, labels, rate, repairs)} of the files motionlab loads, and
    {path: error line} of those it refuses."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run([binary, "inspect", "--json", "--npy", tmp, *files], capture_output=True, text=True)
        reports = json.loads(run.stdout or "[]")
        loaded = {}
        for r in reports:
            loaded[r["file"]] = dict(positions=np.load(r["positions_npy"]), labels=r["points"], rate=r["frame_rate_hz"],
                                     repairs=r["repairs"], analog=None)
            # The analog channels: the motion's own (a file without points), else the marker
            # file's as `analog = true` loads them.
            if r.get("channels_npy"):
                loaded[r["file"]]["analog"] = dict(values=np.load(r["channels_npy"]), rate=r["frame_rate_hz"],
                                                   labels=[c["name"] for c in r["channels"]],
                                                   units=[c["unit"] for c in r["channels"]])
            elif r.get("analog"):
                a = r["analog"]
                loaded[r["file"]]["analog"] = dict(values=np.load(a["npy"]), rate=a["rate_hz"],
                                                   labels=[c["name"] for c in a["channels"]],
                                                   units=[c["unit"] for c in a["channels"]])
    refused = {}
    for line in run.stderr.splitlines():
        for f in files:
            if f not in loaded and line.startswith(f"error: {f}"):
                refused[f] = line
    missing = [f for f in files if f not in loaded and f not in refused]
    if missing:
        sys.exit(f"motionlab neither loaded nor refused {missing}: {run.stderr}")
    return loaded, refused


def peer_names(labels, n):
    """What motionlab names a peer's labels: blank -> P<n>, a subject prefix stripped, a label
    written again -> label#2, #3, ... (the loader's documented repairs)."""
    names, seen = [], {}
    for i in range(n):
        label = labels[i].strip() if i < len(labels) else ""
        if ":" in label and label.rsplit(":", 1)[1].strip():
            label = label.rsplit(":", 1)[1].strip()
        label = label or f"P{i + 1}"
        seen[label] = seen.get(label, 0) + 1
        names.append(label if seen[label] == 1 else f"{label}#{seen[label]}")
    return names


def compare(ours, theirs, who):
    """Differences beyond float32 rounding between two readings, as text (empty: none)."""
    a, b = ours["positions"], theirs["positions"]
    if a.shape != b.shape:
        return [f"{who}: {b.shape[0]} frames x {b.shape[1]} points, motionlab {a.shape[0]} x {a.shape[1]}"]
    problems = []
    gone_a, gone_b = np.isnan(a[:, :, 0]), np.isnan(b[:, :, 0])
    if (gone_a != gone_b).any():
        problems.append(f"{who}: {int((gone_a != gone_b).sum())} samples missing in one reading only")
    both = ~gone_a & ~gone_b
    if both.any():
        d = np.abs(a[both] - b[both])
        allowed = F32 * np.maximum(np.abs(a[both]), np.abs(b[both])) + 1e-9
        if (d > allowed).any():
            problems.append(f"{who}: {int((d > allowed).sum())} coordinates differ beyond float32 rounding (largest {d.max():.4g} mm)")
    if peer_names(theirs["labels"], b.shape[1]) != ours["labels"]:
        problems.append(f"{who}: labels {theirs['labels'][:6]}... vs motionlab's {ours['labels'][:6]}...")
    if abs(theirs["rate"] - ours["rate"]) > 1e-6 * ours["rate"]:
        problems.append(f"{who}: rate {theirs['rate']} Hz, motionlab {ours['rate']} Hz")
    return problems


def analog_names(labels, n):
    """What motionlab names analog labels: blank -> A<n>, a label written again -> label#2, ..."""
    names, seen = [], set()
    for i in range(n):
        label = (labels[i].strip() if i < len(labels) else "") or f"A{i + 1}"
        if label in seen:
            label = next(f"{label}#{k}" for k in range(2, n + 2) if f"{label}#{k}" not in seen)
        seen.add(label)
        names.append(label)
    return names


def ezc3d_analog(path):
    def go(p):
        e = ezc3d.c3d(p)
        a = e["parameters"]["ANALOG"]
        labels, units, k = list(a.get("LABELS", {}).get("value", [])), list(a.get("UNITS", {}).get("value", [])), 2
        while f"LABELS{k}" in a:
            labels += list(a[f"LABELS{k}"]["value"])
            k += 1
        k = 2
        while f"UNITS{k}" in a:
            units += list(a[f"UNITS{k}"]["value"])
            k += 1
        return dict(values=e["data"]["analogs"][0].T, labels=labels, units=units,
                    rate=float(e["header"]["analogs"]["frame_rate"]))
    return with_plain_file(path, go)


def pyc3d_analog(path):
    def go(p):
        with open(p, "rb") as h, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = pyc3d.Reader(h)
            return np.concatenate([a.T for _, _, a in r.read_frames()])
    return with_plain_file(path, go)


def close_columns(a, b):
    """Channels where two (samples x channels) readings differ beyond float32 rounding."""
    d = np.abs(a - b)
    allowed = F32 * np.maximum(np.abs(a), np.abs(b)) + 1e-9
    return [k for k in range(a.shape[1]) if (d[:, k] > allowed[:, k]).any()]


def check_analog(path, ours, exp):
    """Problems (text) and what was said, comparing motionlab's analog channels with ezc3d's
    (py-c3d's on the channels where ezc3d departs from the letter)."""
    raw = RawC3d(path)
    unsigned = (raw.param("ANALOG", "FORMAT") or [""])[0].strip().upper() == "UNSIGNED"
    n = ours["values"].shape[1]
    offsets = raw.param("ANALOG", "OFFSET") or [0]
    offsets = [struct.unpack("<h", struct.pack("<H", o))[0] if o > 32767 else o for o in offsets]
    departs = list(range(n)) if unsigned else [k for k in range(n) if offsets[min(k, len(offsets) - 1)] < 0]
    if exp.get("ezc3d", "ok") != "ok":
        departs = list(range(n))
    problems, said = [], []
    try:
        ez = isolated(ezc3d_analog, path)
    except Exception as e:
        ez = None
        if exp.get("ezc3d", "ok") == "ok":
            problems.append(f"analog: ezc3d refuses ({e})")
    if ez is not None and exp.get("ezc3d", "ok") == "ok":
        if ez["values"].shape != ours["values"].shape:
            problems.append(f"analog: ezc3d {ez['values'].shape}, motionlab {ours['values'].shape}")
        else:
            if analog_names(ez["labels"], n) != ours["labels"]:
                problems.append(f"analog labels: ezc3d {ez['labels'][:6]}..., motionlab {ours['labels'][:6]}...")
            if [u.strip() for u in ez["units"][:n]] + [""] * max(0, n - len(ez["units"])) != ours["units"]:
                problems.append(f"analog units: ezc3d {ez['units'][:6]}..., motionlab {ours['units'][:6]}...")
            if abs(ez["rate"] - ours["rate"]) > 1e-6 * ours["rate"]:
                problems.append(f"analog rate: ezc3d {ez['rate']} Hz, motionlab {ours['rate']} Hz")
            bad = [k for k in close_columns(ours["values"], ez["values"]) if k not in departs]
            if bad:
                problems.append(f"analog: channels {[ours['labels'][k] for k in bad]} differ from ezc3d's beyond float32 rounding")
            agreeing = n - len(departs)
            if agreeing:
                said.append(f"analog {agreeing} channels x {ours['values'].shape[0]} samples: ezc3d agrees")
    if departs:
        who = "py-c3d"
        try:
            py = isolated(pyc3d_analog, path)
        except Exception:
            # Where py-c3d refuses the file too, the raw reading of the account that fits it.
            who = "the raw reading"
            py = raw.analog(exp.get("account", "header"))
        if py.shape != ours["values"].shape:
            problems.append(f"analog: {who} {py.shape}, motionlab {ours['values'].shape}")
        else:
            bad = [k for k in close_columns(ours["values"], py) if k in departs]
            if bad:
                problems.append(f"analog: channels {[ours['labels'][k] for k in bad]} differ from {who}'s")
            said.append(f"analog {len(departs)} channels where ezc3d departs from the letter"
                        f" ({'UNSIGNED words' if unsigned else 'negative OFFSET' if exp.get('ezc3d', 'ok') == 'ok' else exp['why']}): {who} agrees")
    return problems, said


# Every C3D of the repository (data/ and tests/fixtures/): the check must find and compare
# exactly these many, so a moved folder or a glob that finds nothing fails instead of checking
# less. Raise it with the file you add.
N_C3D_FILES = 75

# Malformed fixtures (tests/fixtures/malformed/) where a peer reads other numbers than
# motionlab's lenient reading: {file: {reader: (start of the exact difference expected, why it
# is not motionlab's error)}}. Any other difference on a malformed file fails. None at present:
# every peer that reads a malformed file motionlab loads agrees with it.
MALFORMED_DIFFERS = {}


def check(binary, broken=None):
    """The failures (empty: every file agrees). `broken` spoils one input on purpose (the
    self-test): "drop" loses motionlab's reading of one file, "cell" moves one of its
    coordinates by 1 mm, "malformed" does so in a malformed file motionlab reads, "exception"
    forgets the documented malformed exceptions (when there are any)."""
    files = repository_c3d_files()
    loaded, refused = motionlab_read(binary, files)
    differs = {} if broken == "exception" else MALFORMED_DIFFERS
    if broken == "drop":
        loaded.pop(next(iter(loaded)))
    if broken in ("cell", "malformed"):
        # A coordinate of a well-formed file, or of a malformed one read leniently (which
        # the check compared with nothing before issue 34).
        path = next(p for p in files if p in loaded and (("malformed" in p) == (broken == "malformed")))
        xyz = loaded[path]["positions"]
        i, j = np.argwhere(~np.isnan(xyz[:, :, 0]))[0]
        xyz[i, j, 0] += 1.0
    failures, compared, files_compared, analog_files = [], 0, 0, 0
    files_refused_as_expected = 0
    for path in files:
        name = os.path.basename(path).removesuffix(".gz")
        rel = os.path.relpath(path, ROOT)
        exp = EXPECTED.get(name, {})
        malformed = os.sep + "malformed" + os.sep in path
        if path in refused:
            if exp.get("reference", "") is None or malformed:
                print(f"{rel}: refused, as {'tests/malformed.rs expects' if malformed else 'every reader does: ' + exp['why']}")
                files_refused_as_expected += 1
            else:
                failures.append(f"{rel}: motionlab refused it: {refused[path]}")
            continue
        if path not in loaded:
            failures.append(f"{rel}: motionlab's reading is missing")
            continue
        ours = loaded[path]
        said_analog = []
        if ours["analog"] is not None:
            problems, said_analog = check_analog(path, ours["analog"], exp)
            failures += [f"{rel}: {p}" for p in problems]
            analog_files += 1
        if ours["positions"].shape[1] == 0:
            # No 3-D point (an EMG system's export): the analog channels are the data.
            if ours["analog"] is None:
                failures.append(f"{rel}: motionlab loaded neither points nor analog channels")
            print(f"{rel}: no points; {'; '.join(said_analog)}")
            files_compared += bool(said_analog) and not problems
            continue
        readers = {}
        for who in ("ezc3d", "pyc3d"):
            try:
                got = isolated(read_with, who, path)
                readers[who] = got if got["positions"].size else "reads no point"
            except Exception as e:  # a peer's refusal is data here, whatever it raises
                readers[who] = f"refuses ({type(e).__name__}: {str(e)[:80]})"
        try:
            readers["raw"] = raw_read(path, exp.get("account", "header"))
        except Exception as e:
            readers["raw"] = f"refuses ({type(e).__name__}: {e})"
        said = []
        agreed = 0
        for who, got in readers.items():
            expected = exp.get(who, "ok")
            if isinstance(got, str):
                if expected == "ok" and not malformed:
                    failures.append(f"{rel}: {who} {got}")
                said.append(f"{who} {got.split(' (')[0]}")
                continue
            problems = compare(ours, got, who)
            if expected == "wrong":
                if not problems:
                    failures.append(f"{rel}: {who} is documented as wrong here but agrees; update EXPECTED")
                said.append(f"{who} wrong ({exp['why']})")
            elif problems and malformed:
                known = differs.get(name, {}).get(who)
                if known and problems[0].startswith(known[0]):
                    said.append(f"{who} differs on this malformed file as documented ({problems[0]}: {known[1]})")
                else:
                    failures.append(f"{rel}: {who} differs on this malformed file and MALFORMED_DIFFERS does not explain it: {problems[0]}")
            elif problems:
                failures += [f"{rel}: {p}" for p in problems]
            else:
                compared += int((~np.isnan(got['positions'][:, :, 0])).sum())
                agreed += 1
                said.append(f"{who} agrees")
        right = [w for w, g in readers.items() if not isinstance(g, str) and exp.get(w, "ok") == "ok"]
        if not right:
            failures.append(f"{rel}: no reader to check motionlab against")
        said += said_analog
        files_compared += agreed > 0
        print(f"{rel}: {'; '.join(said)}" + (f"; repaired: {'; '.join(ours['repairs'])}" if ours["repairs"] else ""))
    print(f"{len(files)} C3D files, {len(loaded)} loaded, {len(refused)} refused; {files_compared} files agree with at least "
          f"one reader documented as right; {compared} sample comparisons with readers that read the file right; "
          f"analog channels compared in {analog_files} files")
    if analog_files == 0:
        failures.append("no file's analog channels were compared")
    if len(files) != N_C3D_FILES:
        failures.append(f"found {len(files)} C3D files, N_C3D_FILES says {N_C3D_FILES}")
    # Every file either refused as documented or compared with a reader that reads it right.
    if files_compared + files_refused_as_expected != N_C3D_FILES:
        failures.append(f"{files_compared} files compared and {files_refused_as_expected} refused as documented, "
                        f"of the {N_C3D_FILES} intended")
    return failures


def self_test(binary):
    """Each deliberately broken input must fail the check."""
    for broken in ("drop", "cell", "malformed", "exception"):
        if broken == "exception" and not MALFORMED_DIFFERS:
            continue
        failures = check(binary, broken)
        if not failures:
            sys.exit(f"self-test: the check passed with a broken input ({broken})")
        print(f"self-test ({broken}): fails as it should: {failures[0]}")
    print("self-test passed: every broken input failed the check")


def default_binary():
    target = os.environ.get("CARGO_TARGET_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "motionlab-target")
    binary = os.path.join(target, "debug", "motionlab")
    if not os.path.exists(binary):
        subprocess.run(["cargo", "build", "-p", "motionlab-cli"], cwd=ROOT, check=True)
    return binary


if __name__ == "__main__":
    cmd = sys.argv[1] if len(sys.argv) > 1 else "check"
    if cmd == "reference":
        reference()
    elif cmd in ("check", "self-test"):
        binary = sys.argv[2] if len(sys.argv) > 2 else default_binary()
        if cmd == "self-test":
            self_test(binary)
            sys.exit(0)
        failures = check(binary)
        if failures:
            print("FAILED:\n  " + "\n  ".join(failures))
            sys.exit(1)
        print("every loaded file agrees with every reader documented as right, to float32 rounding")
    else:
        sys.exit("usage: conformance_crosscheck.py check [motionlab] | self-test [motionlab] | reference")
