//! `motionlab.Motion`: a loaded motion, its positions, mask and channels as NumPy arrays that
//! borrow motionlab's own buffers (no copy: the arrays keep the motion alive and are
//! read-only, since stages share the same buffer).

use std::path::PathBuf;
use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use motionlab_core::{Axis, Channels, ErrorKind, FrameRate, Motion, PointKind};

use crate::array::{borrowed, f64_array, i64_array, read_f64, read_f64_dims};
use crate::{detached, error, guarded, to_py_err};

/// A motion-capture recording as motionlab loaded it: positions in mm (frames × points × 3,
/// NaN where a sample is missing), the frame rate, point names, the skeleton when the source
/// has one, events, and channels (a channel file's signals).
///
/// The arrays are views of motionlab's own buffers (no copy) and read-only; `np.array(m.positions)`
/// makes a writable copy. Build one from your own arrays with `Motion(positions, rate, …)` or
/// `Motion.from_channels(values, rate, …)`.
#[pyclass(name = "Motion", module = "motionlab", frozen)]
pub struct PyMotion {
    pub inner: Arc<Motion>,
}

fn axis(s: &str) -> PyResult<Axis> {
    match s.to_ascii_lowercase().as_str() {
        "x" => Ok(Axis::X),
        "y" => Ok(Axis::Y),
        "z" => Ok(Axis::Z),
        _ => Err(error(
            ErrorKind::WrongType,
            format!("up_axis: expected \"x\", \"y\" or \"z\", found {s:?}"),
        )),
    }
}

fn rate(hz: f64) -> PyResult<FrameRate> {
    FrameRate::new(hz).map_err(|e| to_py_err(e.with_field("rate")))
}

#[pymethods]
impl PyMotion {
    /// A motion from your own positions: `positions` frames × points × 3 in mm (NaN = missing),
    /// `rate` in Hz, `point_names` (default `p0`, `p1`, …), the up axis (`"x"`, `"y"`, `"z"`) and
    /// whether the points are `"marker"`s or skeleton `"joint"`s. The values are copied.
    #[new]
    #[pyo3(signature = (positions, rate, point_names=None, name="motion", up_axis="z", point_kind="marker"))]
    fn py_new(
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        rate: f64,
        point_names: Option<Vec<String>>,
        name: &str,
        up_axis: &str,
        point_kind: &str,
    ) -> PyResult<Self> {
        let (values, shape) = read_f64(positions, 3, "positions")?;
        if shape[2] != 3 {
            return Err(error(
                ErrorKind::WrongValueCount,
                format!("positions: expected frames × points × 3, found shape {shape:?}"),
            ));
        }
        let names = point_names.unwrap_or_else(|| (0..shape[1]).map(|k| format!("p{k}")).collect());
        if names.len() != shape[1] {
            return Err(error(
                ErrorKind::WrongValueCount,
                format!("point_names: {} names for {} points", names.len(), shape[1]),
            ));
        }
        let kind = match point_kind {
            "marker" => PointKind::Marker,
            "joint" => PointKind::Joint,
            other => {
                return Err(error(
                    ErrorKind::WrongType,
                    format!("point_kind: expected \"marker\" or \"joint\", found {other:?}"),
                ));
            }
        };
        let flat: Vec<[f64; 3]> = values.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        let (rate, up) = (self::rate(rate)?, axis(up_axis)?);
        let name = name.to_string();
        let m = detached(py, move || Motion::new(name, rate, up, kind, names, flat))?;
        Ok(PyMotion { inner: Arc::new(m) })
    }

    /// A motion of channels only (a channel file's kind: no points): `values` samples ×
    /// channels, or one channel as a 1-D array (NaN = missing), `rate` in Hz, channel `names`
    /// (default `ch0`, `ch1`, …) and `units` (default empty). The values are copied.
    #[staticmethod]
    #[pyo3(signature = (values, rate, names=None, units=None, name="channels"))]
    fn from_channels(
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        rate: f64,
        names: Option<Vec<String>>,
        units: Option<Vec<String>>,
        name: &str,
    ) -> PyResult<Self> {
        let (flat, mut shape) = read_f64_dims(values, &[1, 2], "values")?;
        if shape.len() == 1 {
            // One channel: a univariate series as claspy or ruptures take it.
            shape.push(1);
        }
        let names = names.unwrap_or_else(|| (0..shape[1]).map(|k| format!("ch{k}")).collect());
        let units = units.unwrap_or_else(|| vec![String::new(); names.len()]);
        let rate = self::rate(rate)?;
        let name = name.to_string();
        let m = detached(py, move || {
            Motion::from_channels(name, rate, Channels::new(names, units, flat)?)
        })?;
        Ok(PyMotion { inner: Arc::new(m) })
    }

