//! Virtual markers computed from real ones — e.g. a "root" for marker sets that have none
//! (the MoCap Toolbox dance data: the centroid of `Hip_FL Hip_FR Hip_BL Hip_BR`).

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Motion, Point3, Preprocessor, Result};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// When the centroid of several markers is missing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MissingIf {
    /// Missing when any listed marker is missing: the centroid of a subset sits
    /// elsewhere, and its jump would read as root motion (false curvature and path length).
    #[default]
    Any,
    /// Missing only when every listed marker is missing; otherwise the centroid of the valid ones.
    All,
}

/// Adds a virtual marker at the centroid (mean position) of the named markers, appended after the
/// existing points. Use it to make a root for marker sets without one:
/// `{ type = "add_centroid", name = "root", markers = ["Hip_FL", "Hip_FR", "Hip_BL", "Hip_BR"] }`.
///
/// `p_new[i] = (1/n) Σ_k p[i][k]` over the listed markers. Missing samples: with
/// `missing_if = "any"` the new marker is missing at every frame where any listed
/// marker is missing; with `"all"` it is the centroid of the markers valid at that frame and
/// missing only when none is. Nothing is interpolated.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AddCentroidParams {
    /// Name of the new marker (must not exist yet). Required.
    pub name: String,
    /// Markers to average (at least one). Required.
    pub markers: Vec<String>,
    /// `"any"` or `"all"`: when the centroid is missing (see above).
    #[serde(default)]
    pub missing_if: MissingIf,
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct AddCentroid {
    name: String,
    markers: Vec<String>,
    missing_if: MissingIf,
}

impl ParamGuard for AddCentroidParams {
    type Checked = AddCentroid;
    fn check(self) -> Result<AddCentroid> {
        if self.name.trim().is_empty() {
            return Err(Error::new(ErrorKind::InvalidParameter, "must be a non-empty marker name")
                .with_field("name"));
        }
        if self.markers.is_empty() {
            return Err(Error::new(ErrorKind::InvalidParameter, "must list at least one marker")
                .with_field("markers"));
        }
        for (i, m) in self.markers.iter().enumerate() {
            if self.markers[..i].contains(m) {
                return Err(Error::new(
                    ErrorKind::DuplicateName,
                    format!("marker {m:?} is listed twice"),
                )
                .with_field("markers"));
            }
        }
        Ok(AddCentroid { name: self.name, markers: self.markers, missing_if: self.missing_if })
    }
}

impl AddCentroid {
    /// The centroid trajectory (NaN where missing) of the listed markers.
    pub fn centroid(&self, motion: &Motion) -> Result<Vec<Point3>> {
        let idx: Vec<usize> = self
            .markers
            .iter()
            .map(|n| motion.point_index(n).map_err(|e| e.under_field("markers")))
            .collect::<Result<_>>()?;
        Ok((0..motion.n_frames())
            .map(|i| {
                let (mut acc, mut n) = ([0.0; 3], 0usize);
                for &k in &idx {
                    if motion.is_missing(i, k) {
                        if self.missing_if == MissingIf::Any {
                            return [f64::NAN; 3];
                        }
                        continue;
                    }
                    let p = motion.position(i, k);
                    acc = [acc[0] + p[0], acc[1] + p[1], acc[2] + p[2]];
                    n += 1;
                }
                if n == 0 {
                    [f64::NAN; 3]
                } else {
                    let n = n as f64;
                    [acc[0] / n, acc[1] / n, acc[2] / n]
                }
            })
            .collect())
    }
}

