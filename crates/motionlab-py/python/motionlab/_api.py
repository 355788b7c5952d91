"""The Python half of motionlab's API: each function calls the native module
(``motionlab._motionlab``) and gives its result a typed dataclass. ``motionlab/__init__.py``
re-exports the public names (its ``__all__``); this module's own imports (NumPy, ``os``,
``typing``) stay here, out of ``dir(motionlab)``."""

from __future__ import annotations

import collections.abc
import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _motionlab as _native
from ._motionlab import ArgumentError, Motion, MotionlabError, Segmentation

if TYPE_CHECKING:  # polars is imported where a table is made
    import polars

Frames = Union[Sequence[int], np.ndarray]
#: A motion, or plain NumPy data: a 1-D series or a samples × channels array (a channel
#: motion, as claspy and ruptures take it), or frames × points × 3 positions in mm.
MotionLike = Union[Motion, np.ndarray, Sequence[float], Sequence[Sequence[float]]]
PathLike = Union[str, "os.PathLike[str]"]


class Text(str):
    """Text as the CLI prints it; shown as such (not quoted) in a REPL or notebook."""

    def __repr__(self) -> str:
        return str(self)


def _argument_error(message: str, field_path: str) -> ArgumentError:
    """An :class:`ArgumentError` made on the Python side, with the attributes the native
    module's errors carry."""
    e = ArgumentError(f"{field_path}: {message}")
    e.kind, e.message, e.file, e.line, e.field = "WrongType", message, None, None, field_path
    return e


def _motion(x: Any, rate: Optional[float], what: str = "motion") -> Motion:
    """``x`` as a :class:`Motion`: a motion as it is; a 1-D series or a samples × channels
    array as a channel motion at ``rate`` Hz (1 Hz without one: one sample per second, so
    durations in seconds count samples); frames × points × 3 positions (mm) at ``rate`` Hz,
    which they need (speeds and durations depend on it)."""
    if isinstance(x, Motion):
        if rate is not None and float(rate) != x.rate:
            raise _argument_error(f"{x.rate} Hz is the motion's own rate; rate={rate} is for arrays", "rate")
        return x
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise _argument_error(f"expected a motionlab.Motion or an array of numbers ({e})", what) from None
    if a.ndim in (1, 2):
        return Motion.from_channels(a, 1.0 if rate is None else float(rate))
    if a.ndim == 3:
        if rate is None:
            raise _argument_error("positions (frames × points × 3, mm) need their frame rate in Hz: rate=…", "rate")
        return Motion(a, float(rate))
    raise _argument_error(
        f"expected a motionlab.Motion, a 1-D series, samples × channels or frames × points × 3; found shape {a.shape}", what
    )


