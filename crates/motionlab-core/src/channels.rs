//! [`Channels`]: sampled signals other than point positions — what channel-reading segmenters
//! (ClaSP, kernel change points, BOCPD, FLOSS…) consume.
//!
//! They come from two places: a channel file (a TSSB series, the columns of a CSV of sensor
//! values — a [`Motion`](crate::Motion) with channels and no points), or features computed from a
//! take's points (marker speeds, joint angles: a segmenter's `input = { features = … }`). Either
//! way a segmenter reads the same thing, so the same `clasp` runs on a benchmark series and on a
//! CMU take's limb speeds.
//!
//! Values are sample-major (`values[sample * n_channels + channel]`), the layout every
//! multichannel segmenter iterates in; NaN marks a missing sample.

use crate::stage::Trace;
use crate::{Error, ErrorKind, Result};

/// Signals sampled at a motion's frame rate: `n_samples × names.len()` values, sample-major.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Channels {
    names: Vec<String>,
    units: Vec<String>,
    n_samples: usize,
    values: Vec<f64>,
}

impl Channels {
    /// Channels from sample-major values. Fails when the names are empty or repeat, the units
    /// are not one per channel, or the values are not whole samples. Non-finite values are
    /// kept as NaN (missing).
    pub fn new(names: Vec<String>, units: Vec<String>, mut values: Vec<f64>) -> Result<Self> {
        let d = names.len();
        if d == 0 {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                "channels need at least one named channel",
            ));
        }
        if units.len() != d {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!("{} units for {d} channels", units.len()),
            ));
        }
        let mut seen = std::collections::HashSet::with_capacity(d);
        for n in &names {
            if n.is_empty() {
                return Err(Error::new(ErrorKind::InvalidParameter, "a channel name is empty"));
            }
            if !seen.insert(n.as_str()) {
                return Err(Error::new(
                    ErrorKind::DuplicateName,
                    format!("channel name {n:?} appears twice"),
                ));
            }
        }
        if !values.len().is_multiple_of(d) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!("{} values is not a whole number of samples of {d} channels", values.len()),
            ));
        }
        for v in values.iter_mut().filter(|v| !v.is_finite()) {
            *v = f64::NAN;
        }
        Ok(Channels { n_samples: values.len() / d, names, units, values })
    }

    /// The traces as channels (each trace's name and unit; every trace one value per sample).
    pub fn from_traces(traces: &[Trace]) -> Result<Self> {
        let Some(first) = traces.first() else {
            return Err(Error::new(ErrorKind::EmptySequence, "no traces to make channels of"));
        };
        let n = first.values.len();
        if let Some(t) = traces.iter().find(|t| t.values.len() != n) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "trace {:?} has {} values, trace {:?} {n}: channels need one value per sample each",
                    t.name,
                    t.values.len(),
                    first.name
                ),
            ));
        }
        let mut values = Vec::with_capacity(n * traces.len());
        for s in 0..n {
            values.extend(traces.iter().map(|t| t.values[s]));
        }
        Channels::new(
            traces.iter().map(|t| t.name.clone()).collect(),
            traces.iter().map(|t| t.unit.clone()).collect(),
            values,
        )
    }

    pub fn names(&self) -> &[String] {
        &self.names
    }
    /// Each channel's unit (`mm/s`, `deg`, or empty for unitless values).
    pub fn units(&self) -> &[String] {
        &self.units
    }
    pub fn n_channels(&self) -> usize {
        self.names.len()
    }
    pub fn n_samples(&self) -> usize {
        self.n_samples
    }
    /// True when there is no channel.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
    /// Every value, sample-major.
    pub fn values(&self) -> &[f64] {
        &self.values
    }
    /// One channel's values over all samples.
    pub fn channel(&self, k: usize) -> impl ExactSizeIterator<Item = f64> + '_ {
        let d = self.n_channels();
        (0..self.n_samples).map(move |s| self.values[s * d + k])
    }
    /// Number of missing (NaN) values.
    pub fn missing_count(&self) -> usize {
        self.values.iter().filter(|v| v.is_nan()).count()
    }
    /// Index of a named channel; the error lists the closest names.
    pub fn index(&self, name: &str) -> Result<usize> {
        self.names.iter().position(|n| n == name).ok_or_else(|| {
            let close = crate::registry::closest_names(name, self.names.iter().map(String::as_str));
            let hint = if close.is_empty() {
                format!(" (channels: {})", self.names.join(", "))
            } else {
                format!(" (closest: {})", close.join(", "))
            };
            Error::new(ErrorKind::UnknownName, format!("no channel named {name:?}{hint}"))
                .with_field(name)
        })
    }
    /// A copy holding only the named channels, in the given order.
    pub fn select(&self, names: &[impl AsRef<str>]) -> Result<Channels> {
        let idx: Vec<usize> =
            names.iter().map(|n| self.index(n.as_ref())).collect::<Result<_>>()?;
        let d = self.n_channels();
        let mut values = Vec::with_capacity(self.n_samples * idx.len());
        for s in 0..self.n_samples {
            values.extend(idx.iter().map(|&k| self.values[s * d + k]));
        }
        Channels::new(
            idx.iter().map(|&k| self.names[k].clone()).collect(),
            idx.iter().map(|&k| self.units[k].clone()).collect(),
            values,
        )
    }
    /// A copy holding samples `start..end` (the caller checks the range).
    pub(crate) fn slice_samples(&self, start: usize, end: usize) -> Channels {
        let d = self.n_channels();
        Channels {
            names: self.names.clone(),
            units: self.units.clone(),
            n_samples: end - start,
            values: self.values[start * d..end * d].to_vec(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn traces_become_sample_major_channels_and_select_reorders() {
        let t = [
            Trace::new("a", "mm/s", vec![1.0, 2.0, 3.0]),
            Trace::new("b", "", vec![10.0, f64::INFINITY, 30.0]),
        ];
        let c = Channels::from_traces(&t).unwrap();
        assert_eq!((c.n_samples(), c.n_channels()), (3, 2));
        assert_eq!(&c.values()[..2], &[1.0, 10.0]);
        assert!(c.values()[3].is_nan(), "non-finite is missing");
        assert_eq!(c.missing_count(), 1);
        assert_eq!(c.channel(0).collect::<Vec<_>>(), vec![1.0, 2.0, 3.0]);
        let s = c.select(&["b", "a"]).unwrap();
        assert_eq!(s.names(), ["b", "a"]);
        assert_eq!(s.units(), ["", "mm/s"]);
        assert_eq!(&s.values()[4..], &[30.0, 3.0]);
        let e = c.select(&["aa"]).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        assert!(e.to_string().contains("closest: a"), "{e}");
        assert_eq!(c.slice_samples(1, 3).n_samples(), 2);
    }

    #[test]
    fn malformed_channels_are_errors() {
        let v = |n: &[&str]| n.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(
            Channels::new(vec![], vec![], vec![]).unwrap_err().kind(),
            ErrorKind::EmptySequence
        );
        assert_eq!(
            Channels::new(v(&["a", "a"]), v(&["", ""]), vec![]).unwrap_err().kind(),
            ErrorKind::DuplicateName
        );
        assert_eq!(
            Channels::new(v(&["a", "b"]), v(&[""]), vec![]).unwrap_err().kind(),
            ErrorKind::WrongValueCount
        );
        assert_eq!(
            Channels::new(v(&["a", "b"]), v(&["", ""]), vec![1.0]).unwrap_err().kind(),
            ErrorKind::WrongValueCount
        );
        let t = [Trace::new("a", "", vec![1.0]), Trace::new("b", "", vec![])];
        assert_eq!(Channels::from_traces(&t).unwrap_err().kind(), ErrorKind::WrongValueCount);
        assert_eq!(Channels::from_traces(&[]).unwrap_err().kind(), ErrorKind::EmptySequence);
    }
}
