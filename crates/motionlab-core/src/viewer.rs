//! What an interactive viewer page shows, as plain data (no polars, no HTML).
//!
//! A [`ViewerSpec`] is one sequence of a run: the motion to play back ([`ViewerMotion`]: rate,
//! point names, positions in mm with NaN for missing samples, bones, root) and time-aligned
//! [`Lane`]s under it — point events (a method's candidates, fused candidates, ground truth with
//! its tolerance, each mark optionally judged matched / false positive / missed), traces (the
//! signals a stage decided on, with its thresholds) and intervals (matched stretches of a
//! matching run, gait cycles). Workflows fill it; `motionlab-report` renders it. Every index is
//! a frame of the motion (0 = first stored frame).

use serde::{Deserialize, Serialize};

use crate::motion::Motion;
use crate::segmentation::Segmentation;
use crate::stage::{Threshold, Trace};
use crate::units::Axis;
use crate::{Error, ErrorKind, Result};

/// One viewer page: a motion and the lanes drawn under it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewerSpec {
    /// File stem of the page (`86_01` → `86_01.html`); letters, digits, `-` and `_` only.
    pub name: String,
    /// Heading of the page (`86_01 — sonoda_table1`).
    pub title: String,
    pub motion: ViewerMotion,
    /// Drawn top to bottom in this order.
    pub lanes: Vec<Lane>,
    /// When set, the page offers annotation mode: boundaries marked at the playhead, judged
    /// live against the candidate lanes, kept in the browser and downloaded as annotation files.
    #[serde(default)]
    pub annotation: Option<AnnotationSpec>,
}

/// What a page needs to annotate its motion: the name its files give the sequence, the key its
/// marks are kept under in the browser, and the tolerance they are judged at.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AnnotationSpec {
    /// The `sequence` cell of the files it writes: the motion file's stem (`86_01`), as the
    /// `boundaries_csv` reader matches it.
    pub sequence: String,
    /// SHA-256 of the motion's input file, 64 lower-case hex digits: the browser keeps a take's
    /// marks under it, so every page of the same take (another run, another experiment) finds
    /// them.
    pub input_sha256: String,
    /// Half-width of the match window, frames: the tolerance the run judged candidates at
    /// (None: exact frames only).
    pub tolerance_frames: Option<f64>,
}

/// The motion a viewer plays back.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewerMotion {
    pub frame_rate_hz: f64,
    /// The vertical axis of the positions (drawn up, the floor is the plane of the other two).
    pub up_axis: Axis,
    pub point_names: Vec<String>,
    /// Frame-major positions in mm (`positions_mm[frame * points + point]`); NaN = missing.
    /// f32 is ample for display (0.001 mm at 10 m) and halves the memory of long takes.
    pub positions_mm: Vec<[f32; 3]>,
    pub n_frames: usize,
    /// Pairs of point indices joined by a line; empty = markers drawn as dots only.
    pub bones: Vec<(usize, usize)>,
    /// The point whose floor path is drawn and which the camera follows.
    pub root: Option<usize>,
}

impl ViewerMotion {
    /// The motion's positions, with bones from its skeleton when it has one, else from
    /// `bones` (pairs of point names, as an experiment's `bones` list gives them), else none
    /// (markers only); `root` names the point to follow (`None`, or a name the motion lacks,
    /// follows the centroid instead — it is a display choice, not an input error).
    ///
    /// Fails with [`ErrorKind::UnknownName`] when a bone names a point the motion lacks.
    pub fn from_motion(motion: &Motion, bones: &[[String; 2]], root: Option<&str>) -> Result<Self> {
        let n_points = motion.n_points();
        let bones: Vec<(usize, usize)> = match &motion.skeleton {
            // Forward kinematics names its points after the skeleton; bones index them.
            Some(s) if s.skeleton.point_names() == motion.point_names() => s.skeleton.bones(),
            _ => bones
                .iter()
                .map(|[a, b]| Ok((motion.point_index(a)?, motion.point_index(b)?)))
                .collect::<Result<_>>()?,
        };
        let positions_mm =
            motion.positions().iter().map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect();
        let out = ViewerMotion {
            frame_rate_hz: motion.frame_rate().hz(),
            up_axis: motion.up_axis(),
            point_names: motion.point_names().to_vec(),
            positions_mm,
            n_frames: motion.n_frames(),
            bones,
            root: root.and_then(|r| motion.point_names().iter().position(|n| n == r)),
        };
        debug_assert!(out.bones.iter().all(|(a, b)| *a < n_points && *b < n_points));
        Ok(out)
    }
    pub fn n_points(&self) -> usize {
        self.point_names.len()
    }
}

