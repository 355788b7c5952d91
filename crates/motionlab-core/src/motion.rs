//! [`Motion`]: what every loader produces and every stage reads.
//!
//! Positions are world coordinates in **millimetres**, stored frame-major (`F × M`), with an
//! explicit up axis. A missing sample (occluded marker, residual < 0 in C3D, NaN in TSV) is
//! flagged in the missing mask **and** stored as NaN, so a stage that forgets to check the mask
//! propagates NaN instead of computing a silently wrong number.
//!
//! A motion may also carry [`Channels`] — signals sampled at its frame rate besides the
//! positions. A channel file (a TSSB series, a CSV of sensor values) loads as a motion with
//! channels and no points ([`Motion::from_channels`]); stages that need points say so when
//! they meet one.
//!
//! A motion knows its [`Dimensionality`]: 3-D world positions in mm (every marker and
//! skeleton format), or 2-D image positions in pixels (video pose estimation: OpenPose, COCO
//! keypoints, MediaPipe), stored as `[x, y, 0]`. It may carry a per-sample confidence
//! (a pose estimator's score, 0–1). Stages that need depth (hull volumes, joint angles, the
//! floor plane) say so ([`crate::Segmenter::accepts_2d`]) and are refused 2-D datasets when an
//! experiment is validated; [`Motion::require_3d`] is the same check at run time.

use std::path::PathBuf;

use crate::channels::Channels;
use crate::skeleton::SkeletonMotion;
use crate::units::{Axis, FrameRate, LengthUnit, Seconds};
use crate::{Error, ErrorKind, Location, Result};

/// A 3-D point in millimetres.
pub type Point3 = [f64; 3];

/// Whether the points of a motion are physical markers or joint centres from a skeleton.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PointKind {
    Marker,
    Joint,
}

/// Whether a motion's positions are 3-D world coordinates (mm) or 2-D image coordinates
/// (pixels, stored as `[x, y, 0]`), as video pose estimators write them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Dimensionality {
    /// World coordinates, mm.
    #[default]
    #[serde(rename = "3d")]
    Three,
    /// Image coordinates, pixels (x right, y down); the third coordinate is 0.
    #[serde(rename = "2d")]
    Two,
}

impl Dimensionality {
    /// The unit of the positions: `mm` or `px`.
    pub fn length_unit(self) -> &'static str {
        match self {
            Dimensionality::Three => "mm",
            Dimensionality::Two => "px",
        }
    }
    /// `3-D (mm)` / `2-D image (px)`, for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Dimensionality::Three => "3-D (mm)",
            Dimensionality::Two => "2-D image (px)",
        }
    }
}

/// An annotated instant in a recording (C3D `EVENT` parameters, e.g. a foot strike).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Event {
    /// `Foot Strike`, `Foot Off`, …
    pub label: String,
    /// `Left`, `Right`, `General`, …
    pub context: String,
    /// Time as stored in the file (seconds from the start of the capture).
    pub time: Seconds,
    /// Fractional frame index into this motion's frames (0 = the first stored frame).
    pub frame: f64,
}

/// What a loader knew or decided about a file beyond its numbers: the unit its lengths were
/// in, and every repair it made to read a file that departs from its format's letter but that
/// other readers open (a renamed duplicate label, a truncated unit string). `motionlab inspect`
/// prints both; a run's `provenance.json` lists the repairs of each input.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LoadNotes {
    /// The unit of the file's lengths (positions are mm whatever it was); `None` when the
    /// loader does not say.
    pub length_unit: Option<LengthUnit>,
    /// How `length_unit` was known, for people: `POINT:UNITS "mm"`, `inferred from the
    /// first frame: 59.66 units tall along y`.
    pub length_unit_from: String,
    /// One line per repair, in the order the loader made them (a strict loader refuses them).
    pub repairs: Vec<String>,
}

