"""Every stage by name with the TOML's parameters gives the CLI's numbers: the segmenters,
fuser and evaluators of experiments/sonoda_table1.toml on CMU 86_01 (candidates and every
evaluation table, P/R with its chance columns included), and a channel segmenter on a TSSB
series; `list()` and `describe()` are the CLI's text."""

import re

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

import numpy as np
import polars as pl
import pytest

import motionlab as ml
from conftest import ROOT, assert_frame_equals_csv, cli_run, data, run_cli

SEQUENCE = "86_01"


def sonoda_86_01(tmp_path):
    """experiments/sonoda_table1.toml with 86_01 as its only dataset (absolute paths)."""
    text = (ROOT / "experiments/sonoda_table1.toml").read_text()
    start, end = text.index("[[dataset]]"), text.index("[segmentation]")
    dataset = (
        f'[[dataset]]\nfiles = ["{data("cmu86/86_01.amc.gz")}"]\nloader = {{ type = "asf_amc" }}\n'
        f'ground_truth = {{ type = "cmu86_labels", file = "{data("cmu86/mocap.txt")}" }}\n\n'
    )
    path = tmp_path / "sonoda_86_01.toml"
    path.write_text(text[:start] + dataset + text[end:])
    return path


@pytest.fixture(scope="module")
def sonoda(cli, tmp_path_factory):
    """(experiment file, its parsed TOML, the CLI's run directory)."""
    tmp = tmp_path_factory.mktemp("sonoda")
    exp = sonoda_86_01(tmp)
    run_dir = cli_run(cli, exp, tmp / "reports")
    return exp, tomllib.loads(exp.read_text()), run_dir


def stage(spec):
    spec = dict(spec)
    kind = spec.pop("type")
    return kind, spec.pop("name", kind), spec


@pytest.fixture(scope="module")
def ours(sonoda):
    """86_01's methods as the Python API runs the experiment's stages."""
    _, exp, _ = sonoda
    m = ml.load(data("cmu86/86_01.amc.gz"), "asf_amc")
    truth = ml.read_truth("cmu86_labels", data("cmu86/mocap.txt"), m)
    methods = {}
    for spec in exp["segmentation"]["segmenter"]:
        kind, name, params = stage(spec)
        methods[name] = ml.segment(kind, m, **params).candidates
    kind, name, params = stage(exp["segmentation"]["fuser"])
    methods[name] = ml.fuse(kind, m, {k: methods[k] for k in exp["segmentation"]["fuse"]}, **params)
    return m, truth, methods


def test_candidates_are_the_clis(sonoda, ours):
    _, exp, run_dir = sonoda
    _, _, methods = ours
    cli = pl.read_csv(run_dir / "tables/candidates.csv").filter(pl.col("sequence") == SEQUENCE)
    assert list(methods) == list(dict.fromkeys(cli["method"].to_list()))
    for method, frames in methods.items():
        theirs = cli.filter(pl.col("method") == method)["frame"].to_list()
        assert frames.tolist() == theirs, method
        assert len(frames) > 0, method


def test_every_evaluation_table_is_the_clis(sonoda, ours):
    _, exp, run_dir = sonoda
    m, truth, methods = ours
    results = [{"sequence": SEQUENCE, "motion": m, "truth": truth, "methods": methods}]
    compared = []
    for spec in exp["evaluate"]:
        kind, _, params = stage(spec)
        for name, df in ml.evaluate(kind, results, **params).items():
            csv = run_dir / "tables" / f"{name}.csv"
            cli_columns = pl.read_csv(csv, n_rows=1).columns
            # The workflow adds how each method's parameters were chosen; the evaluator does not.
            assert set(cli_columns) - set(df.columns) <= {"parameters_chosen"}, name
            assert_frame_equals_csv(df, csv)
            compared.append(name)
    assert "table1_precision_recall" in compared and len(compared) >= 4, compared