/// What a point-event lane holds (it decides the default colour and the `n`/`p` keys' lane).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    /// One method's candidate boundaries.
    Candidates,
    /// The fuser's candidates.
    Fused,
    /// Human labels.
    Truth,
    /// Anything else (detected peaks, foot strikes).
    Other,
}

/// How the evaluation judged one mark.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MarkStatus {
    /// A found frame matched to a truth, or a truth some found frame matched.
    Matched,
    /// A found frame no truth matched.
    FalsePositive,
    /// A truth no found frame matched.
    Missed,
}

/// One instant on an event lane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mark {
    pub frame: usize,
    /// Shown in the candidate list and on hover (a transition's labels, an offset).
    pub label: String,
    pub status: Option<MarkStatus>,
}

/// A lane of instants.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EventLane {
    pub name: String,
    pub kind: EventKind,
    /// Half-width of the band drawn around each mark, frames (a truth's matching tolerance).
    pub tolerance_frames: Option<f64>,
    /// Annotated windows `[a, c]` drawn as bands (CMU-86 transition windows), frames.
    pub windows: Vec<(usize, usize)>,
    /// Which method's matching decided the statuses (a truth lane is judged against one).
    pub judged_against: Option<String>,
    /// Sorted by frame.
    pub marks: Vec<Mark>,
}

impl EventLane {
    /// A lane of unjudged marks at `frames`.
    pub fn new(name: impl Into<String>, kind: EventKind, frames: &[usize]) -> Self {
        let mut marks: Vec<Mark> = frames
            .iter()
            .map(|&frame| Mark { frame, label: String::new(), status: None })
            .collect();
        marks.sort_by_key(|m| m.frame);
        EventLane {
            name: name.into(),
            kind,
            tolerance_frames: None,
            windows: Vec::new(),
            judged_against: None,
            marks,
        }
    }
    /// The ground truth's boundaries (labelled `from → to` where the truth names its
    /// segments), with their annotated windows and the matching tolerance in frames.
    pub fn truth(
        name: impl Into<String>,
        truth: &Segmentation,
        tolerance_frames: Option<f64>,
    ) -> Self {
        let transitions = truth.transitions();
        let marks = truth
            .boundaries
            .iter()
            .map(|b| Mark {
                frame: b.frame,
                label: transitions
                    .iter()
                    .find(|t| t.frame == b.frame)
                    .map(|t| format!("{} → {}", t.from, t.to))
                    .unwrap_or_default(),
                status: None,
            })
            .collect();
        EventLane {
            name: name.into(),
            kind: EventKind::Truth,
            tolerance_frames,
            windows: truth.boundaries.iter().filter_map(|b| b.window).collect(),
            judged_against: None,
            marks,
        }
    }
    /// Sets the status of the mark at `frame` (every mark at that frame); false when none is.
    pub fn set_status(&mut self, frame: usize, status: MarkStatus) -> bool {
        let mut found = false;
        for m in self.marks.iter_mut().filter(|m| m.frame == frame) {
            m.status = Some(status);
            found = true;
        }
        found
    }
}

/// One signal of a trace lane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TraceSeries {
    pub name: String,
    /// One value per frame of the motion; NaN where undefined.
    pub values: Vec<f64>,
}

/// A horizontal line on a trace lane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThresholdLine {
    pub name: String,
    pub value: f64,
}

