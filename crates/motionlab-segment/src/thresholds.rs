//! Speed thresholds that transfer across recordings.
//!
//! Sonoda et al. only say "sufficiently large/small". A fixed mm/s value does not transfer
//! between a ballet solo and a walk, so a threshold may instead be a fraction of a robust scale
//! of the sequence's own fastest-marker speed V (its 90th percentile).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, Result};
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
            SpeedThreshold::FractionOfP90(f) => percentile(v, 90.0).map(|p90| f * p90).ok_or_else(|| {
                Error::new(ErrorKind::MissingData, "the fastest-marker speed has no finite value to take a percentile of")
            }),
        }
    }
    /// Checks the value is finite and > 0.
    pub fn check(self, field: &str) -> Result<Self> {
        let v = match self {
            SpeedThreshold::MmPerS(v) | SpeedThreshold::FractionOfP90(v) => v,
        };
        if v.is_finite() && v > 0.0 {
            Ok(self)
        } else {
            Err(Error::new(ErrorKind::OutOfRange, format!("speed threshold must be finite and > 0, found {v}")).with_field(field))
        }
    }
}
