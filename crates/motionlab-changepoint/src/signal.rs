//! The checked view of a sample-major multichannel signal shared by every segmenter here.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, Result};

/// `values` laid out sample-major (`n_samples × n_channels`), checked once.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Signal<'a> {
    pub values: &'a [f64],
    pub n_samples: usize,
    pub n_channels: usize,
}

/// What a segmenter does with a missing (NaN) sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Missing {
    /// Refuse the signal: one error naming the first missing sample and channel.
    Refuse,
    /// Keep NaN samples; the segmenter handles them.
    Allow,
}

impl<'a> Signal<'a> {
    /// Checks the layout and the values: `n_channels ≥ 1`, a whole number of samples, at least
    /// one sample, no ±∞, and NaN only where the segmenter allows it.
    pub fn new(
        values: &'a [f64],
        n_channels: usize,
        stage: &str,
        missing: Missing,
    ) -> Result<Self> {
        if n_channels == 0 {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                format!("{stage}: n_channels is 0, expected at least one channel"),
            )
            .with_field("n_channels"));
        }
        if !values.len().is_multiple_of(n_channels) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{stage}: {} values do not make whole samples of {n_channels} channels (values are sample-major: n_samples × n_channels)",
                    values.len()
                ),
            )
            .with_field("values"));
        }
        let n_samples = values.len() / n_channels;
        if n_samples == 0 {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                format!("{stage}: the signal has no samples"),
            )
            .with_field("values"));
        }
        for (i, v) in values.iter().enumerate() {
            if v.is_infinite() {
                return Err(Error::new(
                    ErrorKind::NonFinite,
                    format!(
                        "{stage}: sample {} of channel {} is {v}, expected a finite number",
                        i / n_channels,
                        i % n_channels
                    ),
                )
                .with_field("values"));
            }
            if v.is_nan() && missing == Missing::Refuse {
                return Err(Error::new(
                    ErrorKind::MissingData,
                    format!(
                        "{stage}: sample {} of channel {} is missing (NaN); this segmenter needs every sample, fill the gaps first (the fill_gaps preprocessor)",
                        i / n_channels,
                        i % n_channels
                    ),
                )
                .with_field("values"));
            }
        }
        Ok(Signal { values, n_samples, n_channels })
    }

    /// Sample `i` as a slice of its channels.
    #[inline]
    pub fn row(&self, i: usize) -> &'a [f64] {
        &self.values[i * self.n_channels..(i + 1) * self.n_channels]
    }

    /// One channel, copied out.
    pub fn channel(&self, c: usize) -> Vec<f64> {
        (0..self.n_samples).map(|i| self.values[i * self.n_channels + c]).collect()
    }

    /// Whether every channel holds one value throughout.
    pub fn is_constant(&self) -> bool {
        let first = self.row(0);
        (1..self.n_samples).all(|i| self.row(i) == first)
    }
}

/// A per-channel rescaling applied before a segmenter sees the signal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Normalize {
    /// The values as given.
    #[default]
    None,
    /// `(x − min) / (max − min)` per channel, into [0, 1] — numpy's
    /// `(ts - ts.min()) / (ts.max() - ts.min())`, operation for operation. A constant channel
    /// becomes 0 (numpy would give NaN).
    MinMax,
    /// `(x − mean) / s` per channel, s the sample standard deviation (n − 1); a constant
    /// channel is only centred.
    ZScore,
}

impl Normalize {
    /// `values` (sample-major, `n_channels` per sample; NaN skipped and kept) rescaled.
    pub fn apply(self, values: &[f64], n_channels: usize) -> Vec<f64> {
        let mut x = values.to_vec();
        if self == Normalize::None || n_channels == 0 {
            return x;
        }
        let n = values.len() / n_channels;
        for c in 0..n_channels {
            let finite = (0..n).map(|i| values[i * n_channels + c]).filter(|v| !v.is_nan());
            let (shift, scale) = match self {
                Normalize::None => (0.0, 1.0),
                Normalize::MinMax => {
                    let (lo, hi) = finite
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                            (lo.min(v), hi.max(v))
                        });
                    if lo.is_infinite() {
                        continue;
                    }
                    (lo, hi - lo)
                }
                Normalize::ZScore => {
                    let v: Vec<f64> = finite.collect();
                    if v.is_empty() {
                        continue;
                    }
                    let mean = v.iter().sum::<f64>() / v.len() as f64;
                    let var = if v.len() > 1 {
                        v.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64
                    } else {
                        0.0
                    };
                    (mean, var.sqrt())
                }
            };
            for i in 0..n {
                let v = &mut x[i * n_channels + c];
                let centred = *v - shift;
                *v = if scale > 0.0 {
                    centred / scale
                } else if self == Normalize::MinMax && !centred.is_nan() {
                    0.0
                } else {
                    centred
                };
            }
        }
        x
    }
}

/// Change-point candidates from ruptures-style breakpoints (segment ends, the last being `n`):
/// every breakpoint but `n`, which are the first samples of the second, third, … segments.
pub(crate) fn candidates_from_breakpoints(breakpoints: &[usize], n_samples: usize) -> Vec<usize> {
    let mut out: Vec<usize> =
        breakpoints.iter().copied().filter(|&b| b > 0 && b < n_samples).collect();
    out.sort_unstable();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_and_value_errors_name_what_is_wrong() {
        let e = Signal::new(&[1.0, 2.0, 3.0], 2, "x", Missing::Refuse).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongValueCount);
        let e = Signal::new(&[], 1, "x", Missing::Refuse).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::EmptySequence);
        let e = Signal::new(&[1.0], 0, "x", Missing::Refuse).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("n_channels"));
        let e = Signal::new(&[1.0, 2.0, f64::NAN, 4.0], 2, "x", Missing::Refuse).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        assert!(e.to_string().contains("sample 1 of channel 0"), "{e}");
        assert!(Signal::new(&[1.0, f64::NAN], 1, "x", Missing::Allow).is_ok());
        let e = Signal::new(&[1.0, f64::INFINITY], 1, "x", Missing::Allow).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NonFinite);
    }

    #[test]
    fn normalisations_by_hand() {
        // Two channels: [1, 3, 5] and the constant [7, 7, 7].
        let x = [1.0, 7.0, 3.0, 7.0, 5.0, 7.0];
        assert_eq!(Normalize::MinMax.apply(&x, 2), [0.0, 0.0, 0.5, 0.0, 1.0, 0.0]);
        assert_eq!(Normalize::ZScore.apply(&x, 2), [-1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        assert_eq!(Normalize::None.apply(&x, 2), x);
        // NaN stays NaN and does not enter min, max or mean.
        let g = Normalize::MinMax.apply(&[2.0, f64::NAN, 4.0], 1);
        assert!(g[0] == 0.0 && g[1].is_nan() && g[2] == 1.0);
        // numpy's operation order: (x - min) / (max - min).
        let v = [0.1, 0.7, 0.3];
        assert_eq!(Normalize::MinMax.apply(&v, 1)[2], (0.3 - 0.1) / (0.7 - 0.1));
    }

    #[test]
    fn breakpoints_map_to_candidates_without_n() {
        assert_eq!(candidates_from_breakpoints(&[30, 70, 100], 100), vec![30, 70]);
        assert_eq!(candidates_from_breakpoints(&[100], 100), Vec::<usize>::new());
    }
}
