//! `motionlab.Stream`: a streaming segmenter's session, fed samples as they arrive.

use std::sync::Mutex;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use motionlab_core::{
    Axis, Decision, ErrorKind, FrameRate, SegmenterSession, StreamLayout, registry,
};

use crate::array::read_f64_dims;
use crate::convert::params;
use crate::stages::build;
use crate::{error, to_py_err};

/// A streaming segmenter (`bocpd_online`, the `*_online` trackers) on a stream of channel rows
/// (`channels=[…]`) or frames of marker positions (`points=[…]`, mm, NaN = missing), at `rate`
/// samples per second. `update(samples)` takes the next samples — one sample (`width` values),
/// a block (`n × width`, or `n × points × 3`) — and returns every boundary decided so far as
/// `(boundary, decided_at)` pairs (sample indices from the stream's first sample; delay =
/// `decided_at − boundary`); `finish()` ends the stream and returns them all.
#[pyclass(name = "Stream", module = "motionlab")]
pub struct PyStream {
    /// A Python object may be shared between threads; the session is one stream's state.
    session: Mutex<Box<dyn SegmenterSession>>,
    decided: Vec<Decision>,
    finished: bool,
}

#[pymethods]
impl PyStream {
    #[new]
    #[pyo3(signature = (name, rate, channels=None, points=None, up_axis=None, params=None))]
    fn new(
        name: String,
        rate: f64,
        channels: Option<Vec<String>>,
        points: Option<Vec<String>>,
        up_axis: Option<String>,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let p = self::params(params)?;
        let rate = FrameRate::new(rate).map_err(|e| to_py_err(e.with_field("rate")))?;
        let layout = match (channels, points) {
            (Some(c), None) if !c.is_empty() => StreamLayout::channels(c, rate),
            (None, Some(p)) if !p.is_empty() => {
                let up = match up_axis.as_deref() {
                    None | Some("y") => Axis::Y,
                    Some("x") => Axis::X,
                    Some("z") => Axis::Z,
                    Some(other) => {
                        return Err(error(
                            ErrorKind::InvalidParameter,
                            format!("up_axis: {other:?}, expected \"x\", \"y\" or \"z\""),
                        ));
                    }
                };
                StreamLayout::points(p, rate, up)
            }
            _ => {
                return Err(error(
                    ErrorKind::InvalidParameter,
                    "give exactly one non-empty list: channels=[…] or points=[…]",
                ));
            }
        };
        let stage = build(&name, &p, registry::build_segmenter).map_err(to_py_err)?;
        let Some(streaming) = stage.streaming() else {
            return Err(error(
                ErrorKind::InvalidParameter,
                format!(
                    "{name} needs the whole series: only a streaming segmenter takes samples as they arrive (the `*_online` segmenters)"
                ),
            ));
        };
        if streaming.consumes() != layout.kind {
            return Err(error(
                ErrorKind::InvalidParameter,
                format!(
                    "{name} reads {}, and this stream carries {}",
                    streaming.consumes().describe(),
                    layout.kind.describe()
                ),
            ));
        }
        let session = streaming.start(&layout).map_err(to_py_err)?;
        Ok(PyStream { session: Mutex::new(session), decided: Vec::new(), finished: false })
    }

    /// Takes the next samples; returns every `(boundary, decided_at)` decided so far.
    fn update(&mut self, samples: &Bound<'_, PyAny>) -> PyResult<Vec<(usize, usize)>> {
        if self.finished {
            return Err(error(ErrorKind::InvalidParameter, "the stream has finished"));
        }
        let (values, _) = read_f64_dims(samples, &[1, 2, 3], "samples")?;
        let session = self.session.get_mut().unwrap_or_else(|p| p.into_inner());
        session.push(&values, &mut self.decided).map_err(to_py_err)?;
        Ok(self.pairs())
    }

    /// Ends the stream (what only the end decides) and returns every `(boundary, decided_at)`.
    fn finish(&mut self) -> PyResult<Vec<(usize, usize)>> {
        if !self.finished {
            let session = self.session.get_mut().unwrap_or_else(|p| p.into_inner());
            session.finish(&mut self.decided).map_err(to_py_err)?;
            self.finished = true;
        }
        Ok(self.pairs())
    }

    /// Samples taken so far.
    #[getter]
    fn samples_seen(&self) -> usize {
        match self.session.lock() {
            Ok(s) => s.samples_seen(),
            Err(p) => p.into_inner().samples_seen(),
        }
    }
}

impl PyStream {
    fn pairs(&self) -> Vec<(usize, usize)> {
        self.decided.iter().map(|d| (d.boundary, d.decided_at)).collect()
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyStream>()
}
