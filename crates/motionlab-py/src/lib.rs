//! # motionlab-py
//!
//! The native half of the `motionlab` Python package (`motionlab._motionlab`): thin PyO3
//! wrappers that call motionlab's own crates — the registry's loaders and stages by name, the
//! evaluators, the matcher's DP kernels, the engine's runs, `list`/`describe` and loader choice (the
//! engine's, shared with the CLI) —
//! and hand their results to Python as NumPy arrays and plain records. Nothing is computed
//! here that a motionlab crate does not compute; the Python half
//! (`python/motionlab/__init__.py`) turns tables into Polars DataFrames and gives each result
//! a small class.
//!
//! Every call that may take long releases the GIL ([`detached`]); every error is a
//! `motionlab.MotionlabError` carrying the CLI's one-line message, its kind and location —
//! raised as `ArgumentError` (also a `ValueError`) when an argument of the call caused it and as
//! `FileError` when a file did (`cause`); a panic inside motionlab becomes a `MotionlabError`
//! too (it never unwinds into the interpreter).

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

// Every plugin and workflow crate, named once in the bundle (crates/motionlab-plugins), as the
// CLI names it: the linker keeps their `inventory` registrations (the tests compare `list()`
// with the CLI's).
use motionlab_plugins as _;

mod array;
mod changepoint;
mod convert;
mod eval;
mod matching;
mod motion;
mod run;
mod stages;
mod streaming;

pyo3::create_exception!(
    motionlab,
    MotionlabError,
    pyo3::exceptions::PyException,
    "Every motionlab error: the CLI's one-line message (file, line or key path, what was expected), with `kind`, `file`, `line`, `field` and `message` attributes. Raised as one of its subclasses when the cause is known: `ArgumentError` (also a `ValueError`) for a bad argument of the call, `FileError` for a problem in a file."
);

/// `motionlab.ArgumentError(MotionlabError, ValueError)` and `motionlab.FileError(MotionlabError)`,
/// made once at import. Two bases need `type(name, bases, ns)`: `create_exception!` takes one.
static ARGUMENT_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static FILE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

fn subclass(
    py: Python<'_>,
    name: &str,
    bases: Vec<Bound<'_, PyType>>,
    doc: &str,
) -> PyResult<Py<PyType>> {
    let ns = PyDict::new(py);
    ns.set_item("__doc__", doc)?;
    ns.set_item("__module__", "motionlab")?;
    let t = py.get_type::<PyType>().call1((name, PyTuple::new(py, bases)?, ns))?;
    Ok(t.cast_into::<PyType>()?.unbind())
}

/// Which exception class an error is raised as. The cause is a file when the error is located in
/// one (a loader's or a truth reader's file, an experiment file, the file a motion was loaded
/// from) or is the operating system's; it is an argument when the error names none: a stage's
/// parameter, an array or a value given to the call. Run and report problems (an existing run,
/// a refused program, a failed check on results) and internal errors stay `MotionlabError`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cause {
    Argument,
    File,
    Other,
}

pub(crate) fn cause(e: &motionlab_core::Error) -> Cause {
    use motionlab_core::ErrorKind::*;
    match e.kind() {
        Report | Mismatch | NotAllowed => Cause::Other,
        Io | Syntax | Truncated | TooLarge => Cause::File,
        _ if e.location().file.is_some() => Cause::File,
        _ => Cause::Argument,
    }
}

/// The Python exception of a motionlab error, with its parts as attributes.
pub(crate) fn to_py_err(e: motionlab_core::Error) -> PyErr {
    Python::attach(|py| {
        let class = match cause(&e) {
            Cause::Argument => ARGUMENT_ERROR.get(py),
            Cause::File => FILE_ERROR.get(py),
            Cause::Other => None,
        };
        let err = match class {
            Some(t) => PyErr::from_type(t.bind(py).clone(), e.to_string()),
            None => MotionlabError::new_err(e.to_string()),
        };
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
    let py = m.py();
    let base = py.get_type::<MotionlabError>();
    m.add("MotionlabError", &base)?;
    let argument = ARGUMENT_ERROR.get_or_try_init(py, || {
        subclass(
            py,
            "ArgumentError",
            vec![base.clone(), py.get_type::<pyo3::exceptions::PyValueError>()],
            "A bad argument of the call: an unknown plugin or parameter, a parameter of the wrong type or out of range, an array of the wrong shape or with values a stage refuses. Also a ValueError, as Python code expects.",
        )
    })?;
    m.add("ArgumentError", argument.bind(py))?;
    let file = FILE_ERROR.get_or_try_init(py, || {
        subclass(
            py,
            "FileError",
            vec![base.clone()],
            "A problem in a file (its `file` attribute; `line` or `field` where known): unreadable, malformed, or holding values a stage refuses — a loader's or ground-truth reader's file, an experiment file, or the file a motion was loaded from.",
        )
    })?;
    m.add("FileError", file.bind(py))?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<array::ArrayBuffer>()?;
    motion::register(m)?;
    stages::register(m)?;
    eval::register(m)?;
    matching::register(m)?;
    run::register(m)?;
    changepoint::register(m)?;
    streaming::register(m)?;
    Ok(())
}
