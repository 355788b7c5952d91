"""The multistream matcher on NumPy arrays: a, b, H (and R) of experiments/yabe_exercises.toml's
first repetition equal the CLI run's, built from the same stages by name; the plugin on
motions agrees; missing samples are refused; the GIL is released."""

import threading
import time

import numpy as np
import polars as pl
import pytest

import motionlab as ml
from conftest import ROOT, cli_run, data

SKELETON = {"skeleton": "../asf/13.asf"}


def prepared(path, start, end):
    """A take as the experiment's dataset gives it: loaded, cut, then its preprocessors."""
    m = ml.load(data(path), "asf_amc", **SKELETON).slice(start, end)
    m = ml.preprocess("initial_pose_normalisation", m)
    return ml.preprocess("distinct_points", m)


@pytest.fixture(scope="module")
def cli_repetitions(cli, tmp_path_factory):
    run_dir = cli_run(cli, ROOT / "experiments/yabe_exercises.toml", tmp_path_factory.mktemp("yabe"))
    return pl.read_csv(run_dir / "tables/repetitions.csv")


def test_first_repetition_a_b_h_r_are_the_clis(cli_repetitions):
    model = prepared("mocap6/amc/13_30.amc.gz", 56, 180)
    take = prepared("mocap6/amc/13_29.amc.gz", 0, 405)
    # The experiment's detector, with its count set as the workflow sets it: 3 repetitions × 2
    # peaks; the first repetition's window joins the windows of the first two peaks.
    found = ml.detect_points("velocity_peaks", take, marker="lhand", before={"seconds": 0.4}, after={"seconds": 0.4},
                             smoothing={"seconds": 0.2}, count=6)
    (s0, e0), (s1, e1) = found.windows[0], found.windows[1]
    start, end = min(s0, s1), max(e0, e1)
    window = take.slice(start, end)
    assert model.point_names == window.point_names
    match = ml.multistream_match(model.positions, window.positions, k=8)
    row = cli_repetitions.filter((pl.col("take") == "13_29") & (pl.col("repetition") == "rep 1"))
    assert row.height == 1
    assert (start, end - 1) == (row["window_start_frame"][0], row["window_end_frame"][0])
    assert (start + match.a, start + match.b) == (row["a_frame"][0], row["b_frame"][0])
    assert match.H == row["H_mm"][0]  # exactly: the CSV holds the shortest text of the float
    assert match.R == row["R_frames2"][0]
    assert match.h.sum() == pytest.approx(match.H, rel=1e-12)
    assert len(match.paths) == model.n_points and match.paths[0][0].tolist() == [0, match.a]
    # The registered matcher on the motions (points by name) gives the same.
    a = ml.align("multistream_two_stage", model, window)
    assert (a.start, a.end, a.total_distance) == (match.a, match.b, match.H)
    sync = ml.synchronise("synchronisation", a, model.n_frames, k=8)
    assert sync.total == match.R


def test_subsequence_dp_matches_the_plugin():
    model = prepared("mocap6/amc/13_30.amc.gz", 56, 180)
    take = prepared("mocap6/amc/13_29.amc.gz", 0, 405)
    k = model.point_names.index("lhand")
    ours = ml.subsequence_dp(model.positions[:, k], take.positions[:, k])
    plugin = ml.align("subsequence_dp", model, take, marker="lhand")
    assert (ours.a, ours.b, ours.cost) == (plugin.start, plugin.end, plugin.total_distance)
    assert ours.path.tolist() == [list(p) for p in plugin.paths[0]]
    assert ours.end_costs[ours.b] == ours.cost == ours.end_costs.min()


def test_missing_samples_are_refused():
    model = np.zeros((10, 2, 3))
    target = np.zeros((30, 2, 3))
    target[7, 1, 2] = np.nan
    with pytest.raises(ml.MotionlabError, match=r"point 1 of the target is missing \(NaN\) at frame 7") as e:
        ml.multistream_match(model, target)
    assert e.value.kind == "MissingData"
    with pytest.raises(ml.MotionlabError, match="expected 3 dimensions"):
        ml.multistream_match(np.zeros((10, 3)), target)


def test_long_matches_release_the_gil():
    rng = np.random.default_rng(3)
    model = np.cumsum(rng.normal(size=(120, 31, 3)), axis=0)
    target = np.cumsum(rng.normal(size=(6000, 31, 3)), axis=0)
    done = threading.Event()
    t0 = time.perf_counter()
    worker = threading.Thread(target=lambda: (ml.multistream_match(model, target), done.set()))
    worker.start()
    ticks = 0
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - t0
    # Holding the GIL for the whole match would allow a handful of ticks at most.
    assert elapsed > 0.05 and ticks >= 10, (elapsed, ticks)
