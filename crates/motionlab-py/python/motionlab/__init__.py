"""motionlab for Python: motionlab's loaders, every registered stage, the evaluators, the
multistream matcher and whole experiment runs, on NumPy arrays and Polars DataFrames.

Everything here calls motionlab's Rust crates (the native module ``motionlab._motionlab``); the
numbers are the CLI's, bit for bit. Stages are named and parameterised exactly as in an
experiment's TOML: ``segment("fastest_marker_speed", motion, v_low={"fraction_of_p90": 0.45})``
is ``{ type = "fastest_marker_speed", v_low = { fraction_of_p90 = 0.45 } }``, and a bad
parameter raises :class:`MotionlabError` with the CLI's message (key path and what was
expected). ``describe(name)`` prints a plugin's documentation; ``motionlab.segmenters``,
``motionlab.loaders``, … hold one typed function per plugin with that documentation as its
docstring.

Long calls release the GIL; a panic inside motionlab raises :class:`MotionlabError` instead of
aborting the interpreter.

    import motionlab as ml
    m = ml.load("data/cmu86/86_01.amc.gz")                      # positions: frames x points x 3, mm
    out = ml.segment("fastest_marker_speed", m, v_low={"fraction_of_p90": 0.15})
    truth = ml.read_truth("cmu86_labels", "data/cmu86/mocap.txt", m)
    print(ml.boundary_pr(out.candidates, truth, rate=m.rate, n_frames=m.n_frames, tolerance_s=0.5))
"""

from __future__ import annotations

import builtins
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _motionlab as _native
from ._motionlab import Motion, MotionlabError, Segmentation, __version__

__all__ = [
    "Motion", "MotionlabError", "Segmentation", "Text", "Features", "SegmenterOutput", "SubsequenceMatch",
    "MultistreamMatch", "RunResult", "TcpdF1", "__version__",
    "load", "list", "describe", "plugins", "workflows", "preprocess", "features", "segment", "fuse", "read_truth",
    "detect_points", "align", "synchronise", "gait_cycles", "waveform_parameters", "synthesize_walk",
    "evaluate", "boundary_pr", "covering", "tcpd_f1", "penalty_path", "subsequence_dp", "multistream_match", "run", "validate",
    "loaders", "ground_truth_readers", "preprocessors", "feature_extractors", "segmenters", "fusers", "point_detectors",
    "matchers", "synchronisers", "gait_cycle_detectors", "waveform_analyzers", "walk_synthesizers", "evaluators",
]

Frames = Union[Sequence[int], np.ndarray]


class Text(str):
    """Text as the CLI prints it; shown as such (not quoted) in a REPL or notebook."""

    def __repr__(self) -> str:
        return str(self)


def _frame(table: Mapping[str, Any], pandas: bool = False):
    """A motionlab table (``{"name", "title", "columns"}``) as a Polars DataFrame (pandas on
    request)."""
    import polars as pl

    df = pl.DataFrame({k: v for k, v in table["columns"].items()})
    return df.to_pandas() if pandas else df


def _frames(tables: Iterable[Mapping[str, Any]], pandas: bool = False) -> Dict[str, Any]:
    return {t["name"]: _frame(t, pandas) for t in tables}


# ---------------------------------------------------------------------------------------------
# The registry
# ---------------------------------------------------------------------------------------------


def list() -> Text:  # noqa: A001 - the CLI's command name
    """Every registered workflow and plugin by kind: the text of ``motionlab list``."""
    return Text(_native.list_text())


def describe(name: str) -> Text:
    """A workflow's or plugin's documentation and parameters: the text of
    ``motionlab describe NAME`` (the same doc comments the code carries)."""
    return Text(_native.describe(name))


def plugins() -> builtins.list[Dict[str, Any]]:
    """Every registered plugin as a record: ``name``, ``kind``, ``kind_label``, ``crate``,
    ``params_type``, ``doc`` and ``params`` (each with ``name``, ``type_name``, ``default``,
    ``default_note``, ``required``, ``description``) — what ``describe`` prints."""
    return _native.plugins()


