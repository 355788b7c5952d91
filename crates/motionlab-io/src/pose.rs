//! What the video pose-estimation loaders (`openpose`, `coco_keypoints`, `mediapipe`) share:
//! the keypoint layouts, the rule that picks one person per frame, and the step from
//! `(x, y, confidence)` keypoints to a 2-D [`Motion`] with a per-sample confidence.
//!
//! Not a plugin: each loader is its own file; this holds their common rules so that they are
//! stated (and tested) once.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::units::{Axis, FrameRate};
use motionlab_core::{Error, ErrorKind, LoadNotes, Motion, PointKind, Result};

/// OpenPose's BODY_25 keypoints (its default model), in file order.
pub const BODY_25: [&str; 25] = [
    "Nose",
    "Neck",
    "RShoulder",
    "RElbow",
    "RWrist",
    "LShoulder",
    "LElbow",
    "LWrist",
    "MidHip",
    "RHip",
    "RKnee",
    "RAnkle",
    "LHip",
    "LKnee",
    "LAnkle",
    "REye",
    "LEye",
    "REar",
    "LEar",
    "LBigToe",
    "LSmallToe",
    "LHeel",
    "RBigToe",
    "RSmallToe",
    "RHeel",
];

/// OpenPose's experimental BODY_25B keypoints (what Pose2Sim uses), in file order — not the
/// BODY_25 order.
pub const BODY_25B: [&str; 25] = [
    "Nose",
    "LEye",
    "REye",
    "LEar",
    "REar",
    "LShoulder",
    "RShoulder",
    "LElbow",
    "RElbow",
    "LWrist",
    "RWrist",
    "LHip",
    "RHip",
    "LKnee",
    "RKnee",
    "LAnkle",
    "RAnkle",
    "Neck",
    "Head",
    "LBigToe",
    "LSmallToe",
    "LHeel",
    "RBigToe",
    "RSmallToe",
    "RHeel",
];

/// OpenPose's COCO model (18 keypoints, with a neck), in file order.
pub const COCO_18: [&str; 18] = [
    "Nose",
    "Neck",
    "RShoulder",
    "RElbow",
    "RWrist",
    "LShoulder",
    "LElbow",
    "LWrist",
    "RHip",
    "RKnee",
    "RAnkle",
    "LHip",
    "LKnee",
    "LAnkle",
    "REye",
    "LEye",
    "REar",
    "LEar",
];

/// The COCO dataset's 17 person keypoints (`categories[].keypoints` of COCO files).
pub const COCO_17: [&str; 17] = [
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
];

/// MediaPipe's BlazePose 33 pose landmarks, in order.
pub const BLAZEPOSE_33: [&str; 33] = [
    "nose",
    "left_eye_inner",
    "left_eye",
    "left_eye_outer",
    "right_eye_inner",
    "right_eye",
    "right_eye_outer",
    "left_ear",
    "right_ear",
    "mouth_left",
    "mouth_right",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_pinky",
    "right_pinky",
    "left_index",
    "right_index",
    "left_thumb",
    "right_thumb",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
    "left_heel",
    "right_heel",
    "left_foot_index",
    "right_foot_index",
];

/// Which person of a frame with several becomes the motion's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PersonRule {
    /// The person with the highest mean confidence over all their keypoints (an undetected
    /// keypoint counts as 0), in every frame independently; on a tie the first listed.
    #[default]
    HighestMeanConfidence,
    /// The person whose keypoints are nearest (mean pixel distance over the keypoints detected
    /// in both) to the previous chosen person's; the first frame with people, and a frame
    /// sharing no detected keypoint with the previous choice, by highest mean confidence.
    NearestPrevious,
}

/// One detected person: `(x, y, confidence)` per keypoint, as the file gives them.
pub type Person = Vec<[f64; 3]>;

/// Whether a keypoint counts as detected: finite, with a confidence above 0 (OpenPose writes
/// an undetected keypoint `0,0,0`; COCO flags one `v = 0`, whatever filler coordinates it
/// carries) and at least `min_confidence`.
pub fn detected(k: [f64; 3], min_confidence: f64) -> bool {
    k.iter().all(|v| v.is_finite()) && k[2] > 0.0 && k[2] >= min_confidence
}

fn mean_confidence(p: &Person) -> f64 {
    if p.is_empty() {
        return 0.0;
    }
    p.iter().map(|k| if k[2].is_finite() { k[2] } else { 0.0 }).sum::<f64>() / p.len() as f64
}

