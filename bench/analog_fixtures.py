#!/usr/bin/env python3
"""Hand-made analog-only C3D files and ezc3d's reading of them (run once, output committed).

The three analog-only files of the c3d.org sample set issue 38 names (Cometa EMG, an EMG walk,
a Mega Electronics isokinetic EMG/angle/torque file) are not in the shared data, and ezc3d's
Python writer refuses a file without points (ZeroDivisionError in ezc3d 1.7.2's write). So
this script writes three small analog-only files with a C3D writer of its own, written from the
C3D User Guide's layout independently of motionlab's reader (Intel processor, 512-byte blocks,
parameter section in block 2, data after it), covering what the analog reading must get right:
16-bit signed storage with per-channel ANALOG:SCALE and OFFSET and ANALOG:GEN_SCALE, unsigned
storage (ANALOG:FORMAT "UNSIGNED", OFFSET 32768 written as -32768), float storage, an analog rate that is 10 × or
20 × the point rate, LABELS2 continuing LABELS, and units per channel.

Then it reads each with ezc3d 1.7.2 and py-c3d 0.6.0 and writes
``tests/fixtures/analog/reference.json``: per file the rate, labels, units and every value as
the C3D letter gives it (py-c3d agrees on every channel; ezc3d on the channels listed, as it
takes |OFFSET| and reads "UNSIGNED" words as signed: the EMG_L/EMG_R and Trigger channels). ``crates/motionlab-io/tests/conformance.rs`` compares motionlab's loads
with it; ``bench/conformance_crosscheck.py check`` compares again in CI, live, with ezc3d.

It also writes, for one real Schreiber & Moissenet 2019 file (markers plus 8 EMG and two
force plates at 1500 Hz), ezc3d's reading of its analog channels (first samples and sums).

Run: bench/analog_fixtures.py
"""
import gzip
import json
import math
import os
import struct
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_modules  # noqa: E402

ensure_modules("numpy", "ezc3d", "c3d")

import ezc3d  # noqa: E402
import numpy as np  # noqa: E402

OUT = os.path.join(ROOT, "tests", "fixtures", "analog")
# A real marker file with analog channels (8 EMG, 2 force plates at 1500 Hz): its channels as
# ezc3d reads them (sums and first samples) go to reference.json's "real" section.
REAL = ["data/schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz"]
BLOCK = 512


def record(group_id, name, body):
    """A group (group_id < 0) or parameter record: name length, id, name, offset to the next
    record (counted from the offset word), body, an empty description."""
    name = name.encode("ascii")
    rest = body + b"\x00"  # description length 0
    return struct.pack("<bb", len(name), group_id) + name + struct.pack("<h", 2 + len(rest)) + rest


def param(group_id, name, kind, dims, data):
    return record(group_id, name, struct.pack("<bB", kind, len(dims)) + bytes(dims) + data)


def ints(values):
    return 2, [len(values)] if len(values) > 1 else [], struct.pack(f"<{len(values)}h", *values)


def floats(values):
    return 4, [len(values)] if len(values) > 1 else [], struct.pack(f"<{len(values)}f", *values)


def chars(strings):
    width = max(len(s) for s in strings)
    return -1, [width, len(strings)], b"".join(s.ljust(width).encode("ascii") for s in strings)


