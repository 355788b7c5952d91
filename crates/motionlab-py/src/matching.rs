//! The matcher's DP on plain NumPy arrays: the single-stream subsequence DP and the two-stage
//! multistream match (Yabe & Tanaka), with the synchronisation `R` by the registered
//! `synchronisation` stage.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use motionlab_core::{Error, ErrorKind, Result};
use motionlab_match::dp::{Euclidean3, Trajectory3, Workspace, subsequence_match};

use crate::array::read_f64;
use crate::convert::{f64s, path_to_py};
use crate::detached;

/// Per-point structure-of-arrays trajectories of a `frames × points × 3` array; a non-finite
/// sample is refused as the matchers refuse a missing one.
fn trajectories(values: &[f64], shape: &[usize], role: &str) -> Result<Vec<Trajectory3>> {
    let (n, l, d) = (shape[0], shape[1], shape[2]);
    if d != 3 {
        return Err(Error::new(
            ErrorKind::WrongValueCount,
            format!("{role}: expected frames × points × 3, found shape [{n}, {l}, {d}]"),
        ));
    }
    let mut out: Vec<Trajectory3> = (0..l).map(|_| Trajectory3::with_capacity(n)).collect();
    for (i, frame) in values.chunks_exact(3 * l.max(1)).take(n).enumerate() {
        for (k, (p, traj)) in frame.chunks_exact(3).zip(out.iter_mut()).enumerate() {
            let q = [p[0], p[1], p[2]];
            if !q.iter().all(|c| c.is_finite()) {
                return Err(Error::new(
                    ErrorKind::MissingData,
                    format!(
                        "DP matching refuses missing samples: point {k} of the {role} is missing (NaN) at frame {i}; fill gaps first (preprocessor `fill_gaps`)"
                    ),
                ));
            }
            traj.push(q);
        }
    }
    Ok(out)
}

/// Subsequence DP of one 3-D trajectory (`model`: n × 3, `target`: m × 3, mm), free start and
/// end (`motionlab_match::dp::subsequence_match`): `{"a", "b", "cost", "path", "end_costs"}`.
#[pyfunction]
fn subsequence_dp<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    target: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let as3 = |a: &Bound<'py, PyAny>, role: &str| -> PyResult<Vec<Trajectory3>> {
        let (v, shape) = read_f64(a, 2, role)?;
        trajectories(&v, &[shape[0], 1, shape[1]], role).map_err(crate::to_py_err)
    };
    let (s, t) = (as3(model, "model")?, as3(target, "target")?);
    let found = detached(py, move || {
        subsequence_match(&Euclidean3::new(&s[0], &t[0]), &mut Workspace::new())
    })?;
    let d = PyDict::new(py);
    d.set_item("a", found.start)?;
    d.set_item("b", found.end)?;
    d.set_item("cost", found.cost)?;
    d.set_item("path", path_to_py(py, &found.path)?)?;
    d.set_item("end_costs", f64s(py, found.end_costs)?)?;
    Ok(d)
}

/// The two-stage multistream match of `model` (n × L × 3) against `target` (m × L × 3, mm),
/// point `l` against point `l` (`motionlab_match::multistream::two_stage`), and — with paths
/// and `k` — the synchronisation of the registered `synchronisation` stage: `{"a", "b", "H",
/// "h", "paths", "G", "start_costs", "R", "r", "sync_frames"}`.
#[pyfunction]
#[pyo3(signature = (model, target, keep_paths=true, k=Some(8)))]
fn multistream_match<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    target: &Bound<'py, PyAny>,
    keep_paths: bool,
    k: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let ((mv, ms), (tv, ts)) = (read_f64(model, 3, "model")?, read_f64(target, 3, "target")?);
    let (s, t) = (
        trajectories(&mv, &ms, "model").map_err(crate::to_py_err)?,
        trajectories(&tv, &ts, "target").map_err(crate::to_py_err)?,
    );
    let n = s.first().map_or(0, Trajectory3::len);
    let (m, sync) = detached(py, move || {
        let m = motionlab_match::multistream::two_stage(&s, &t, keep_paths)?;
        let sync = match (k, keep_paths) {
            (Some(k), true) => {
                let mut p = toml::Table::new();
                p.insert("k".into(), toml::Value::Integer(k as i64));
                Some(
                    motionlab_match::build_synchroniser("synchronisation", &toml::Value::Table(p))?
                        .synchronise(&m.alignment, n)?,
                )
            }
            _ => None,
        };
        Ok((m, sync))
    })?;
    let d = PyDict::new(py);
    let al = &m.alignment;
    d.set_item("a", al.start)?;
    d.set_item("b", al.end)?;
    d.set_item("H", al.total_distance)?;
    d.set_item("h", f64s(py, al.point_distances.clone())?)?;
    d.set_item(
        "paths",
        PyList::new(py, al.paths.iter().map(|p| path_to_py(py, p)).collect::<PyResult<Vec<_>>>()?)?,
    )?;
    d.set_item("G", f64s(py, m.end_costs)?)?;
    d.set_item("start_costs", f64s(py, m.start_costs)?)?;
    match sync {
        Some(s) => {
            d.set_item("R", s.total)?;
            d.set_item("r", f64s(py, s.section_values)?)?;
            d.set_item("sync_frames", s.model_frames)?;
        }
        None => {
            d.set_item("R", py.None())?;
            d.set_item("r", py.None())?;
            d.set_item("sync_frames", py.None())?;
        }
    }
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(subsequence_dp, m)?)?;
    m.add_function(wrap_pyfunction!(multistream_match, m)?)?;
    Ok(())
}