def test_boundary_pr_on_plain_arrays_is_the_evaluators_table(sonoda, ours):
    _, _, run_dir = sonoda
    m, truth, methods = ours
    # A library's boundaries (plain lists of frames) scored with the chance columns: the same
    # numbers as the experiment's table (its tolerance: 0.5 s).
    df = ml.boundary_pr({k: v.tolist() for k, v in methods.items()}, truth, rate=m.rate, n_frames=m.n_frames, tolerance_s=0.5,
                        sequence=SEQUENCE, claim_against=["speed", "direction", "hull"])
    assert {"chance_precision", "chance_recall", "chance_f1", "p_value", "above_chance"} <= set(df.columns)
    assert_frame_equals_csv(df, run_dir / "tables/table1_precision_recall.csv")
    # Frames alone as the truth (no transition windows: the default rule does not read them).
    df2 = ml.boundary_pr(methods["pca"], truth.boundaries, rate=m.rate, n_frames=m.n_frames, tolerance_s=0.5, sequence=SEQUENCE)
    row = df.filter((pl.col("method") == "pca") & (pl.col("sequence") == SEQUENCE))
    assert df2.filter(pl.col("sequence") == SEQUENCE)["f1"].to_list() == row["f1"].to_list()


def test_tssb_channel_segmenter_is_the_clis(cli, tmp_path):
    series = ROOT / "data/tssb/datasets/ArrowHead.txt"
    exp = tmp_path / "tssb.toml"
    exp.write_text(
        '[experiment]\nname = "tssb_arrowhead"\n\n[[dataset]]\n'
        f'files = ["{series}"]\nloader = {{ type = "channels", rate_hz = 1.0 }}\n'
        f'ground_truth = {{ type = "tssb_desc", file = "{ROOT / "data/tssb/datasets/desc.txt"}" }}\n\n'
        '[segmentation]\n[[segmentation.segmenter]]\ntype = "kernel_cpd"\ncost = "rbf"\nsearch = "binseg"\nn_bkps = 1\n\n'
        '[[evaluate]]\ntype = "boundary_metrics"\n'
    )
    run_dir = cli_run(cli, exp, tmp_path / "reports")
    m = ml.load(series, "channels", rate_hz=1.0)
    out = ml.segment("kernel_cpd", m, cost="rbf", search="binseg", n_bkps=1)
    theirs = pl.read_csv(run_dir / "tables/candidates.csv")["frame"].to_list()
    assert out.candidates.tolist() == theirs and theirs
    truth = ml.read_truth("tssb_desc", ROOT / "data/tssb/datasets/desc.txt", m)
    assert truth.boundaries.tolist() == [753]
    tables = ml.evaluate("boundary_metrics", [{"sequence": "ArrowHead", "motion": m, "truth": truth, "methods": {"kernel_cpd": out.candidates}}])
    for name, df in tables.items():
        assert_frame_equals_csv(df, run_dir / "tables" / f"{name}.csv")


def test_list_and_describe_are_the_clis(cli):
    assert ml.listing() == run_cli(cli, "list").stdout
    for name in ["fastest_marker_speed", "boundary_pr", "asf_amc", "multistream_two_stage", "segmentation"]:
        assert ml.describe(name) == run_cli(cli, "describe", name).stdout
    names = {p.name for p in ml.plugins()}
    listed = set(re.findall(r"^  ([a-z0-9_]+) ", ml.listing(), re.M))
    assert names <= listed and len(names) >= 45
    doc = ml.segmenters.fastest_marker_speed.__doc__
    assert doc == ml.describe("fastest_marker_speed")


def test_typed_functions_call_the_stage():
    m = ml.load(data("cmu86/86_01.amc.gz"))
    a = ml.segmenters.speed_minima(m, v_low={"fraction_of_p90": 0.15})
    b = ml.segment("speed_minima", m, v_low={"fraction_of_p90": 0.15})
    assert np.array_equal(a.candidates, b.candidates)
    f = ml.feature_extractors.marker_speed(m)
    assert set(f.traces) and all(len(v) == m.n_frames for v in f.traces.values())
    assert f.to_polars().height == m.n_frames
    walk = ml.load(data("mct/walk1.tsv.gz"))
    filled = ml.preprocessors.fill_gaps(walk)
    assert 0 < filled.missing_count < walk.missing_count, "short gaps filled, the long ones left"
    present = ~walk.missing
    assert np.array_equal(filled.positions[present], walk.positions[present])