def workflows() -> builtins.list[Dict[str, Any]]:
    """Every workflow (an experiment's section) as a record: ``name``, ``crate``, ``doc``,
    ``params``."""
    return _native.workflows()


# ---------------------------------------------------------------------------------------------
# Loading and stages
# ---------------------------------------------------------------------------------------------


def load(path: Union[str, os.PathLike], loader: Optional[str] = None, **params: Any) -> Motion:
    """Loads a motion file: C3D, BVH, ASF/AMC (the ``.asf`` found beside the ``.amc``),
    Qualisys TSV or a channel file (TSSB series, CSV, ``.npy``, Parquet); ``.gz`` is read transparently.

    ``loader`` names a registered loader (``motionlab list``); without it, the loader registered
    for the file's extension at its defaults, as ``motionlab inspect`` picks it. ``params`` are
    the loader's parameters as in TOML (``load(p, "asf_amc", skeleton="../asf/13.asf")``).
    """
    return _native.load(os.fspath(path), loader, params)


@dataclass
class Features:
    """A feature extractor's per-frame traces (NaN where undefined), their units, and labels."""

    traces: Dict[str, np.ndarray]
    units: Dict[str, str]
    labels: Dict[str, builtins.list]

    def to_polars(self):
        """The traces and labels as columns of one DataFrame (NaN as null)."""
        import polars as pl

        return pl.DataFrame({**self.traces, **self.labels}).fill_nan(None)


@dataclass
class SegmenterOutput:
    """What a segmenter found: candidate boundary frames, the traces it decided on, its
    thresholds and the frames it flagged as unreliable."""

    candidates: np.ndarray
    traces: Dict[str, np.ndarray]
    units: Dict[str, str]
    thresholds: builtins.list
    flagged_frames: np.ndarray


def preprocess(name: str, motion: Motion, **params: Any) -> Motion:
    """The preprocessor ``name`` (``fill_gaps``, ``butterworth``, …) applied to a motion; a new
    motion."""
    return _native.preprocess(name, motion, params)


def features(name: str, motion: Motion, **params: Any) -> Features:
    """The feature extractor ``name`` (``marker_speed``, ``hull_volume``, …) on a motion."""
    return Features(**_native.features(name, motion, params))


def segment(name: str, motion: Motion, **params: Any) -> SegmenterOutput:
    """The segmenter ``name`` on a motion:
    ``segment("fastest_marker_speed", m, v_low={"fraction_of_p90": 0.45})``.

    A segmenter that reads channels (``clasp``, ``kernel_cpd``, ``bocpd``, ``floss``,
    ``window``) takes a channel file's motion, or ``Motion.from_channels(values, rate)`` of
    features you computed (``features(...)``)."""
    return SegmenterOutput(**_native.segment(name, motion, params))


def fuse(name: str, motion: Motion, candidates: Mapping[str, Frames], **params: Any) -> np.ndarray:
    """The fuser ``name`` (``union_merge``) on several methods' candidates
    (``{method: frames}``, in order)."""
    return _native.fuse(name, motion, dict(candidates), params)


def read_truth(name: str, path: Union[str, os.PathLike], motion: Motion, **params: Any) -> Segmentation:
    """The ground-truth reader ``name`` (``boundaries_csv``, ``elan_eaf``, ``cmu86_labels``, …)
    on a file, in frames of ``motion``."""
    return _native.read_truth(name, os.fspath(path), motion, params)


def detect_points(name: str, motion: Motion, **params: Any) -> Dict[str, Any]:
    """The point detector ``name`` (``velocity_peaks``) on a take: the velocity function, its
    threshold, the peaks and the window cut around each."""
    return _native.detect_points(name, motion, params)


