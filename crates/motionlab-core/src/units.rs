//! Units in types: lengths are millimetres, times are seconds or frames, and the conversion
//! between frames and seconds always goes through a [`FrameRate`].
//!
//! Parameters that transfer across recordings at different rates are written as a
//! [`TimeSpan`] (`{ seconds = 0.1 }` or `{ frames = 12 }` in TOML) and resolved against the
//! motion's rate only when a stage runs.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::fmt;

use crate::{Error, ErrorKind, Result};

macro_rules! scalar_unit {
    ($(#[$doc:meta])* $name:ident, $suffix:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq, PartialOrd, Serialize, Deserialize, JsonSchema)]
        #[serde(transparent)]
        pub struct $name(pub f64);

        impl $name {
            pub const fn new(value: f64) -> Self {
                $name(value)
            }
            pub const fn value(self) -> f64 {
                self.0
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{} {}", self.0, $suffix)
            }
        }
    };
}

scalar_unit!(
    /// A length in millimetres — the unit of every position inside motionlab.
    Millimetres, "mm"
);
scalar_unit!(
    /// A speed in millimetres per second.
    MillimetresPerSecond, "mm/s"
);
scalar_unit!(
    /// A volume in cubic millimetres.
    CubicMillimetres, "mm³"
);
scalar_unit!(
    /// A time in seconds.
    Seconds, "s"
);
scalar_unit!(
    /// An angle in degrees (the unit of BVH/AMC channels and of reported joint angles).
    Degrees, "deg"
);

/// Frames per second of a motion. Always finite and > 0 (checked by [`FrameRate::new`]).
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Serialize, Deserialize, JsonSchema)]
#[serde(try_from = "f64", into = "f64")]
pub struct FrameRate(f64);

impl FrameRate {
    pub fn new(hz: f64) -> Result<Self> {
        if hz.is_finite() && hz > 0.0 {
            Ok(FrameRate(hz))
        } else {
            Err(Error::new(
                ErrorKind::OutOfRange,
                format!("frame rate must be a finite number > 0 Hz, found {hz}"),
            ))
        }
    }
    pub fn hz(self) -> f64 {
        self.0
    }
    /// Time of the start of frame `index` (frame 0 starts at 0 s).
    pub fn frame_to_seconds(self, index: usize) -> Seconds {
        Seconds(index as f64 / self.0)
    }
    /// Fractional frame index of a time.
    pub fn seconds_to_frames(self, t: Seconds) -> f64 {
        t.0 * self.0
    }
    /// Duration of one frame.
    pub fn frame_period(self) -> Seconds {
        Seconds(1.0 / self.0)
    }
}

impl TryFrom<f64> for FrameRate {
    type Error = Error;
    fn try_from(value: f64) -> Result<Self> {
        FrameRate::new(value)
    }
}

impl From<FrameRate> for f64 {
    fn from(r: FrameRate) -> f64 {
        r.0
    }
}

impl fmt::Display for FrameRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} Hz", self.0)
    }
}

/// A length of time given in frames or in seconds: `{ frames = 15 }` or `{ seconds = 0.125 }`.
///
/// Experiments should prefer seconds so one parameter set transfers across frame rates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum TimeSpan {
    /// A number of frames at the motion's own rate.
    Frames(f64),
    /// A duration in seconds.
    Seconds(f64),
}

impl TimeSpan {
    /// The span as a (fractional) number of frames at `rate`.
    pub fn frames_at(self, rate: FrameRate) -> f64 {
        match self {
            TimeSpan::Frames(n) => n,
            TimeSpan::Seconds(s) => s * rate.hz(),
        }
    }
    /// The span rounded to the nearest whole number of frames at `rate`.
    pub fn whole_frames_at(self, rate: FrameRate) -> usize {
        let f = self.frames_at(rate).round();
        if f.is_finite() && f > 0.0 { f as usize } else { 0 }
    }
    pub fn raw(self) -> f64 {
        match self {
            TimeSpan::Frames(v) | TimeSpan::Seconds(v) => v,
        }
    }
    /// Checks the span is finite and ≥ 0 (or > 0 when `strictly_positive`).
    pub fn check(self, field: &str, strictly_positive: bool) -> Result<Self> {
        let v = self.raw();
        let ok = v.is_finite() && if strictly_positive { v > 0.0 } else { v >= 0.0 };
        if ok {
            Ok(self)
        } else {
            let want = if strictly_positive { "> 0" } else { ">= 0" };
            Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a finite time span {want}, found {self}"),
            )
            .with_field(field))
        }
    }
}

