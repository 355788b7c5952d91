//! `template_extractor`: the height of the points' centroid, per frame.
//!
//! Written by `motionlab plugin new` as a working placeholder in the shape every plugin has
//! (CONTRIBUTING.md, "A plugin is one file"): a params struct whose doc comment is what
//! `motionlab describe template_extractor` prints, a `ParamGuard` that validates it into the
//! stage that runs, the `FeatureExtractor` impl, one `register_plugin!` line and a known-answer
//! test. Replace the feature, its doc comment and its test together.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Error, ErrorKind, FeatureCache, FeatureExtractor, FeatureSet, Motion, Result, Trace,
};

/// The height of the points' centroid above the lab floor, per frame (trace
/// `centroid_height_mm`, mm along the motion's up axis).
///
/// Missing samples: the centroid of a frame is over its present points; a frame with fewer
/// than `min_points` of them has no height (NaN).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TemplateExtractorParams {
    /// The fewest present points (≥ 1) a frame needs to have a height.
    #[serde(default = "default_min_points")]
    pub min_points: usize,
}

fn default_min_points() -> usize {
    1
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct TemplateExtractor {
    min_points: usize,
}

impl ParamGuard for TemplateExtractorParams {
    type Checked = TemplateExtractor;
    fn check(self) -> Result<TemplateExtractor> {
        if self.min_points == 0 {
            return Err(Error::new(ErrorKind::OutOfRange, "expected at least 1 point, found 0")
                .with_field("min_points"));
        }
        Ok(TemplateExtractor { min_points: self.min_points })
    }
}

impl FeatureExtractor for TemplateExtractor {
    fn extract(&self, motion: &Motion, _cache: &FeatureCache) -> Result<FeatureSet> {
        let heights = (0..motion.n_frames())
            .map(|f| {
                let present: Vec<f64> = (0..motion.n_points())
                    .filter(|&p| !motion.is_missing(f, p))
                    .map(|p| motion.height(motion.position(f, p)))
                    .collect();
                if present.len() < self.min_points {
                    f64::NAN
                } else {
                    present.iter().sum::<f64>() / present.len() as f64
                }
            })
            .collect();
        Ok(FeatureSet {
            traces: vec![Trace::new("centroid_height_mm", "mm", heights)],
            labels: Vec::new(),
        })
    }
}

motionlab_core::register_plugin!(FeatureExtractor, TemplateExtractorParams, "template_extractor");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_feature_extractor;
    use motionlab_core::{Axis, FrameRate, PointKind};

    /// Two markers, Z up, at heights 100 + f and 300 + f mm in frame f; the second missing in
    /// frame 2.
    fn two_rising_markers() -> Motion {
        let mut positions: Vec<[f64; 3]> = (0..4)
            .flat_map(|f| [[0.0, 0.0, 100.0 + f as f64], [50.0, 0.0, 300.0 + f as f64]])
            .collect();
        positions[2 * 2 + 1] = [f64::NAN; 3];
        Motion::new(
            "rising",
            FrameRate::new(100.0).unwrap(),
            Axis::Z,
            PointKind::Marker,
            vec!["a".into(), "b".into()],
            positions,
        )
        .unwrap()
    }

    fn heights(params: &str) -> Result<Vec<f64>> {
        let params: toml::Value = toml::from_str(params).unwrap();
        let set = build_feature_extractor("template_extractor", &params)?
            .extract(&two_rising_markers(), &FeatureCache::new())?;
        Ok(set.traces[0].values.clone())
    }

    #[test]
    fn the_centroid_height_is_the_mean_of_the_present_points() {
        assert_eq!(heights("").unwrap(), [200.0, 201.0, 102.0, 203.0]);
        let two = heights("min_points = 2").unwrap();
        assert!(two[2].is_nan() && two[3] == 203.0, "{two:?}");
    }

    #[test]
    fn a_bad_parameter_names_its_field() {
        let e = heights("min_points = 0").unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("min_points"))
        );
    }
}