def align(name: str, model: Motion, target: Motion, **params: Any) -> Dict[str, Any]:
    """The matcher ``name`` (``multistream_two_stage``, ``subsequence_dp``) on two motions
    (points matched by name): ``start`` (a), ``end`` (b), ``point_distances`` (h_l),
    ``total_distance`` (H) and ``paths``."""
    return _native.align(name, model, target, params)


def synchronise(name: str, alignment: Mapping[str, Any], model_frames: int, **params: Any) -> Dict[str, Any]:
    """The synchroniser ``name`` (``synchronisation``) on an alignment as :func:`align`
    returns it: ``model_frames`` examined, ``section_values`` (r_q), ``total`` (R)."""
    return _native.synchronise(name, dict(alignment), model_frames, params)


def gait_cycles(name: str, motion: Motion, **params: Any) -> builtins.list[Dict[str, Any]]:
    """The gait-cycle detector ``name`` (``c3d_events``, ``heel_height``) on a walk."""
    return _native.gait_cycles(name, motion, params)


def waveform_parameters(name: str, curves: Mapping[str, Any], cycles: Sequence[Mapping[str, Any]], **params: Any) -> Dict[str, Any]:
    """The waveform analyzer ``name`` on angle curves (``{"frame_rate", "channels",
    "values"}``, degrees) over gait cycles: DC, amplitude and frequency."""
    return _native.waveform_parameters(name, dict(curves), builtins.list(cycles), params)


def synthesize_walk(name: str, walk: Mapping[str, Any], cycles: Sequence[Mapping[str, Any]], changes: Mapping[str, Any], **params: Any) -> Dict[str, Any]:
    """The walk synthesizer ``name`` on a walk's angle curves, its cycles and change rates."""
    return _native.synthesize_walk(name, dict(walk), builtins.list(cycles), dict(changes), params)


# ---------------------------------------------------------------------------------------------
# Evaluation
# ---------------------------------------------------------------------------------------------


def evaluate(name: str, results: Any, *, pandas: bool = False, **params: Any) -> Dict[str, Any]:
    """The evaluator ``name`` on results of the kind it reads, every table as a DataFrame
    (by table name).

    Segmentation evaluators (``boundary_pr``, ``boundary_metrics``, ``transitions``) read a list
    of sequences ``{"sequence": str, "motion": Motion, "truth": Segmentation | None,
    "methods": {method: frames}}``; ``judgement`` a list of takes ``{"take", "point_names",
    "repetitions": [{"repetition", "window_start", "alignment", "synchronisation"}]}``;
    ``change_rates`` a gait study ``{"normal_condition", "trials"}``."""
    return _frames(_native.evaluate(name, results, params), pandas)


def _truth(truth: Any, rate: float) -> Segmentation:
    if isinstance(truth, Segmentation):
        return truth
    return Segmentation(truth, rate)


def _methods(found: Any) -> Dict[str, Frames]:
    return dict(found) if isinstance(found, Mapping) else {"method": found}


def boundary_pr(
    found: Union[Frames, Mapping[str, Frames]],
    truth: Union[Frames, Segmentation],
    *,
    rate: float,
    n_frames: int,
    tolerance_s: Optional[float] = None,
    tolerance_frames: Optional[float] = None,
    sequence: str = "sequence",
    pandas: bool = False,
    **params: Any,
):
    """Precision, recall and F1 of found boundary frames against the truth, with the chance
    columns (``chance_precision``, ``chance_recall``, ``chance_f1``, ``p_value``,
    ``above_chance``) and the periodic baseline: the ``table1_precision_recall`` table of the
    ``boundary_pr`` evaluator, as a DataFrame.

    ``found`` is one method's frames or ``{method: frames}``; ``truth`` frames or a
    :class:`Segmentation`; ``rate`` (Hz) and ``n_frames`` give the sequence the chance baseline
    draws from. The tolerance in seconds or frames (default: the evaluator's); other keywords
    are the evaluator's parameters (``span``, ``chance_draws``, …; ``describe("boundary_pr")``).
    Works on boundaries from any library."""
    if tolerance_s is not None and tolerance_frames is not None:
        raise MotionlabError("give tolerance_s or tolerance_frames, not both")
    if tolerance_s is not None:
        params["tolerance"] = {"seconds": float(tolerance_s)}
    elif tolerance_frames is not None:
        params["tolerance"] = {"frames": tolerance_frames}
    # The evaluator reads only the sequence's length and rate (no pose rule here): a channel
    # motion of one zero channel gives both.
    motion = Motion.from_channels(np.zeros((int(n_frames), 1)), float(rate), name=sequence)
    results = [{"sequence": sequence, "motion": motion, "truth": _truth(truth, rate), "methods": _methods(found)}]
    return evaluate("boundary_pr", results, pandas=pandas, **params)["table1_precision_recall"]


