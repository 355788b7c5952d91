//! Speed thresholds that transfer across recordings.
//!
//! Sonoda et al. only say "sufficiently large/small". A fixed mm/s value does not transfer
//! between a ballet solo and a walk, so a threshold may instead be a fraction of a robust scale
//! of the sequence's own fastest-marker speed V (its 90th percentile). Likewise the hull-volume
//! change threshold: a rate in mm³/s, or a fraction of the sequence's own 90th percentile.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, FrameRate, Result};
use motionlab_features::signal::percentile;

/// A speed threshold: `{ mm_per_s = 150.0 }` or `{ fraction_of_p90 = 0.1 }`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum SpeedThreshold {
    /// An absolute speed in mm/s.
    MmPerS(f64),
    /// A fraction of the 90th percentile of the sequence's fastest-marker speed V.
    FractionOfP90(f64),
}

impl SpeedThreshold {
    /// The threshold in mm/s for a sequence whose fastest-marker speed is `v`.
    pub fn resolve(self, v: &[f64]) -> Result<f64> {
        match self {
            SpeedThreshold::MmPerS(x) => Ok(x),
            SpeedThreshold::FractionOfP90(f) => speed_p90(v).map(|p90| f * p90),
        }
    }
    /// Two thresholds for the same `v`, taking its 90th percentile at most once.
    pub fn resolve_pair(first: Self, second: Self, v: &[f64]) -> Result<(f64, f64)> {
        let mut p90 = None;
        let mut resolve = |t: Self| match t {
            SpeedThreshold::MmPerS(x) => Ok(x),
            SpeedThreshold::FractionOfP90(f) => Ok(f * match p90 {
                Some(p) => p,
                None => *p90.insert(speed_p90(v)?),
            }),
        };
        Ok((resolve(first)?, resolve(second)?))
    }
    /// Checks the value is finite and > 0.
    pub fn check(self, field: &str) -> Result<Self> {
        let v = match self {
            SpeedThreshold::MmPerS(v) | SpeedThreshold::FractionOfP90(v) => v,
        };
        if v.is_finite() && v > 0.0 {
            Ok(self)
        } else {
            Err(Error::new(
                ErrorKind::OutOfRange,
                format!("speed threshold must be finite and > 0, found {v}"),
            )
            .with_field(field))
        }
    }
}

/// The 90th percentile of the fastest-marker speed `v` (finite values).
fn speed_p90(v: &[f64]) -> Result<f64> {
    percentile(v, 90.0).ok_or_else(|| {
        Error::new(
            ErrorKind::MissingData,
            "the fastest-marker speed has no finite value to take a percentile of",
        )
    })
}

/// A threshold on the per-frame change of the hull volume `D` (mm³ per frame) that transfers
/// across frame rates and body sizes: `{ mm3_per_s = 2.0e6 }` (a rate, divided by the motion's
/// frame rate) or `{ fraction_of_p90 = 0.5 }` (of the sequence's own `D`).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum VolumeChangeThreshold {
    /// A rate of volume change in mm³/s; per frame it is this divided by the frame rate.
    Mm3PerS(f64),
    /// A fraction of the 90th percentile of the sequence's `D` (finite values).
    FractionOfP90(f64),
}

impl VolumeChangeThreshold {
    /// The threshold in mm³ per frame for a sequence whose `D` is `d`, at `rate`.
    pub fn resolve(self, d: &[f64], rate: FrameRate) -> Result<f64> {
        match self {
            VolumeChangeThreshold::Mm3PerS(x) => Ok(x / rate.hz()),
            VolumeChangeThreshold::FractionOfP90(f) => {
                percentile(d, 90.0).map(|p90| f * p90).ok_or_else(|| {
                    Error::new(
                        ErrorKind::MissingData,
                        "the hull-volume change D has no finite value to take a percentile of",
                    )
                })
            }
        }
    }
    /// Checks the value is finite and > 0.
    pub fn check(self, field: &str) -> Result<Self> {
        let v = match self {
            VolumeChangeThreshold::Mm3PerS(v) | VolumeChangeThreshold::FractionOfP90(v) => v,
        };
        if v.is_finite() && v > 0.0 {
            Ok(self)
        } else {
            Err(Error::new(
                ErrorKind::OutOfRange,
                format!("volume-change threshold must be finite and > 0, found {v}"),
            )
            .with_field(field))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_resolve_against_the_sequence_and_the_rate() {
        let v: Vec<f64> = (0..=10).map(|i| i as f64 * 100.0).chain([f64::NAN]).collect();
        assert_eq!(SpeedThreshold::MmPerS(80.0).resolve(&v).unwrap(), 80.0);
        assert!((SpeedThreshold::FractionOfP90(0.5).resolve(&v).unwrap() - 450.0).abs() < 1e-9);
        let pair = SpeedThreshold::resolve_pair(
            SpeedThreshold::FractionOfP90(0.5),
            SpeedThreshold::MmPerS(80.0),
            &v,
        )
        .unwrap();
        assert!((pair.0 - 450.0).abs() < 1e-9 && pair.1 == 80.0);
        let pair = SpeedThreshold::resolve_pair(
            SpeedThreshold::FractionOfP90(0.5),
            SpeedThreshold::FractionOfP90(0.1),
            &v,
        )
        .unwrap();
        assert!((pair.0 - 450.0).abs() < 1e-9 && (pair.1 - 90.0).abs() < 1e-9);
        assert!(
            SpeedThreshold::resolve_pair(
                SpeedThreshold::MmPerS(1.0),
                SpeedThreshold::FractionOfP90(0.1),
                &[f64::NAN]
            )
            .is_err()
        );
        let r = FrameRate::new(120.0).unwrap();
        assert_eq!(VolumeChangeThreshold::Mm3PerS(1.2e6).resolve(&v, r).unwrap(), 1e4);
        assert!(
            (VolumeChangeThreshold::FractionOfP90(0.1).resolve(&v, r).unwrap() - 90.0).abs() < 1e-9
        );
        assert!(VolumeChangeThreshold::FractionOfP90(0.1).resolve(&[f64::NAN], r).is_err());
        let e = VolumeChangeThreshold::Mm3PerS(0.0).check("t").unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("t"));
        assert!(SpeedThreshold::MmPerS(f64::INFINITY).check("v_low").is_err());
    }
}