def _plain(x: Any) -> Any:
    """A result dataclass (and dataclasses inside lists and dicts) as the plain records the
    native module reads; anything else as it is."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: _plain(getattr(x, f.name)) for f in dataclasses.fields(x)}
    if isinstance(x, Mapping):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    return x


def _frame(table: Mapping[str, Any], pandas: bool = False):
    """A motionlab table (``{"name", "title", "columns"}``) as a Polars DataFrame (pandas on
    request)."""
    import polars as pl

    df = pl.DataFrame({k: v for k, v in table["columns"].items()})
    return df.to_pandas() if pandas else df


# ---------------------------------------------------------------------------------------------
# The registry
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Param:
    """One parameter of a plugin or workflow, as ``describe`` prints it: its TOML type, its
    default (written as TOML; None when required), what leaving it out means when no value
    says it, and its documentation."""

    name: str
    type_name: str
    default: Optional[str]
    default_note: Optional[str]
    required: bool
    description: str


@dataclass(frozen=True)
class Plugin:
    """A registered plugin: its name, kind (``segmenter``, ``matcher``, …) and the kind's
    label, the crate that registers it, its params type, its documentation and parameters."""

    name: str
    kind: str
    kind_label: str
    crate: str
    params_type: str
    doc: str
    params: List[Param]


@dataclass(frozen=True)
class Workflow:
    """A workflow (an experiment's section): name, crate, documentation and parameters."""

    name: str
    crate: str
    doc: str
    params: List[Param]


def _params(rows: Sequence[Mapping[str, Any]]) -> List[Param]:
    return [Param(**p) for p in rows]


def listing() -> Text:
    """Every registered workflow and plugin by kind: the text of ``motionlab list``."""
    return Text(_native.list_text())


def describe(name: str) -> Text:
    """A workflow's or plugin's documentation and parameters: the text of
    ``motionlab describe NAME`` (the same doc comments the code carries)."""
    return Text(_native.describe(name))


def plugins() -> List[Plugin]:
    """Every registered plugin, core's kinds and the kinds family crates declare: what
    ``motionlab list`` lists and ``describe`` prints, as records."""
    return [Plugin(**{**p, "params": _params(p["params"])}) for p in _native.plugins()]


def workflows() -> List[Workflow]:
    """Every workflow (an experiment's section) as a record."""
    return [Workflow(**{**w, "params": _params(w["params"])}) for w in _native.workflows()]


# ---------------------------------------------------------------------------------------------
# Loading and stages
# ---------------------------------------------------------------------------------------------


def load(path: PathLike, loader: Optional[str] = None, **params: Any) -> Motion:
    """Loads a motion file: C3D, BVH, ASF/AMC (the ``.asf`` found beside the ``.amc``),
    Qualisys TSV, OpenSim TRC (markers) and MOT/STO (named channels) or a channel file (TSSB series, CSV, ``.npy``, Parquet); ``.gz`` is read
    transparently. Video keypoints load as 2-D motions (``Motion.dimensionality == "2d"``, px,
    with ``Motion.confidence``): a folder of OpenPose JSON frames, COCO keypoint ``.json``,
    MediaPipe ``.pbtxt`` — their files store no rate, so give ``rate_hz``. Xsens ``.mvnx`` loads
    as segment positions with orientation and joint-angle channels.

    ``loader`` names a registered loader (``listing()``); without it, the loader registered for
    the file's extension, as ``motionlab inspect`` picks it. ``params`` are the loader's
    parameters as in TOML, with or without its name: ``load("Adiac.txt", rate_hz=1.0)``,
    ``load(p, "asf_amc", skeleton="../asf/13.asf")``.
    """
    return _native.load(os.fspath(path), loader, params)


@dataclass
class Trace:
    """A per-frame trace: its name, unit and values (NaN where undefined)."""

    name: str
    unit: str
    values: np.ndarray


@dataclass
class Threshold:
    """A threshold a segmenter decided with: its name, the trace it applies to, its value
    (in the trace's unit)."""

    name: str
    trace: str
    value: float


@dataclass
class Features:
    """A feature extractor's per-frame traces (NaN where undefined), their units, and labels."""

    traces: Dict[str, np.ndarray]
    units: Dict[str, str]
    labels: Dict[str, List[str]]

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
    thresholds: List[Threshold]
    flagged_frames: np.ndarray


@dataclass
class PointDetection:
    """A point detector's result: the velocity function it thresholded, the threshold, the
    peak frames and the window ``(first, last)`` frame cut around each."""

    velocity: Trace
    threshold: float
    peaks: List[int]
    windows: List[Tuple[int, int]]


@dataclass
class Alignment:
    """A matcher's alignment of a model to a stretch of the target: ``start`` (a) and ``end``
    (b) target frames, each point's distance (h_l), the total (H) and each point's warping
    path of (model frame, target frame) pairs."""

    start: int
    end: int
    point_distances: List[float]
    total_distance: float
    paths: List[List[Tuple[int, int]]]


@dataclass
class Synchronisation:
    """A synchroniser's result: the model frames examined, their section values (r_q) and
    the total (R)."""

    model_frames: List[int]
    section_values: List[float]
    total: float


@dataclass
class GaitCycle:
    """One gait cycle: first and one-past-last frame, and the side (``"left"``/``"right"``)."""

    start: int
    end: int
    side: str


@dataclass
class AngleCurves:
    """Joint-angle curves of a walk (degrees): the frame rate (Hz), the channel names and
    their values (one list per channel)."""

    frame_rate: float
    channels: List[str]
    values: List[List[float]]


@dataclass
class WaveformParameters:
    """A waveform analyzer's result: per channel the DC and amplitude (degrees), and the
    gait frequency (Hz)."""

    channels: List[str]
    dc: List[float]
    amplitude: List[float]
    frequency_hz: float


def preprocess(name: str, motion: MotionLike, *, rate: Optional[float] = None, **params: Any) -> Motion:
    """The preprocessor ``name`` (``fill_gaps``, ``butterworth``, …) applied to a motion or an
    array (``rate`` in Hz for an array); a new motion."""
    return _native.preprocess(name, _motion(motion, rate), params)


def features(name: str, motion: MotionLike, *, rate: Optional[float] = None, **params: Any) -> Features:
    """The feature extractor ``name`` (``marker_speed``, ``hull_volume``, …) on a motion or an
    array (``rate`` in Hz for an array): its traces and the labels it gives each frame."""
    return Features(**_native.features(name, _motion(motion, rate), params))


def segment(name: str, motion: MotionLike, *, rate: Optional[float] = None, **params: Any) -> SegmenterOutput:
    """The segmenter ``name`` on a motion or on plain NumPy data:
    ``segment("clasp", ts)`` for a 1-D series (or samples × channels),
    ``segment("fastest_marker_speed", m, v_low={"fraction_of_p90": 0.45})`` for a motion.

    An array of one or two dimensions is a channel motion at ``rate`` Hz (1 Hz when not given:
    durations in seconds then count samples); frames × points × 3 positions (mm) need
    ``rate``."""
    out = _native.segment(name, _motion(motion, rate), params)
    out["thresholds"] = [Threshold(**t) for t in out["thresholds"]]
    return SegmenterOutput(**out)


def fuse(name: str, motion: MotionLike, candidates: Mapping[str, Frames], *, rate: Optional[float] = None, **params: Any) -> np.ndarray:
    """The fuser ``name`` (``union_merge``) on several methods' candidates
    (``{method: frames}``, in order) of a motion or an array."""
    return _native.fuse(name, _motion(motion, rate), dict(candidates), params)


def read_truth(name: str, path: PathLike, motion: MotionLike, *, rate: Optional[float] = None, **params: Any) -> Segmentation:
    """The ground-truth reader ``name`` (``boundaries_csv``, ``elan_eaf``, ``cmu86_labels``,
    ``tssb_desc``, …) on a file, in frames of ``motion`` (a motion or an array)."""
    return _native.read_truth(name, os.fspath(path), _motion(motion, rate), params)


def detect_points(name: str, motion: MotionLike, *, rate: Optional[float] = None, **params: Any) -> PointDetection:
    """The point detector ``name`` (``velocity_peaks``) on a take (a motion, or positions with
    their ``rate``): the velocity function, its threshold, the peaks and the window cut around
    each."""
    d = _native.detect_points(name, _motion(motion, rate), params)
    return PointDetection(
        velocity=Trace(d["velocity"]["name"], d["velocity"]["unit"], np.asarray(d["velocity"]["values"], dtype=np.float64)),
        threshold=d["threshold"],
        peaks=d["peaks"],
        windows=[tuple(w) for w in d["windows"]],
    )


def _alignment(d: Mapping[str, Any]) -> Alignment:
    return Alignment(**{**d, "paths": [[tuple(p) for p in path] for path in d["paths"]]})


def align(name: str, model: MotionLike, target: MotionLike, *, rate: Optional[float] = None, **params: Any) -> Alignment:
    """The matcher ``name`` (``multistream_two_stage``, ``subsequence_dp``) on two motions
    (points matched by name) or two position arrays at ``rate`` Hz."""
    return _alignment(_native.align(name, _motion(model, rate, "model"), _motion(target, rate, "target"), params))


def synchronise(name: str, alignment: Union[Alignment, Mapping[str, Any]], model_frames: int, **params: Any) -> Synchronisation:
    """The synchroniser ``name`` (``synchronisation``) on an alignment as :func:`align`
    returns it, for a model of ``model_frames`` frames."""
    return Synchronisation(**_native.synchronise(name, _plain(alignment), int(model_frames), params))


def gait_cycles(name: str, motion: MotionLike, *, rate: Optional[float] = None, **params: Any) -> List[GaitCycle]:
    """The gait-cycle detector ``name`` (``c3d_events``, ``heel_height``) on a walk."""
    return [GaitCycle(**c) for c in _native.gait_cycles(name, _motion(motion, rate), params)]


def waveform_parameters(name: str, curves: Union[AngleCurves, Mapping[str, Any]], cycles: Sequence[Union[GaitCycle, Mapping[str, Any]]],
                        **params: Any) -> WaveformParameters:
    """The waveform analyzer ``name`` on angle curves (:class:`AngleCurves` or
    ``{"frame_rate", "channels", "values"}``, degrees) over gait cycles: DC, amplitude and
    frequency."""
    return WaveformParameters(**_native.waveform_parameters(name, _plain(curves), _plain(cycles), params))


def synthesize_walk(name: str, walk: Union[AngleCurves, Mapping[str, Any]], cycles: Sequence[Union[GaitCycle, Mapping[str, Any]]],
                    changes: Mapping[str, Any], **params: Any) -> AngleCurves:
    """The walk synthesizer ``name`` on a walk's angle curves, its cycles and change rates
    (``{"dc_percent", "amplitude_percent", "frequency_percent"}``): the changed walk."""
    return AngleCurves(**_native.synthesize_walk(name, _plain(walk), _plain(cycles), _plain(changes), params))


# ---------------------------------------------------------------------------------------------
# Evaluation
# ---------------------------------------------------------------------------------------------


@dataclass
class Evaluation(collections.abc.Mapping):
    """An evaluator's tables by name, each a DataFrame (Polars; pandas on request). Reads as a
    mapping: ``ev["table1_precision_recall"]``, ``ev.items()``."""

    tables: Dict[str, Any]

    def __getitem__(self, name: str) -> Any:
        return self.tables[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.tables)

    def __len__(self) -> int:
        return len(self.tables)


def _sequences(results: Any) -> Any:
    """Segmentation results with arrays in place of motions (at the sequence's ``rate``) and
    frames in place of truths made into what the native module reads; other results as plain
    records."""
    if not isinstance(results, (tuple, list)):
        return _plain(results)
    out = []
    for r in results:
        if isinstance(r, Mapping) and "methods" in r:
            r = dict(r)
            rate = r.get("rate")
            if r.get("motion") is not None and not isinstance(r["motion"], Motion):
                r["motion"] = _motion(r["motion"], rate)
            if rate is None and isinstance(r.get("motion"), Motion):
                rate = r["motion"].rate
            if r.get("truth") is not None and not isinstance(r["truth"], Segmentation) and rate is not None:
                r["truth"] = Segmentation(r["truth"], float(rate))
            out.append(r)
        else:
            out.append(_plain(r))
    return out


def evaluate(name: str, results: Any, *, pandas: bool = False, **params: Any) -> Evaluation:
    """The evaluator ``name`` on results of the kind it reads, every table as a DataFrame
    (by table name).

    Segmentation evaluators (``boundary_pr``, ``boundary_metrics``, ``transitions``) read a list
    of sequences ``{"sequence": str, "motion": Motion | array, "truth": Segmentation | frames |
    None, "methods": {method: frames}}``, where ``"rate"`` (Hz) and ``"n_frames"`` may stand for
    the motion (they are all these evaluators read of it); ``judgement`` a list of takes
    ``{"take", "point_names", "repetitions": [{"repetition", "window_start", "alignment",
    "synchronisation"}]}``; ``change_rates`` a gait study ``{"normal_condition", "trials"}``."""
    tables = _native.evaluate(name, _sequences(results), params)
    return Evaluation({t["name"]: _frame(t, pandas) for t in tables})


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
) -> polars.DataFrame:
    """Precision, recall and F1 of found boundary frames against the truth, with the chance
    columns (``chance_precision``, ``chance_recall``, ``chance_f1``, ``p_value``,
    ``above_chance``) and the periodic baseline: the ``table1_precision_recall`` table of the
    ``boundary_pr`` evaluator, as a DataFrame.

    ``found`` is one method's frames or ``{method: frames}``; ``truth`` frames or a
    :class:`Segmentation`; ``rate`` (Hz) and ``n_frames`` are the sequence the chance baseline
    draws from (no motion needed). The tolerance in seconds or frames (default: the
    evaluator's); other keywords are the evaluator's parameters (``span``, ``chance_draws``, …;
    ``describe("boundary_pr")``). Works on boundaries from any library."""
    if tolerance_s is not None and tolerance_frames is not None:
        raise _argument_error("give tolerance_s or tolerance_frames, not both", "tolerance")
    if tolerance_s is not None:
        params["tolerance"] = {"seconds": float(tolerance_s)}
    elif tolerance_frames is not None:
        params["tolerance"] = {"frames": tolerance_frames}
    results = [{"sequence": sequence, "rate": float(rate), "n_frames": int(n_frames), "truth": _truth(truth, rate),
                "methods": _methods(found)}]
    return evaluate("boundary_pr", results, pandas=pandas, **params)["table1_precision_recall"]