def _annotators(truth: Any) -> builtins.list:
    if isinstance(truth, Segmentation):
        return truth.annotators
    items = builtins.list(truth)
    if items and all(isinstance(t, (builtins.list, tuple, np.ndarray)) for t in items):
        return items
    return [items]


@dataclass(frozen=True)
class TcpdF1:
    """TCPDBench's F1 with its precision and recall."""

    f1: float
    precision: float
    recall: float


def tcpd_f1(truth: Any, predictions: Frames, margin_frames: int) -> TcpdF1:
    """TCPDBench's F1 (van den Burg & Williams 2020): ``truth`` is one annotator's frames, a
    list of several annotators' frames, or a :class:`Segmentation`; frame 0 is added to every
    set as TCPDBench does."""
    return TcpdF1(*_native.tcpd_f1(_annotators(truth), predictions, int(margin_frames)))


def covering(truth: Any, predictions: Frames, n_frames: int) -> float:
    """TCPDBench's segment covering of the annotators' partitions of ``0..n_frames`` by the
    predicted change points (``truth`` as for :func:`tcpd_f1`)."""
    return _native.covering(_annotators(truth), predictions, int(n_frames))


# ---------------------------------------------------------------------------------------------
# Matching on arrays
# ---------------------------------------------------------------------------------------------


@dataclass
class SubsequenceMatch:
    """Single-stream subsequence DP: the best stretch ``[a, b]`` of the target for the whole
    model, its cost (mm summed along the path), the path (k × 2: model frame, target frame) and
    ``h(j)`` for every end ``j``."""

    a: int
    b: int
    cost: float
    path: np.ndarray
    end_costs: np.ndarray


@dataclass
class MultistreamMatch:
    """The two-stage multistream match (Yabe & Tanaka §3.1.3): the common stretch ``[a, b]``,
    ``H = Σ h_l`` (mm) and each point's ``h_l``, each point's warping path (k × 2: model frame,
    target frame), ``G(j)``, the summed backward cost of every start, and the synchronisation
    ``R = Σ r_q`` with its ``r_q`` at the model frames ``sync_frames`` (None without paths)."""

    a: int
    b: int
    H: float
    h: np.ndarray
    paths: builtins.list
    G: np.ndarray
    start_costs: np.ndarray
    R: Optional[float]
    r: Optional[np.ndarray]
    sync_frames: Optional[builtins.list]


def _f64(a: Any) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def penalty_path(values: Any, path: Sequence[Any] = ("bic", "whole_cost"), choose: str = "elbow", *, pandas: bool = False, **params: Any):
    """``kernel_cpd``'s penalty path (CROPS) of ``values`` (n samples, or n × channels): every
    segmentation optimal for a penalty in ``path`` (numbers in the cost's units, or ``"bic"``
    and ``"whole_cost"``), one row each, fewest change points first — ``n_changes``,
    ``pen_min``, ``pen_max`` (the penalty interval it owns), ``cost`` (unpenalised),
    ``chosen`` (the one ``choose`` picks: ``"elbow"``, ``"bic"`` or ``"widest"``) and
    ``change_points`` (space-separated sample indices). Other ``kernel_cpd`` parameters
    (``search``, ``cost``, ``min_size``, ``gamma``…) as keywords. A Polars DataFrame (pandas
    with ``pandas=True``)."""
    x = _f64(values)
    if x.ndim == 1:
        x = x.reshape(-1, 1)
    table = _native.penalty_path(x, {**params, "penalty": {"path": builtins.list(path), "choose": choose}})
    return _frame(table, pandas)


