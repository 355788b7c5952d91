//! The viewer page of each walk.

use motionlab_core::viewer::{
    EventKind, EventLane, Interval, IntervalKind, IntervalLane, Lane, Mark, TraceLane,
    ViewerMotion, ViewerSpec,
};
use motionlab_core::{Result, Trace};
use motionlab_experiment::Datasets;
use motionlab_experiment::workflow::WorkItem;

use super::{GaitWorkflow, WalkRecord};

impl GaitWorkflow {
    /// The viewer page of one walk: its markers (or skeleton), the file's events (foot strike,
    /// foot off) per side, the gait cycles per side (foot strike to the next of the same foot)
    /// and the `figure_channels` angles the walk has.
    pub(super) fn viewer(
        &self,
        item: &WorkItem,
        r: &WalkRecord,
        data: &Datasets,
    ) -> Result<ViewerSpec> {
        let loaded = data.load(item.dataset, item.file)?;
        let motion = &loaded.motion;
        let n = motion.n_frames();
        let vm = ViewerMotion::from_motion(motion, &[], None)?;
        let what = if r.control {
            "control walk".to_string()
        } else {
            format!("subject {}, {}", r.subject, r.condition)
        };
        let mut spec =
            ViewerSpec::new(viewer_name(&r.sequence), format!("{} — {what}", r.sequence), vm);
        // Events per "context label" (`Left Foot Strike`), in order of first appearance.
        let mut lanes: Vec<EventLane> = Vec::new();
        for e in &motion.events {
            let f = e.frame.round();
            if !(f.is_finite() && f >= 0.0 && (f as usize) < n) {
                continue;
            }
            // Files number repeated labels (`Foot Strike1`, `Foot Strike2`): one lane for all.
            let label = e.label.trim().trim_end_matches(|c: char| c.is_ascii_digit()).trim_end();
            let name = format!("{} {label}", e.context.trim()).trim().to_string();
            let mark = Mark {
                frame: f as usize,
                label: format!("{name}, {:.3} s", e.time.value()),
                status: None,
            };
            match lanes.iter_mut().find(|l| l.name == name) {
                Some(l) => l.marks.push(mark),
                None => {
                    let mut l = EventLane::new(name, EventKind::Other, &[]);
                    l.marks.push(mark);
                    lanes.push(l);
                }
            }
        }
        let mut sides: Vec<&str> = Vec::new();
        for c in &r.cycles {
            if !sides.contains(&c.side.as_str()) {
                sides.push(&c.side);
            }
        }
        // A walk without file events (a skeleton walk, cycles from heel height): its detector's
        // foot strikes, the cycles' bounds.
        if lanes.is_empty() {
            for side in &sides {
                let mut frames: Vec<usize> = r
                    .cycles
                    .iter()
                    .filter(|c| c.side == *side)
                    .flat_map(|c| [c.start, c.end])
                    .filter(|f| *f < n)
                    .collect();
                frames.dedup();
                lanes.push(EventLane::new(
                    format!("{side} foot strikes (detected)"),
                    EventKind::Other,
                    &frames,
                ));
            }
        }
        for mut l in lanes {
            l.marks.sort_by_key(|m| m.frame);
            spec.lanes.push(Lane::Events(l));
        }
        let rate = motion.frame_rate().hz();
        for side in sides {
            let intervals = r
                .cycles
                .iter()
                .filter(|c| c.side == side && c.start < n)
                .enumerate()
                .map(|(k, c)| Interval {
                    start: c.start,
                    end: c.end.min(n - 1).max(c.start),
                    label: format!(
                        "{side} cycle {}: {:.2} s",
                        k + 1,
                        c.end.saturating_sub(c.start) as f64 / rate
                    ),
                })
                .collect();
            spec.lanes.push(Lane::Intervals(IntervalLane {
                name: format!("gait cycles ({side})"),
                kind: IntervalKind::GaitCycle,
                intervals,
            }));
        }
        // The control walk names its channels after its skeleton: the figure channels through
        // `[gait.control] channel_map`.
        let map = self.control.as_ref().filter(|_| r.control).map(|c| &c.spec.channel_map);
        let traces: Vec<Trace> = self
            .section
            .figure_channels
            .iter()
            .filter_map(|ch| {
                let ch = map.and_then(|m| m.get(ch)).unwrap_or(ch);
                let k = r.curves.channels.iter().position(|c| c == ch)?;
                let mut v = r.curves.values[k].clone();
                v.resize(n, f64::NAN);
                Some(Trace::new(ch.clone(), "deg", v))
            })
            .collect();
        if !traces.is_empty() {
            spec.lanes.extend(
                TraceLane::from_traces("joint angles", &traces, &[], n)
                    .into_iter()
                    .map(Lane::Trace),
            );
        }
        Ok(spec)
    }
}

/// A viewer page's file stem for a sequence (`normal/2014001_C4_05` → `normal_2014001_C4_05`).
pub(super) fn viewer_name(sequence: &str) -> String {
    let name: String = sequence
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
        .collect();
    if name.is_empty() { "walk".into() } else { name }
}
