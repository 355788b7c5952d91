//! Marker trajectories taken out of a [`Motion`] for the DP kernels, refusing missing samples.
//!
//! The matchers look markers up **by name** in the model and in the target, so the two motions
//! may list their points in different orders; a name the target lacks is an error.

use motionlab_core::{Error, ErrorKind, Location, Motion, Result};

use crate::dp::Trajectory3;

/// The structure-of-arrays trajectory of each named point, in the order of `names`.
///
/// Fails with [`ErrorKind::UnknownName`] for a name the motion lacks, with
/// [`ErrorKind::EmptySequence`] for a motion without frames, and with
/// [`ErrorKind::MissingData`] at the first missing sample (the DP has no rule for a gap: a
/// missing sample has no distance to anything).
pub fn trajectories(
    motion: &Motion,
    names: &[String],
    role: &str,
    stage: &str,
) -> Result<Vec<Trajectory3>> {
    motion.require_frames(1, stage)?;
    let indices: Vec<usize> = names.iter().map(|n| motion.point_index(n)).collect::<Result<_>>()?;
    let mut out: Vec<Trajectory3> =
        indices.iter().map(|_| Trajectory3::with_capacity(motion.n_frames())).collect();
    for frame in 0..motion.n_frames() {
        let points = motion.frame(frame);
        let missing = motion.frame_missing(frame);
        for (traj, (&k, name)) in out.iter_mut().zip(indices.iter().zip(names)) {
            if missing[k] {
                let loc = motion.source.as_ref().map(Location::file).unwrap_or_default();
                return Err(Error::new(
                    ErrorKind::MissingData,
                    format!(
                        "{stage} refuses missing samples: marker {name:?} of the {role} {:?} is missing at frame {frame} \
                         ({} missing samples in all); fill gaps first (preprocessor `fill_gaps`)",
                        motion.name,
                        motion.missing_count()
                    ),
                )
                .with_location(loc.field(name.clone())));
            }
            traj.push(points[k]);
        }
    }
    Ok(out)
}

/// Checks a list of point names from parameters: not empty, no blank or repeated name.
pub fn check_names(names: &[String], field: &str) -> Result<()> {
    if names.is_empty() {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            "expected at least one marker name, found an empty list",
        )
        .with_field(field));
    }
    let mut seen = std::collections::HashSet::new();
    for n in names {
        if n.trim().is_empty() {
            return Err(Error::new(ErrorKind::InvalidParameter, "marker names must not be blank")
                .with_field(field));
        }
        if !seen.insert(n.as_str()) {
            return Err(Error::new(
                ErrorKind::DuplicateName,
                format!("marker {n:?} is listed twice"),
            )
            .with_field(field));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_testkit::{motion_from_fn, named_motion};

    #[test]
    fn picks_points_by_name_in_the_requested_order() {
        let m = named_motion(3, 10.0, &["a", "b"], |i, k| [i as f64, k as f64, 0.0]);
        let t = trajectories(&m, &["b".into(), "a".into()], "model", "test").unwrap();
        assert_eq!(t[0].x, vec![0.0, 1.0, 2.0]);
        assert_eq!(t[0].y, vec![1.0, 1.0, 1.0]);
        assert_eq!(t[1].y, vec![0.0, 0.0, 0.0]);
        let e = trajectories(&m, &["c".into()], "model", "test").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
    }

    #[test]
    fn a_missing_sample_is_refused_naming_marker_and_frame() {
        let m = motion_from_fn(
            4,
            10.0,
            2,
            |i, k| if (i, k) == (2, 1) { [f64::NAN; 3] } else { [0.0; 3] },
        );
        let e = trajectories(&m, &["m0".into(), "m1".into()], "target", "multistream_two_stage")
            .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::MissingData);
        assert_eq!(e.location().field.as_deref(), Some("m1"));
        let msg = e.to_string();
        assert!(
            msg.contains("frame 2") && msg.contains("fill_gaps") && msg.contains("target"),
            "{msg}"
        );
        // The same motion is fine when only the complete marker is asked for.
        assert!(trajectories(&m, &["m0".into()], "target", "x").is_ok());
    }

    #[test]
    fn names_must_be_present_and_distinct() {
        assert!(check_names(&[], "points").is_err());
        let e = check_names(&["a".into(), "a".into()], "points").unwrap_err();
        assert_eq!(
            (e.kind(), e.location().field.as_deref()),
            (ErrorKind::DuplicateName, Some("points"))
        );
        assert!(check_names(&[" ".into()], "points").is_err());
        assert!(check_names(&["a".into(), "b".into()], "points").is_ok());
    }
}
