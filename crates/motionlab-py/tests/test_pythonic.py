"""The package as a claspy or ruptures user meets it: a TSSB series loaded with NumPy goes
straight into every segmenter and metric and gives the CLI's numbers; `load` picks the loader
by extension as `motionlab inspect` does, parameters and all; a namespace of the package's own
names only; no builtin shadowed; a dataclass for every result; argument errors are
`ValueError`s; boundaries scored from a rate and a length; README's example runs as written."""

import dataclasses
import inspect
import json
import re
import subprocess
import sys
import warnings

import numpy as np
import polars as pl
import pytest

import motionlab as ml
from conftest import ROOT, assert_frame_equals_csv, cli_run, data, run_cli

TSSB = ROOT / "data/tssb/datasets"
DESC = TSSB / "desc.txt"


def tssb_experiment(tmp_path, series, segmenters, evaluate="boundary_metrics"):
    """A channel experiment on one TSSB series, as the tssb benchmark loads it (1 Hz)."""
    exp = tmp_path / f"{series.stem}.toml"
    body = "".join(f"[[segmentation.segmenter]]\n{s}\n\n" for s in segmenters)
    exp.write_text(
        f'[experiment]\nname = "py_{series.stem.lower()}"\n\n[[dataset]]\n'
        f'files = ["{series}"]\nloader = {{ type = "channels", rate_hz = 1.0 }}\n'
        f'ground_truth = {{ type = "tssb_desc", file = "{DESC}" }}\n\n'
        f"[segmentation]\n{body}"
        f'[[evaluate]]\ntype = "{evaluate}"\n'
    )
    return exp


@pytest.fixture(scope="module")
def cbf_run(cli, tmp_path_factory):
    """The CLI's run of clasp (claspy's defaults) and PELT on TSSB's CBF (960 samples)."""
    tmp = tmp_path_factory.mktemp("cbf")
    exp = tssb_experiment(tmp, TSSB / "CBF.txt", ['type = "clasp"', 'type = "kernel_cpd"\nname = "PELT"\nsearch = "pelt"'])
    run_dir = cli_run(cli, exp, tmp / "reports")
    return pl.read_csv(run_dir / "tables/candidates.csv"), run_dir


def test_segmenters_take_a_numpy_series_and_give_the_clis_candidates(cbf_run):
    candidates, _ = cbf_run
    ts = np.loadtxt(TSSB / "CBF.txt")  # as claspy's and ruptures' examples load a series
    assert ts.ndim == 1
    for name, kind, params in [("clasp", "clasp", {}), ("PELT", "kernel_cpd", {"search": "pelt"})]:
        theirs = candidates.filter(pl.col("method") == name)["frame"].to_list()
        assert theirs, name
        assert ml.segment(kind, ts, **params).candidates.tolist() == theirs, name
        # samples × channels, a plain list and the typed function: the same.
        assert ml.segment(kind, ts[:, None], **params).candidates.tolist() == theirs, name
        assert getattr(ml.segmenters, kind)(ts.tolist(), **params).candidates.tolist() == theirs, name


def test_a_1d_series_is_a_one_channel_motion():
    ts = np.loadtxt(TSSB / "ArrowHead.txt")
    m = ml.Motion.from_channels(ts, rate=1.0)
    loaded = ml.load(TSSB / "ArrowHead.txt", rate_hz=1.0)
    assert m.channels.shape == (len(ts), 1) == loaded.channels.shape
    assert np.array_equal(m.channels.view(np.uint64), loaded.channels.view(np.uint64))
    with pytest.raises(ml.ArgumentError, match=r"values: expected 1 or 2 dimensions, found shape \[2, 3, 4\]"):
        ml.Motion.from_channels(np.zeros((2, 3, 4)), rate=1.0)


def test_a_rate_given_to_an_array_reaches_the_stage():
    # A series with a rate is the channel motion at that rate (1 Hz without one).
    ts = np.loadtxt(TSSB / "CBF.txt")
    at_1 = ml.segment("clasp", ts)
    at_10 = ml.segment("clasp", ts, rate=10.0)
    assert at_1.candidates.tolist() == ml.segment("clasp", ml.Motion.from_channels(ts, 1.0)).candidates.tolist()
    assert at_10.candidates.tolist() == ml.segment("clasp", ml.Motion.from_channels(ts, 10.0)).candidates.tolist()
    m = ml.load(data("cmu86/86_01.amc.gz"))
    # Positions need their rate; with it an array is the motion it came from.
    with pytest.raises(ml.ArgumentError, match="rate: positions"):
        ml.segment("speed_minima", np.asarray(m.positions))
    a = ml.segment("speed_minima", np.asarray(m.positions), rate=m.rate)
    assert a.candidates.tolist() == ml.segment("speed_minima", m).candidates.tolist()
    with pytest.raises(ml.ArgumentError, match="motion's own rate"):
        ml.segment("speed_minima", m, rate=m.rate * 2)


