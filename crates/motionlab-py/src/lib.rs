//! # motionlab-py
//!
//! The native half of the `motionlab` Python package (`motionlab._motionlab`): thin PyO3
//! wrappers that call motionlab's own crates — the registry's loaders and stages by name, the
//! evaluators, the matcher's DP kernels, the engine's runs and the CLI's `list`/`describe` —
//! and hand their results to Python as NumPy arrays and plain records. Nothing is computed
//! here that a motionlab crate does not compute; the Python half
//! (`python/motionlab/__init__.py`) turns tables into Polars DataFrames and gives each result
//! a small class.
//!
//! Every call that may take long releases the GIL ([`detached`]); every error is a
//! `motionlab.MotionlabError` carrying the CLI's one-line message, its kind and location; a
//! panic inside motionlab becomes that exception too (it never unwinds into the interpreter).

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::prelude::*;

// Plugin crates are never called by name from some of these modules; naming them keeps the
// linker from dropping their `inventory` registrations (the tests compare `list()` with the
// CLI's, which names the same crates).
use motionlab_changepoint as _;
use motionlab_eval as _;
use motionlab_external as _;
use motionlab_features as _;
use motionlab_gait as _;
use motionlab_io as _;
use motionlab_match as _;
use motionlab_parquet as _;
use motionlab_profile as _;
use motionlab_segment as _;
use motionlab_workflows as _;

mod array;
mod changepoint;
mod convert;
mod eval;
mod matching;
mod motion;
mod run;
mod stages;

pyo3::create_exception!(
    motionlab,
    MotionlabError,
    pyo3::exceptions::PyException,
    "A motionlab error: the CLI's one-line message (file, line or key path, what was expected), with `kind`, `file`, `line`, `field` and `message` attributes."
);

/// The Python exception of a motionlab error, with its parts as attributes.
pub(crate) fn to_py_err(e: motionlab_core::Error) -> PyErr {
    Python::attach(|py| {
        let err = MotionlabError::new_err(e.to_string());
        let value = err.value(py);
        let loc = e.location();
        let set = |k: &str, v: Bound<'_, PyAny>| value.setattr(k, v);
        let _ = set(
            "kind",
            format!("{:?}", e.kind())
                .into_pyobject(py)
                .map(|v| v.into_any())
                .unwrap_or_else(|_| py.None().into_bound(py)),
        );
        let _ = value.setattr("message", e.message());
        let _ = value.setattr("file", loc.file.as_ref().map(|f| f.display().to_string()));
        let _ = value.setattr("line", loc.line);
        let _ = value.setattr("field", loc.field.clone());
        err
    })
}

/// A motionlab error made here (bad Python input), as a Python exception.
pub(crate) fn error(kind: motionlab_core::ErrorKind, message: impl Into<String>) -> PyErr {
    to_py_err(motionlab_core::Error::new(kind, message))
}

/// The message of a caught panic.
fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_string());
    format!(
        "internal error inside motionlab (a bug, please report it with the call that caused it): {what}"
    )
}

/// Runs `f` without the GIL (other Python threads run meanwhile), turning its error and any
/// panic into a `MotionlabError`.
pub(crate) fn detached<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> motionlab_core::Result<T> + Send,
) -> PyResult<T> {
    match py.detach(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(to_py_err(e)),
        Err(payload) => Err(error(motionlab_core::ErrorKind::Report, panic_message(payload))),
    }
}

/// Runs `f` with the GIL held (it builds Python objects), turning a panic into a
/// `MotionlabError`.
pub(crate) fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => Err(error(motionlab_core::ErrorKind::Report, panic_message(payload))),
    }
}

/// The native module.
#[pymodule]
fn _motionlab(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MotionlabError", m.py().get_type::<MotionlabError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<array::ArrayBuffer>()?;
    motion::register(m)?;
    stages::register(m)?;
    eval::register(m)?;
    matching::register(m)?;
    run::register(m)?;
    changepoint::register(m)?;
    Ok(())
}
