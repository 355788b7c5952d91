"""Every bad input raises motionlab.MotionlabError with the CLI's message — the key path and
what was expected — never a crash: unknown plugins, unknown keys, wrong types, bad values and
malformed files, each compared with what the CLI prints for the same mistake."""

import numpy as np
import pytest

import motionlab as ml
from conftest import ROOT, data, run_cli

MOTION = None


def motion():
    global MOTION
    if MOTION is None:
        MOTION = ml.load(data("cmu86/86_01.amc.gz"))
    return MOTION


def cli_error(cli, tmp_path, segmenter_toml):
    """The CLI's message for an experiment whose one segmenter is `segmenter_toml`."""
    exp = tmp_path / "bad.toml"
    exp.write_text(
        '[experiment]\nname = "bad"\n\n[[dataset]]\n'
        f'files = ["{data("cmu86/86_01.amc.gz")}"]\nloader = {{ type = "asf_amc" }}\n\n'
        f"[segmentation]\n[[segmentation.segmenter]]\n{segmenter_toml}\n"
    )
    err = run_cli(cli, "validate", str(exp), ok=False).stderr.strip()
    assert err.startswith("error: ") and "\n" not in err, err
    return err


CASES = [
    # (what, the segmenter in TOML, the same call in Python, the kind)
    ("unknown plugin", 'type = "fastest_marker_sped"', ("fastest_marker_sped", {}), "UnknownPlugin"),
    ("unknown key", 'type = "fastest_marker_speed"\nv_lo = { fraction_of_p90 = 0.4 }', ("fastest_marker_speed", {"v_lo": {"fraction_of_p90": 0.4}}), "UnknownKey"),
    ("unknown variant", 'type = "fastest_marker_speed"\nv_low = { slow = 0.4 }', ("fastest_marker_speed", {"v_low": {"slow": 0.4}}), "WrongType"),
    ("wrong type", 'type = "direction_change"\nc_min = "sharp"', ("direction_change", {"c_min": "sharp"}), "WrongType"),
    ("out of range", 'type = "direction_change"\nlag = { seconds = 0.0 }', ("direction_change", {"lag": {"seconds": 0.0}}), None),
]


@pytest.mark.parametrize("what,toml,call,kind", CASES, ids=[c[0] for c in CASES])
def test_bad_parameters_raise_the_clis_message(cli, tmp_path, what, toml, call, kind):
    name, params = call
    with pytest.raises(ml.MotionlabError) as e:
        ml.segment(name, motion(), **params)
    ours = str(e.value)
    theirs = cli_error(cli, tmp_path, toml)
    # The CLI prefixes the file, line and the experiment's key path (segmentation.segmenter[0]);
    # the Python message names the plugin; the rest — key path and what was expected — is one text.
    tail = ours[len(name) + 1:] if ours.startswith(name + ".") else ours
    assert theirs.endswith(tail), f"\nCLI:    {theirs}\nPython: {ours}"
    if kind:
        assert e.value.kind == kind
    assert e.value.message and e.value.message in ours


MALFORMED = ["truncated.bvh", "c3d_truncated.c3d", "short_row.tsv", "86_frame_gap.amc", "bvh_nan.bvh", "corrupt_header.c3d", "tsv_empty.tsv"]


@pytest.mark.parametrize("name", MALFORMED)
def test_malformed_files_raise_the_clis_message(cli, name):
    path = ROOT / "tests/fixtures/malformed" / name
    with pytest.raises(ml.MotionlabError) as e:
        ml.load(path)
    theirs = run_cli(cli, "inspect", str(path), ok=False).stderr.strip()
    assert theirs == f"error: {e.value}"
    assert e.value.file == str(path)


def test_bad_experiment_raises_the_clis_message(cli):
    for name in ["unknown_param.toml", "wrong_type.toml", "unknown_plugin.toml", "toml_syntax_error.toml"]:
        path = ROOT / "tests/fixtures/malformed" / name
        with pytest.raises(ml.MotionlabError) as e:
            ml.validate(path)
        theirs = run_cli(cli, "validate", str(path), ok=False).stderr.strip()
        assert theirs == f"error: {e.value}", name
        with pytest.raises(ml.MotionlabError):
            ml.run(path, reports="/nonexistent-reports")


def test_python_values_that_are_no_toml_raise():
    with pytest.raises(ml.MotionlabError, match=r"v_low: a Python `set` is no parameter value"):
        ml.segment("fastest_marker_speed", motion(), v_low={1, 2})
    with pytest.raises(ml.MotionlabError, match="no loader reads .xyz files"):
        ml.load(ROOT / "README.md.xyz")
    with pytest.raises(ml.MotionlabError, match="frame indices must be >= 0"):
        ml.boundary_pr([-1], [3], rate=100.0, n_frames=10)
    with pytest.raises(ml.MotionlabError, match="is a segmenter, but a preprocessor is expected"):
        ml.preprocess("speed_minima", motion())
    # NumPy scalars and arrays are numbers and lists, as in TOML.
    out = ml.segment("speed_minima", motion(), v_low={"fraction_of_p90": np.float32(0.25)})
    assert len(out.candidates) > 0