impl Preprocessor for AddCentroid {
    fn apply(&self, motion: Motion) -> Result<Motion> {
        if motion.point_names().contains(&self.name) {
            return Err(Error::new(
                ErrorKind::DuplicateName,
                format!(
                    "{} already has a point named {:?}; choose another name",
                    motion.name, self.name
                ),
            )
            .with_field("name"));
        }
        let centroid = self.centroid(&motion)?;
        let m = motion.n_points();
        let mut names = motion.point_names().to_vec();
        names.push(self.name.clone());
        let mut positions = Vec::with_capacity(motion.n_frames() * (m + 1));
        for (i, c) in centroid.into_iter().enumerate() {
            positions.extend_from_slice(motion.frame(i));
            positions.push(c);
        }
        // 2-D image keypoints stay 2-D; the virtual point has no estimator's confidence (NaN).
        let two_d = motion.dimensionality() == motionlab_core::Dimensionality::Two;
        let confidence: Option<Vec<f32>> = motion.confidence().map(|c| {
            c.chunks(m.max(1)).flat_map(|row| row.iter().copied().chain([f32::NAN])).collect()
        });
        let mut out = Motion::new(
            motion.name.clone(),
            motion.frame_rate(),
            motion.up_axis(),
            motion.point_kind(),
            names,
            positions,
        )?;
        // The skeleton's points stay first and in order, so its indices remain valid.
        out.source = motion.source;
        out.format = motion.format;
        out.skeleton = motion.skeleton;
        out.events = motion.events;
        if two_d {
            out = out.into_image_2d();
        }
        if let Some(c) = confidence {
            out = out.with_confidence(c)?;
        }
        Ok(out)
    }
}

motionlab_core::register_plugin!(Preprocessor, AddCentroidParams, "add_centroid");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::build_preprocessor;
    use motionlab_testkit::named_motion;

    fn hips() -> Motion {
        // Four hip markers at the corners of a 200 × 100 mm rectangle moving along x; Hip_BR is
        // missing at frame 1.
        named_motion(3, 60.0, &["Head", "Hip_FL", "Hip_FR", "Hip_BL", "Hip_BR"], |i, k| {
            let x = 10.0 * i as f64;
            match k {
                0 => [x, 0.0, 1700.0],
                1 => [x + 100.0, 50.0, 1000.0],
                2 => [x + 100.0, -50.0, 1000.0],
                3 => [x - 100.0, 50.0, 1000.0],
                _ if i == 1 => [f64::NAN; 3],
                _ => [x - 100.0, -50.0, 1000.0],
            }
        })
    }

    fn params(extra: &str) -> toml::Value {
        toml::from_str(&format!(
            "name = \"root\"\nmarkers = [\"Hip_FL\", \"Hip_FR\", \"Hip_BL\", \"Hip_BR\"]\n{extra}"
        ))
        .unwrap()
    }

    #[test]
    fn centroid_of_the_hips_becomes_a_new_last_marker() {
        let m = build_preprocessor("add_centroid", &params("")).unwrap().apply(hips()).unwrap();
        assert_eq!(m.n_points(), 6);
        let r = m.point_index("root").unwrap();
        assert_eq!(r, 5);
        assert_eq!(m.position(0, r), [0.0, 0.0, 1000.0]);
        assert_eq!(m.position(2, r), [20.0, 0.0, 1000.0]);
        // Default: missing when any hip is missing; the mask agrees with the NaN.
        assert!(m.is_missing(1, r));
        assert_eq!(m.position(1, 0), [10.0, 0.0, 1700.0]); // others untouched
    }

    #[test]
    fn missing_if_all_averages_the_valid_markers() {
        let m = build_preprocessor("add_centroid", &params("missing_if = \"all\""))
            .unwrap()
            .apply(hips())
            .unwrap();
        let p = m.position(1, 5);
        // Mean of (110, 50), (110, −50), (−90, 50): (130/3, 50/3).
        assert!((p[0] - 130.0 / 3.0).abs() < 1e-12 && (p[1] - 50.0 / 3.0).abs() < 1e-12, "{p:?}");
        assert!(!m.is_missing(1, 5));
    }

    #[test]
    fn bad_names_are_reported_with_their_field() {
        let e = build_preprocessor("add_centroid", &params(""))
            .unwrap()
            .apply(hips().select_points(&["Head"]).unwrap())
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
        assert!(e.location().field.as_deref().unwrap_or("").starts_with("markers"), "{e}");
        let taken: toml::Value = toml::from_str("name = \"Head\"\nmarkers = [\"Hip_FL\"]").unwrap();
        let e = build_preprocessor("add_centroid", &taken).unwrap().apply(hips()).unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::DuplicateName, Some("name"))
        );
        let empty: toml::Value = toml::from_str("name = \"r\"\nmarkers = []").unwrap();
        let e = build_preprocessor("add_centroid", &empty).err().unwrap();
        assert_eq!(e.location().field.as_deref(), Some("markers"));
    }
}
