//! Every registered stage by name, built from the same parameter schema as an experiment's
//! TOML (`registry::build_<kind>`), run on motions from Python; `list`, `describe` and the
//! plugin records as the CLI prints them.

use std::path::PathBuf;
use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use motionlab_core::registry;
use motionlab_core::{
    Boundary, ErrorKind, FeatureCache, FrameRate, MethodCandidates, Result, Segmentation,
};
use motionlab_features::{
    AngleCurves, GaitCycle, build_gait_cycle_detector, build_waveform_analyzer,
};
use motionlab_gait::{WalkChanges, build_walk_synthesizer};
use motionlab_match::{build_matcher, build_point_detector, build_synchroniser};

use crate::convert::{f64s, frames, frames_to_py, from_py, params, to_py};
use crate::motion::PyMotion;
use crate::{detached, to_py_err};

/// Builds a stage by name; a bad parameter's error names the plugin before the key path
/// (`fastest_marker_speed.v_low: unknown variant …`), an unknown name says what is registered.
pub fn build<T: ?Sized>(
    name: &str,
    params: &toml::Value,
    f: fn(&str, &toml::Value) -> Result<Box<T>>,
) -> Result<Box<T>> {
    f(name, params)
        .map_err(|e| if e.kind() == ErrorKind::UnknownPlugin { e } else { e.under_field(name) })
}

/// A ground-truth segmentation: boundary frames (with their annotated windows when the source
/// gives them), the labelled segments they separate, and each annotator's frames.
#[pyclass(name = "Segmentation", module = "motionlab", frozen)]
pub struct PySegmentation {
    pub inner: Segmentation,
}

#[pymethods]
impl PySegmentation {
    /// A segmentation from boundary frames at `rate` Hz (optionally each annotator's own list
    /// of frames, as a consensus keeps them).
    #[new]
    #[pyo3(signature = (boundaries, rate, annotators=None))]
    fn py_new(
        boundaries: &Bound<'_, PyAny>,
        rate: f64,
        annotators: Option<Vec<Bound<'_, PyAny>>>,
    ) -> PyResult<Self> {
        let mut f = frames(boundaries, "boundaries")?;
        f.sort_unstable();
        let rate = FrameRate::new(rate).map_err(|e| to_py_err(e.with_field("rate")))?;
        let annotators = annotators
            .unwrap_or_default()
            .iter()
            .enumerate()
            .map(|(k, a)| {
                let mut v = frames(a, &format!("annotators[{k}]"))?;
                v.sort_unstable();
                Ok(v)
            })
            .collect::<PyResult<Vec<_>>>()?;
        Ok(PySegmentation {
            inner: Segmentation {
                frame_rate: rate,
                boundaries: f.into_iter().map(|frame| Boundary { frame, window: None }).collect(),
                segments: Vec::new(),
                annotators,
                annotator_names: Vec::new(),
            },
        })
    }
    /// Boundary frames (int64).
    #[getter]
    fn boundaries<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        frames_to_py(py, &self.inner.frames())
    }
    /// Each boundary's annotated transition window `(first, last)` frame, or None.
    #[getter]
    fn windows(&self) -> Vec<Option<(usize, usize)>> {
        self.inner.boundaries.iter().map(|b| b.window).collect()
    }
    /// Labelled segments as `(start, end, label)` (end exclusive).
    #[getter]
    fn segments(&self) -> Vec<(usize, usize, String)> {
        self.inner.segments.iter().map(|s| (s.start, s.end, s.label.clone())).collect()
    }
    /// Each annotator's boundary frames (one list when the boundaries are one annotator's).
    #[getter]
    fn annotators(&self) -> Vec<Vec<usize>> {
        self.inner.annotator_frames()
    }
    /// Frame rate of the frames, Hz.
    #[getter]
    fn rate(&self) -> f64 {
        self.inner.frame_rate.hz()
    }
    fn __len__(&self) -> usize {
        self.inner.boundaries.len()
    }
    fn __repr__(&self) -> String {
        format!(
            "<motionlab.Segmentation: {} boundaries, {} segments at {} Hz>",
            self.inner.boundaries.len(),
            self.inner.segments.len(),
            self.inner.frame_rate.hz()
        )
    }
}