/// Signals in one unit, drawn against time on one lane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TraceLane {
    pub name: String,
    /// `mm/s`, `mm³/frame`, … or empty for dimensionless.
    pub unit: String,
    pub series: Vec<TraceSeries>,
    pub thresholds: Vec<ThresholdLine>,
}

impl TraceLane {
    /// One lane per unit of a stage's traces, each with the thresholds that apply to its
    /// traces, named `<stage>` (`<stage> (<unit>)` when the stage has several units). A trace
    /// shorter than `n_frames` (a speed has one value fewer than positions) is undefined (NaN)
    /// after its end; a longer one is left for [`ViewerSpec::validate`] to refuse.
    pub fn from_traces(
        stage: &str,
        traces: &[Trace],
        thresholds: &[Threshold],
        n_frames: usize,
    ) -> Vec<TraceLane> {
        let mut units: Vec<&str> = Vec::new();
        for t in traces {
            if !units.contains(&t.unit.as_str()) {
                units.push(&t.unit);
            }
        }
        let several = units.len() > 1;
        units
            .into_iter()
            .map(|unit| {
                let group: Vec<&Trace> = traces.iter().filter(|t| t.unit == unit).collect();
                TraceLane {
                    name: if several && !unit.is_empty() {
                        format!("{stage} ({unit})")
                    } else {
                        stage.to_string()
                    },
                    unit: unit.to_string(),
                    series: group
                        .iter()
                        .map(|t| {
                            let mut values = t.values.clone();
                            if values.len() < n_frames {
                                values.resize(n_frames, f64::NAN);
                            }
                            TraceSeries { name: t.name.clone(), values }
                        })
                        .collect(),
                    thresholds: thresholds
                        .iter()
                        .filter(|h| group.iter().any(|t| t.name == h.trace))
                        .map(|h| ThresholdLine { name: h.name.clone(), value: h.value })
                        .collect(),
                }
            })
            .collect()
    }
}

/// What an interval lane holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IntervalKind {
    /// Stretches `[a, b]` a matching run aligned to its model.
    Matched,
    /// Gait cycles (foot strike to the next foot strike of the same foot).
    GaitCycle,
    Other,
}

/// A stretch of frames `[start, end]` (both included).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub start: usize,
    pub end: usize,
    pub label: String,
}

/// A lane of stretches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IntervalLane {
    pub name: String,
    pub kind: IntervalKind,
    pub intervals: Vec<Interval>,
}

/// One time-aligned lane under the motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Lane {
    Events(EventLane),
    Trace(TraceLane),
    Intervals(IntervalLane),
}

impl Lane {
    pub fn name(&self) -> &str {
        match self {
            Lane::Events(l) => &l.name,
            Lane::Trace(l) => &l.name,
            Lane::Intervals(l) => &l.name,
        }
    }
}

impl ViewerSpec {
    pub fn new(name: impl Into<String>, title: impl Into<String>, motion: ViewerMotion) -> Self {
        ViewerSpec {
            name: name.into(),
            title: title.into(),
            motion,
            lanes: Vec::new(),
            annotation: None,
        }
    }

