//! NumPy arrays in and out through NumPy's array interface (`__array_interface__`, version 3),
//! without the `numpy` crate.
//!
//! Written by hand rather than with rust-numpy (the crate made for this): rust-numpy pulls in
//! `ndarray` and turns on default features of `num-complex`, `num-integer` and
//! `matrixmultiply`, crates the workspace already builds for nalgebra and polars. Cargo hashes
//! a crate's features into its build, so linking rust-numpy rebuilt the whole polars and
//! nalgebra stack a second time for this one crate (a second `polars-core` and everything above
//! it in the target directory). The array interface is all that is needed: an object whose
//! `__array_interface__` gives a pointer, a shape and a type is what `numpy.asarray` makes a
//! view of (keeping the object alive as the array's base), so motionlab's own buffers become
//! arrays without a copy, and inputs are read as contiguous bytes.

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyTuple};

use motionlab_core::ErrorKind;

use crate::error;

enum Data {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    /// A view of another object's buffer (a motion's positions), kept alive by `owner`.
    Borrowed {
        ptr: usize,
        _owner: Py<PyAny>,
    },
}

/// A buffer NumPy can view: owned values, or a view into an object kept alive with it.
#[pyclass(frozen, module = "motionlab._motionlab")]
pub struct ArrayBuffer {
    data: Data,
    typestr: &'static str,
    shape: Vec<usize>,
    readonly: bool,
}

#[pymethods]
impl ArrayBuffer {
    /// NumPy's array interface (version 3): shape, type, data pointer and read-only flag.
    #[getter]
    fn __array_interface__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let ptr = match &self.data {
            Data::F64(v) => v.as_ptr() as usize,
            Data::I64(v) => v.as_ptr() as usize,
            Data::Bool(v) => v.as_ptr() as usize,
            Data::Borrowed { ptr, .. } => *ptr,
        };
        let d = PyDict::new(py);
        d.set_item("shape", PyTuple::new(py, &self.shape)?)?;
        d.set_item("typestr", self.typestr)?;
        d.set_item("data", (ptr, self.readonly))?;
        d.set_item("version", 3)?;
        Ok(d)
    }
}

const F64: &str = if cfg!(target_endian = "little") { "<f8" } else { ">f8" };
const I64: &str = if cfg!(target_endian = "little") { "<i8" } else { ">i8" };
const BOOL: &str = "|b1";
const F32: &str = if cfg!(target_endian = "little") { "<f4" } else { ">f4" };

fn array<'py>(py: Python<'py>, buffer: ArrayBuffer) -> PyResult<Bound<'py, PyAny>> {
    let b = Bound::new(py, buffer)?;
    py.import("numpy")?.call_method1("asarray", (b,))
}

/// Owned float64 values as an array of `shape`.
pub fn f64_array<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    array(
        py,
        ArrayBuffer {
            data: Data::F64(values),
            typestr: F64,
            shape: shape.to_vec(),
            readonly: false,
        },
    )
}

/// Owned int64 values as an array of `shape`.
pub fn i64_array<'py>(
    py: Python<'py>,
    values: Vec<i64>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    array(
        py,
        ArrayBuffer {
            data: Data::I64(values),
            typestr: I64,
            shape: shape.to_vec(),
            readonly: false,
        },
    )
}

/// Owned booleans as an array of `shape`.
pub fn bool_array<'py>(
    py: Python<'py>,
    values: Vec<bool>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    array(
        py,
        ArrayBuffer {
            data: Data::Bool(values),
            typestr: BOOL,
            shape: shape.to_vec(),
            readonly: false,
        },
    )
}

/// The element types a borrowed view can have.
pub trait Element {
    const TYPESTR: &'static str;
}
impl Element for f64 {
    const TYPESTR: &'static str = F64;
}
impl Element for f32 {
    const TYPESTR: &'static str = F32;
}
impl Element for bool {
    const TYPESTR: &'static str = BOOL;
}

/// A read-only view of `values` (owned by `owner`, which the array keeps alive) as an array
/// of `shape`. The caller guarantees that `values` lives as long as `owner` and never changes
/// (a frozen class holding an `Arc` of an immutable value).
pub fn borrowed<'py, T: Element>(
    owner: &Bound<'py, PyAny>,
    values: &[T],
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let n: usize = shape.iter().product();
    if n != values.len() {
        return Err(error(
            ErrorKind::Report,
            format!("a view of {} values cannot have shape {shape:?}", values.len()),
        ));
    }
    let data = Data::Borrowed { ptr: values.as_ptr() as usize, _owner: owner.clone().unbind() };
    array(
        owner.py(),
        ArrayBuffer { data, typestr: T::TYPESTR, shape: shape.to_vec(), readonly: true },
    )
}

/// Any array-like as contiguous float64 values and its shape, checking the number of
/// dimensions (one copy: the values are read as bytes).
pub fn read_f64(v: &Bound<'_, PyAny>, ndim: usize, what: &str) -> PyResult<(Vec<f64>, Vec<usize>)> {
    read_f64_dims(v, &[ndim], what)
}

/// [`read_f64`] for an array of any of the numbers of dimensions `ndims`.
pub fn read_f64_dims(
    v: &Bound<'_, PyAny>,
    ndims: &[usize],
    what: &str,
) -> PyResult<(Vec<f64>, Vec<usize>)> {
    let py = v.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("float64")?)?;
    let a = np.call_method("ascontiguousarray", (v,), Some(&kwargs)).map_err(|e| {
        error(ErrorKind::WrongType, format!("{what}: expected an array of numbers ({e})"))
    })?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    if !ndims.contains(&shape.len()) {
        let expected = ndims.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(" or ");
        return Err(error(
            ErrorKind::WrongValueCount,
            format!("{what}: expected {expected} dimensions, found shape {shape:?}"),
        ));
    }
    let bytes = a.call_method0("tobytes")?;
    let bytes = bytes.cast::<PyBytes>()?.as_bytes();
    let values = bytes
        .chunks_exact(8)
        .map(|c| f64::from_ne_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
        .collect();
    Ok((values, shape))
}