/// `motionlab list`'s text.
#[pyfunction]
fn list_text() -> String {
    motionlab_cli::describe::list()
}

/// `motionlab describe NAME`'s text.
#[pyfunction]
fn describe(py: Python<'_>, name: String) -> PyResult<String> {
    detached(py, move || motionlab_cli::describe::describe(&name))
}

/// Every registered plugin — core's kinds and the kinds family crates declare (matcher,
/// gait-cycle detector, …) — as records: name, kind, kind label, crate, params type,
/// documentation and its parameters (name, type, default, default note, required,
/// description): what `describe` prints.
#[pyfunction]
fn plugins<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    let record = |name: &str,
                  kind: &str,
                  label: &str,
                  crate_name: &str,
                  params_type: &str,
                  doc: String,
                  params: Vec<registry::ParamDoc>| {
        let d = PyDict::new(py);
        d.set_item("name", name)?;
        d.set_item("kind", kind)?;
        d.set_item("kind_label", label)?;
        d.set_item("crate", crate_name)?;
        d.set_item("params_type", params_type)?;
        d.set_item("doc", doc)?;
        d.set_item("params", to_py(py, &params)?)?;
        Ok(d)
    };
    let mut rows = registry::plugins()
        .into_iter()
        .map(|p| {
            let kind = to_py(py, &p.kind)?.extract::<String>()?;
            record(p.name, &kind, p.kind.label(), p.crate_name, p.params_type, p.doc(), p.params())
        })
        .collect::<PyResult<Vec<_>>>()?;
    for p in registry::custom_plugins() {
        let label = registry::declared_kind(p.kind).map_or(p.kind, |d| d.label);
        rows.push(record(p.name, p.kind, label, p.crate_name, p.params_type, p.doc(), p.params())?);
    }
    PyList::new(py, rows)
}

/// Every workflow (an experiment's section): name, crate, documentation, parameters.
#[pyfunction]
fn workflows<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    let rows = motionlab_experiment::workflow::workflows()
        .into_iter()
        .map(|w| {
            let d = PyDict::new(py);
            d.set_item("name", w.name)?;
            d.set_item("crate", w.crate_name)?;
            d.set_item("doc", w.doc())?;
            d.set_item("params", to_py(py, &w.params())?)?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    PyList::new(py, rows)
}

/// The preprocessor `name` applied to a motion (a new motion).
#[pyfunction]
#[pyo3(signature = (name, motion, params=None))]
fn preprocess(
    py: Python<'_>,
    name: String,
    motion: &PyMotion,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyMotion> {
    let p = self::params(params)?;
    let m = Arc::clone(&motion.inner);
    let out =
        detached(py, move || build(&name, &p, registry::build_preprocessor)?.apply((*m).clone()))?;
    Ok(PyMotion { inner: Arc::new(out) })
}

/// The feature extractor `name` on a motion: `{"traces": {name: array}, "units": {name: unit},
/// "labels": {name: [str]}}`.
#[pyfunction]
#[pyo3(signature = (name, motion, params=None))]
fn features<'py>(
    py: Python<'py>,
    name: String,
    motion: &PyMotion,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let p = self::params(params)?;
    let m = Arc::clone(&motion.inner);
    let set = detached(py, move || {
        build(&name, &p, registry::build_feature_extractor)?.extract(&m, &FeatureCache::new())
    })?;
    let (traces, units, labels) = (PyDict::new(py), PyDict::new(py), PyDict::new(py));
    for t in set.traces {
        units.set_item(&t.name, &t.unit)?;
        traces.set_item(&t.name, f64s(py, t.values)?)?;
    }
    for l in set.labels {
        labels.set_item(&l.name, l.values)?;
    }
    let d = PyDict::new(py);
    d.set_item("traces", traces)?;
    d.set_item("units", units)?;
    d.set_item("labels", labels)?;
    Ok(d)
}

/// The segmenter `name` on a motion: `{"candidates", "traces", "units", "thresholds",
/// "flagged_frames"}`.
#[pyfunction]
#[pyo3(signature = (name, motion, params=None))]
fn segment<'py>(
    py: Python<'py>,
    name: String,
    motion: &PyMotion,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let p = self::params(params)?;
    let m = Arc::clone(&motion.inner);
    let out = detached(py, move || {
        let file = m.source.clone().unwrap_or_default();
        build(&name, &p, registry::build_segmenter)?
            .segment(&m, &FeatureCache::new())
            .map_err(|e| e.in_file(&file))
    })?;
    let (traces, units) = (PyDict::new(py), PyDict::new(py));
    for t in out.traces {
        units.set_item(&t.name, &t.unit)?;
        traces.set_item(&t.name, f64s(py, t.values)?)?;
    }
    let d = PyDict::new(py);
    d.set_item("candidates", frames_to_py(py, &out.candidates)?)?;
    d.set_item("traces", traces)?;
    d.set_item("units", units)?;
    d.set_item("thresholds", to_py(py, &out.thresholds)?)?;
    d.set_item("flagged_frames", frames_to_py(py, &out.flagged_frames)?)?;
    Ok(d)
}