def test_load_picks_the_loader_by_extension_as_the_cli_does(cli):
    path = TSSB / "Adiac.txt"
    ours = ml.load(path, rate_hz=1.0)  # a parameter without the loader's name
    named = ml.load(path, "channels", rate_hz=1.0)
    assert ours.format == named.format == "channels" and ours.rate == 1.0
    assert np.array_equal(ours.channels.view(np.uint64), named.channels.view(np.uint64))
    # Without the rate the same loader is picked and says what the CLI says.
    with pytest.raises(ml.FileError) as e:
        ml.load(path)
    assert "rate_hz" in str(e.value)
    # The CLI picks the same loader and, as `inspect` describes what it can, says the rate is
    # unknown rather than refusing the file.
    meta = json.loads(run_cli(cli, "inspect", "--json", str(path)).stdout)
    meta = meta[0] if isinstance(meta, list) else meta
    assert meta["format"] == "channels" and meta["frame_rate_hz"] is None
    # The CLI's pick for a file of every other format.
    files = [data("cmu86/86_01.amc.gz"), data("cmu131/131_01.bvh.gz"), data("mct/walk1.c3d.gz"), data("mct/walk1.tsv.gz")]
    meta = json.loads(run_cli(cli, "inspect", "--json", *files).stdout)
    assert [ml.load(f).format for f in files] == [m["format"] for m in meta] == ["asf_amc", "bvh", "c3d", "qualisys_tsv"]
    # A parameter the picked loader does not have is the loader's own error, under its name.
    with pytest.raises(ml.ArgumentError, match=r"^channels\.rate: unknown field"):
        ml.load(path, rate=1.0)


def test_the_namespace_holds_the_packages_names_only():
    public = {n for n in dir(ml) if not n.startswith("_")}
    assert set(ml.__all__) <= set(dir(ml)), set(ml.__all__) - set(dir(ml))
    # `list` is the deprecated alias, left out of __all__ so `import *` shadows no builtin.
    expected = set(ml.__all__) - {"__version__"} | {"list"}
    assert public == expected, public ^ expected
    for leaked in ["np", "os", "builtins", "dataclass", "field", "Path", "Any", "Dict", "List", "Optional", "Union"]:
        assert not hasattr(ml, leaked), leaked
    star = {}
    exec("from motionlab import *", star)
    assert "list" not in star and star["segment"] is ml.segment


def test_no_builtin_is_shadowed_and_list_is_a_deprecated_alias(cli):
    import builtins

    assert not set(ml.__all__) & set(dir(builtins))
    text = run_cli(cli, "list").stdout
    assert ml.listing() == text
    with pytest.warns(DeprecationWarning, match=r"motionlab\.listing\(\)"):
        assert ml.list() == text
    plugins = ml.plugins()
    assert all(isinstance(p, ml.Plugin) and all(isinstance(q, ml.Param) for q in p.params) for p in plugins)
    assert {p.name for p in plugins} == set(re.findall(r"^  ([a-z0-9_]+) ", text, re.M)) - {w.name for w in ml.workflows()}
    # No plugin has a parameter `rate`: the keyword that gives an array its frame rate.
    assert not [p.name for p in plugins if any(q.name == "rate" for q in p.params)]


def returns(f):
    return inspect.signature(f).return_annotation


def test_every_function_returns_a_typed_result():
    # No dict or Any left as a return type: a dataclass, a motionlab class, an array, a number.
    for name in ml.__all__:
        f = getattr(ml, name)
        if inspect.isfunction(f):
            r = str(returns(f))
            assert "Dict" not in r and "Any" not in r and r != str(inspect.Signature.empty), (name, r)
    for name in ["Plugin", "Workflow", "Param", "Trace", "Threshold", "Features", "SegmenterOutput", "PointDetection", "Alignment",
                 "Synchronisation", "GaitCycle", "AngleCurves", "WaveformParameters", "Evaluation", "TcpdF1", "SubsequenceMatch",
                 "MultistreamMatch", "RunResult", "Validation"]:
        assert dataclasses.is_dataclass(getattr(ml, name)), name


