#!/usr/bin/env python3
"""Video pose-estimation conformance: motionlab's `openpose`, `coco_keypoints` and `mediapipe`
loaders against the formats' own software (bench/.venv-pose: pycocotools, protobuf).

Every shipped sample under data/formats/ is read by motionlab (``motionlab inspect --json
--npy``: the positions of the person each frame chose, at the loaders' defaults) and by:

- OpenPose folder: Python's ``json`` (OpenPose has no reader library; its files are JSON);
- COCO annotation file: pycocotools ``COCO(path)`` (images in its order, each image's
  annotations from ``getAnnIds``/``loadAnns``);
- COCO results file: Python's ``json`` (pycocotools loads results only against a ground truth);
- MediaPipe ``.pbtxt``: protobuf's ``text_format.Parse`` into a message built from MediaPipe's
  ``NormalizedLandmark``/``NormalizedLandmarkList``/``LandmarksDetectionResult`` field lists.

The rule each loader documents is applied here independently: the person of highest mean
confidence (third value; an undetected keypoint counts 0; first on a tie), keypoints with
confidence 0 or below the loader's default threshold (OpenPose 0.05, COCO and MediaPipe 0) as
missing. x and y must equal motionlab's to 1e-12 relative (1e-7 for MediaPipe: protobuf keeps
float32, motionlab the decimal text), the third coordinate 0, missing samples at the same places.

The script prints how many files it compared and fails unless it compared exactly the expected
number. Run: bench/pose_crosscheck.py [path/to/motionlab]
"""
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
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory, text_format
    from pycocotools.coco import COCO
except ImportError:
    ensure_venv("requirements-pose.txt")
    raise

EXPECTED = 4


def motionlab_binary():
    if len(sys.argv) > 1:
        return sys.argv[1]
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    return os.path.join(target, "debug", "motionlab")


ML = motionlab_binary()


def inspect(path, tmp):
    out = os.path.join(tmp, os.path.basename(path.rstrip("/")) + "_npy")
    r = subprocess.run([ML, "inspect", "--json", "--npy", out, path], check=True, capture_output=True, text=True)
    return json.loads(r.stdout)[0], np.load(os.path.join(out, "0.npy"))


def chosen(people, n, threshold):
    """The documented rule: highest mean confidence, first on a tie; missing by threshold."""
    if not people:
        return np.full((n, 3), np.nan)
    means = [sum(k[2] for k in p) / len(p) for p in people]
    best = max(range(len(people)), key=lambda i: (means[i], -i))
    out = np.full((n, 3), np.nan)
    for j, (x, y, c) in enumerate(people[best]):
        if c > 0 and c >= threshold:
            out[j] = (x, y, 0.0)
    return out


def triples(flat):
    return [tuple(flat[i : i + 3]) for i in range(0, len(flat), 3)]


COMPARED = []


def compare(name, expected, got, rtol):
    COMPARED.append(name)
    assert expected.shape == got.shape, f"{name}: shape {got.shape}, expected {expected.shape}"
    gone_e, gone_g = np.isnan(expected), np.isnan(got)
    if not np.array_equal(gone_e, gone_g):
        bad = np.argwhere(gone_e != gone_g)[0]
        raise SystemExit(f"{name}: missing differs first at frame {bad[0]} point {bad[1]}")
    ok = ~gone_e
    diff = np.abs(expected[ok] - got[ok]) > rtol * np.maximum(np.abs(expected[ok]), 1.0)
    if diff.any():
        i = np.argwhere(diff)[0][0]
        raise SystemExit(f"{name}: value {got[ok][i]} vs {expected[ok][i]}")
    print(f"{name}: {got.shape[0]} frames x {got.shape[1]} points agree ({int(gone_g.any(axis=2).sum())} missing samples)")