def _annotators(truth: Any) -> List[Any]:
    if isinstance(truth, Segmentation):
        return truth.annotators
    items = list(truth)
    if items and all(isinstance(t, (list, tuple, np.ndarray)) for t in items):
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
    paths: List[np.ndarray]
    G: np.ndarray
    start_costs: np.ndarray
    R: Optional[float]
    r: Optional[np.ndarray]
    sync_frames: Optional[List[int]]


def _f64(a: Any) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def penalty_path(
    values: Any,
    path: Sequence[Any] = ("bic", "whole_cost"),
    choose: str = "elbow",
    *,
    pandas: bool = False,
    **params: Any,
) -> polars.DataFrame:
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
    table = _native.penalty_path(x, {**params, "penalty": {"path": [*path], "choose": choose}})
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
    figures: List[Path] = field(default_factory=list)
    items: int = 0

    def __repr__(self) -> str:
        names = ", ".join(self.tables)
        return f"RunResult(run_dir={str(self.run_dir)!r}, {self.items} item(s), tables: {names})"


@dataclass(frozen=True)
class Validation:
    """What ``motionlab validate`` counts of a valid experiment: its workflow, datasets, input
    files, parameter combinations and work items."""

    workflow: str
    datasets: int
    input_files: int
    combinations: int
    items: int


def run(
    experiment: PathLike,
    overrides: Sequence[str] = (),
    *,
    reports: PathLike = "reports",
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


def validate(experiment: PathLike, overrides: Sequence[str] = (), *, allow_external: bool = False) -> Validation:
    """Checks every file, plugin and parameter of an experiment without running it (``motionlab
    validate``); raises :class:`MotionlabError` with the CLI's message otherwise."""
    return Validation(**_native.validate(os.fspath(experiment), [str(o) for o in overrides], allow_external))