/// The index of the person `rule` picks among `people` (`None` when there are none), given the
/// previous chosen person's keypoints.
pub fn choose_person(
    people: &[Person],
    rule: PersonRule,
    previous: Option<&Person>,
    min_confidence: f64,
) -> Option<usize> {
    let by_confidence = || {
        let mut best: Option<(usize, f64)> = None;
        for (i, p) in people.iter().enumerate() {
            let c = mean_confidence(p);
            if best.is_none_or(|(_, b)| c > b) {
                best = Some((i, c));
            }
        }
        best.map(|(i, _)| i)
    };
    match (rule, previous) {
        (PersonRule::HighestMeanConfidence, _) | (PersonRule::NearestPrevious, None) => {
            by_confidence()
        }
        (PersonRule::NearestPrevious, Some(prev)) => {
            let mut best: Option<(usize, f64)> = None;
            for (i, p) in people.iter().enumerate() {
                let (mut sum, mut n) = (0.0, 0usize);
                for (a, b) in p.iter().zip(prev) {
                    if detected(*a, min_confidence) && detected(*b, min_confidence) {
                        sum += (a[0] - b[0]).hypot(a[1] - b[1]);
                        n += 1;
                    }
                }
                if n > 0 {
                    let d = sum / n as f64;
                    if best.is_none_or(|(_, b)| d < b) {
                        best = Some((i, d));
                    }
                }
            }
            best.map(|(i, _)| i).or_else(by_confidence)
        }
    }
}

/// The frames' people as one 2-D motion: in each frame the person `rule` picks; keypoints not
/// [`detected`] (and every keypoint of a frame without people) are missing samples. The
/// confidence of each sample is the file's (0 where the frame has no person). `names` gives
/// the keypoints; every person must have that many (the loaders check it with the place).
#[allow(clippy::too_many_arguments)]
pub fn motion_of_people(
    name: String,
    frames: &[Vec<Person>],
    names: Vec<String>,
    rule: PersonRule,
    min_confidence: f64,
    rate: FrameRate,
    mut notes: LoadNotes,
) -> Result<(Motion, Vec<Option<usize>>)> {
    let m = names.len();
    let mut positions = Vec::with_capacity(frames.len() * m);
    let mut confidence = Vec::with_capacity(frames.len() * m);
    let mut chosen = Vec::with_capacity(frames.len());
    let mut previous: Option<&Person> = None;
    let (mut several, mut none, mut low) = (0usize, 0usize, 0usize);
    for people in frames {
        let pick = choose_person(people, rule, previous, min_confidence);
        chosen.push(pick);
        several += usize::from(people.len() > 1);
        match pick {
            Some(i) => {
                let p = &people[i];
                if p.len() != m {
                    return Err(Error::new(
                        ErrorKind::WrongValueCount,
                        format!(
                            "a person of {} keypoints; expected {m} ({})",
                            p.len(),
                            names.join(" ")
                        ),
                    ));
                }
                previous = Some(p);
                for k in p {
                    let ok = detected(*k, min_confidence);
                    if !ok && k[2] > 0.0 && k[2] < min_confidence {
                        low += 1;
                    }
                    positions.push(if ok { [k[0], k[1], 0.0] } else { [f64::NAN; 3] });
                    confidence.push(if k[2].is_finite() { k[2] as f32 } else { 0.0 });
                }
            }
            None => {
                none += 1;
                positions.extend(std::iter::repeat_n([f64::NAN; 3], m));
                confidence.extend(std::iter::repeat_n(0.0_f32, m));
            }
        }
    }
    if frames.is_empty() {
        return Err(Error::new(ErrorKind::EmptySequence, "no frame to read"));
    }
    if several > 0 {
        notes.repairs.push(format!(
            "{several} of {} frames hold several people: one chosen per frame by {}",
            frames.len(),
            match rule {
                PersonRule::HighestMeanConfidence => "highest mean confidence",
                PersonRule::NearestPrevious => "nearness to the previous frame's choice",
            }
        ));
    }
    if none > 0 {
        notes.repairs.push(format!("{none} frames hold no person: every keypoint missing"));
    }
    if low > 0 {
        notes.repairs.push(format!(
            "{low} keypoints below min_confidence = {min_confidence}: read as missing"
        ));
    }
    let mut motion = Motion::new(name, rate, Axis::Y, PointKind::Marker, names, positions)?
        .into_image_2d()
        .with_confidence(confidence)?;
    motion.load_notes = notes;
    Ok((motion, chosen))
}