def test_results_are_dataclasses_at_run_time():
    walk = ml.load(data("schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz"))  # a walk with foot strikes
    cycles = ml.gait_cycles("c3d_events", walk)
    assert cycles and all(isinstance(c, ml.GaitCycle) and c.end > c.start for c in cycles)
    m = ml.load(data("cmu86/86_01.amc.gz"))
    out = ml.segment("fastest_marker_speed", m)
    assert isinstance(out, ml.SegmenterOutput) and all(isinstance(t, ml.Threshold) for t in out.thresholds)
    found = ml.detect_points("velocity_peaks", m, marker="lhand", count=2)
    assert isinstance(found, ml.PointDetection) and isinstance(found.velocity, ml.Trace)
    assert len(found.velocity.values) == m.n_frames and len(found.peaks) == len(found.windows) == 2
    model, take = m.slice(0, 60), m.slice(0, 200)
    a = ml.align("multistream_two_stage", model, take)
    assert isinstance(a, ml.Alignment) and (a.start, a.total_distance) == (0, 0.0)
    s = ml.synchronise("synchronisation", a, model.n_frames, k=4)
    # The dataclass goes back in as the record it came from.
    assert isinstance(s, ml.Synchronisation) and s == ml.synchronise("synchronisation", dataclasses.asdict(a), model.n_frames, k=4)
    ev = ml.evaluate("boundary_metrics", [{"sequence": "86_01", "motion": m, "truth": [500, 1500], "methods": {"x": out.candidates}}])
    assert isinstance(ev, ml.Evaluation) and len(ev) >= 1 and all(isinstance(df, pl.DataFrame) for df in ev.values())


def test_argument_errors_are_value_errors_and_file_errors_are_not():
    ts = np.loadtxt(TSSB / "CBF.txt")
    for call in [
        lambda: ml.segment("clsp", ts),  # unknown plugin
        lambda: ml.segment("clasp", ts, windw=3),  # unknown key
        lambda: ml.segment("kernel_cpd", ts, search="exhaustive"),  # unknown variant
        lambda: ml.segment("clasp", np.zeros((2, 3, 4, 5))),  # no motion's shape
        lambda: ml.boundary_pr([1], [2], rate=1.0, n_frames=10, tolerance_s=1.0, tolerance_frames=1),
        lambda: ml.boundary_pr([1], [2], rate=1.0, n_frames=0),
        lambda: ml.covering([5], [-1], 10),
        lambda: ml.Motion(np.zeros((5, 2, 3)), -1.0),
    ]:
        with pytest.raises(ValueError) as e:
            call()
        assert isinstance(e.value, ml.ArgumentError) and isinstance(e.value, ml.MotionlabError), e.value
        assert e.value.file is None and e.value.message
    for name in ["truncated.bvh", "c3d_truncated.c3d", "86_frame_gap.amc", "tsv_empty.tsv"]:
        with pytest.raises(ml.FileError) as e:
            ml.load(ROOT / "tests/fixtures/malformed" / name)
        assert not isinstance(e.value, ValueError) and e.value.file
    with pytest.raises(ml.FileError) as e:
        ml.validate(ROOT / "tests/fixtures/malformed/unknown_param.toml")
    assert e.value.line


def test_boundaries_are_scored_from_a_rate_and_a_length_without_a_motion(monkeypatch, cbf_run):
    candidates, run_dir = cbf_run
    found = {m: candidates.filter(pl.col("method") == m)["frame"].to_list() for m in ["clasp", "PELT"]}
    # What the CLI scored with a motion, scored from the series' rate and length alone; no Motion
    # is built on the way (the name is taken away from the package while it runs).
    n = len(np.loadtxt(TSSB / "CBF.txt"))

    class NoMotion:
        def __init__(self, *a, **k):
            raise AssertionError("a Motion was built to score boundaries")

    monkeypatch.setattr(ml._api, "Motion", NoMotion)
    ev = ml.evaluate("boundary_metrics", [{"sequence": "CBF", "rate": 1.0, "n_frames": n, "truth": [384, 704], "methods": found}])
    assert len(ev) >= 1
    for name, df in ev.items():
        assert_frame_equals_csv(df, run_dir / "tables" / f"{name}.csv")
    table = ml.boundary_pr(found, [384, 704], rate=1.0, n_frames=n, tolerance_frames=5, sequence="CBF")
    assert table.filter(pl.col("sequence") == "CBF").height == 2


def test_readme_from_python_example_runs_as_written():
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## From Python"):]
    section = section[: section.index("\n## ", 1)]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert blocks, "README's From Python section has a Python example"
    for code in blocks:
        p = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", code], cwd=ROOT, capture_output=True, text=True)
        assert p.returncode == 0, f"README example failed:\n{code}\n{p.stderr}"
        assert p.stdout.strip(), "the example prints its result"
