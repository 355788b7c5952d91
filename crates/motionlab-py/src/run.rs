//! Whole experiments through the engine, as `motionlab run` and `motionlab validate` do them.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use motionlab_engine::front::RunChoices;

use crate::detached;

/// Runs an experiment file (with dotted `overrides`) into a fresh run directory under
/// `reports`, as `motionlab run` does: `{"run_dir", "tables", "figures", "items", "complete"}`
/// (table and figure files relative to the run directory). Progress bars on stderr when it is
/// a terminal and `quiet` is false, as the CLI's. An experiment that names a program runs only
/// with `allow_external` or a trust record (`motionlab trust`), as `motionlab run`.
// One Python keyword argument per `motionlab run` option: the signature is the Python API.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (experiment, overrides=Vec::new(), reports=PathBuf::from("reports"), threads=None, quiet=false, no_cache=false, allow_external=false))]
fn run<'py>(
    py: Python<'py>,
    experiment: PathBuf,
    overrides: Vec<String>,
    reports: PathBuf,
    threads: Option<usize>,
    quiet: bool,
    no_cache: bool,
    allow_external: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let choices = RunChoices { reports, threads, quiet, no_cache, allow_external };
    let command: Vec<String> =
        ["motionlab.run (Python)".to_string(), experiment.display().to_string()]
            .into_iter()
            .chain(overrides.iter().cloned())
            .collect();
    let summary = detached(py, move || {
        motionlab_engine::run_file(&experiment, &overrides, &choices.options(command))
    })?;
    let d = PyDict::new(py);
    d.set_item("run_dir", summary.run_dir.display().to_string())?;
    let text = |v: &[PathBuf]| v.iter().map(|p| p.display().to_string()).collect::<Vec<_>>();
    d.set_item("tables", text(&summary.written.tables))?;
    d.set_item("figures", text(&summary.written.figures))?;
    d.set_item("items", summary.items)?;
    d.set_item("complete", summary.complete)?;
    Ok(d)
}

/// Checks every file, plugin and parameter of an experiment without running it, as
/// `motionlab validate`: `{"workflow", "datasets", "input_files", "combinations", "items"}`
/// (with the same consent check for the programs it names).
#[pyfunction]
#[pyo3(signature = (experiment, overrides=Vec::new(), allow_external=false))]
fn validate<'py>(
    py: Python<'py>,
    experiment: PathBuf,
    overrides: Vec<String>,
    allow_external: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let v = detached(py, move || {
        motionlab_engine::front::validate(&experiment, &overrides, allow_external)
    })?;
    let d = PyDict::new(py);
    d.set_item("workflow", v.workflow)?;
    d.set_item("datasets", v.datasets)?;
    d.set_item("input_files", v.input_files)?;
    d.set_item("combinations", v.combinations)?;
    d.set_item("items", v.items)?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    Ok(())
}