/// Checks a `min_confidence` parameter (a probability).
pub fn check_min_confidence(v: f64) -> Result<f64> {
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(Error::new(
            ErrorKind::OutOfRange,
            format!("min_confidence = {v}; expected a confidence from 0 to 1"),
        )
        .with_field("min_confidence"))
    }
}

/// The `rate_hz` parameter as a rate; missing (the files of these formats carry no rate) is
/// an error naming the key, so that `inspect` can describe the file at 1 Hz.
pub fn rate_of(rate_hz: Option<f64>, loader: &str) -> Result<FrameRate> {
    match rate_hz {
        Some(hz) => FrameRate::new(hz).map_err(|e| e.with_field("rate_hz")),
        None => Err(Error::new(
            ErrorKind::MissingKey,
            format!(
                "{loader} files do not store a frame rate: give the loader `rate_hz` (the video's frames per second)"
            ),
        )
        .with_field("rate_hz")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn person(c: f64, x: f64) -> Person {
        vec![[x, 10.0, c], [x + 1.0, 20.0, c], [0.0, 0.0, 0.0]]
    }

    #[test]
    fn highest_mean_confidence_counts_undetected_keypoints_as_zero() {
        let a = vec![[1.0, 1.0, 0.9], [0.0, 0.0, 0.0]]; // mean 0.45
        let b = vec![[1.0, 1.0, 0.5], [2.0, 2.0, 0.5]]; // mean 0.5
        assert_eq!(
            choose_person(&[a.clone(), b], PersonRule::HighestMeanConfidence, None, 0.0),
            Some(1)
        );
        assert_eq!(
            choose_person(&[a.clone(), a], PersonRule::HighestMeanConfidence, None, 0.0),
            Some(0),
            "tie: first"
        );
        assert_eq!(choose_person(&[], PersonRule::HighestMeanConfidence, None, 0.0), None);
    }

    #[test]
    fn nearest_previous_follows_the_person_not_the_confidence() {
        let prev = person(0.5, 100.0);
        let near = person(0.3, 103.0);
        let far = person(0.9, 400.0);
        let people = [far.clone(), near];
        assert_eq!(choose_person(&people, PersonRule::NearestPrevious, Some(&prev), 0.0), Some(1));
        assert_eq!(
            choose_person(&people, PersonRule::HighestMeanConfidence, Some(&prev), 0.0),
            Some(0)
        );
        // Nothing in common with the previous choice: by confidence.
        let blind = vec![[0.0; 3]; 3];
        assert_eq!(choose_person(&people, PersonRule::NearestPrevious, Some(&blind), 0.0), Some(0));
    }

    #[test]
    fn undetected_and_low_confidence_keypoints_are_missing_with_their_confidence_kept() {
        let frames = vec![vec![vec![[5.0, 6.0, 0.8], [7.0, 8.0, 0.04], [0.0, 0.0, 0.0]]], vec![]];
        let names = vec!["a".to_string(), "b".into(), "c".into()];
        let (m, chosen) = motion_of_people(
            "t".into(),
            &frames,
            names,
            PersonRule::HighestMeanConfidence,
            0.05,
            FrameRate::new(30.0).unwrap(),
            LoadNotes::default(),
        )
        .unwrap();
        assert_eq!(chosen, vec![Some(0), None]);
        assert_eq!(m.dimensionality(), motionlab_core::Dimensionality::Two);
        assert_eq!(m.position(0, 0), [5.0, 6.0, 0.0]);
        assert!(m.is_missing(0, 1) && m.is_missing(0, 2));
        assert!((0..3).all(|k| m.is_missing(1, k)));
        assert_eq!(m.confidence().unwrap(), &[0.8_f32, 0.04, 0.0, 0.0, 0.0, 0.0]);
        let notes = m.load_notes.repairs.join("\n");
        assert!(notes.contains("1 frames hold no person"), "{notes}");
        assert!(notes.contains("1 keypoints below min_confidence = 0.05"), "{notes}");
        assert!(check_min_confidence(1.5).is_err() && check_min_confidence(0.3).is_ok());
        assert_eq!(
            rate_of(None, "openpose").unwrap_err().location().field.as_deref(),
            Some("rate_hz")
        );
    }
}
