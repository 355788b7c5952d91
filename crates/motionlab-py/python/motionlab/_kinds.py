"""The kinds the package knows how to call: each kind's namespace, positional arguments and
generic function. No imports beyond the standard library, so the build backend
(``build_backend/motionlab_build.py``) can write the stubs with nothing but the compiled
module."""

# kind -> (namespace, positional arguments, the generic function's name)
KINDS = {
    "loader": ("loaders", ["path"], "load"),
    "ground_truth": ("ground_truth_readers", ["path", "motion"], "read_truth"),
    "preprocessor": ("preprocessors", ["motion"], "preprocess"),
    "feature_extractor": ("feature_extractors", ["motion"], "features"),
    "segmenter": ("segmenters", ["motion"], "segment"),
    "fuser": ("fusers", ["motion", "candidates"], "fuse"),
    "point_detector": ("point_detectors", ["motion"], "detect_points"),
    "matcher": ("matchers", ["model", "target"], "align"),
    "synchroniser": ("synchronisers", ["alignment", "model_frames"], "synchronise"),
    "gait_cycle_detector": ("gait_cycle_detectors", ["motion"], "gait_cycles"),
    "waveform_analyzer": ("waveform_analyzers", ["curves", "cycles"], "waveform_parameters"),
    "walk_synthesizer": ("walk_synthesizers", ["walk", "cycles", "changes"], "synthesize_walk"),
    "evaluator": ("evaluators", ["results"], "evaluate"),
}


# Kinds whose plugins read a motion: their functions take NumPy data too, with its `rate`.
TAKES_MOTION = {"motion", "model", "target"}


def takes_rate(positional):
    """Whether a kind's function has the ``rate`` keyword (for arrays given as motions)."""
    return bool(TAKES_MOTION & set(positional))
