"""Loading: positions bit for bit as the CLI loads them, one take of every format.

The CLI's positions are `motionlab inspect --json --npy DIR`'s (float64, frames × points × 3,
NaN = missing — the exact bits), its metadata the JSON. A channel file has no positions; its
channels are checked against NumPy's own parse of the file, and a channel segmenter's
candidates against the CLI's (test_stages.py)."""

import json

import numpy as np
import pytest

import motionlab as ml
from conftest import ROOT, data, run_cli

TAKES = {
    "86_01": ("cmu86/86_01.amc.gz", "asf_amc"),
    "131_01": ("cmu131/131_01.bvh.gz", "bvh"),
    "walk1_c3d": ("mct/walk1.c3d.gz", "c3d"),
    "walk1_tsv": ("mct/walk1.tsv.gz", "qualisys_tsv"),
    "walk_free_01_trc": ("formats/opensim-core/walk_free_01.trc", "trc"),
    "blanks_trc": ("formats/opensim-core/dataWithBlanksForMissingMarkers.trc", "trc"),
}


@pytest.fixture(scope="module")
def cli_positions(cli, tmp_path_factory):
    """Each take's positions and metadata as the CLI loaded them: `{name: (array, meta)}`."""
    out = tmp_path_factory.mktemp("positions")
    files = [data(rel) for rel, _ in TAKES.values()]
    meta = json.loads(run_cli(cli, "inspect", "--json", "--npy", str(out), *files).stdout)
    return {name: (np.load(out / f"{k}.npy"), meta[k]) for k, name in enumerate(TAKES)}


@pytest.mark.parametrize("name", list(TAKES))
def test_positions_are_the_clis_bit_for_bit(cli_positions, name):
    rel, loader = TAKES[name]
    ours = ml.load(data(rel))
    theirs, meta = cli_positions[name]
    assert ours.positions.shape == theirs.shape == (meta["frames"], len(meta["points"]), 3)
    assert ours.positions.dtype == np.float64
    # Bit for bit, NaN (missing) included.
    assert np.array_equal(ours.positions.view(np.uint64), theirs.view(np.uint64))
    assert ours.point_names == meta["points"]
    assert ours.rate == meta["frame_rate_hz"]
    assert ours.missing_count == meta["missing_samples"]
    assert ours.up_axis == meta["up_axis"] and ours.point_kind == meta["point_kind"]
    assert ours.format == meta["format"] == loader
    # The named loader gives the same motion as the one picked by extension.
    again = ml.load(data(rel), loader)
    assert np.array_equal(again.positions.view(np.uint64), theirs.view(np.uint64))


def test_walk1_has_gaps_as_nan_in_the_mask_too():
    m = ml.load(data("mct/walk1.tsv.gz"))
    assert m.missing_count > 0
    assert np.array_equal(np.isnan(m.positions).any(axis=2), m.missing)
    assert m.missing.sum() == m.missing_count


def test_positions_are_a_read_only_view_without_copy():
    m = ml.load(data("cmu86/86_01.amc.gz"))
    a, b = m.positions, m.positions
    assert np.shares_memory(a, b), "two reads are views of one buffer, not copies"
    assert not a.flags.writeable
    with pytest.raises(ValueError):
        a[0, 0, 0] = 1.0
    del m
    assert np.isfinite(a).all(), "the view keeps the motion alive"


def test_skeleton_events_and_polars():
    m = ml.load(data("cmu86/86_01.amc.gz"))
    s = m.skeleton
    # The skeleton's joints first, then the leaves' end sites (`ltoes_end`, …).
    joints = s["joint_names"]
    assert joints == m.point_names[: len(joints)] and s["parents"][0] == -1
    assert all(n.endswith("_end") for n in m.point_names[len(joints):])
    assert s["offsets"].shape == (len(joints), 3)
    assert s["channel_values"].shape[0] == m.n_frames
    df = m.to_polars()
    assert df.height == m.n_frames and df.columns[:2] == ["frame", "time_s"]
    assert df["root_y_mm"].to_numpy().tolist() == m.positions[:, 0, 1].tolist()
    c3d = ml.load(data("mct/walk1.c3d.gz"))
    assert c3d.skeleton is None
    assert isinstance(c3d.events, list)
    tsv = ml.load(data("mct/walk1.tsv.gz")).to_polars()
    assert tsv.null_count().sum_horizontal()[0] > 0, "missing samples are null"


