#!/usr/bin/env python3
"""Builds the fuzz seed corpora in fuzz/corpus/<target>/ from the shipped real files in data/
and the malformed fixtures in tests/fixtures/ (see README.md). Deterministic; the corpora are
not committed (.gitignore), so run this (fuzz/seed.sh does) on a fresh clone.

Big files are cut to a few frames *with their frame counts patched*, so the seeds are small
valid files — the fuzzer then mutates from a file that parses all the way through, instead of
spending its time on multi-hundred-KB inputs that all fail at the same truncation check.
"""

import gzip
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "data"
FIXTURES = ROOT / "tests" / "fixtures"
sys.path.insert(0, str(FIXTURES))
from c3d_edit import C3d  # noqa: E402

TARGETS = ["bvh", "asf", "amc", "c3d", "qualisys_tsv", "cmu86_labels", "mocap6_labels", "boundaries_csv", "elan_eaf", "plugin_reply", "gunzip", "experiment_toml", "trc", "mot", "openpose", "coco_keypoints", "mediapipe", "mvnx"]


def read(p: Path) -> bytes:
    return gzip.open(p).read() if p.suffix == ".gz" else p.read_bytes()


def bvh_frames(text: str, k: int) -> str:
    """The BVH cut to its first k frames, `Frames:` patched."""
    head, motion = text.split("MOTION", 1)
    lines = motion.lstrip("\r\n").splitlines(keepends=True)
    # lines[0] = "Frames: N", lines[1] = "Frame Time: t", then frames
    return head + "MOTION\n" + f"Frames: {k}\n" + lines[1] + "".join(lines[2 : 2 + k])


def amc_frames(text: str, k: int) -> str:
    """The AMC cut before the frame-number line of frame k + 1."""
    out, frames = [], 0
    for line in text.splitlines(keepends=True):
        if line.strip().isdigit():
            frames += 1
            if frames > k:
                break
        out.append(line)
    return "".join(out)


def tsv_rows(text: str, first: int, k: int) -> str:
    """Header plus rows first..first+k-1 (0-based), NO_OF_FRAMES patched."""
    lines = text.splitlines(keepends=True)
    header = [l for l in lines if l[:1].isalpha()]
    rows = [l for l in lines if not l[:1].isalpha() and l.strip()]
    header = [f"NO_OF_FRAMES\t{k}\n" if l.startswith("NO_OF_FRAMES") else l for l in header]
    return "".join(header + rows[first : first + k])


