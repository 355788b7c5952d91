//! `penalty_path`: `kernel_cpd`'s penalty path (CROPS) of an array, as a table.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;

use motionlab_changepoint::{KernelCpdParams, StopRule};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Table};

use crate::array::read_f64;
use crate::convert::{params, table_to_py};
use crate::detached;

/// One row of the path: one segmentation.
#[derive(Serialize)]
struct PathRow {
    n_changes: usize,
    pen_min: f64,
    pen_max: f64,
    cost: f64,
    chosen: bool,
    /// The change points (segment starts but the first), space-separated sample indices.
    change_points: String,
}

/// `kernel_cpd` with `params` (which must hold `penalty = {"path": [min, max], …}`) on
/// `values` (n × channels, float64): one row per segmentation of the path, fewest change
/// points first, as the table `penalty_path` (`{"name", "title", "columns"}`).
#[pyfunction]
#[pyo3(signature = (values, params=None))]
fn penalty_path<'py>(
    py: Python<'py>,
    values: &Bound<'py, PyAny>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (v, shape) = read_f64(values, 2, "values")?;
    let p = self::params(params)?;
    let table = detached(py, move || {
        let parsed: KernelCpdParams = p
            .try_into()
            .map_err(|e: toml::de::Error| Error::new(ErrorKind::InvalidParameter, e.to_string()))?;
        let stage = parsed.check()?;
        if !matches!(stage.stop, StopRule::Path { .. }) {
            return Err(Error::new(
                ErrorKind::MissingKey,
                "penalty_path needs penalty = {\"path\": [min, max]} among the parameters",
            )
            .with_field("penalty"));
        }
        let run = stage.run(&v, shape[1])?;
        let path = run.path.unwrap_or_default();
        let rows: Vec<PathRow> = path
            .iter()
            .enumerate()
            .map(|(i, s)| PathRow {
                n_changes: s.n_changes(),
                pen_min: s.pen_min,
                pen_max: s.pen_max,
                cost: s.cost,
                chosen: run.chosen == Some(i),
                change_points: s.breakpoints[..s.n_changes()]
                    .iter()
                    .map(|b| b.to_string())
                    .collect::<Vec<_>>()
                    .join(" "),
            })
            .collect();
        Table::from_records(
            "penalty_path",
            "kernel_cpd's penalty path: every segmentation optimal for a penalty of the range, with its penalty interval and unpenalised cost",
            &rows,
        )
    })?;
    table_to_py(py, &table)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(penalty_path, m)?)?;
    Ok(())
}