def test_channel_file_values_are_numpys_parse():
    path = ROOT / "data/tssb/datasets/ArrowHead.txt"
    m = ml.load(path, "channels", rate_hz=1.0)
    assert m.n_points == 0 and m.positions.shape == (m.n_frames, 0, 3)
    ref = np.loadtxt(path)
    assert m.channels.shape == (len(ref), 1)
    assert np.array_equal(m.channels[:, 0].view(np.uint64), ref.view(np.uint64))
    assert m.channel_names == ["value"]
    assert m.to_polars()["value"].to_list() == ref.tolist()


def test_slice_and_select_match_the_dataset_cut():
    m = ml.load(data("cmu86/86_01.amc.gz"))
    s = m.slice(100, 200)
    assert s.n_frames == 100
    assert np.array_equal(s.positions, m.positions[100:200])
    sel = m.select(["lhand", "root"])
    assert np.array_equal(sel.positions[:, 0], m.positions[:, m.point_names.index("lhand")])


def test_motion_from_numpy_round_trips():
    rng = np.random.default_rng(1)
    pos = rng.normal(size=(50, 4, 3))
    pos[3, 2] = np.nan
    m = ml.Motion(pos, 100.0, ["a", "b", "c", "d"])
    assert np.array_equal(m.positions, pos, equal_nan=True)
    assert m.missing_count == 1 and m.missing[3, 2]
    with pytest.raises(ml.MotionlabError, match="appears twice"):
        ml.Motion(pos, 100.0, ["a", "a", "c", "d"])


def test_a_parquet_channel_file_loads_the_values_of_its_text_file():
    # pyarrow wrote the fixture from NumPy's parse of the same series (tests/fixtures/make.py).
    text = ml.load(ROOT / "data/tssb/datasets/ArrowHead.txt", "channels", rate_hz=1.0)
    parquet = ml.load(ROOT / "crates/motionlab-parquet/tests/fixtures/ArrowHead.parquet", "channels", rate_hz=1.0)
    assert parquet.channel_names == ["value"]
    assert np.array_equal(parquet.channels.view(np.uint64), text.channels.view(np.uint64))


def test_mot_channels_are_the_files_columns():
    """An OpenSim .mot loads as named channels, each column's values as NumPy parses them."""
    path = data("formats/opensim-core/subject01_walk1_ik.mot")
    m = ml.load(path)
    ref = np.loadtxt(path, skiprows=12)
    assert m.n_frames == 73 and m.channels.shape == (73, 164)
    assert np.array_equal(m.channels, ref[:, 1:])
    assert m.channel_names[:2] == ["pelvis_tx", "pelvis_ty"]
    assert "ground_force_vx#2" in m.channel_names
    assert abs(m.rate - 60.0) < 1e-9


# Video keypoints: the loader picked like the CLI's (a folder: `openpose`; `.json`:
# `coco_keypoints`; `.pbtxt`: `mediapipe`), at the rate given (the files store none), as 2-D
# positions with a confidence per sample, equal bit for bit to the CLI's `inspect --npy`.
KEYPOINTS = {
    "openpose": "formats/pose2sim/openpose_balancing_cam01_json",
    "coco_keypoints": "formats/mmpose-coco/test_coco.json",
    "mediapipe": "formats/mediapipe/pose_landmarks.pbtxt",
}


@pytest.mark.parametrize("loader", list(KEYPOINTS))
def test_keypoints_load_by_extension_or_folder_as_2d_with_confidence(cli, tmp_path, loader):
    path = data(KEYPOINTS[loader])
    m = ml.load(path, rate_hz=30.0)
    assert m.format == loader and m.dimensionality == "2d" and m.rate == 30.0
    assert m.confidence.shape == m.missing.shape and m.confidence.dtype == np.float32
    assert np.all(m.positions[~m.missing][:, 2] == 0.0)
    meta = json.loads(run_cli(cli, "inspect", "--json", "--npy", str(tmp_path), path).stdout)[0]
    assert meta["format"] == loader and meta["dimensionality"] == "2d"
    theirs = np.load(tmp_path / "0.npy")
    assert np.array_equal(m.positions.view(np.uint64), theirs.view(np.uint64))
    assert ml.load(data("formats/opensim-core/walk_free_01.trc")).confidence is None
