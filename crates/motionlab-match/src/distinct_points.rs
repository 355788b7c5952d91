//! Preprocessor `distinct_points`: each distinct point once, so a sum over points (the
//! multistream distance H, Yabe & Tanaka §3.1.3) weights every body place equally.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Millimetres, Motion, Preprocessor, Result};

/// Keeps one point of every group of **coincident** points and drops the others.
///
/// Skeleton loaders place a joint at the *start* of its bone, so every child of one bone sits
/// at the same place: in a CMU ASF skeleton the root appears four times (`root`, `lhipjoint`,
/// `rhipjoint`, `lowerback`), the thorax's end three times (`lowerneck`, `lclavicle`,
/// `rclavicle`) and each wrist's end twice (`lhand`, `lthumb`; `rhand`, `rthumb`) —
/// 38 joints, 31 distinct places. Summed over all points, the multistream distance
/// `H = Σ_l h_l` then counts the trunk four times as much as a hand; matching after this
/// step counts each distinct place once (use it before `multistream_two_stage`; leaving the
/// step out keeps the old behaviour, every point as loaded).
///
/// **Coincident** (choice): two points coincide when, in **every** frame, both are missing or
/// both are present at most `max_distance_mm` apart — a property of the data, so it works for
/// marker sets and for motions whose skeleton a preprocessor has already dropped (by
/// skeleton offsets alone, a zero-length bone in one frame could not be told from a joint
/// that is merely close). The default `max_distance_mm` accepts the rounding of forward
/// kinematics and no two real markers. From each group the point **first in the motion's order** is kept
/// under its own name (`root`, `lowerneck`, `lhand`, `rhand` above); the others are
/// dropped, the order of the kept points is unchanged.
///
/// Missing samples: a point missing where another is present does not coincide with it, so
/// gaps never merge points; missing samples of kept points stay missing. The skeleton, when
/// the motion has one, is dropped (the kept points no longer hold every joint of it).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DistinctPointsParams {
    /// Largest distance (mm) at which two points still count as the same place, in every frame.
    /// The default is the rounding of forward kinematics; no two real markers are that close.
    #[serde(default = "default_max_distance")]
    pub max_distance_mm: Millimetres,
}

fn default_max_distance() -> Millimetres {
    Millimetres(1e-6)
}

/// The validated stage.
#[derive(Clone, Copy, Debug)]
pub struct DistinctPoints {
    max_distance_mm: f64,
}

impl ParamGuard for DistinctPointsParams {
    type Checked = DistinctPoints;
    fn check(self) -> Result<DistinctPoints> {
        let d = self.max_distance_mm.0;
        if !(d.is_finite() && d >= 0.0) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!("must be a finite distance >= 0 mm, found {d}"),
            )
            .with_field("max_distance_mm"));
        }
        Ok(DistinctPoints { max_distance_mm: d })
    }
}

impl DistinctPoints {
    /// Groups of coincident points as indices, each group in the motion's order, groups in the
    /// order of their first point.
    pub fn groups(&self, motion: &Motion) -> Vec<Vec<usize>> {
        let m = motion.n_points();
        let limit = self.max_distance_mm * self.max_distance_mm;
        let same = |a: usize, b: usize| {
            (0..motion.n_frames()).all(|i| {
                match (motion.is_missing(i, a), motion.is_missing(i, b)) {
                    (true, true) => true,
                    (false, false) => {
                        let (p, q) = (motion.position(i, a), motion.position(i, b));
                        (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)
                            <= limit
                    }
                    _ => false,
                }
            })
        };
        let mut group_of: Vec<Option<usize>> = vec![None; m];
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for k in 0..m {
            if group_of[k].is_some() {
                continue;
            }
            let g = groups.len();
            group_of[k] = Some(g);
            let mut members = vec![k];
            for (j, slot) in group_of.iter_mut().enumerate().skip(k + 1) {
                if slot.is_none() && same(k, j) {
                    *slot = Some(g);
                    members.push(j);
                }
            }
            groups.push(members);
        }
        groups
    }
}

impl Preprocessor for DistinctPoints {
    fn apply(&self, motion: Motion) -> Result<Motion> {
        let groups = self.groups(&motion);
        if groups.len() == motion.n_points() {
            let mut out = motion;
            out.skeleton = None;
            return Ok(out);
        }
        let keep: Vec<&str> = groups.iter().map(|g| motion.point_names()[g[0]].as_str()).collect();
        motion.select_points(&keep)
    }
}

motionlab_core::register_plugin!(Preprocessor, DistinctPointsParams, "distinct_points");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_loader, build_preprocessor, default_params};
    use motionlab_testkit::named_motion;

    fn stage(toml_text: &str) -> Box<dyn Preprocessor> {
        let v: toml::Value = toml::from_str(toml_text).unwrap();
        build_preprocessor("distinct_points", &v).unwrap()
    }

    #[test]
    fn coincident_points_are_kept_once_under_the_first_name() {
        // a and c coincide in every frame; b coincides with a only at frame 0; d is missing
        // where e is present (never merged), e coincides with nothing else.
        let m = named_motion(4, 10.0, &["a", "b", "c", "d", "e"], |i, k| {
            let t = i as f64;
            match k {
                0 | 2 => [t, 0.0, 0.0],
                1 => [t * t, 0.0, 0.0],
                3 if i == 2 => [f64::NAN; 3],
                _ => [5.0, 5.0, 5.0],
            }
        });
        let out = stage("").apply(m.clone()).unwrap();
        assert_eq!(out.point_names(), ["a", "b", "d", "e"]);
        assert_eq!(out.position(3, 0), [3.0, 0.0, 0.0]);
        assert!(out.is_missing(2, 2), "a kept point keeps its gaps");
        // A looser tolerance merges b into a (|t² − t| ≤ 6 mm over frames 0..4).
        assert_eq!(stage("max_distance_mm = 6.0").apply(m).unwrap().point_names(), ["a", "d", "e"]);
    }

    #[test]
    fn a_cmu_skeleton_has_31_distinct_places_among_38_joints() {
        let path = motionlab_testkit::data_path("mocap6/amc/13_29.amc.gz");
        let take = build_loader("asf_amc", &default_params())
            .unwrap()
            .load(&path)
            .unwrap()
            .slice_frames(0, 200)
            .unwrap();
        assert_eq!(take.n_points(), 38);
        let s = DistinctPointsParams { max_distance_mm: default_max_distance() }.check().unwrap();
        let names =
            |g: &Vec<usize>| g.iter().map(|&k| take.point_names()[k].as_str()).collect::<Vec<_>>();
        let merged: Vec<Vec<&str>> =
            s.groups(&take).iter().filter(|g| g.len() > 1).map(names).collect();
        assert_eq!(
            merged,
            [
                vec!["root", "lhipjoint", "rhipjoint", "lowerback"],
                vec!["lowerneck", "lclavicle", "rclavicle"],
                vec!["lhand", "lthumb"],
                vec!["rhand", "rthumb"],
            ]
        );
        let out =
            build_preprocessor("distinct_points", &default_params()).unwrap().apply(take).unwrap();
        assert_eq!(out.n_points(), 31);
        assert!(out.skeleton.is_none());
    }

    #[test]
    fn a_bad_tolerance_is_an_error_naming_the_field() {
        let v: toml::Value = toml::from_str("max_distance_mm = -1.0").unwrap();
        let e = build_preprocessor("distinct_points", &v).err().unwrap();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::OutOfRange, Some("max_distance_mm"))
        );
    }
}