    /// Positions in mm, frames × points × 3, NaN where missing (a read-only view, no copy).
    #[getter]
    fn positions<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let m = &slf.get().inner;
        // The motion is never mutated (a frozen class holding an `Arc`), and the array keeps
        // `slf` alive as its base.
        borrowed(slf.as_any(), m.positions().as_flattened(), &[m.n_frames(), m.n_points(), 3])
    }

    /// The missing mask, frames × points (True = missing; a read-only view, no copy).
    #[getter]
    fn missing<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let m = &slf.get().inner;
        borrowed(slf.as_any(), m.missing_mask(), &[m.n_frames(), m.n_points()])
    }

    /// `"3d"` (world positions, mm) or `"2d"` (image positions in px, the third coordinate 0:
    /// video pose estimation — OpenPose, COCO keypoints, MediaPipe).
    #[getter]
    fn dimensionality(&self) -> &'static str {
        match self.inner.dimensionality() {
            motionlab_core::Dimensionality::Three => "3d",
            motionlab_core::Dimensionality::Two => "2d",
        }
    }

    /// The per-sample confidence the pose estimator gave, frames × points float32 (a read-only
    /// view, no copy), or None for a source without one.
    #[getter]
    fn confidence<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let m = &slf.get().inner;
        match m.confidence() {
            None => Ok(None),
            Some(c) => borrowed(slf.as_any(), c, &[m.n_frames(), m.n_points()]).map(Some),
        }
    }

    /// Frame rate in Hz.
    #[getter]
    fn rate(&self) -> f64 {
        self.inner.frame_rate().hz()
    }
    #[getter]
    fn n_frames(&self) -> usize {
        self.inner.n_frames()
    }
    #[getter]
    fn n_points(&self) -> usize {
        self.inner.n_points()
    }
    /// Duration in seconds (first frame to one past the last).
    #[getter]
    fn duration_s(&self) -> f64 {
        self.inner.duration().value()
    }
    /// Marker or joint names, in the order of the positions' second axis.
    #[getter]
    fn point_names(&self) -> Vec<String> {
        self.inner.point_names().to_vec()
    }
    /// `"marker"` or `"joint"`.
    #[getter]
    fn point_kind(&self) -> &'static str {
        match self.inner.point_kind() {
            PointKind::Marker => "marker",
            PointKind::Joint => "joint",
        }
    }
    /// `"x"`, `"y"` or `"z"`.
    #[getter]
    fn up_axis(&self) -> String {
        self.inner.up_axis().to_string()
    }
    /// The sequence name (the file's stem).
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }
    /// The file it was loaded from, if any.
    #[getter]
    fn source(&self) -> Option<String> {
        self.inner.source.as_ref().map(|p| p.display().to_string())
    }
    /// The loader that read it (`asf_amc`, `c3d`, …).
    #[getter]
    fn format(&self) -> String {
        self.inner.format.clone()
    }
    /// Number of missing point samples.
    #[getter]
    fn missing_count(&self) -> usize {
        self.inner.missing_count()
    }

    /// The skeleton (BVH, ASF/AMC) as a dict — `joint_names`, `parents` (int64, -1 for the
    /// root), `offsets` (joints × 3, mm, in the parent's frame), `channel_names`
    /// (`joint.channel`) and `channel_values` (frames × channels: degrees and mm as in the
    /// file) — or None.
    #[getter]
    fn skeleton<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let py = slf.py();
        let Some(s) = &slf.get().inner.skeleton else { return Ok(None) };
        let d = PyDict::new(py);
        let joints = &s.skeleton.joints;
        d.set_item("joint_names", joints.iter().map(|j| j.name.clone()).collect::<Vec<_>>())?;
        let parents: Vec<i64> = joints.iter().map(|j| j.parent.map_or(-1, |p| p as i64)).collect();
        d.set_item("parents", i64_array(py, parents, &[joints.len()])?)?;
        let offsets: Vec<f64> = joints.iter().flat_map(|j| j.offset).collect();
        d.set_item("offsets", f64_array(py, offsets, &[joints.len(), 3])?)?;
        d.set_item("channel_names", s.skeleton.channel_names())?;
        d.set_item(
            "channel_values",
            borrowed(slf.as_any(), s.channel_values(), &[s.n_frames(), s.n_channels()])?,
        )?;
        Ok(Some(d))
    }

    /// Events (C3D), sorted by time: dicts with `label`, `context`, `time_s` and `frame`
    /// (fractional index into this motion's frames).
    #[getter]
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let rows = self
            .inner
            .events
            .iter()
            .map(|e| {
                let d = PyDict::new(py);
                d.set_item("label", &e.label)?;
                d.set_item("context", &e.context)?;
                d.set_item("time_s", e.time.value())?;
                d.set_item("frame", e.frame)?;
                Ok(d)
            })
            .collect::<PyResult<Vec<_>>>()?;
        PyList::new(py, rows)
    }

    /// The channel names (empty for a marker or skeleton file).
    #[getter]
    fn channel_names(&self) -> Vec<String> {
        self.inner.channels().names().to_vec()
    }
    /// The channel units (empty strings where unknown).
    #[getter]
    fn channel_units(&self) -> Vec<String> {
        self.inner.channels().units().to_vec()
    }
    /// The channels, samples × channels (NaN = missing; a read-only view, no copy), or None
    /// when the motion has none.
    #[getter]
    fn channels<'py>(slf: &Bound<'py, Self>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let c = slf.get().inner.channels();
        if c.is_empty() {
            return Ok(None);
        }
        borrowed(slf.as_any(), c.values(), &[c.n_samples(), c.n_channels()]).map(Some)
    }

    /// Frames `start..end` (end exclusive) as a new motion; events, skeleton and channels cut
    /// alike (a dataset's `cut = { frames = [start, end] }`).
    fn slice(&self, py: Python<'_>, start: usize, end: usize) -> PyResult<PyMotion> {
        let m = Arc::clone(&self.inner);
        Ok(PyMotion { inner: Arc::new(detached(py, move || m.slice_frames(start, end))?) })
    }

    /// Only the named points, in the given order, as a new motion.
    fn select(&self, py: Python<'_>, names: Vec<String>) -> PyResult<PyMotion> {
        let m = Arc::clone(&self.inner);
        Ok(PyMotion { inner: Arc::new(detached(py, move || m.select_points(&names))?) })
    }

    /// The motion as a Polars DataFrame, one row per frame: `frame`, `time_s`, then
    /// `<point>_x_mm`, `<point>_y_mm`, `<point>_z_mm` for every point (null where missing), then
    /// every channel.
    fn to_polars<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        guarded(|| {
            let m = &slf.get().inner;
            let cols = PyDict::new(py);
            let n = m.n_frames();
            cols.set_item("frame", i64_array(py, (0..n as i64).collect(), &[n])?)?;
            let rate = m.frame_rate();
            cols.set_item(
                "time_s",
                f64_array(py, (0..n).map(|i| rate.frame_to_seconds(i).value()).collect(), &[n])?,
            )?;
            let np = py.import("numpy")?;
            let positions = Self::positions(slf)?;
            for (k, name) in m.point_names().iter().enumerate() {
                for (a, axis) in ["x", "y", "z"].iter().enumerate() {
                    let col = positions.call_method1("__getitem__", ((py.Ellipsis(), k, a),))?;
                    cols.set_item(
                        format!("{name}_{axis}_mm"),
                        np.call_method1("ascontiguousarray", (col,))?,
                    )?;
                }
            }
            if let Some(values) = Self::channels(slf)? {
                for (k, name) in m.channels().names().iter().enumerate() {
                    let col = values.call_method1("__getitem__", ((py.Ellipsis(), k),))?;
                    cols.set_item(name, np.call_method1("ascontiguousarray", (col,))?)?;
                }
            }
            let pl = py.import("polars")?;
            let df = pl.getattr("DataFrame")?.call1((cols,))?;
            // NaN (missing) as null, the DataFrame way of saying "no value".
            df.call_method1("fill_nan", (py.None(),))
        })
    }

    fn __repr__(&self) -> String {
        let m = &self.inner;
        let what = if m.n_points() == 0 {
            format!("{} channels", m.channels().n_channels())
        } else {
            format!(
                "{} {}s",
                m.n_points(),
                if m.point_kind() == PointKind::Joint { "joint" } else { "marker" }
            )
        };
        let fmt = if m.format.is_empty() { String::new() } else { format!(", {}", m.format) };
        format!(
            "<motionlab.Motion {:?}{fmt}: {} frames × {what} at {} Hz>",
            m.name,
            m.n_frames(),
            m.frame_rate().hz()
        )
    }

    fn __len__(&self) -> usize {
        self.inner.n_frames()
    }
}