def write_c3d(path, point_rate, per_frame, n_frames, channels, raw, float_storage, extra_analog=(), unsigned=False):
    """channels: [(label, unit, scale, offset)]; raw[frame][sample][channel]: stored numbers."""
    n = len(channels)
    labels = [c[0] for c in channels]
    groups = [(-1, "POINT"), (-2, "ANALOG")]
    point_scale = -1.0 if float_storage else 0.1
    analog = [
        ("USED", ints([n])),
        ("RATE", floats([point_rate * per_frame])),
        ("LABELS", chars(labels[:2] if n > 2 else labels)),
        ("UNITS", chars([c[1] for c in channels])),
        ("SCALE", floats([c[2] for c in channels])),
        ("OFFSET", ints([c[3] for c in channels])),
        ("GEN_SCALE", floats([0.5])),
    ]
    if n > 2:
        analog.append(("LABELS2", chars(labels[2:])))
    analog += list(extra_analog)
    param_blocks = 2
    data_start = 2 + param_blocks
    point = [
        ("USED", ints([0])),
        ("RATE", floats([point_rate])),
        ("SCALE", floats([point_scale])),
        ("DATA_START", ints([data_start])),
        ("FRAMES", ints([n_frames])),
    ]
    body = b""
    for gid, name in groups:
        body += record(gid, name, b"")
    for gid, items in ((1, point), (2, analog)):
        for name, (kind, dims, data) in items:
            body += param(gid, name, kind, dims, data)
    body += b"\x00\x00"  # a zero name length ends the chain
    section = bytes([1, 0x50, param_blocks, 84]) + body
    assert len(section) <= param_blocks * BLOCK
    section = section.ljust(param_blocks * BLOCK, b"\x00")
    header = bytearray(BLOCK)
    struct.pack_into("<BB", header, 0, 2, 0x50)
    struct.pack_into("<HHHHH", header, 2, 0, n * per_frame, 1, n_frames, 0)
    struct.pack_into("<f", header, 12, point_scale)
    struct.pack_into("<HH", header, 16, data_start, per_frame)
    struct.pack_into("<f", header, 20, point_rate)
    data = b""
    for frame in raw:
        for sample in frame:
            data += struct.pack(f"<{n}f" if float_storage else f"<{n}H" if unsigned else f"<{n}h", *sample)
    data = data.ljust(-(-len(data) // BLOCK) * BLOCK, b"\x00")
    with open(path, "wb") as f:
        f.write(bytes(header) + section + data)


def files():
    """(name, arguments of write_c3d): three small analog-only recordings."""
    # EMG at 1000 Hz (points at 100 Hz, 10 samples a frame), 16-bit signed: a 50 Hz burst, a
    # slow ramp and a constant, each with its own scale and offset.
    f, per = 12, 10
    emg = [[[int(round(3000 * math.sin(2 * math.pi * 50 * (i * per + s) / 1000.0))),
             -2000 + 30 * (i * per + s),
             17] for s in range(per)] for i in range(f)]
    yield "emg_int16.c3d", dict(point_rate=100.0, per_frame=per, n_frames=f, float_storage=False, raw=emg,
                                channels=[("EMG1", "V", 0.001, 0), ("EMG2", "mV", 0.002, 10), ("Trigger", "V", -0.25, -3)])
    # An unsigned 16-bit converter (ANALOG:FORMAT "UNSIGNED", words 0..65535 around 32768):
    # the offset 32768 does not fit the signed OFFSET parameter and is written as -32768, which
    # ezc3d reads as its magnitude.
    f, per = 6, 20
    unsigned = [[[32768 + int(round(20000 * math.sin((i * per + s) / 7.0))), 65535 - 250 * (i * per + s)]
                 for s in range(per)] for i in range(f)]
    yield "emg_unsigned.c3d", dict(point_rate=50.0, per_frame=per, n_frames=f, float_storage=False, raw=unsigned,
                                   unsigned=True, channels=[("EMG_L", "uV", 0.5, -32768), ("EMG_R", "uV", 0.5, -32768)],
                                   extra_analog=[("FORMAT", chars(["UNSIGNED"]))])
    # An isokinetic dynamometer: angle, velocity, torque and EMG as floats at 500 Hz.
    f, per = 8, 10
    iso = [[[-40.0 + 0.5 * (i * per + s), 60.0 + 0.25 * math.cos((i * per + s) / 5.0),
             12.5 * math.sin((i * per + s) / 9.0), 0.001 * ((i * per + s) % 7 - 3)]
            for s in range(per)] for i in range(f)]
    yield "isokinetic_float.c3d", dict(point_rate=50.0, per_frame=per, n_frames=f, float_storage=True, raw=iso,
                                       channels=[("Angle", "deg", 1.0, 0), ("Velocity", "deg/s", 1.0, 0),
                                                 ("Torque", "Nm", 2.0, 1), ("EMG", "V", 1.0, 0)])


def letter(args):
    """The values the C3D User Guide gives for what write_c3d stored: (word - OFFSET) x SCALE x
    GEN_SCALE, with OFFSET read as the stored 16-bit word, signed, or unsigned when
    ANALOG:FORMAT is "UNSIGNED" (as the words are); [sample][channel]."""
    unsigned = args.get("unsigned", False)
    out = []
    for frame in args["raw"]:
        for sample in frame:
            row = []
            for (_, _, scale, offset), word in zip(args["channels"], sample):
                off = offset + 65536 if unsigned and offset < 0 else offset
                if args["float_storage"]:
                    word = float(np.float32(word))  # what the file holds
                row.append((word - off) * float(np.float32(scale)) * 0.5)
            out.append(row)
    return np.array(out)


def ezc3d_analog(path):
    e = ezc3d.c3d(path)
    a = e["parameters"]["ANALOG"]
    labels = list(a["LABELS"]["value"]) + list(a.get("LABELS2", {}).get("value", []))
    return dict(rate_hz=float(e["header"]["analogs"]["frame_rate"]), labels=labels,
                units=list(a.get("UNITS", {}).get("value", [])),
                points=int(e["data"]["points"].shape[1]),
                values=e["data"]["analogs"][0].T)  # [sample][channel]


def pyc3d_analog(path):
    import warnings

    import c3d as pyc3d

    with open(path, "rb") as h, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = pyc3d.Reader(h)
        # read_frames gives each frame's analog block as [channel][sample].
        return np.concatenate([a.T for _, _, a in r.read_frames()])


def agreeing(a, b):
    """Channels (0-based) on which two readings agree to float32 rounding."""
    return [k for k in range(a.shape[1]) if np.allclose(a[:, k], b[:, k], rtol=2.0 ** -22, atol=1e-9)]


def main():
    ensure_modules("c3d")
    os.makedirs(OUT, exist_ok=True)
    out = {}
    for name, args in files():
        path = os.path.join(OUT, name)
        write_c3d(path, **args)
        want = letter(args)
        ez = ezc3d_analog(path)
        py = pyc3d_analog(path)
        assert agreeing(py, want) == list(range(want.shape[1])), f"{name}: py-c3d differs from the letter"
        out[name] = dict(rate_hz=ez["rate_hz"], labels=ez["labels"], units=ez["units"], points=ez["points"],
                         ezc3d_agrees=agreeing(ez["values"], want), pyc3d_agrees=agreeing(py, want),
                         values=want.tolist())
        print(f"{name}: {want.shape[0]} samples x {want.shape[1]} channels at {ez['rate_hz']} Hz, {ez['points']} points; "
              f"ezc3d agrees on channels {out[name]['ezc3d_agrees']}, py-c3d on all")
    real = {}
    for rel in REAL:
        with tempfile.NamedTemporaryFile(suffix=".c3d") as t:
            t.write(gzip.decompress(open(os.path.join(ROOT, rel), "rb").read()))
            t.flush()
            ez = ezc3d_analog(t.name)
        v = ez["values"]
        real[rel] = dict(rate_hz=ez["rate_hz"], labels=ez["labels"], units=ez["units"], samples=int(v.shape[0]),
                         first=v[:3].tolist(), sum=v.sum(axis=0).tolist(), abs_sum=np.abs(v).sum(axis=0).tolist(),
                         weighted_sum=(v * np.arange(1, v.shape[0] + 1)[:, None]).sum(axis=0).tolist())
        print(f"{rel}: {v.shape[0]} samples x {v.shape[1]} channels at {ez['rate_hz']} Hz (ezc3d)")
    with open(os.path.join(OUT, "reference.json"), "w") as f:
        f.write('{\n"generated_by": "bench/analog_fixtures.py",\n')
        f.write('"values": "the C3D letter: (word - OFFSET) x SCALE x GEN_SCALE, OFFSET unsigned when ANALOG:FORMAT is UNSIGNED; '
                'py-c3d 0.6.0 gives them on every channel, ezc3d 1.7.2 on the channels ezc3d_agrees lists (it takes |OFFSET| '
                'and reads UNSIGNED words as signed)",\n"files": {\n')
        f.write(",\n".join(f"{json.dumps(k)}: {json.dumps(v, separators=(',', ':'))}" for k, v in out.items()))
        f.write('\n},\n"real": {\n')
        f.write(",\n".join(f"{json.dumps(k)}: {json.dumps(v, separators=(',', ':'))}" for k, v in real.items()))
        f.write("\n}\n}\n")


if __name__ == "__main__":
    main()