def main() -> None:
    corpus = ROOT / "fuzz" / "corpus"
    for t in TARGETS:
        d = corpus / t
        d.mkdir(parents=True, exist_ok=True)
    seeds: dict[str, dict[str, bytes]] = {t: {} for t in TARGETS}

    for p in sorted((DATA / "cmu131").glob("*.bvh.gz")):
        text = read(p).decode()
        for k in (1, 8, 60):
            seeds["bvh"][f"{p.name[:-7]}_{k}f.bvh"] = bvh_frames(text, k).encode()
        seeds["bvh"][f"{p.name[:-7]}_8f_crlf.bvh"] = bvh_frames(text, 8).replace("\r\n", "\n").replace("\n", "\r\n").encode()

    for p in [DATA / "cmu86/86.asf", DATA / "mocap6/asf/13.asf", DATA / "mocap6/asf/14.asf"]:
        seeds["asf"][p.name] = read(p)
    for p, name in [(DATA / "cmu86/86_01.amc.gz", "86_01"), (DATA / "mocap6/amc/13_29.amc.gz", "13_29")]:
        text = read(p).decode()
        for k in (1, 6, 40):
            seeds["amc"][f"{name}_{k}f.amc"] = amc_frames(text, k).encode()

    c3ds = [DATA / "mct/walk1.c3d.gz", DATA / "mct/dance1.c3d.gz"] + sorted(DATA.glob("schreiber2019/*/dynamic/*.c3d.gz"))[:2]
    for p in c3ds:
        stem = p.name[:-7]
        for k in (1, 10):
            seeds["c3d"][f"{stem}_{k}f.c3d"] = C3d(read(p)).keep_frames(k)

    # Other writers' files (tests/fixtures/conformance/), each exposing a reading repair or its
    # control, cut to 10 frames with their counts patched (MotionMonitor's with the 576-byte
    # stride of its parameters' account, the one that fits it; the processor-0 file whole).
    # The PyMO walk at 1 and 8 frames.
    conformance = FIXTURES / "conformance"
    for p in sorted((conformance / "c3d").glob("*")):
        if p.suffix.lower() != ".c3d":
            continue
        data = p.read_bytes()
        try:
            c = C3d(data)
        except ValueError:
            seeds["c3d"][f"conformance_{p.name}"] = data
            continue
        stride = 576 if "MotionMonitor" in p.name else c.frame_bytes
        c.keep_frames(10)
        seeds["c3d"][f"conformance_{p.name}"] = bytes(c.b[: c.data_start + 10 * stride])
    for p in sorted((conformance / "bvh").glob("*.bvh")):
        text = p.read_text()
        for k in (1, 8):
            seeds["bvh"][f"conformance_{p.stem}_{k}f.bvh"] = bvh_frames(text, k).encode()

    walk1 = read(DATA / "mct/walk1.tsv.gz").decode()
    seeds["qualisys_tsv"]["walk1_rows_0_10.tsv"] = tsv_rows(walk1, 0, 10).encode()
    # walk1's 27 missing samples (NaN) are in rows 201–211 and 306–321 (1-based).
    seeds["qualisys_tsv"]["walk1_rows_196_20_nan.tsv"] = tsv_rows(walk1, 195, 20).encode()
    dance1 = read(DATA / "mct/dance1.tsv.gz").decode()
    seeds["qualisys_tsv"]["dance1_rows_0_5.tsv"] = tsv_rows(dance1, 0, 5).encode()

    # TRC and MOT/STO: every shipped sample cut to its header and first 6 rows (counts left as
    # written: a NumFrames that differs from the rows is one of the quirks to survive).
    for p in sorted((DATA / "formats").glob("*/*")):
        if p.suffix in (".trc", ".mot", ".sto"):
            lines = read(p).decode().split("\n")
            if p.suffix == ".trc":
                keep = lines[:12]
            else:
                end = next(i for i, l in enumerate(lines) if l.strip() == "endheader")
                keep = lines[: end + 8]
            target = "trc" if p.suffix == ".trc" else "mot"
            seeds[target][f"{p.parent.name}_{p.name}"] = "\n".join(keep).encode() + b"\n"

    # Video keypoints: a few OpenPose frames (frame 37 holds three people), the COCO files, the
    # MediaPipe landmarks, and the malformed corpus's cases of each.
    for k in (0, 37, 99):
        p = DATA / f"formats/pose2sim/openpose_balancing_cam01_json/cam01.{k:04}.json"
        seeds["openpose"][p.name] = read(p)
    for p in [DATA / "formats/mmpose-coco/test_coco.json", DATA / "formats/cocoapi/person_keypoints_val2014_fakekeypoints100_results.json"]:
        seeds["coco_keypoints"][p.name] = read(p)
    seeds["mediapipe"]["pose_landmarks.pbtxt"] = read(DATA / "formats/mediapipe/pose_landmarks.pbtxt")
    for p in sorted((FIXTURES / "malformed").glob("*")):
        if p.is_dir() and p.name.startswith("openpose_"):
            for f in sorted(p.glob("*.json")):
                seeds["openpose"][f"malformed_{f.name}"] = read(f)
        elif p.name.startswith("coco_"):
            seeds["coco_keypoints"][p.name] = read(p)
        elif p.name.startswith("mediapipe_"):
            seeds["mediapipe"][p.name] = read(p)
    # MVNX: no shipped file; the schema's layout, one calibration and two normal frames.
    seeds["mvnx"]["two_frames.mvnx"] = (
        b'<?xml version="1.0"?>\n<mvnx version="4"><subject frameRate="60"><segments><segment label="Pelvis"/><segment label="L5"/></segments>'
        b'<joints><joint label="jL5S1"/></joints><footContactDefinition><contactDefinition index="0" label="LeftFoot_Heel"/>'
        b'<contactDefinition index="1" label="RightFoot_Heel"/></footContactDefinition><frames>'
        b'<frame type="tpose"><orientation>1 0 0 0 1 0 0 0</orientation><position>0 0 1 0 0 1.1</position></frame>'
        b'<frame type="normal"><orientation>1 0 0 0 1 0 0 0</orientation><position>0 0 1 0 0 1.1</position><jointAngle>1 2 3</jointAngle><footContacts>0 1</footContacts></frame>'
        b'<frame type="normal"><orientation>1 0 0 0 1 0 0 0</orientation><position>0 0 1 0 0 1.1</position><jointAngle>1 2 3</jointAngle><footContacts>1 0</footContacts></frame>'
        b'</frames></subject></mvnx>\n'
    )

    seeds["cmu86_labels"]["mocap.txt"] = read(DATA / "cmu86/mocap.txt")
    for p in sorted((DATA / "mocap6/truelabels").glob("*.txt")):
        seeds["mocap6_labels"][p.name] = read(p)

    # The user-annotation readers: the shipped example annotations (CSV and ELAN).
    for p in sorted((FIXTURES / "annotations").glob("*.csv")):
        seeds["boundaries_csv"][p.name] = read(p)
    for p in sorted((FIXTURES / "annotations").glob("*.eaf")):
        seeds["elan_eaf"][p.name] = read(p)

    for p in sorted((ROOT / "experiments").glob("*.toml")):
        seeds["experiment_toml"][p.name] = read(p)
    # An experiment naming a program (the consent scan's input), as a stage and in a sweep grid.
    ext = ROOT / "examples/external-segmenter/speed_minima_vs_python.toml"
    seeds["experiment_toml"][ext.name] = read(ext)
    seeds["experiment_toml"]["external_swept.toml"] = read(ext) + (
        b'\n[[sweep]]\ngrid = { "segmentation.segmenter[python].command" = [["sh", "-c", "echo"], ["python3", "x.py"]] }\n'
    )

    # External programs' stdout (protocol 1): replies of both kinds, valid and not; the last
    # byte picks the motion's length (n % 17 frames).
    replies = {
        "segmenter_min.json": b'{"candidates": [1, 3]}\n\x05',
        "segmenter_full.json": b'{"candidates": [0, 2], "traces": [{"name": "V_mm_per_s", "unit": "mm/s", "values": [1.5, null, 2, 0]}], '
        b'"thresholds": [{"name": "v_low", "trace": "V_mm_per_s", "value": 1.75}], "flagged_frames": [1]}\x04',
        "features.json": b'{"traces": [{"name": "height_mm", "unit": "mm", "values": [1, 2, 3]}], "labels": [{"name": "side", "values": ["l", "r", "l"]}]}\x03',
        "nan.json": b'{"candidates": [], "traces": [{"name": "V", "values": [NaN, 1]}]}\x02',
        "out_of_range.json": b'{"candidates": [7]}\x02',
    }
    seeds["plugin_reply"].update(replies)

    # The bounded reader: shipped files re-compressed small (one member, two members, a cut
    # stream, a lying trailer) and a few plain bytes.
    small = tsv_rows(dance1, 0, 3).encode()
    one = gzip.compress(small, mtime=0)
    seeds["gunzip"]["one_member.tsv.gz"] = one
    seeds["gunzip"]["two_members.tsv.gz"] = one + gzip.compress(b"second member\n", mtime=0)
    seeds["gunzip"]["cut.tsv.gz"] = one[: len(one) // 2]
    seeds["gunzip"]["lying_trailer.tsv.gz"] = one[:-4] + (3).to_bytes(4, "little")
    seeds["gunzip"]["zeros_200k.gz"] = gzip.compress(bytes(200_000), mtime=0)
    seeds["gunzip"]["plain.tsv"] = small

    # The malformed corpus, by extension.
    by_ext = {".bvh": "bvh", ".asf": "asf", ".amc": "amc", ".c3d": "c3d", ".tsv": "qualisys_tsv", ".toml": "experiment_toml", ".csv": "boundaries_csv", ".eaf": "elan_eaf"}
    for d in [FIXTURES / "malformed", FIXTURES / "fuzz"]:
        for p in sorted(d.glob("*")) if d.is_dir() else []:
            name = p.name
            if name.startswith("cmu86_"):
                target = "cmu86_labels"
            elif name.startswith("mocap6_"):
                target = "mocap6_labels"
            else:
                target = by_ext.get(p.suffix)
            if target and p.is_file():
                seeds[target][f"fixture_{name}"] = p.read_bytes()

    for t, files in seeds.items():
        for name, data in files.items():
            (corpus / t / name).write_bytes(data)
        print(f"{t:16} {len(files):3} seeds, {sum(len(b) for b in files.values()) // 1024:5} KiB")


if __name__ == "__main__":
    main()