/// The fuser `name` on several methods' candidates (`{method: frames}`, in order).
#[pyfunction]
#[pyo3(signature = (name, motion, candidates, params=None))]
fn fuse<'py>(
    py: Python<'py>,
    name: String,
    motion: &PyMotion,
    candidates: &Bound<'py, PyDict>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = self::params(params)?;
    let m = Arc::clone(&motion.inner);
    let methods: Vec<(String, Vec<usize>)> = candidates
        .iter()
        .map(|(k, v)| Ok((k.extract::<String>()?, frames(&v, &format!("candidates[{k}]"))?)))
        .collect::<PyResult<_>>()?;
    let fused = detached(py, move || {
        let inputs: Vec<MethodCandidates<'_>> =
            methods.iter().map(|(n, f)| MethodCandidates { method: n, frames: f }).collect();
        build(&name, &p, registry::build_fuser)?.fuse(&m, &inputs)
    })?;
    frames_to_py(py, &fused)
}

/// The ground-truth reader `name` on a file, for a motion (frames at the motion's rate).
#[pyfunction]
#[pyo3(signature = (name, path, motion, params=None))]
fn read_truth(
    py: Python<'_>,
    name: String,
    path: PathBuf,
    motion: &PyMotion,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<PySegmentation> {
    let p = self::params(params)?;
    let m = Arc::clone(&motion.inner);
    let s = detached(py, move || {
        build(&name, &p, registry::build_ground_truth)?
            .read(&path, &m)
            .map_err(|e| e.in_file(&path))
    })?;
    Ok(PySegmentation { inner: s })
}

/// The point detector `name` on a take: `{"velocity": {name, unit, values}, "threshold",
/// "peaks", "windows"}`.
#[pyfunction]
#[pyo3(signature = (name, motion, params=None))]
fn detect_points<'py>(
    py: Python<'py>,
    name: String,
    motion: &PyMotion,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = self::params(params)?;
    let m = Arc::clone(&motion.inner);
    let d = detached(py, move || build(&name, &p, build_point_detector)?.detect(&m))?;
    to_py(py, &d)
}

/// The matcher `name`: the model aligned to (a stretch of) the target, as an alignment record
/// (`start`, `end`, `point_distances`, `total_distance`, `paths`).
#[pyfunction]
#[pyo3(signature = (name, model, target, params=None))]
fn align<'py>(
    py: Python<'py>,
    name: String,
    model: &PyMotion,
    target: &PyMotion,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = self::params(params)?;
    let (s, t) = (Arc::clone(&model.inner), Arc::clone(&target.inner));
    let a = detached(py, move || build(&name, &p, build_matcher)?.align(&s, &t))?;
    to_py(py, &a)
}