    /// Checks what a renderer relies on: a file-safe name, a positive rate, positions for every
    /// frame and point, bones, root and marks inside the motion, one trace value per frame and
    /// intervals with `start ≤ end` inside the motion. The error names the lane.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: String| {
            Err(Error::new(ErrorKind::OutOfRange, format!("viewer {:?}: {what}", self.name)))
        };
        if self.name.is_empty()
            || !self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return bad(
                "the name must be letters, digits, '-' or '_' (it is the page's file name)".into(),
            );
        }
        let m = &self.motion;
        if !(m.frame_rate_hz.is_finite() && m.frame_rate_hz > 0.0) {
            return bad(format!("frame rate {} Hz is not a positive number", m.frame_rate_hz));
        }
        if m.n_points() == 0 || m.n_frames == 0 || m.positions_mm.len() != m.n_frames * m.n_points()
        {
            return bad(format!(
                "{} positions for {} frames of {} points (expected frames × points, both > 0)",
                m.positions_mm.len(),
                m.n_frames,
                m.n_points()
            ));
        }
        if let Some((a, b)) = m.bones.iter().find(|(a, b)| *a >= m.n_points() || *b >= m.n_points())
        {
            return bad(format!("bone ({a}, {b}) names a point outside 0..{}", m.n_points()));
        }
        if let Some(r) = m.root.filter(|r| *r >= m.n_points()) {
            return bad(format!("root {r} is outside 0..{}", m.n_points()));
        }
        if let Some(a) = &self.annotation {
            if a.sequence.trim().is_empty() {
                return bad("annotation: the sequence name is empty".into());
            }
            if a.input_sha256.len() != 64
                || !a.input_sha256.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
            {
                return bad(format!(
                    "annotation: input_sha256 {:?} is not 64 lower-case hex digits",
                    a.input_sha256
                ));
            }
            if a.tolerance_frames.is_some_and(|t| !(t.is_finite() && t >= 0.0)) {
                return bad(
                    "annotation: the tolerance must be a finite number of frames ≥ 0".into()
                );
            }
        }
        for lane in &self.lanes {
            match lane {
                Lane::Events(l) => {
                    let outside = l
                        .marks
                        .iter()
                        .map(|k| k.frame)
                        .chain(l.windows.iter().flat_map(|w| [w.0, w.1]))
                        .find(|f| *f >= m.n_frames);
                    if let Some(f) = outside {
                        return bad(format!(
                            "lane {:?}: frame {f} is outside 0..{}",
                            l.name, m.n_frames
                        ));
                    }
                    if l.tolerance_frames.is_some_and(|t| !(t.is_finite() && t >= 0.0)) {
                        return bad(format!(
                            "lane {:?}: the tolerance must be a finite number of frames ≥ 0",
                            l.name
                        ));
                    }
                }
                Lane::Trace(l) => {
                    if let Some(s) = l.series.iter().find(|s| s.values.len() != m.n_frames) {
                        return bad(format!(
                            "lane {:?}: series {:?} has {} values for {} frames",
                            l.name,
                            s.name,
                            s.values.len(),
                            m.n_frames
                        ));
                    }
                }
                Lane::Intervals(l) => {
                    if let Some(i) =
                        l.intervals.iter().find(|i| i.start > i.end || i.end >= m.n_frames)
                    {
                        return bad(format!(
                            "lane {:?}: interval [{}, {}] is not inside 0..{}",
                            l.name, i.start, i.end, m.n_frames
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Segment;
    use crate::motion::PointKind;
    use crate::skeleton::{ChannelKind, Joint, Skeleton, SkeletonMotion};
    use crate::units::FrameRate;

    fn markers() -> Motion {
        let rate = FrameRate::new(100.0).unwrap();
        let pos = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1000.0], [10.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0]];
        Motion::new("m", rate, Axis::Z, PointKind::Marker, vec!["foot".into(), "head".into()], pos)
            .unwrap()
    }

    #[test]
    fn bones_come_from_the_skeleton_else_the_list_else_none() {
        let m = markers();
        let v = ViewerMotion::from_motion(&m, &[], Some("foot")).unwrap();
        assert!(v.bones.is_empty());
        assert_eq!((v.n_frames, v.root), (2, Some(0)));
        assert!(v.positions_mm[3][0].is_nan(), "missing stays NaN");
        let v = ViewerMotion::from_motion(&m, &[["foot".into(), "head".into()]], None).unwrap();
        assert_eq!(v.bones, vec![(0, 1)]);
        let e = ViewerMotion::from_motion(&m, &[["foot".into(), "hand".into()]], None).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::UnknownName);

        // A skeleton's own bones win over a list.
        let mut arm = Joint::new("root", None, [0.0; 3], vec![ChannelKind::Translation(Axis::X)]);
        arm.end_sites.push([0.0, 0.0, 100.0]);
        let skel = Skeleton { joints: vec![arm] };
        let sm = SkeletonMotion::new(skel.clone(), vec![0.0, 5.0]).unwrap();
        let mut m = Motion::new(
            "s",
            FrameRate::new(10.0).unwrap(),
            Axis::Z,
            PointKind::Joint,
            skel.point_names(),
            sm.positions(),
        )
        .unwrap();
        m.skeleton = Some(sm);
        let v =
            ViewerMotion::from_motion(&m, &[["root".into(), "root".into()]], Some("root")).unwrap();
        assert_eq!(v.bones, vec![(0, 1)]);
    }

    #[test]
    fn truth_lanes_carry_labels_windows_and_tolerance() {
        let rate = FrameRate::new(10.0).unwrap();
        let mut t = Segmentation::from_segments(
            rate,
            vec![
                Segment { start: 0, end: 5, label: "walk".into() },
                Segment { start: 5, end: 9, label: "jump".into() },
            ],
        )
        .unwrap();
        t.boundaries[0].window = Some((4, 6));
        let mut lane = EventLane::truth("ground truth", &t, Some(2.0));
        assert_eq!(lane.marks[0].label, "walk → jump");
        assert_eq!(lane.windows, vec![(4, 6)]);
        assert!(lane.set_status(5, MarkStatus::Missed));
        assert!(!lane.set_status(6, MarkStatus::Missed));
        assert_eq!(lane.marks[0].status, Some(MarkStatus::Missed));
    }

    #[test]
    fn trace_lanes_group_by_unit_with_their_thresholds() {
        let traces = vec![
            Trace::new("V_mm_per_s", "mm/s", vec![1.0, 2.0]),
            Trace::new("v_m", "mm/s", vec![2.0]),
            Trace::new("C", "", vec![0.5, 0.1]),
        ];
        let th = vec![Threshold { name: "v_low".into(), trace: "V_mm_per_s".into(), value: 3.0 }];
        let lanes = TraceLane::from_traces("speed", &traces, &th, 2);
        assert!(lanes[0].series[1].values[1].is_nan(), "a short trace is undefined after its end");
        assert_eq!(lanes.len(), 2);
        assert_eq!(
            (lanes[0].name.as_str(), lanes[0].series.len(), lanes[0].thresholds.len()),
            ("speed (mm/s)", 2, 1)
        );
        assert_eq!((lanes[1].name.as_str(), lanes[1].thresholds.len()), ("speed", 0));
    }

    #[test]
    fn validation_names_what_is_outside_the_motion() {
        let v = ViewerMotion::from_motion(&markers(), &[], None).unwrap();
        let mut spec = ViewerSpec::new("m", "m", v);
        assert!(spec.validate().is_ok());
        spec.lanes.push(Lane::Events(EventLane::new("speed", EventKind::Candidates, &[1, 2])));
        let e = spec.validate().unwrap_err();
        assert!(e.to_string().contains("frame 2 is outside 0..2"), "{e}");
        spec.lanes[0] = Lane::Trace(TraceLane {
            name: "V".into(),
            unit: String::new(),
            series: vec![TraceSeries { name: "V".into(), values: vec![1.0] }],
            thresholds: vec![],
        });
        assert!(spec.validate().unwrap_err().to_string().contains("1 values for 2 frames"));
        spec.lanes.clear();
        let sha = "0123456789abcdef".repeat(4);
        spec.annotation = Some(AnnotationSpec {
            sequence: "m".into(),
            input_sha256: sha.clone(),
            tolerance_frames: Some(5.0),
        });
        assert!(spec.validate().is_ok());
        spec.annotation = Some(AnnotationSpec {
            sequence: "m".into(),
            input_sha256: sha.to_uppercase(),
            tolerance_frames: None,
        });
        assert!(spec.validate().unwrap_err().to_string().contains("input_sha256"));
        spec.annotation = Some(AnnotationSpec {
            sequence: "m".into(),
            input_sha256: sha,
            tolerance_frames: Some(-1.0),
        });
        assert!(spec.validate().unwrap_err().to_string().contains("tolerance"));
        spec.annotation = None;
        spec.name = "a/b".into();
        assert!(spec.validate().is_err());
    }
}
