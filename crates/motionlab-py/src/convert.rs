//! Python values to and from what motionlab's crates take and give: stage parameters as the
//! TOML value an experiment file would hold, records through serde's JSON model, frame lists,
//! and [`Table`]s as columns (NumPy arrays and lists) for the Python half to make DataFrames of.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use motionlab_core::{ColumnValues, ErrorKind, Table};

use crate::array::{bool_array, f64_array, i64_array};
use crate::error;

/// A stage's keyword parameters as the TOML table an experiment file gives it (without
/// `type`). `None` values are left out (the key's default applies), as a key left out of TOML.
pub fn params(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<toml::Value> {
    let mut table = toml::Table::new();
    if let Some(kwargs) = kwargs {
        for (k, v) in kwargs.iter() {
            let key: String = k
                .extract()
                .map_err(|_| error(ErrorKind::WrongType, "parameter names must be strings"))?;
            if v.is_none() {
                continue;
            }
            table.insert(key.clone(), to_toml(&v, &key)?);
        }
    }
    Ok(toml::Value::Table(table))
}

/// A Python value as TOML: bool, int, float, str (and `os.PathLike`), dict with string keys,
/// list/tuple/NumPy array; a NumPy scalar as its Python number.
pub fn to_toml(v: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return v.extract::<i64>().map(toml::Value::Integer).map_err(|_| {
            error(ErrorKind::OutOfRange, format!("{path}: integer {v} does not fit in 64 bits"))
        });
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let key: String = k.extract().map_err(|_| {
                error(
                    ErrorKind::WrongType,
                    format!("{path}: table keys must be strings, found {k}"),
                )
            })?;
            if x.is_none() {
                continue;
            }
            let sub = format!("{path}.{key}");
            t.insert(key, to_toml(&x, &sub)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if v.is_instance_of::<PyList>()
        || v.is_instance_of::<PyTuple>()
        || v.hasattr("__array__")? && v.hasattr("tolist")?
    {
        let items = if v.hasattr("tolist")?
            && !v.is_instance_of::<PyList>()
            && !v.is_instance_of::<PyTuple>()
        {
            v.call_method0("tolist")?
        } else {
            v.clone()
        };
        // A NumPy 0-d array or scalar gives a plain number from tolist().
        if !(items.is_instance_of::<PyList>() || items.is_instance_of::<PyTuple>()) {
            return to_toml(&items, path);
        }
        let mut out = Vec::new();
        for (i, x) in items.try_iter()?.enumerate() {
            out.push(to_toml(&x?, &format!("{path}[{i}]"))?);
        }
        return Ok(toml::Value::Array(out));
    }
    if let Ok(p) = v.call_method0("__fspath__") {
        return to_toml(&p, path);
    }
    // NumPy scalars and other numbers.
    if v.hasattr("__index__")? {
        return to_toml(&v.call_method0("__index__")?, path);
    }
    if v.hasattr("__float__")? {
        return Ok(toml::Value::Float(v.call_method0("__float__")?.extract()?));
    }
    let ty = v.get_type().name().map(|n| n.to_string()).unwrap_or_default();
    Err(error(
        ErrorKind::WrongType,
        format!(
            "{path}: a Python `{ty}` is no parameter value; expected a bool, number, string, list or dict (as in TOML)"
        ),
    ))
}

/// A Python value in serde's JSON model (for records with serde derives: alignments, gait
/// studies…). NumPy arrays through `tolist()`.
pub fn to_json(v: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use serde_json::Value;
    if v.is_none() {
        return Ok(Value::Null);
    }
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        if let Ok(i) = v.extract::<i64>() {
            return Ok(Value::from(i));
        }
        return Ok(Value::from(v.extract::<u64>()?));
    }
    if v.is_instance_of::<PyFloat>() {
        let f: f64 = v.extract()?;
        // serde_json has no NaN; motionlab's records read null as NaN where they allow it.
        return Ok(serde_json::Number::from_f64(f).map(Value::Number).unwrap_or(Value::Null));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut m = serde_json::Map::new();
        for (k, x) in d.iter() {
            m.insert(k.str()?.to_string(), to_json(&x)?);
        }
        return Ok(Value::Object(m));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        return Ok(Value::Array(v.try_iter()?.map(|x| to_json(&x?)).collect::<PyResult<_>>()?));
    }
    if v.hasattr("tolist")? {
        return to_json(&v.call_method0("tolist")?);
    }
    if v.hasattr("__index__")? {
        return to_json(&v.call_method0("__index__")?);
    }
    if v.hasattr("__float__")? {
        return to_json(&v.call_method0("__float__")?);
    }
    if v.hasattr("__dict__")? {
        return to_json(&v.getattr("__dict__")?);
    }
    let ty = v.get_type().name().map(|n| n.to_string()).unwrap_or_default();
    Err(error(ErrorKind::WrongType, format!("a Python `{ty}` cannot be read as a record field")))
}

/// A serde record from a Python value (dict with the record's fields), naming the field that
/// does not fit.
pub fn from_py<T: serde::de::DeserializeOwned>(v: &Bound<'_, PyAny>, what: &str) -> PyResult<T> {
    let json = to_json(v)?;
    serde_path_to_json(json).map_err(|(path, msg)| {
        let field = if path.is_empty() || path == "." {
            what.to_string()
        } else {
            format!("{what}.{path}")
        };
        crate::to_py_err(motionlab_core::Error::new(ErrorKind::WrongType, msg).with_field(field))
    })
}

fn serde_path_to_json<T: serde::de::DeserializeOwned>(
    json: serde_json::Value,
) -> Result<T, (String, String)> {
    serde_path_to_error::deserialize(json)
        .map_err(|e| (e.path().to_string(), e.inner().to_string()))
}

/// A serde record as Python values (dicts, lists, numbers; NaN from null).
pub fn to_py<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_value(value)
        .map_err(|e| error(ErrorKind::Report, format!("cannot convert a result: {e}")))?;
    json_to_py(py, &json)
}

fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (_, Some(u)) => u.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(a) => {
            PyList::new(py, a.iter().map(|x| json_to_py(py, x)).collect::<PyResult<Vec<_>>>()?)?
                .into_any()
        }
        Value::Object(m) => {
            let d = PyDict::new(py);
            for (k, x) in m {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// Frame indices from a Python sequence or NumPy array of non-negative integers (any integer
/// dtype; floats must be whole numbers).
pub fn frames(v: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<usize>> {
    let items = if v.hasattr("tolist")? && !v.is_instance_of::<PyList>() {
        v.call_method0("tolist")?
    } else {
        v.clone()
    };
    let mut out = Vec::new();
    for (i, x) in items
        .try_iter()
        .map_err(|_| {
            error(ErrorKind::WrongType, format!("{what}: expected a sequence of frame indices"))
        })?
        .enumerate()
    {
        let x = x?;
        let f: i64 = if let Ok(n) = x.extract::<i64>() {
            n
        } else if let Ok(f) = x.extract::<f64>() {
            if f.fract() != 0.0 || !f.is_finite() {
                return Err(error(
                    ErrorKind::WrongType,
                    format!("{what}[{i}]: expected a whole frame index, found {f}"),
                ));
            }
            f as i64
        } else {
            return Err(error(
                ErrorKind::WrongType,
                format!("{what}[{i}]: expected a frame index, found {x}"),
            ));
        };
        out.push(frame(f, what)?);
    }
    Ok(out)
}

fn frame(f: i64, what: &str) -> PyResult<usize> {
    usize::try_from(f).map_err(|_| {
        error(ErrorKind::OutOfRange, format!("{what}: frame indices must be >= 0, found {f}"))
    })
}

/// Frames as a NumPy int64 array.
pub fn frames_to_py<'py>(py: Python<'py>, frames: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    i64_array(py, frames.iter().map(|&f| f as i64).collect(), &[frames.len()])
}

/// A table as `{"name", "title", "columns": {name: NumPy array or list of str/None}}`, columns
/// in order.
pub fn table_to_py<'py>(py: Python<'py>, t: &Table) -> PyResult<Bound<'py, PyDict>> {
    let cols = PyDict::new(py);
    for c in &t.columns {
        let v: Bound<'py, PyAny> = match &c.values {
            ColumnValues::F64(v) => f64_array(py, v.clone(), &[v.len()])?,
            ColumnValues::I64(v) => i64_array(py, v.clone(), &[v.len()])?,
            ColumnValues::Bool(v) => bool_array(py, v.clone(), &[v.len()])?,
            ColumnValues::Str(v) => PyList::new(py, v)?.into_any(),
        };
        cols.set_item(&c.name, v)?;
    }
    let d = PyDict::new(py);
    d.set_item("name", &t.name)?;
    d.set_item("title", &t.title)?;
    d.set_item("columns", cols)?;
    Ok(d)
}

/// Tables as a list of [`table_to_py`] dicts.
pub fn tables_to_py<'py>(py: Python<'py>, tables: &[Table]) -> PyResult<Bound<'py, PyList>> {
    PyList::new(py, tables.iter().map(|t| table_to_py(py, t)).collect::<PyResult<Vec<_>>>()?)
}

/// A float64 vector as a NumPy array.
pub fn f64s<'py>(py: Python<'py>, v: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
    let n = v.len();
    f64_array(py, v, &[n])
}

/// A warping path as a `k × 2` int64 array of (model frame, target frame).
pub fn path_to_py<'py>(py: Python<'py>, path: &[(usize, usize)]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = path.iter().flat_map(|&(i, j)| [i as i64, j as i64]).collect();
    i64_array(py, flat, &[path.len(), 2])
}
