//! Evaluators by name on results given from Python (segmentation, matching or gait results,
//! whichever the evaluator reads), and the change-point metrics on plain frame lists.

use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use motionlab_core::registry;
use motionlab_core::{
    ErrorKind, EvalInput, EvalInputType, FrameRate, MethodResult, Motion, SequenceResult,
};
use motionlab_gait::GaitStudy;
use motionlab_match::{MatchingResult, RepetitionResult};

use crate::convert::{frames, from_py, params, tables_to_py};
use crate::motion::PyMotion;
use crate::stages::{PySegmentation, build};
use crate::{detached, error, to_py_err};

/// One sequence of segmentation results: `{"sequence", "motion", "truth", "methods"}`, or
/// `"rate"` (Hz) and `"n_frames"` instead of the motion (what the evaluators read of it).
fn sequence(v: &Bound<'_, PyAny>, k: usize) -> PyResult<SequenceResult> {
    let d = v.cast::<PyDict>().map_err(|_| {
        error(
            ErrorKind::WrongType,
            format!("results[{k}]: expected a dict with sequence, motion, truth and methods"),
        )
    })?;
    let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
        d.get_item(key)?.ok_or_else(|| {
            error(ErrorKind::MissingKey, format!("results[{k}]: missing key {key:?}"))
        })
    };
    // The motion, or only what the evaluators read of it: its rate (Hz) and length (frames).
    let name = match d.get_item("sequence")? {
        Some(s) => Some(s.extract::<String>()?),
        None => None,
    };
    let motion: Arc<Motion> = match d.get_item("motion")? {
        Some(m) => {
            let m: PyRef<'_, PyMotion> = m.extract().map_err(|_| {
                error(
                    ErrorKind::WrongType,
                    format!("results[{k}].motion: expected a motionlab.Motion"),
                )
            })?;
            Arc::clone(&m.inner)
        }
        None => {
            let (Some(rate), Some(n)) = (d.get_item("rate")?, d.get_item("n_frames")?) else {
                return Err(error(
                    ErrorKind::MissingKey,
                    format!("results[{k}]: missing key \"motion\" (or \"rate\" and \"n_frames\")"),
                ));
            };
            let rate = FrameRate::new(rate.extract()?)
                .map_err(|e| to_py_err(e.with_field(format!("results[{k}].rate"))))?;
            let n_frames: usize = n.extract().map_err(|_| {
                error(
                    ErrorKind::WrongType,
                    format!("results[{k}].n_frames: expected a number of frames (>= 1)"),
                )
            })?;
            let seq = name.clone().unwrap_or_else(|| "sequence".to_string());
            Arc::new(
                Motion::timeline(seq, rate, n_frames)
                    .map_err(|e| to_py_err(e.with_field(format!("results[{k}].n_frames"))))?,
            )
        }
    };
    let truth = match d.get_item("truth")? {
        None => None,
        Some(t) if t.is_none() => None,
        Some(t) => match t.extract::<PyRef<'_, PySegmentation>>() {
            Ok(s) => Some(s.inner.clone()),
            Err(_) => {
                return Err(error(
                    ErrorKind::WrongType,
                    format!(
                        "results[{k}].truth: expected a motionlab.Segmentation (motionlab.Segmentation(frames, rate) makes one)"
                    ),
                ));
            }
        },
    };
    let methods = get("methods")?;
    let methods = methods.cast::<PyDict>().map_err(|_| {
        error(
            ErrorKind::WrongType,
            format!("results[{k}].methods: expected a dict {{method: frames}}"),
        )
    })?;
    let methods = methods
        .iter()
        .map(|(name, f)| {
            let method: String = name.extract()?;
            let candidates = frames(&f, &format!("results[{k}].methods[{method}]"))?;
            Ok(MethodResult { method, candidates })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let sequence = name.unwrap_or_else(|| motion.name.clone());
    Ok(SequenceResult { sequence, motion, truth, methods })
}

/// One take's matched repetitions: `{"take", "point_names", "repetitions": [{"repetition",
/// "window_start", "alignment", "synchronisation"}]}` (alignments and synchronisations as
/// `align`/`synchronise` return them).
fn matching(v: &Bound<'_, PyAny>, k: usize) -> PyResult<MatchingResult> {
    let what = format!("results[{k}]");
    let get = |key: &str| -> PyResult<Bound<'_, PyAny>> {
        v.get_item(key)
            .map_err(|_| error(ErrorKind::MissingKey, format!("{what}: missing key {key:?}")))
    };
    let repetitions = get("repetitions")?
        .try_iter()?
        .enumerate()
        .map(|(r, rep)| {
            let rep = rep?;
            let at = format!("{what}.repetitions[{r}]");
            Ok(RepetitionResult {
                repetition: rep.get_item("repetition")?.extract()?,
                window_start: rep.get_item("window_start")?.extract()?,
                alignment: from_py(&rep.get_item("alignment")?, &format!("{at}.alignment"))?,
                synchronisation: from_py(
                    &rep.get_item("synchronisation")?,
                    &format!("{at}.synchronisation"),
                )?,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    Ok(MatchingResult {
        take: get("take")?.extract()?,
        point_names: get("point_names")?.extract()?,
        repetitions,
    })
}

/// The evaluator `name` on results of the type it reads: a list of sequence dicts
/// (segmentation evaluators), a list of take dicts (matching), or a gait study dict. Returns
/// its tables (`[{"name", "title", "columns"}]`).
#[pyfunction]
#[pyo3(signature = (name, results, params=None))]
fn evaluate<'py>(
    py: Python<'py>,
    name: String,
    results: &Bound<'py, PyAny>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyList>> {
    let p = self::params(params)?;
    let evaluator = detached(py, || build(&name, &p, registry::build_evaluator))?;
    let wants = evaluator.input_type();
    let tables = if wants == EvalInputType::segmentation() {
        let seqs = results
            .try_iter()?
            .enumerate()
            .map(|(k, s)| sequence(&s?, k))
            .collect::<PyResult<Vec<_>>>()?;
        detached(py, move || {
            evaluator.evaluate(EvalInput::new(&seqs)).map_err(|e| e.under_field(name.clone()))
        })?
    } else if wants == motionlab_match::matching_results() {
        let takes = results
            .try_iter()?
            .enumerate()
            .map(|(k, t)| matching(&t?, k))
            .collect::<PyResult<Vec<_>>>()?;
        detached(py, move || {
            evaluator.evaluate(EvalInput::new(&takes)).map_err(|e| e.under_field(name.clone()))
        })?
    } else if wants == motionlab_gait::gait_study() {
        let study: GaitStudy = from_py(results, "results")?;
        detached(py, move || {
            evaluator.evaluate(EvalInput::new(&study)).map_err(|e| e.under_field(name.clone()))
        })?
    } else {
        return Err(error(
            ErrorKind::Mismatch,
            format!("{name} evaluates {}, which the Python binding cannot build yet", wants.name),
        ));
    };
    tables_to_py(py, &tables)
}

/// TCPDBench's F1 (precision, recall) of `predictions` against one or more annotators' frames,
/// with a margin in frames (`motionlab_eval::cpd_metrics::tcpd_f_measure`).
#[pyfunction]
fn tcpd_f1(
    annotators: Vec<Bound<'_, PyAny>>,
    predictions: &Bound<'_, PyAny>,
    margin_frames: usize,
) -> PyResult<(f64, f64, f64)> {
    let annotators = annotators
        .iter()
        .enumerate()
        .map(|(k, a)| frames(a, &format!("annotators[{k}]")))
        .collect::<PyResult<Vec<_>>>()?;
    let predictions = frames(predictions, "predictions")?;
    Ok(motionlab_eval::cpd_metrics::tcpd_f_measure(&annotators, &predictions, margin_frames))
}

/// TCPDBench's segment covering of the annotators' partitions of `0..n_frames` by the
/// predicted one (`motionlab_eval::cpd_metrics::covering`).
#[pyfunction]
fn covering(
    annotators: Vec<Bound<'_, PyAny>>,
    predictions: &Bound<'_, PyAny>,
    n_frames: usize,
) -> PyResult<f64> {
    let annotators = annotators
        .iter()
        .enumerate()
        .map(|(k, a)| frames(a, &format!("annotators[{k}]")))
        .collect::<PyResult<Vec<_>>>()?;
    let predictions = frames(predictions, "predictions")?;
    if n_frames == 0 {
        return Err(error(ErrorKind::OutOfRange, "n_frames: a covering needs at least one frame"));
    }
    Ok(motionlab_eval::cpd_metrics::covering(&annotators, &predictions, n_frames))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(tcpd_f1, m)?)?;
    m.add_function(wrap_pyfunction!(covering, m)?)?;
    Ok(())
}
