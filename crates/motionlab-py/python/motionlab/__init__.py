"""motionlab for Python: motionlab's loaders, every registered stage, the evaluators, the
multistream matcher and whole experiment runs, on NumPy arrays and Polars DataFrames.

Everything here calls motionlab's Rust crates (the native module ``motionlab._motionlab``); the
numbers are the CLI's, bit for bit. Stages are named and parameterised exactly as in an
experiment's TOML: ``segment("fastest_marker_speed", motion, v_low={"fraction_of_p90": 0.45})``
is ``{ type = "fastest_marker_speed", v_low = { fraction_of_p90 = 0.45 } }``. Every stage takes
a :class:`Motion` or plain NumPy data (a 1-D series or samples × channels; frames × points × 3
positions in mm with their ``rate``). ``describe(name)`` prints a plugin's documentation,
``plugins()`` lists them as records; ``motionlab.segmenters``, ``motionlab.loaders``, … hold one
typed function per plugin with that documentation as its docstring. Every result is a
dataclass.

Errors: :class:`MotionlabError` carries the CLI's message (key path and what was expected); a
bad argument raises its subclass :class:`ArgumentError`, also a ``ValueError``; a problem in a
file its subclass :class:`FileError`. Long calls release the GIL; a panic inside motionlab
raises :class:`MotionlabError` instead of aborting the interpreter.

    import numpy as np
    import motionlab as ml
    ts = np.loadtxt("data/tssb/datasets/ArrowHead.txt")        # a TSSB series, as NumPy reads it
    out = ml.segment("kernel_cpd", ts, cost="rbf", n_bkps=1)    # change points, like ruptures
    print(out.candidates, ml.covering([753], out.candidates, n_frames=len(ts)))
"""

import warnings as _warnings

from . import _motionlab
from ._api import (
    Alignment,
    AngleCurves,
    Evaluation,
    Features,
    GaitCycle,
    MultistreamMatch,
    Param,
    Plugin,
    PointDetection,
    RunResult,
    SegmenterOutput,
    SubsequenceMatch,
    Synchronisation,
    TcpdF1,
    Text,
    Threshold,
    Trace,
    Validation,
    WaveformParameters,
    Workflow,
    align,
    boundary_pr,
    covering,
    penalty_path,
    describe,
    detect_points,
    evaluate,
    features,
    fuse,
    gait_cycles,
    listing,
    load,
    multistream_match,
    plugins,
    preprocess,
    read_truth,
    run,
    segment,
    subsequence_dp,
    synchronise,
    synthesize_walk,
    tcpd_f1,
    validate,
    waveform_parameters,
    workflows,
)
from ._motionlab import ArgumentError, FileError, Motion, MotionlabError, Segmentation, Stream, __version__

# One typed function per plugin, by kind (`motionlab.segmenters.clasp(ts, …)`), built from the
# registry at import.
from ._typed import (
    evaluators,
    feature_extractors,
    fusers,
    gait_cycle_detectors,
    ground_truth_readers,
    loaders,
    matchers,
    point_detectors,
    preprocessors,
    segmenters,
    synchronisers,
    walk_synthesizers,
    waveform_analyzers,
)

# `list` is left out on purpose: `from motionlab import *` must not shadow the builtin.
__all__ = [
    # data and errors
    "Motion", "Segmentation", "MotionlabError", "ArgumentError", "FileError", "__version__",
    # results
    "Text", "Param", "Plugin", "Workflow", "Trace", "Threshold", "Features", "SegmenterOutput", "PointDetection",
    "Alignment", "Synchronisation", "GaitCycle", "AngleCurves", "WaveformParameters", "Evaluation", "TcpdF1",
    "SubsequenceMatch", "MultistreamMatch", "RunResult", "Validation",
    # the registry
    "listing", "describe", "plugins", "workflows",
    # stages by name
    "load", "preprocess", "features", "segment", "fuse", "read_truth", "detect_points", "align", "synchronise",
    "gait_cycles", "waveform_parameters", "synthesize_walk", "evaluate",
    # metrics and matching on arrays
    "boundary_pr", "covering", "tcpd_f1", "penalty_path", "subsequence_dp", "multistream_match",
    # whole runs
    "run", "validate",
    # streaming segmenters, fed samples as they arrive
    "Stream",
    # one typed function per plugin, by kind
    "loaders", "ground_truth_readers", "preprocessors", "feature_extractors", "segmenters", "fusers", "point_detectors",
    "matchers", "synchronisers", "gait_cycle_detectors", "waveform_analyzers", "walk_synthesizers", "evaluators",
]


def list() -> Text:  # noqa: A001 - the deprecated name, kept working
    """Deprecated alias of :func:`listing` (the name shadowed the builtin ``list``): warns
    with a ``DeprecationWarning`` and returns the text of ``motionlab list``."""
    _warnings.warn(
        "motionlab.list() is deprecated: use motionlab.listing() for the text of `motionlab list`, "
        "motionlab.plugins() for records",
        DeprecationWarning,
        stacklevel=2,
    )
    return listing()
