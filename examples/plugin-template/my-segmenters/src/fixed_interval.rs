//! `fixed_interval`: a candidate every N seconds — the chance baseline for boundary detection.
//!
//! A plugin is one file (CONTRIBUTING.md): the params struct whose doc comment is what
//! `motionlab describe fixed_interval` prints, a `ParamGuard` that validates it into the stage
//! that runs, the `Segmenter` impl, and one `register_plugin!` line.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, FeatureCache, Motion, Result, Segmenter, SegmenterOutput, TimeSpan,
};

/// Candidates at fixed time steps, ignoring the motion: the chance baseline a segmenter must beat.
///
/// Candidate frames `round((offset + k · interval) · rate)` for k = 1, 2, … while inside the
/// motion. It reads no position, so its precision against human labels is what mere
/// regularity earns: a method whose precision is not clearly above it, at a similar number of
/// candidates, has not found the boundaries. Missing samples: irrelevant (positions are not read).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FixedIntervalParams {
    /// Time between two candidates (`{ seconds = 2.0 }` or `{ frames = 240 }`), > 0.
    #[serde(default = "default_interval")]
    pub interval: TimeSpan,
    /// Shift of every candidate, ≥ 0 (the first is at offset + interval).
    #[serde(default = "default_offset")]
    pub offset: TimeSpan,
}

fn default_interval() -> TimeSpan {
    TimeSpan::Seconds(2.0)
}

fn default_offset() -> TimeSpan {
    TimeSpan::Seconds(0.0)
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct FixedInterval {
    interval: TimeSpan,
    offset: TimeSpan,
}

impl ParamGuard for FixedIntervalParams {
    type Checked = FixedInterval;
    fn check(self) -> Result<FixedInterval> {
        Ok(FixedInterval {
            interval: self.interval.check("interval", true)?,
            offset: self.offset.check("offset", false)?,
        })
    }
}

impl Segmenter for FixedInterval {
    fn segment(&self, motion: &Motion, _cache: &FeatureCache) -> Result<SegmenterOutput> {
        let rate = motion.frame_rate();
        let (step, start) = (self.interval.frames_at(rate), self.offset.frames_at(rate));
        if step < 1.0 {
            let msg = format!("interval {} is under one frame at {rate}", self.interval);
            return Err(Error::new(ErrorKind::OutOfRange, msg).with_field("interval"));
        }
        let n = motion.n_frames() as f64;
        let candidates = (1..)
            .map(|k| (start + k as f64 * step).round())
            .take_while(|&f| f < n)
            .map(|f| f as usize)
            .collect();
        Ok(SegmenterOutput { candidates, ..Default::default() })
    }
}

motionlab_core::register_plugin!(Segmenter, FixedIntervalParams, "fixed_interval");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::still;
    use motionlab_core::registry::build_segmenter;

    #[test]
    fn candidates_every_interval_after_the_offset() {
        let seg = |toml_text: &str, motion: &Motion| {
            let params: toml::Value = toml::from_str(toml_text).unwrap();
            build_segmenter("fixed_interval", &params)
                .unwrap()
                .segment(motion, &FeatureCache::new())
                .unwrap()
                .candidates
        };
        // 10 s at 100 Hz: every 2 s → 200, 400, 600, 800 (1000 is past the last frame, 999).
        assert_eq!(seg("", &still(1000, 100.0)), vec![200, 400, 600, 800]);
        // 1.5 frames apart from 0.25 frames on: 1.75 → 2, 3.25 → 3, 4.75 → 5, 6.25 → 6.
        assert_eq!(
            seg("interval = { frames = 1.5 }\noffset = { frames = 0.25 }", &still(7, 10.0)),
            vec![2, 3, 5, 6]
        );
    }

    #[test]
    fn bad_parameters_name_their_field() {
        let params: toml::Value = toml::from_str("interval = { seconds = 0.0 }").unwrap();
        let e = build_segmenter("fixed_interval", &params).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("interval"));
        let params: toml::Value = toml::from_str("interval = { frames = 0.5 }").unwrap();
        let e = build_segmenter("fixed_interval", &params)
            .unwrap()
            .segment(&still(5, 10.0), &FeatureCache::new())
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::OutOfRange);
    }
}