def openpose(tmp):
    folder = os.path.join(ROOT, "data/formats/pose2sim/openpose_balancing_cam01_json")
    frames = []
    for f in sorted(glob.glob(os.path.join(folder, "*.json"))):
        people = [triples(p["pose_keypoints_2d"]) for p in json.load(open(f))["people"] if p.get("pose_keypoints_2d")]
        frames.append(people)
    n = len(frames[0][0])
    expected = np.stack([chosen(p, n, 0.05) for p in frames])
    report, got = inspect(folder, tmp)
    assert report["format"] == "openpose" and report["dimensionality"] == "2d", report
    compare("openpose " + os.path.basename(folder), expected, got, 1e-12)


def coco_annotations(tmp):
    path = os.path.join(ROOT, "data/formats/mmpose-coco/test_coco.json")
    coco = COCO(path)
    person = coco.getCatIds(catNms=["person"])
    n = len(coco.loadCats(person)[0]["keypoints"])
    expected = []
    for img in coco.dataset["images"]:
        anns = coco.loadAnns(coco.getAnnIds(imgIds=[img["id"]], catIds=person))
        expected.append(chosen([triples(a["keypoints"]) for a in anns], n, 0.0))
    report, got = inspect(path, tmp)
    assert report["format"] == "coco_keypoints" and report["points"] == coco.loadCats(person)[0]["keypoints"], report
    compare("coco annotations test_coco.json (pycocotools)", np.stack(expected), got, 1e-12)


def coco_results(tmp):
    path = os.path.join(ROOT, "data/formats/cocoapi/person_keypoints_val2014_fakekeypoints100_results.json")
    dets = [d for d in json.load(open(path)) if d.get("category_id", 1) == 1]
    ids = list(dict.fromkeys(d["image_id"] for d in dets))
    n = len(dets[0]["keypoints"]) // 3
    expected = np.stack([chosen([triples(d["keypoints"]) for d in dets if d["image_id"] == i], n, 0.0) for i in ids])
    _, got = inspect(path, tmp)
    compare("coco results " + os.path.basename(path), expected, got, 1e-12)


def mediapipe(tmp):
    path = os.path.join(ROOT, "data/formats/mediapipe/pose_landmarks.pbtxt")
    f = descriptor_pb2.FileDescriptorProto(name="landmarks_check.proto", package="mediapipe")
    lm = f.message_type.add(name="NormalizedLandmark")
    for i, field in enumerate(["x", "y", "z", "visibility", "presence"], 1):
        lm.field.add(name=field, number=i, type=descriptor_pb2.FieldDescriptorProto.TYPE_FLOAT, label=descriptor_pb2.FieldDescriptorProto.LABEL_OPTIONAL)
    lst = f.message_type.add(name="NormalizedLandmarkList")
    lst.field.add(name="landmark", number=1, type=descriptor_pb2.FieldDescriptorProto.TYPE_MESSAGE, type_name=".mediapipe.NormalizedLandmark", label=descriptor_pb2.FieldDescriptorProto.LABEL_REPEATED)
    res = f.message_type.add(name="LandmarksDetectionResult")
    res.field.add(name="landmarks", number=1, type=descriptor_pb2.FieldDescriptorProto.TYPE_MESSAGE, type_name=".mediapipe.NormalizedLandmarkList", label=descriptor_pb2.FieldDescriptorProto.LABEL_OPTIONAL)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(f)
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName("mediapipe.LandmarksDetectionResult"))
    msg = text_format.Parse(open(path).read(), cls())
    people = [[(l.x, l.y, l.visibility if l.HasField("visibility") else (l.presence if l.HasField("presence") else 1.0)) for l in msg.landmarks.landmark]]
    expected = chosen(people, len(people[0]), 0.0)[None]
    _, got = inspect(path, tmp)
    compare("mediapipe pose_landmarks.pbtxt (protobuf)", expected, got, 1e-7)


def main():
    with tempfile.TemporaryDirectory() as tmp:
        openpose(tmp)
        coco_annotations(tmp)
        coco_results(tmp)
        mediapipe(tmp)
    if len(COMPARED) != EXPECTED:
        raise SystemExit(f"compared {len(COMPARED)} samples, expected {EXPECTED}")
    print(f"compared {EXPECTED} pose-estimation samples read by json, pycocotools and protobuf")
    print("every pose-estimation sample agrees")


if __name__ == "__main__":
    main()