impl fmt::Display for TimeSpan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TimeSpan::Frames(n) => write!(f, "{n} frames"),
            TimeSpan::Seconds(s) => write!(f, "{s} s"),
        }
    }
}

/// A length unit a file format may store positions in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LengthUnit {
    Millimetre,
    Centimetre,
    Metre,
    Inch,
    /// The CMU mocap database's ASF unit with `:units length 0.45`: 1 unit = 1/0.45 inch
    /// = 56.444… mm. The cgspeed BVH conversions of CMU data use the same unit.
    CmuUnit,
}

impl LengthUnit {
    pub fn millimetres_per_unit(self) -> f64 {
        match self {
            LengthUnit::Millimetre => 1.0,
            LengthUnit::Centimetre => 10.0,
            LengthUnit::Metre => 1000.0,
            LengthUnit::Inch => 25.4,
            LengthUnit::CmuUnit => 25.4 / 0.45,
        }
    }
    /// Parses the unit strings found in file headers (`mm`, `cm`, `m`, `in`…).
    pub fn from_label(label: &str) -> Option<Self> {
        match label.trim().to_ascii_lowercase().as_str() {
            "mm" | "millimetre" | "millimeter" | "millimetres" | "millimeters" => {
                Some(LengthUnit::Millimetre)
            }
            "cm" | "centimetre" | "centimeter" => Some(LengthUnit::Centimetre),
            "m" | "metre" | "meter" | "metres" | "meters" => Some(LengthUnit::Metre),
            "in" | "inch" | "inches" => Some(LengthUnit::Inch),
            _ => None,
        }
    }
}

/// A coordinate axis. Motions record which one points up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
    /// The two other axes, in increasing order: the floor plane when `self` is up.
    pub fn others(self) -> [usize; 2] {
        match self {
            Axis::X => [1, 2],
            Axis::Y => [0, 2],
            Axis::Z => [0, 1],
        }
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Axis::X => "x",
            Axis::Y => "y",
            Axis::Z => "z",
        };
        f.write_str(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timespan_resolves_against_the_rate() {
        let r120 = FrameRate::new(120.0).unwrap();
        let r60 = FrameRate::new(60.0).unwrap();
        assert_eq!(TimeSpan::Seconds(0.125).frames_at(r120), 15.0);
        assert_eq!(TimeSpan::Seconds(0.125).whole_frames_at(r60), 8); // 7.5 rounds half away from zero
        assert_eq!(TimeSpan::Frames(10.0).frames_at(r60), 10.0);
    }

    #[test]
    fn timespan_parses_from_toml_tables() {
        #[derive(Deserialize)]
        struct P {
            tol: TimeSpan,
        }
        let p: P = toml::from_str("tol = { seconds = 0.1 }").unwrap();
        assert_eq!(p.tol, TimeSpan::Seconds(0.1));
        let p: P = toml::from_str("tol = { frames = 5 }").unwrap();
        assert_eq!(p.tol, TimeSpan::Frames(5.0));
        assert!(toml::from_str::<P>("tol = { minutes = 5 }").is_err());
    }

    #[test]
    fn timespan_check_rejects_negative_and_nan() {
        assert!(TimeSpan::Seconds(-0.1).check("tol", false).is_err());
        assert!(TimeSpan::Frames(0.0).check("l", true).is_err());
        assert!(TimeSpan::Frames(f64::NAN).check("l", false).is_err());
        assert!(TimeSpan::Frames(0.0).check("tol", false).is_ok());
    }

    #[test]
    fn frame_rate_rejects_zero_and_converts() {
        assert!(FrameRate::new(0.0).is_err());
        assert!(FrameRate::new(f64::INFINITY).is_err());
        let r = FrameRate::new(100.0).unwrap();
        assert_eq!(r.frame_to_seconds(250).0, 2.5);
        assert_eq!(r.seconds_to_frames(Seconds(0.97)), 97.0);
    }

    #[test]
    fn cmu_unit_is_one_over_0_45_inch() {
        assert!((LengthUnit::CmuUnit.millimetres_per_unit() - 56.444_444).abs() < 1e-5);
    }
}
