"""Known answers on hand-made inputs for the array API (boundary_pr, covering, TCPDBench F1),
and the generated stubs are current."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import motionlab as ml


def test_boundary_pr_known_answer():
    # Truths at 100 and 300 (rate 100 Hz, tolerance 0.1 s = 10 frames); found 105 (matches 100),
    # 200 (extra), 311 (11 frames from 300: no match).
    df = ml.boundary_pr([105, 200, 311], [100, 300], rate=100.0, n_frames=1000, tolerance_s=0.1)
    row = df.row(0, named=True)
    assert (row["n_truth"], row["n_found"], row["n_matched"]) == (2, 3, 1)
    assert row["precision"] == pytest.approx(1 / 3) and row["recall"] == 0.5 and row["f1"] == pytest.approx(0.4)
    # Chance, exact: 3 distinct random frames of 1000 against two disjoint windows of 21 frames:
    # E[M] = 2 (1 - C(979, 3) / C(1000, 3)).
    miss = (979 * 978 * 977) / (1000 * 999 * 998)
    assert row["chance_expectation"] == "exact"
    assert row["chance_matched"] == pytest.approx(2 * (1 - miss), rel=1e-12)
    assert 0 < row["p_value"] <= 1
    same = ml.boundary_pr({"method": [105, 200, 311]}, ml.Segmentation([100, 300], 100.0), rate=100.0, n_frames=1000,
                          tolerance_frames=10)
    assert same.row(0, named=True)["n_matched"] == 1


def test_covering_and_tcpd_f1_known_answers():
    # One annotator: changes at 50 of 100 frames; predicted 50 exactly → covering 1, F1 1.
    assert ml.covering([50], [50], 100) == 1.0
    f = ml.tcpd_f1([50], [50], margin_frames=5)
    assert (f.f1, f.precision, f.recall) == (1.0, 1.0, 1.0)
    # No prediction: segments [0,100) vs truth [0,50),[50,100): each covered with J = 1/2.
    assert ml.covering([50], [], 100) == pytest.approx(0.5)
    # TCPDBench adds 0 to both sets: X = {0}, T = {0, 50}: P = 1, R = 1/2, F = 2/3.
    f = ml.tcpd_f1([50], [], margin_frames=5)
    assert (f.precision, f.recall) == (1.0, 0.5) and f.f1 == pytest.approx(2 / 3)
    # Two annotators, recall averaged over them (0 added to every set): {0, 50} is recalled
    # fully by {0, 52}, {0, 80} half: R = (1 + 1/2) / 2.
    f = ml.tcpd_f1([[50], [80]], [52], margin_frames=5)
    assert f.recall == pytest.approx(0.75)


def test_segmentation_round_trips():
    s = ml.Segmentation([30, 10, 20], 50.0, annotators=[[10, 20], [30]])
    assert s.boundaries.tolist() == [10, 20, 30] and len(s) == 3 and s.rate == 50.0
    assert s.annotators == [[10, 20], [30]]


def test_the_installed_stubs_are_the_built_modules():
    # The build backend writes them from the module it built (never committed): the installed
    # file must be exactly what the registry of this build gives, and valid Python.
    stub = Path(ml.__file__).with_name("_typed.pyi")
    assert stub.is_file(), f"{stub}: no stubs installed (was the package built by build_backend/motionlab_build.py?)"
    fresh = subprocess.run([sys.executable, "-m", "motionlab._stubgen"], capture_output=True, text=True, check=True).stdout
    assert stub.read_text() == fresh
    assert "def fastest_marker_speed(motion: MotionLike, *, rate: Optional[float] = None, " in fresh
    from motionlab._kinds import KINDS
    callable_plugins = [p.name for p in ml.plugins() if p.kind in KINDS]
    assert len(callable_plugins) >= 40
    for name in callable_plugins:
        assert f"    def {name}(" in fresh, name
    compile(fresh, str(stub), "exec")


def test_version_and_errors_are_exported():
    assert ml.__version__ == "0.1.0"
    assert issubclass(ml.MotionlabError, Exception)
    # Argument errors are ValueErrors too; file errors are not; both are MotionlabErrors.
    assert issubclass(ml.ArgumentError, ml.MotionlabError) and issubclass(ml.ArgumentError, ValueError)
    assert issubclass(ml.FileError, ml.MotionlabError) and not issubclass(ml.FileError, ValueError)
    assert not issubclass(ml.MotionlabError, ValueError)
