"""ml.penalty_path: kernel_cpd's penalty path (CROPS) as a DataFrame."""
import numpy as np
import pytest

import motionlab as ml


def _steps():
    rng = np.random.default_rng(11)
    i = np.arange(400)
    return np.array([0.0, 1.5, 0.5, 3.0])[i // 100] + 0.6 * rng.random(400) + 0.3 * np.sin(i * 0.7)


def test_the_path_covers_the_range_and_finds_the_three_steps():
    df = ml.penalty_path(_steps(), path=[0.05, 400.0], search="pelt", cost="l2", jump=1)
    assert df.columns == ["n_changes", "pen_min", "pen_max", "cost", "chosen", "change_points"]
    assert df["pen_max"][0] == 400.0 and df["pen_min"][-1] == 0.05
    # Contiguous intervals, ever more change points, ever lower cost, towards lower penalties.
    assert (df["pen_min"][:-1].to_numpy() == df["pen_max"][1:].to_numpy()).all()
    assert (np.diff(df["n_changes"].to_numpy()) > 0).all()
    assert (np.diff(df["cost"].to_numpy()) < 0).all()
    chosen = df.filter(df["chosen"])
    assert chosen.height == 1
    found = [int(c) for c in chosen["change_points"][0].split()]
    assert len(found) == 3 and all(abs(f - w) <= 3 for f, w in zip(found, [100, 200, 300]))


def test_a_path_is_required_and_a_bad_range_is_one_error():
    with pytest.raises(ml.MotionlabError, match="penalty.path"):
        ml.penalty_path(_steps(), path=[5.0, 1.0])