/// A motion-capture recording: `n_frames` frames of `point_names.len()` points, and of its
/// channels when it has any (a channel file's motion has channels and no points).
#[derive(Clone, Debug)]
pub struct Motion {
    /// A short name for reports (file stem unless a dataset renames it).
    pub name: String,
    /// The file it was loaded from, when it was.
    pub source: Option<PathBuf>,
    /// The loader that read it (`bvh`, `c3d`, …).
    pub format: String,
    frame_rate: FrameRate,
    up_axis: Axis,
    point_kind: PointKind,
    point_names: Vec<String>,
    positions: Vec<Point3>,
    missing: Vec<bool>,
    n_frames: usize,
    dimensionality: Dimensionality,
    /// Per-sample confidence (frame-major like the positions), when the source gives one.
    confidence: Option<Vec<f32>>,
    /// Present when the source has a skeleton (BVH, ASF/AMC): hierarchy, channel values and
    /// per-frame local rotations. `point_names` are then its joints, in skeleton order.
    pub skeleton: Option<SkeletonMotion>,
    /// Annotated events (C3D), sorted by time.
    pub events: Vec<Event>,
    /// Signals at the frame rate besides the positions (one sample per frame); empty for a
    /// marker or skeleton file.
    channels: Channels,
    /// The loader's length unit and repairs ([`LoadNotes`]); empty for a motion not loaded
    /// from a file.
    pub load_notes: LoadNotes,
}