def subsequence_dp(model: Any, target: Any) -> SubsequenceMatch:
    """The paper's single-stream subsequence DP (free start and end) of one 3-D trajectory:
    ``model`` n × 3 against ``target`` m × 3 (mm); local distance ``|s_i − t_j|``."""
    return SubsequenceMatch(**_native.subsequence_dp(_f64(model), _f64(target)))


def multistream_match(model: Any, target: Any, keep_paths: bool = True, k: Optional[int] = 8) -> MultistreamMatch:
    """The two-stage multistream DP over every point at once: ``model`` n × L × 3 against
    ``target`` m × L × 3 (mm), point ``l`` against point ``l``; ``k`` model frames examined for
    the synchronisation R (the paper's 8; None for none). NaN samples are refused. Runs the
    SIMD kernel of motionlab-match without the GIL."""
    return MultistreamMatch(**_native.multistream_match(_f64(model), _f64(target), keep_paths, k))


# ---------------------------------------------------------------------------------------------
# Whole runs
# ---------------------------------------------------------------------------------------------


@dataclass
class RunResult:
    """A finished run: its directory, every table (by name) as a DataFrame read from the run's
    Parquet files, and the figure files."""

    run_dir: Path
    tables: Dict[str, Any]
    figures: builtins.list = field(default_factory=builtins.list)
    items: int = 0

    def __repr__(self) -> str:
        names = ", ".join(self.tables)
        return f"RunResult(run_dir={str(self.run_dir)!r}, {self.items} item(s), tables: {names})"


def run(
    experiment: Union[str, os.PathLike],
    overrides: Sequence[str] = (),
    *,
    reports: Union[str, os.PathLike] = "reports",
    threads: Optional[int] = None,
    quiet: bool = False,
    no_cache: bool = False,
    allow_external: bool = False,
    pandas: bool = False,
) -> RunResult:
    """Runs an experiment as ``motionlab run EXPERIMENT OVERRIDES…`` does — a fresh run
    directory under ``reports`` with tables, figures, pages and provenance — and returns every
    table as a Polars DataFrame (pandas with ``pandas=True``). Progress bars as in the CLI when
    stderr is a terminal. An experiment that names a program runs only with
    ``allow_external=True`` or a trust record (``motionlab trust``), as with the CLI."""
    out = _native.run(os.fspath(experiment), [str(o) for o in overrides], os.fspath(reports), threads, quiet, no_cache, allow_external)
    run_dir = Path(out["run_dir"])
    import polars as pl

    tables = {}
    for rel in out["tables"]:
        p = Path(rel)
        if p.suffix == ".parquet":
            df = pl.read_parquet(run_dir / p)
            tables[p.stem] = df.to_pandas() if pandas else df
    return RunResult(run_dir=run_dir, tables=tables, figures=[run_dir / f for f in out["figures"]], items=out["items"])


def validate(experiment: Union[str, os.PathLike], overrides: Sequence[str] = (), *, allow_external: bool = False) -> Dict[str, Any]:
    """Checks every file, plugin and parameter of an experiment without running it (``motionlab
    validate``); raises :class:`MotionlabError` with the CLI's message otherwise."""
    return _native.validate(os.fspath(experiment), [str(o) for o in overrides], allow_external)


# One typed function per plugin, by kind (`motionlab.segmenters.clasp(m, …)`); built from the
# registry, so it needs the generic functions above.
from ._typed import (  # noqa: E402
    evaluators, feature_extractors, fusers, gait_cycle_detectors, ground_truth_readers, loaders, matchers,
    point_detectors, preprocessors, segmenters, synchronisers, waveform_analyzers, walk_synthesizers,
)
