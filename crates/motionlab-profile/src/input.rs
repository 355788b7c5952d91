//! Checks of the sample-major channel input shared by the segmenters.

use motionlab_core::{Error, ErrorKind, Result};

/// Channel data split into one contiguous vector per channel.
pub(crate) struct Channels {
    pub channels: Vec<Vec<f64>>,
    pub n_samples: usize,
}

impl Channels {
    pub fn slices(&self, start: usize, end: usize) -> Vec<&[f64]> {
        self.channels.iter().map(|c| &c[start..end]).collect()
    }
    /// True when every channel holds one value throughout.
    pub fn all_constant(&self) -> bool {
        self.channels.iter().all(|c| c.iter().all(|&v| v == c[0]))
    }
}

/// Splits `values` (`n_samples × n_channels`, sample-major) into channels, refusing an empty
/// input, a length that is not a multiple of `n_channels` and non-finite samples (NaN gaps are
/// to be filled before, e.g. by the `fill_gaps` preprocessor).
pub(crate) fn channels(values: &[f64], n_channels: usize, stage: &str) -> Result<Channels> {
    if n_channels == 0 {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("{stage}: n_channels is 0, expected at least one channel"),
        )
        .with_field("n_channels"));
    }
    if !values.len().is_multiple_of(n_channels) {
        return Err(Error::new(
            ErrorKind::WrongValueCount,
            format!("{stage}: {} values do not split into {n_channels} channels (expected a multiple of {n_channels})", values.len()),
        )
        .with_field("values"));
    }
    let n_samples = values.len() / n_channels;
    if n_samples == 0 {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!("{stage}: the series has no samples"),
        )
        .with_field("values"));
    }
    if let Some(at) = values.iter().position(|v| !v.is_finite()) {
        let (sample, channel) = (at / n_channels, at % n_channels);
        let kind = if values[at].is_nan() { ErrorKind::MissingData } else { ErrorKind::NonFinite };
        return Err(Error::new(
            kind,
            format!("{stage}: sample {sample} of channel {channel} is {}; the segmenter needs finite samples (fill gaps first, e.g. with the fill_gaps preprocessor)", values[at]),
        )
        .with_field(format!("values[{sample}][{channel}]")));
    }
    let channels = (0..n_channels)
        .map(|c| (0..n_samples).map(|s| values[s * n_channels + c]).collect())
        .collect();
    Ok(Channels { channels, n_samples })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_sample_major_values_into_channels() {
        let ch = channels(&[1.0, 10.0, 2.0, 20.0, 3.0, 30.0], 2, "t").unwrap();
        assert_eq!(ch.n_samples, 3);
        assert_eq!(ch.channels, vec![vec![1.0, 2.0, 3.0], vec![10.0, 20.0, 30.0]]);
    }

    #[test]
    fn refuses_empty_ragged_and_nan_input_naming_the_sample() {
        assert_eq!(channels(&[], 1, "t").err().unwrap().kind(), ErrorKind::EmptySequence);
        assert_eq!(channels(&[1.0], 0, "t").err().unwrap().kind(), ErrorKind::OutOfRange);
        assert_eq!(
            channels(&[1.0, 2.0, 3.0], 2, "t").err().unwrap().kind(),
            ErrorKind::WrongValueCount
        );
        let e = channels(&[1.0, 2.0, f64::NAN, 4.0], 2, "t").err().unwrap();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        assert_eq!(e.location().field.as_deref(), Some("values[1][0]"));
        assert_eq!(
            channels(&[1.0, f64::INFINITY], 1, "t").err().unwrap().kind(),
            ErrorKind::NonFinite
        );
    }
}