impl Motion {
    /// Builds a motion from frame-major positions (`positions[frame * M + point]`, mm).
    ///
    /// Non-finite coordinates mark the sample missing (and are normalised to NaN). Fails when
    /// the buffer length is not `n_frames × M` or a point name repeats.
    pub fn new(
        name: impl Into<String>,
        frame_rate: FrameRate,
        up_axis: Axis,
        point_kind: PointKind,
        point_names: Vec<String>,
        mut positions: Vec<Point3>,
    ) -> Result<Self> {
        let m = point_names.len();
        if m == 0 {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                "a motion needs at least one marker or joint",
            ));
        }
        if !positions.len().is_multiple_of(m) {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{} positions is not a whole number of frames of {m} points",
                    positions.len()
                ),
            ));
        }
        let mut seen = std::collections::HashSet::with_capacity(m);
        for n in &point_names {
            if !seen.insert(n.as_str()) {
                return Err(Error::new(
                    ErrorKind::DuplicateName,
                    format!("point name {n:?} appears twice"),
                ));
            }
        }
        let n_frames = positions.len() / m;
        let missing: Vec<bool> = positions
            .iter_mut()
            .map(|p| {
                let gone = !p.iter().all(|c| c.is_finite());
                if gone {
                    *p = [f64::NAN; 3];
                }
                gone
            })
            .collect();
        Ok(Motion {
            name: name.into(),
            source: None,
            format: String::new(),
            frame_rate,
            up_axis,
            point_kind,
            point_names,
            positions,
            missing,
            n_frames,
            dimensionality: Dimensionality::Three,
            confidence: None,
            skeleton: None,
            events: Vec::new(),
            channels: Channels::default(),
            load_notes: LoadNotes::default(),
        })
    }

    /// A motion of channels only (a channel file: no points), one frame per sample.
    pub fn from_channels(
        name: impl Into<String>,
        frame_rate: FrameRate,
        channels: Channels,
    ) -> Result<Self> {
        if channels.is_empty() {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                "a motion needs at least one marker, joint or channel",
            ));
        }
        Ok(Motion {
            name: name.into(),
            source: None,
            format: String::new(),
            frame_rate,
            up_axis: Axis::Y,
            point_kind: PointKind::Marker,
            point_names: Vec::new(),
            positions: Vec::new(),
            missing: Vec::new(),
            n_frames: channels.n_samples(),
            dimensionality: Dimensionality::Three,
            confidence: None,
            skeleton: None,
            events: Vec::new(),
            channels,
            load_notes: LoadNotes::default(),
        })
    }

    /// A sequence known only by its length and frame rate: no points and no channels. What
    /// scoring boundary frames reads (an evaluator on frames found by any library, given as
    /// a rate and a length); no stage that reads positions or channels has anything to read in
    /// it. Fails on zero frames.
    pub fn timeline(
        name: impl Into<String>,
        frame_rate: FrameRate,
        n_frames: usize,
    ) -> Result<Self> {
        if n_frames == 0 {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                "a sequence needs at least one frame",
            )
            .with_field("n_frames"));
        }
        Ok(Motion {
            name: name.into(),
            source: None,
            format: String::new(),
            frame_rate,
            up_axis: Axis::Y,
            point_kind: PointKind::Marker,
            point_names: Vec::new(),
            positions: Vec::new(),
            missing: Vec::new(),
            n_frames,
            dimensionality: Dimensionality::Three,
            confidence: None,
            skeleton: None,
            events: Vec::new(),
            channels: Channels::default(),
            load_notes: LoadNotes::default(),
        })
    }

    /// The motion as 2-D image positions in pixels: the third coordinate of every sample
    /// present is set to 0 (a 2-D source has none).
    pub fn into_image_2d(mut self) -> Self {
        for p in &mut self.positions {
            if p[2].is_finite() {
                p[2] = 0.0;
            }
        }
        self.dimensionality = Dimensionality::Two;
        self
    }

    /// The motion with a per-sample confidence (frame-major, one per position); fails unless
    /// there is one value per sample.
    pub fn with_confidence(mut self, confidence: Vec<f32>) -> Result<Self> {
        if confidence.len() != self.positions.len() {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{} confidence values for {} samples ({})",
                    confidence.len(),
                    self.positions.len(),
                    self.name
                ),
            ));
        }
        self.confidence = Some(confidence);
        Ok(self)
    }

    /// 3-D world positions (mm) or 2-D image positions (px).
    pub fn dimensionality(&self) -> Dimensionality {
        self.dimensionality
    }

    /// The unit of the positions (`mm` or `px`), for trace names and labels.
    pub fn length_unit(&self) -> &'static str {
        self.dimensionality.length_unit()
    }

    /// Per-sample confidence, frame-major, when the source gave one.
    pub fn confidence(&self) -> Option<&[f32]> {
        self.confidence.as_deref()
    }

    /// Fails with [`ErrorKind::Mismatch`] naming the stage when the motion is 2-D, for stages
    /// that need depth (the same check validation makes from the loader).
    pub fn require_3d(&self, stage: &str) -> Result<()> {
        if self.dimensionality == Dimensionality::Two {
            let loc = self.source.as_ref().map(Location::file).unwrap_or_default();
            Err(Error::new(
                ErrorKind::Mismatch,
                format!(
                    "{stage} needs 3-D positions, and {} is 2-D image positions (px)",
                    self.name
                ),
            )
            .with_location(loc))
        } else {
            Ok(())
        }
    }

    /// The motion with these channels (replacing any it had); fails unless there is one sample
    /// per frame.
    pub fn with_channels(mut self, channels: Channels) -> Result<Self> {
        if channels.n_samples() != self.n_frames {
            return Err(Error::new(
                ErrorKind::WrongValueCount,
                format!(
                    "{} channel samples for a motion of {} frames ({})",
                    channels.n_samples(),
                    self.n_frames,
                    self.name
                ),
            ));
        }
        self.channels = channels;
        Ok(self)
    }

    /// The channels (empty for a marker or skeleton file).
    pub fn channels(&self) -> &Channels {
        &self.channels
    }

    pub fn with_source(mut self, source: impl Into<PathBuf>, format: impl Into<String>) -> Self {
        self.source = Some(source.into());
        self.format = format.into();
        self
    }

    pub fn frame_rate(&self) -> FrameRate {
        self.frame_rate
    }
    pub fn up_axis(&self) -> Axis {
        self.up_axis
    }
    pub fn point_kind(&self) -> PointKind {
        self.point_kind
    }
    pub fn n_frames(&self) -> usize {
        self.n_frames
    }
    pub fn n_points(&self) -> usize {
        self.point_names.len()
    }
    pub fn point_names(&self) -> &[String] {
        &self.point_names
    }
    /// Duration from the first to one past the last frame.
    pub fn duration(&self) -> Seconds {
        self.frame_rate.frame_to_seconds(self.n_frames)
    }
    /// All positions, frame-major.
    pub fn positions(&self) -> &[Point3] {
        &self.positions
    }
    /// Mutable positions for preprocessing stages. Call [`Motion::refresh_missing`] after
    /// writing NaN or filling gaps so the mask stays true.
    pub fn positions_mut(&mut self) -> &mut [Point3] {
        &mut self.positions
    }
    /// Recomputes the missing mask from the positions (non-finite = missing).
    pub fn refresh_missing(&mut self) {
        for (p, m) in self.positions.iter_mut().zip(self.missing.iter_mut()) {
            *m = !p.iter().all(|c| c.is_finite());
            if *m {
                *p = [f64::NAN; 3];
            }
        }
    }
    /// The positions of every point at one frame.
    pub fn frame(&self, frame: usize) -> &[Point3] {
        let m = self.n_points();
        &self.positions[frame * m..(frame + 1) * m]
    }
    /// The missing flags of every point at one frame.
    pub fn frame_missing(&self, frame: usize) -> &[bool] {
        let m = self.n_points();
        &self.missing[frame * m..(frame + 1) * m]
    }
    pub fn position(&self, frame: usize, point: usize) -> Point3 {
        self.positions[frame * self.n_points() + point]
    }
    pub fn is_missing(&self, frame: usize, point: usize) -> bool {
        self.missing[frame * self.n_points() + point]
    }
    /// The missing mask, frame-major like the positions.
    pub fn missing_mask(&self) -> &[bool] {
        &self.missing
    }
    /// Number of missing point samples over the whole motion.
    pub fn missing_count(&self) -> usize {
        self.missing.iter().filter(|m| **m).count()
    }
    /// One point's trajectory over all frames.
    pub fn trajectory(&self, point: usize) -> impl ExactSizeIterator<Item = Point3> + '_ {
        let m = self.n_points();
        (0..self.n_frames).map(move |f| self.positions[f * m + point])
    }
    /// Index of a named point; the error names the file and lists what exists.
    pub fn point_index(&self, name: &str) -> Result<usize> {
        self.point_names.iter().position(|n| n == name).ok_or_else(|| {
            let close =
                crate::registry::closest_names(name, self.point_names.iter().map(String::as_str));
            let hint = if close.is_empty() {
                String::new()
            } else {
                format!(" (closest: {})", close.join(", "))
            };
            let loc = match &self.source {
                Some(s) => Location::file(s),
                None => Location::default(),
            };
            Error::new(
                ErrorKind::UnknownName,
                format!("no marker or joint named {name:?} in {}{hint}", self.name),
            )
            .with_location(loc.field(name))
        })
    }
    /// The floor-plane coordinates of a point (drops the up axis; keeps the other two in order).
    pub fn horizontal(&self, p: Point3) -> [f64; 2] {
        let [a, b] = self.up_axis.others();
        [p[a], p[b]]
    }
    /// Height of a point above the origin along the up axis.
    pub fn height(&self, p: Point3) -> f64 {
        p[self.up_axis.index()]
    }
    /// A copy holding frames `start..end` (events and skeleton channels cut alike).
    pub fn slice_frames(&self, start: usize, end: usize) -> Result<Motion> {
        if start >= end || end > self.n_frames {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                format!(
                    "frame range {start}..{end} is empty or outside 0..{} of {}",
                    self.n_frames, self.name
                ),
            ));
        }
        let m = self.n_points();
        let mut out = self.clone();
        out.positions = self.positions[start * m..end * m].to_vec();
        out.missing = self.missing[start * m..end * m].to_vec();
        out.confidence = self.confidence.as_ref().map(|c| c[start * m..end * m].to_vec());
        out.n_frames = end - start;
        if !self.channels.is_empty() {
            out.channels = self.channels.slice_samples(start, end);
        }
        out.skeleton = self.skeleton.as_ref().map(|s| s.slice_frames(start, end));
        out.events = self
            .events
            .iter()
            .filter(|e| e.frame >= start as f64 && e.frame < end as f64)
            .map(|e| Event { frame: e.frame - start as f64, ..e.clone() })
            .collect();
        Ok(out)
    }
    /// A copy holding only the named points, in the given order.
    pub fn select_points(&self, names: &[impl AsRef<str>]) -> Result<Motion> {
        let idx: Vec<usize> =
            names.iter().map(|n| self.point_index(n.as_ref())).collect::<Result<_>>()?;
        let m = self.n_points();
        let mut positions = Vec::with_capacity(self.n_frames * idx.len());
        for f in 0..self.n_frames {
            positions.extend(idx.iter().map(|&k| self.positions[f * m + k]));
        }
        let mut out = Motion::new(
            self.name.clone(),
            self.frame_rate,
            self.up_axis,
            self.point_kind,
            idx.iter().map(|&k| self.point_names[k].clone()).collect(),
            positions,
        )?;
        out.source = self.source.clone();
        out.format = self.format.clone();
        out.events = self.events.clone();
        out.channels = self.channels.clone();
        out.load_notes = self.load_notes.clone();
        out.dimensionality = self.dimensionality;
        out.confidence = self.confidence.as_ref().map(|c| {
            (0..self.n_frames).flat_map(|f| idx.iter().map(move |&k| c[f * m + k])).collect()
        });
        Ok(out)
    }
    /// Fails with [`ErrorKind::EmptySequence`] naming the stage when the motion has no points
    /// (a channel file), for stages that read positions.
    pub fn require_points(&self, stage: &str) -> Result<()> {
        if self.point_names.is_empty() {
            let loc = self.source.as_ref().map(Location::file).unwrap_or_default();
            Err(Error::new(
                ErrorKind::EmptySequence,
                format!("{stage} reads marker or joint positions, and {} has none (only the channels {})", self.name, self.channels.names().join(", ")),
            )
            .with_location(loc))
        } else {
            Ok(())
        }
    }
    /// The channels, or [`ErrorKind::EmptySequence`] naming the stage when there are none (a
    /// marker or skeleton file given to a stage that reads channels without features).
    pub fn require_channels(&self, stage: &str) -> Result<&Channels> {
        if self.channels.is_empty() {
            let loc = self.source.as_ref().map(Location::file).unwrap_or_default();
            Err(Error::new(
                ErrorKind::EmptySequence,
                format!("{stage} reads channels, and {} has none: load a channel file, or give the segmenter `input = {{ features = … }}`", self.name),
            )
            .with_location(loc))
        } else {
            Ok(&self.channels)
        }
    }
    /// Fails with [`ErrorKind::EmptySequence`] when the motion has fewer than `min_frames` frames.
    pub fn require_frames(&self, min_frames: usize, stage: &str) -> Result<()> {
        if self.n_frames < min_frames {
            let loc = self.source.as_ref().map(Location::file).unwrap_or_default();
            Err(Error::new(
                ErrorKind::EmptySequence,
                format!(
                    "{stage} needs at least {min_frames} frames, {} has {}",
                    self.name, self.n_frames
                ),
            )
            .with_location(loc))
        } else {
            Ok(())
        }
    }
    /// Fails with [`ErrorKind::MissingData`] naming the first missing sample, for stages that
    /// refuse gaps (they say so in their docs).
    pub fn require_complete(&self, stage: &str) -> Result<()> {
        match self.missing.iter().position(|m| *m) {
            None => Ok(()),
            Some(i) => {
                let m = self.n_points();
                let loc = self.source.as_ref().map(Location::file).unwrap_or_default();
                Err(Error::new(
                    ErrorKind::MissingData,
                    format!(
                        "{stage} refuses missing samples: {} has {} (first: marker {:?} at frame {}); fill gaps first (preprocessor `fill_gaps`)",
                        self.name,
                        self.missing_count(),
                        self.point_names[i % m],
                        i / m
                    ),
                )
                .with_location(loc.field(self.point_names[i % m].clone())))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_point_motion() -> Motion {
        let rate = FrameRate::new(10.0).unwrap();
        let pos = vec![
            [0.0, 0.0, 0.0],
            [1.0, 2.0, 3.0],
            [1.0, 0.0, 0.0],
            [f64::INFINITY, 2.0, 3.0],
            [2.0, 0.0, 0.0],
            [1.0, 2.0, 3.0],
        ];
        Motion::new("t", rate, Axis::Z, PointKind::Marker, vec!["a".into(), "b".into()], pos)
            .unwrap()
    }

    #[test]
    fn a_timeline_has_its_length_and_rate_and_nothing_to_read() {
        let rate = FrameRate::new(250.0).unwrap();
        let m = Motion::timeline("s", rate, 1200).unwrap();
        assert_eq!((m.n_frames(), m.frame_rate().hz()), (1200, 250.0));
        assert_eq!((m.n_points(), m.channels().n_channels(), m.missing_count()), (0, 0, 0));
        assert!(m.positions().is_empty());
        let e = Motion::timeline("s", rate, 0).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::EmptySequence);
    }

    #[test]
    fn non_finite_positions_are_missing_and_nan() {
        let m = two_point_motion();
        assert_eq!(m.n_frames(), 3);
        assert_eq!(m.missing_count(), 1);
        assert!(m.is_missing(1, 1));
        assert!(m.position(1, 1)[0].is_nan());
        assert!(m.require_complete("test").is_err());
    }

    #[test]
    fn wrong_buffer_length_and_duplicate_names_are_errors() {
        let rate = FrameRate::new(10.0).unwrap();
        let e = Motion::new(
            "t",
            rate,
            Axis::Y,
            PointKind::Marker,
            vec!["a".into(), "b".into()],
            vec![[0.0; 3]; 3],
        )
        .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongValueCount);
        let e = Motion::new(
            "t",
            rate,
            Axis::Y,
            PointKind::Marker,
            vec!["a".into(), "a".into()],
            vec![[0.0; 3]; 2],
        )
        .unwrap_err();
        assert_eq!(e.kind(), ErrorKind::DuplicateName);
    }

    #[test]
    fn slicing_and_selecting_keep_values() {
        let m = two_point_motion();
        let s = m.slice_frames(1, 3).unwrap();
        assert_eq!(s.n_frames(), 2);
        assert_eq!(s.position(1, 0), [2.0, 0.0, 0.0]);
        let b = m.select_points(&["b"]).unwrap();
        assert_eq!(b.n_points(), 1);
        assert_eq!(b.missing_count(), 1);
        assert!(m.slice_frames(2, 2).is_err());
        let e = m.point_index("c").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);
    }

    #[test]
    fn a_2d_motion_keeps_its_dimensionality_and_confidence_through_slices_and_selections() {
        let m = two_point_motion().into_image_2d();
        assert_eq!(m.dimensionality(), Dimensionality::Two);
        assert_eq!(m.length_unit(), "px");
        assert_eq!(m.position(0, 1), [1.0, 2.0, 0.0]);
        assert!(m.position(1, 1)[2].is_nan(), "a missing sample stays NaN");
        assert!(m.clone().with_confidence(vec![0.5; 5]).is_err(), "one value per sample");
        let m = m.with_confidence(vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6]).unwrap();
        let s = m.slice_frames(1, 3).unwrap();
        assert_eq!(s.confidence(), Some(&[0.3, 0.4, 0.5, 0.6][..]));
        let b = m.select_points(&["b"]).unwrap();
        assert_eq!(b.confidence(), Some(&[0.2, 0.4, 0.6][..]));
        assert_eq!(b.dimensionality(), Dimensionality::Two);
        let e = b.require_3d("hull_volume").unwrap_err();
        assert!(e.to_string().contains("hull_volume needs 3-D positions"), "{e}");
        assert!(two_point_motion().require_3d("hull_volume").is_ok());
        assert_eq!(two_point_motion().dimensionality().length_unit(), "mm");
    }

    #[test]
    fn horizontal_drops_the_up_axis() {
        let m = two_point_motion();
        assert_eq!(m.horizontal([1.0, 2.0, 3.0]), [1.0, 2.0]);
        assert_eq!(m.height([1.0, 2.0, 3.0]), 3.0);
    }
}
