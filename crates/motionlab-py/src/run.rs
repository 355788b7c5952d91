//! Whole experiments through the engine, as `motionlab run` and `motionlab validate` do them.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use motionlab_engine::RunOptions;
use motionlab_engine::consent::{ExternalPolicy, TrustStore};

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
    let progress: Arc<dyn motionlab_engine::Progress> = if !quiet && std::io::stderr().is_terminal()
    {
        Arc::new(motionlab_cli::progress::Bars::default())
    } else {
        Arc::new(motionlab_engine::Silent)
    };
    let command: Vec<String> =
        ["motionlab.run (Python)".to_string(), experiment.display().to_string()]
            .into_iter()
            .chain(overrides.iter().cloned())
            .collect();
    let summary = detached(py, move || {
        let cache = if no_cache { None } else { motionlab_cache::Cache::open_default() };
        let external = ExternalPolicy { allow_external, trust: TrustStore::open_default() };
        let opts = RunOptions {
            reports_dir: reports,
            threads,
            progress,
            command,
            cache,
            external,
            ..Default::default()
        };
        motionlab_engine::run_file(&experiment, &overrides, &opts)
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
    let (workflow, datasets, inputs, combos, items) = detached(py, move || {
        let plan = motionlab_engine::plan(&experiment, &overrides)?;
        let commands = motionlab_engine::consent::external_commands(&plan);
        motionlab_engine::consent::check(
            &plan.source.path,
            &commands,
            &ExternalPolicy { allow_external, trust: TrustStore::open_default() },
        )?;
        let items: usize = plan.built.iter().map(|b| b.workflow.items(&b.data).len()).sum();
        Ok((
            plan.workflow.name.to_string(),
            plan.file.datasets.len(),
            plan.input_files().len(),
            plan.combos.len(),
            items,
        ))
    })?;
    let d = PyDict::new(py);
    d.set_item("workflow", workflow)?;
    d.set_item("datasets", datasets)?;
    d.set_item("input_files", inputs)?;
    d.set_item("combinations", combos)?;
    d.set_item("items", items)?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    Ok(())
}
