"""`ml.Stream`: a streaming segmenter fed samples as they arrive decides, at the stated samples,
what the same segmenter finds on the whole series (`ml.segment`, the offline adapter)."""

import numpy as np
import pytest

import motionlab as ml
from conftest import data


def test_a_series_fed_in_blocks_decides_what_segment_finds_one_sample_after_the_drop():
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.random(150) * 0.5, 6.0 + rng.random(150) * 0.5])
    params = {"drop_threshold": 40.0, "lambda": 200.0}
    s = ml.Stream("bocpd_online", 50.0, channels=["level"], params=params)
    so_far = []
    for block in np.array_split(x, 7):  # 1-D blocks of one-channel samples
        so_far = s.update(block)
    assert s.samples_seen == 300
    final = s.finish()
    assert final == so_far and len(final) >= 1
    offline = ml.segment("bocpd_online", x.reshape(-1, 1), rate=50.0, **params)
    assert [b for b, _ in final] == list(offline.candidates)
    assert all(d == b + 1 for b, d in final)


def test_a_take_streamed_frame_by_frame_gives_the_offline_tracker_two_frames_late():
    m = ml.load(data("cmu86/86_01.amc.gz"))
    params = {"v_high_mm_per_s": 1500.0, "v_low_mm_per_s": 600.0}
    s = ml.Stream("fastest_marker_speed_online", m.rate, points=m.point_names, up_axis=m.up_axis, params=params)
    for frame in m.positions:  # points × 3, mm
        s.update(frame)
    got = s.finish()
    assert len(got) >= 3
    assert [b for b, _ in got] == list(ml.segment("fastest_marker_speed_online", m, **params).candidates)
    assert all(d == b + 2 for b, d in got)


def test_a_segmenter_that_needs_the_whole_series_or_a_wrong_sample_is_an_argument_error():
    with pytest.raises(ml.ArgumentError, match="needs the whole series"):
        ml.Stream("bocpd", 10.0, channels=["a"])
    s = ml.Stream("bocpd_online", 10.0, channels=["a", "b"])
    with pytest.raises(ml.MotionlabError, match="whole samples of 2"):
        s.update(np.zeros(3))
