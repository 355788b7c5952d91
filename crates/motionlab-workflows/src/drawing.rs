//! Figure and table helpers shared by workflows.

use motionlab_core::{Motion, Point3, Result, Threshold, Trace};
use motionlab_figure::{BarRow, Chart, Pose, RefLine, Series, StickRow, StickStrip};

/// Seconds of each frame of a motion.
pub fn time_axis(motion: &Motion) -> Vec<f64> {
    let rate = motion.frame_rate();
    (0..motion.n_frames()).map(|i| rate.frame_to_seconds(i).value()).collect()
}

/// Frames to seconds at `rate_hz`.
pub fn frames_to_seconds(frames: &[usize], rate_hz: f64) -> Vec<f64> {
    frames.iter().map(|f| *f as f64 / rate_hz).collect()
}

/// A trace name without its unit suffix, for labels (`V_mm_per_s` → `V`).
pub fn label_of(name: &str) -> String {
    motionlab_core::table::split_unit(name).0
}

/// Charts of a stage's traces against time with its thresholds and candidate bars (the papers'
/// "graph with vertical bars below it"): one chart per unit, the one whose traces carry the
/// thresholds first (that is the signal the stage decided on).
pub fn traces_charts(
    title: &str,
    time: &[f64],
    traces: &[Trace],
    thresholds: &[Threshold],
    bars: Vec<BarRow>,
) -> Vec<Chart> {
    let mut units: Vec<&str> = Vec::new();
    for t in traces {
        if !units.contains(&t.unit.as_str()) {
            units.push(&t.unit);
        }
    }
    let decides = |u: &str| {
        traces.iter().any(|t| t.unit == u && thresholds.iter().any(|h| h.trace == t.name))
    };
    units.sort_by_key(|u| !decides(u));
    units
        .into_iter()
        .map(|unit| {
            let group: Vec<&Trace> = traces.iter().filter(|t| t.unit == unit).collect();
            let lines: Vec<Series> = group
                .iter()
                .map(|t| {
                    Series::new(
                        label_of(&t.name),
                        time[..t.values.len().min(time.len())].to_vec(),
                        t.values.clone(),
                    )
                })
                .collect();
            let hlines = thresholds
                .iter()
                .filter(|h| group.iter().any(|t| t.name == h.trace))
                .map(|h| RefLine { label: h.name.clone(), value: h.value })
                .collect();
            let first = group.first().map(|t| label_of(&t.name)).unwrap_or_default();
            let y_label = if unit.is_empty() { first } else { format!("{first} ({unit})") };
            Chart {
                title: title.to_string(),
                x_label: "time (s)".into(),
                y_label,
                lines,
                hlines,
                bar_rows: bars.clone(),
                ..Default::default()
            }
        })
        .collect()
}

/// A side-view stick strip of `n` evenly spaced frames of `[start, end]`: each pose drawn in
/// the plane of the floor axis along which the root travels most and the up axis.
pub fn stick_row(
    motion: &Motion,
    label: &str,
    start: usize,
    end: usize,
    n: usize,
    horizontal_axis: usize,
) -> StickRow {
    let up = motion.up_axis().index();
    let n = n.max(2);
    let frames: Vec<usize> =
        (0..n).map(|k| start + (end.saturating_sub(start)) * k / (n - 1)).collect();
    let rate = motion.frame_rate().hz();
    let poses = frames
        .iter()
        .map(|&f| Pose {
            label: format!("{f} ({:.2} s)", f as f64 / rate),
            points: motion
                .frame(f.min(motion.n_frames() - 1))
                .iter()
                .map(|p: &Point3| [p[horizontal_axis], p[up]])
                .collect(),
        })
        .collect();
    StickRow { label: label.to_string(), poses }
}

/// A stick row of the given frames (labelled by frame number), in the plane of
/// `horizontal_axis` and the up axis.
pub fn stick_row_at(motion: &Motion, frames: &[usize], horizontal_axis: usize) -> StickRow {
    let up = motion.up_axis().index();
    let last = motion.n_frames().saturating_sub(1);
    let poses = frames
        .iter()
        .map(|&f| Pose {
            label: f.to_string(),
            points: motion
                .frame(f.min(last))
                .iter()
                .map(|p: &Point3| [p[horizontal_axis], p[up]])
                .collect(),
        })
        .collect();
    StickRow { label: String::new(), poses }
}

/// The floor axis along which a point moves most over `[start, end]` (for side views).
pub fn main_floor_axis(motion: &Motion, point: Option<usize>, start: usize, end: usize) -> usize {
    let [a, b] = motion.up_axis().others();
    let Some(k) = point else { return a };
    let range = |axis: usize| {
        let vals: Vec<f64> = (start..=end.min(motion.n_frames() - 1))
            .map(|f| motion.position(f, k)[axis])
            .filter(|v| v.is_finite())
            .collect();
        let lo = vals.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if hi > lo { hi - lo } else { 0.0 }
    };
    if range(b) > range(a) { b } else { a }
}

/// Bones for stick figures: from the skeleton when there is one, else from name pairs.
pub fn bones_for(motion: &Motion, pairs: &[[String; 2]]) -> Result<Vec<(usize, usize)>> {
    if !pairs.is_empty() {
        return pairs
            .iter()
            .map(|[a, b]| Ok((motion.point_index(a)?, motion.point_index(b)?)))
            .collect();
    }
    Ok(motion.skeleton.as_ref().map(|s| s.skeleton.bones()).unwrap_or_default())
}

/// A stick strip figure spec.
pub fn stick_strip(
    title: String,
    bones: Vec<(usize, usize)>,
    rows: Vec<StickRow>,
    caption: String,
) -> StickStrip {
    StickStrip { title, bones, rows, caption }
}

/// Axis letter for captions.
pub fn axis_name(i: usize) -> &'static str {
    ["x", "y", "z"][i.min(2)]
}

/// The skeleton bones of `raw` (a motion as its loader read it) as pairs of point names of
/// `kept`, the same motion after preprocessors that dropped points standing at the same place
/// as another (`distinct_points`) and with them the skeleton: a dropped point stands for the
/// kept point that coincides with it in `raw`'s first frame (within 1e-3 mm). Bones that
/// collapse to one point, repeat, or touch a point with no stand-in are left out. Empty when
/// `raw` has no skeleton.
pub fn bones_of_merged_skeleton(raw: &Motion, kept: &Motion) -> Vec<[String; 2]> {
    let Some(s) = &raw.skeleton else { return Vec::new() };
    let names = raw.point_names();
    if s.skeleton.point_names() != names || raw.n_frames() == 0 {
        return Vec::new();
    }
    let stand_in = |j: usize| -> Option<String> {
        if kept.point_names().contains(&names[j]) {
            return Some(names[j].clone());
        }
        let p = raw.position(0, j);
        (0..names.len()).find_map(|k| {
            let q = raw.position(0, k);
            let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
            (k != j && d <= 1e-3 && kept.point_names().contains(&names[k]))
                .then(|| names[k].clone())
        })
    };
    let mut out: Vec<[String; 2]> = Vec::new();
    for (a, b) in s.skeleton.bones() {
        if let (Some(a), Some(b)) = (stand_in(a), stand_in(b))
            && a != b
            && !out.iter().any(|x| (x[0] == a && x[1] == b) || (x[0] == b && x[1] == a))
        {
            out.push([a, b]);
        }
    }
    out
}
