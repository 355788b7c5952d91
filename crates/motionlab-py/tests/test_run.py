"""`run()` is `motionlab run`: the same experiment run by both gives the same tables — every
table `run()` returns (read from the run's Parquet files) equals the CLI run's CSV."""
import dataclasses
import json
import re

import polars as pl

import motionlab as ml
from conftest import ROOT, assert_frame_equals_csv, cli_run, run_cli
from test_stages import sonoda_86_01


def test_run_tables_equal_the_cli_runs_csvs(cli, tmp_path):
    exp = sonoda_86_01(tmp_path)
    overrides = ["segmentation.fuser.merge_mm=200"]
    cli_dir = cli_run(cli, exp, tmp_path / "cli", *overrides)
    result = ml.run(exp, overrides, reports=tmp_path / "py", quiet=True, no_cache=True)
    assert result.run_dir.is_dir() and result.run_dir != cli_dir
    csvs = sorted(p.stem for p in (cli_dir / "tables").glob("*.csv"))
    assert sorted(result.tables) == csvs and len(csvs) >= 5
    for name, df in result.tables.items():
        assert isinstance(df, pl.DataFrame)
        assert_frame_equals_csv(df, cli_dir / "tables" / f"{name}.csv")
    assert all(f.exists() for f in result.figures)
    assert (result.run_dir / "provenance.json").exists()
    # The override reached the run (its provenance records it), and the CLI's run, made with
    # the same override, gave the same tables above.
    assert json.loads((result.run_dir / "provenance.json").read_text())["overrides"] == overrides


def test_validate_counts_like_the_cli(cli):
    exp = ROOT / "experiments/sonoda_table1.toml"
    v = ml.validate(exp)
    line = run_cli(cli, "validate", str(exp)).stdout.splitlines()[0]
    m = re.search(r"valid — (\w+) workflow, (\d+) dataset\(s\), (\d+) input file\(s\), (\d+) combination\(s\), (\d+) work item\(s\)", line)
    assert m, line
    w, *counts = m.groups()
    assert dataclasses.asdict(v) == {"workflow": w, **dict(zip(["datasets", "input_files", "combinations", "items"], map(int, counts)))}
    assert v.items > 0