/// Loads a motion file with the named loader (or, without one, the loader registered for the
/// file's extension, as `motionlab inspect` picks it) and its parameters as a TOML table.
#[pyfunction]
#[pyo3(signature = (path, loader=None, params=None))]
fn load(
    py: Python<'_>,
    path: PathBuf,
    loader: Option<&str>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyMotion> {
    let params = crate::convert::params(params)?;
    let loader = loader.map(str::to_string);
    let m = detached(py, move || {
        let name = match loader {
            Some(name) => name,
            // The loader `motionlab inspect` picks for the extension; its parameters, if any,
            // are then given to that loader (`load("Adiac.txt", rate_hz=1.0)`).
            None => loader_for_extension(&path)?.to_string(),
        };
        let built = motionlab_core::registry::build_loader(&name, &params)
            .map_err(|e| e.under_field(name.clone()))?;
        built.load(&path).map_err(|e| e.in_file(&path))
    })?;
    Ok(PyMotion { inner: Arc::new(m) })
}

/// The name of the loader registered for the file's extension: the CLI's rule (the first
/// loader, in registry order, whose extensions hold it), called rather than copied.
fn loader_for_extension(path: &std::path::Path) -> motionlab_core::Result<&'static str> {
    motionlab_engine::front::loader_for(path).map(|(name, _)| name)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyMotion>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    Ok(())
}
