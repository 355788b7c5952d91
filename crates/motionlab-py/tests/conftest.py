"""Shared by the tests of the Python package: the repository, the CLI binary they compare
with, running it, and comparing a DataFrame with a CSV the CLI wrote.

The CLI is `$MOTIONLAB_CLI`, else `$CARGO_TARGET_DIR/debug/motionlab`; without it the tests
fail (never skip): they exist to compare the binding with the CLI."""

import math
import os
import subprocess
from pathlib import Path

import polars as pl
import pytest

ROOT = Path(__file__).resolve().parents[3]


def data(rel: str) -> str:
    return str(ROOT / "data" / rel)


@pytest.fixture(scope="session")
def cli() -> str:
    candidates = [os.environ.get("MOTIONLAB_CLI")]
    target = os.environ.get("CARGO_TARGET_DIR", str(Path.home() / ".cache" / "motionlab-target"))
    candidates.append(os.path.join(target, "debug", "motionlab"))
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return c
    pytest.fail(f"no motionlab CLI binary (tried {candidates}): build it with `cargo build -p motionlab-cli` or set MOTIONLAB_CLI")


def run_cli(cli: str, *args: str, ok: bool = True) -> subprocess.CompletedProcess:
    """Runs the CLI in the repository root; `ok` says whether it must succeed."""
    p = subprocess.run([cli, *args], cwd=ROOT, capture_output=True, text=True, env={**os.environ, "MOTIONLAB_CACHE_DIR": "/nonexistent-motionlab-cache"})
    if ok and p.returncode != 0:
        raise AssertionError(f"motionlab {' '.join(args)} failed ({p.returncode}):\n{p.stderr}")
    if not ok and p.returncode == 0:
        raise AssertionError(f"motionlab {' '.join(args)} succeeded; expected an error")
    return p


def cli_run(cli: str, experiment: Path, reports: Path, *overrides: str) -> Path:
    """`motionlab run` of an experiment into `reports`; the run directory."""
    p = run_cli(cli, "run", "--quiet", "--no-cache", "--reports", str(reports), str(experiment), *overrides)
    return Path(p.stdout.split(":")[0].strip())


def _cell(v):
    """A cell as the CSV and the DataFrame can both say it: null, NaN and '' are one value."""
    if v is None or (isinstance(v, float) and math.isnan(v)) or v == "":
        return None
    if isinstance(v, bool):
        return str(v).lower()
    return v


def assert_frame_equals_csv(df: pl.DataFrame, csv: Path, columns=None, where=None):
    """Every cell of `df` equals the CLI's CSV (floats exactly: the CSV writes the shortest
    text that reads back as the same float), in row order; `where` filters the CSV's rows
    (column -> value)."""
    ref = pl.read_csv(csv, infer_schema_length=None)
    if where:
        for k, v in where.items():
            ref = ref.filter(pl.col(k) == v)
    columns = columns or df.columns
    missing = [c for c in columns if c not in ref.columns]
    assert not missing, f"{csv.name} has no columns {missing}"
    assert df.height == ref.height, f"{csv.name}: {df.height} rows here, {ref.height} in the CLI's"
    for c in columns:
        ours = [_cell(v) for v in df[c].to_list()]
        theirs = [_cell(v) for v in ref[c].to_list()]
        for i, (a, b) in enumerate(zip(ours, theirs)):
            if isinstance(a, (int, float)) and isinstance(b, (int, float)):
                assert float(a) == float(b), f"{csv.name} row {i} column {c}: {a!r} here, {b!r} in the CLI's"
            else:
                sa, sb = (None if a is None else str(a)), (None if b is None else str(b))
                assert sa == sb, f"{csv.name} row {i} column {c}: {a!r} here, {b!r} in the CLI's"