/// The synchroniser `name` on an alignment record (as `align` returns it) of a model of
/// `model_frames` frames.
#[pyfunction]
#[pyo3(signature = (name, alignment, model_frames, params=None))]
fn synchronise<'py>(
    py: Python<'py>,
    name: String,
    alignment: &Bound<'py, PyAny>,
    model_frames: usize,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = self::params(params)?;
    let a: motionlab_match::Alignment = from_py(alignment, "alignment")?;
    let s =
        detached(py, move || build(&name, &p, build_synchroniser)?.synchronise(&a, model_frames))?;
    to_py(py, &s)
}

/// The gait-cycle detector `name` on a walk: cycles as `{start, end, side}` records.
#[pyfunction]
#[pyo3(signature = (name, motion, params=None))]
fn gait_cycles<'py>(
    py: Python<'py>,
    name: String,
    motion: &PyMotion,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = self::params(params)?;
    let m = Arc::clone(&motion.inner);
    let c = detached(py, move || build(&name, &p, build_gait_cycle_detector)?.cycles(&m))?;
    to_py(py, &c)
}

/// The waveform analyzer `name` on angle curves (`{frame_rate, channels, values}`) over gait
/// cycles: `{channels, dc, amplitude, frequency_hz}`.
#[pyfunction]
#[pyo3(signature = (name, curves, cycles, params=None))]
fn waveform_parameters<'py>(
    py: Python<'py>,
    name: String,
    curves: &Bound<'py, PyAny>,
    cycles: &Bound<'py, PyAny>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = self::params(params)?;
    let curves: AngleCurves = from_py(curves, "curves")?;
    let cycles: Vec<GaitCycle> = from_py(cycles, "cycles")?;
    let w = detached(py, move || {
        build(&name, &p, build_waveform_analyzer)?.parameters(&curves, &cycles)
    })?;
    to_py(py, &w)
}

/// The walk synthesizer `name`: a changed walk (angle curves) from a recorded one, its
/// cycles and the change rates (`{dc_percent, amplitude_percent, frequency_percent}`).
#[pyfunction]
#[pyo3(signature = (name, walk, cycles, changes, params=None))]
fn synthesize_walk<'py>(
    py: Python<'py>,
    name: String,
    walk: &Bound<'py, PyAny>,
    cycles: &Bound<'py, PyAny>,
    changes: &Bound<'py, PyAny>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let p = self::params(params)?;
    let walk: AngleCurves = from_py(walk, "walk")?;
    let cycles: Vec<GaitCycle> = from_py(cycles, "cycles")?;
    let changes: WalkChanges = from_py(changes, "changes")?;
    let out = detached(py, move || {
        build(&name, &p, build_walk_synthesizer)?.synthesize(&walk, &cycles, &changes)
    })?;
    to_py(py, &out)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySegmentation>()?;
    for f in [
        wrap_pyfunction!(list_text, m)?,
        wrap_pyfunction!(describe, m)?,
        wrap_pyfunction!(plugins, m)?,
        wrap_pyfunction!(workflows, m)?,
        wrap_pyfunction!(preprocess, m)?,
        wrap_pyfunction!(features, m)?,
        wrap_pyfunction!(segment, m)?,
        wrap_pyfunction!(fuse, m)?,
        wrap_pyfunction!(read_truth, m)?,
        wrap_pyfunction!(detect_points, m)?,
        wrap_pyfunction!(align, m)?,
        wrap_pyfunction!(synchronise, m)?,
        wrap_pyfunction!(gait_cycles, m)?,
        wrap_pyfunction!(waveform_parameters, m)?,
        wrap_pyfunction!(synthesize_walk, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}
