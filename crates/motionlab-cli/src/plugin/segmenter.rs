//! `template_segmenter`: candidates where the points come to rest.
//!
//! Written by `motionlab plugin new` as a working placeholder in the shape every plugin has
//! (CONTRIBUTING.md, "A plugin is one file"): a params struct whose doc comment is what
//! `motionlab describe template_segmenter` prints, a `ParamGuard` that validates it into the
//! stage that runs, the `Segmenter` impl, one `register_plugin!` line and a known-answer test.
//! Replace the method, its doc comment and its test together.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, FeatureCache, Motion, Result, Segmenter, SegmenterOutput, Threshold, Trace,
};

/// Candidates where the points come to rest: the frames at which the mean speed of the points
/// falls below `max_speed_mm_per_s`, having been at or above it.
///
/// The speed of a point at frame f is |p(f) − p(f − 1)| × rate (mm/s; none at frame 0), the mean
/// is over the points present at both frames. The mean speed and the threshold are returned as
/// a trace for the figures.
///
/// Missing samples: a point missing at frame f or f − 1 is left out of that frame's mean; a
/// frame with no such point has no speed and neither ends nor starts a rest.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TemplateSegmenterParams {
    /// The mean speed (mm/s, > 0) below which the points are at rest.
    #[serde(default = "default_max_speed_mm_per_s")]
    pub max_speed_mm_per_s: f64,
}

fn default_max_speed_mm_per_s() -> f64 {
    100.0
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct TemplateSegmenter {
    max_speed_mm_per_s: f64,
}

impl ParamGuard for TemplateSegmenterParams {
    type Checked = TemplateSegmenter;
    fn check(self) -> Result<TemplateSegmenter> {
        if !(self.max_speed_mm_per_s.is_finite() && self.max_speed_mm_per_s > 0.0) {
            let msg = format!("expected a speed > 0 mm/s, found {}", self.max_speed_mm_per_s);
            return Err(Error::new(ErrorKind::OutOfRange, msg).with_field("max_speed_mm_per_s"));
        }
        Ok(TemplateSegmenter { max_speed_mm_per_s: self.max_speed_mm_per_s })
    }
}

impl Segmenter for TemplateSegmenter {
    fn segment(&self, motion: &Motion, _cache: &FeatureCache) -> Result<SegmenterOutput> {
        let rate = motion.frame_rate().hz();
        let speed: Vec<f64> = (0..motion.n_frames())
            .map(|f| {
                if f == 0 {
                    return f64::NAN;
                }
                let (now, before) = (motion.frame(f), motion.frame(f - 1));
                let steps: Vec<f64> = (0..motion.n_points())
                    .filter(|&p| !motion.is_missing(f, p) && !motion.is_missing(f - 1, p))
                    .map(|p| {
                        (0..3).map(|a| (now[p][a] - before[p][a]).powi(2)).sum::<f64>().sqrt()
                            * rate
                    })
                    .collect();
                if steps.is_empty() {
                    f64::NAN
                } else {
                    steps.iter().sum::<f64>() / steps.len() as f64
                }
            })
            .collect();
        let mut candidates = Vec::new();
        let mut moving = false;
        for (f, v) in speed.iter().enumerate().filter(|(_, v)| v.is_finite()) {
            if *v < self.max_speed_mm_per_s && moving {
                candidates.push(f);
            }
            moving = *v >= self.max_speed_mm_per_s;
        }
        let trace = "mean_speed_mm_per_s";
        Ok(SegmenterOutput {
            candidates,
            traces: vec![Trace::new(trace, "mm/s", speed)],
            thresholds: vec![Threshold {
                name: "max_speed_mm_per_s".into(),
                trace: trace.into(),
                value: self.max_speed_mm_per_s,
            }],
            ..Default::default()
        })
    }
}

motionlab_core::register_plugin!(Segmenter, TemplateSegmenterParams, "template_segmenter");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_segmenter;
    use motionlab_core::{Axis, FrameRate, PointKind};

    /// One marker at 100 Hz moving 10 mm per frame along x for 50 frames, then still: its speed
    /// is 1000 mm/s up to frame 50 and 0 from frame 51 on.
    fn walk_then_stop() -> Motion {
        let positions = (0..100).map(|f: usize| [10.0 * f.min(50) as f64, 0.0, 0.0]).collect();
        Motion::new(
            "walk_then_stop",
            FrameRate::new(100.0).unwrap(),
            Axis::Z,
            PointKind::Marker,
            vec!["m".into()],
            positions,
        )
        .unwrap()
    }

    fn segment(params: &str, motion: &Motion) -> Result<SegmenterOutput> {
        let params: toml::Value = toml::from_str(params).unwrap();
        build_segmenter("template_segmenter", &params)?.segment(motion, &FeatureCache::new())
    }

    #[test]
    fn the_stop_is_the_one_candidate() {
        let out = segment("", &walk_then_stop()).unwrap();
        assert_eq!(out.candidates, [51]);
        assert!(out.traces[0].values[0].is_nan());
        assert_eq!(out.traces[0].values[1..=50], [1000.0; 50]);
        // Above every speed the points are always at rest: nothing ends.
        assert!(
            segment("max_speed_mm_per_s = 2000.0", &walk_then_stop())
                .unwrap()
                .candidates
                .is_empty()
        );
    }

    #[test]
    fn a_bad_threshold_names_its_field() {
        let e = segment("max_speed_mm_per_s = 0.0", &walk_then_stop()).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("max_speed_mm_per_s"))
        );
    }
}
