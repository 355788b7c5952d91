//! The `[segment_stats]` workflow: segment, then describe and classify each segment — a new
//! pipeline shape, added without editing motionlab (its `Workflow` trait, `register_workflow!`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, FeatureCache, Motion, Result, Segmenter, Table, registry};
use motionlab_experiment::spec::StageSpec;
use motionlab_experiment::toml_paths::KeyPath;
use motionlab_experiment::workflow::{
    BuildContext, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin,
};
use motionlab_experiment::{Datasets, build_named_stages, build_stage};
use my_segmenters::segment_classifier::{SegmentClassifier, build_segment_classifier};

/// Segments each sequence, then describes and labels every segment: one row per segment and
/// segmenter (`segment_stats`: sequence, method, index, start/end frame and second, duration,
/// root path length in mm, mean root speed in mm/s, the classifier's label) and a count per
/// label (`segment_labels`).
///
/// Segments run from the first frame to the first candidate, between consecutive candidates,
/// and from the last candidate to the end (end frames exclusive). The path length sums the
/// root's frame-to-frame displacements, skipping steps where either sample is missing; mean
/// speed is that length over the segment's duration. No `[[evaluate]]` (there is nothing to
/// compare the statistics with).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SegmentStatsSection {
    /// The segmenters (`[[segment_stats.segmenter]]`, `{ type = "<segmenter>", … }`); names
    /// (`name = "…"`, else the type) must be unique. At least one is required.
    #[serde(rename = "segmenter")]
    pub segmenters: Vec<StageSpec>,
    /// The segment classifier labelling each segment (`{ type = "by_duration", … }`, a
    /// `segment_classifier`: see `motionlab list`). Required.
    pub classifier: StageSpec,
    /// The point (after preprocessing) whose path and speed describe a segment.
    #[serde(default = "default_root")]
    pub root: String,
}

fn default_root() -> String {
    "root".into()
}

pub struct SegmentStatsWorkflow {
    section: SegmentStatsSection,
    segmenters: Vec<(String, Box<dyn Segmenter>)>,
    classifier: Box<dyn SegmentClassifier>,
}

/// One row of `segment_stats` (also the persisted item result).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentRow {
    pub sequence: String,
    pub method: String,
    /// 0-based, in time order.
    pub segment: usize,
    pub start_frame: usize,
    /// Exclusive.
    pub end_frame: usize,
    pub start_s: f64,
    pub end_s: f64,
    pub duration_s: f64,
    pub path_length_mm: f64,
    pub mean_speed_mm_per_s: f64,
    pub label: String,
}

#[derive(Serialize)]
struct LabelRow {
    method: String,
    label: String,
    segments: usize,
    total_duration_s: f64,
}

impl WorkflowPlugin for SegmentStatsWorkflow {
    type Section = SegmentStatsSection;
    fn build(section: SegmentStatsSection, cx: &BuildContext<'_>) -> Result<Self> {
        let segmenters = build_named_stages(
            cx,
            &section.segmenters,
            &cx.root.key("segmenter"),
            "segmenters",
            registry::build_segmenter,
        )?;
        if segmenters.is_empty() {
            return Err(cx.locate(
                Error::new(
                    ErrorKind::MissingKey,
                    "at least one [[segment_stats.segmenter]] is required",
                ),
                &cx.root,
            ));
        }
        let classifier = build_stage(
            cx.source,
            cx.combo,
            &section.classifier,
            &cx.root.key("classifier"),
            build_segment_classifier,
        )?;
        if !cx.combo.file.evaluators.is_empty() {
            let msg = "[segment_stats] runs no evaluators; remove the [[evaluate]] tables";
            return Err(cx.locate(
                Error::new(ErrorKind::InvalidParameter, msg),
                KeyPath::default().key("evaluate"),
            ));
        }
        Ok(SegmentStatsWorkflow { section, segmenters, classifier })
    }
}

motionlab_experiment::register_workflow!(SegmentStatsWorkflow, "segment_stats");

impl Workflow for SegmentStatsWorkflow {
    fn run_item(&self, item: &WorkItem, data: &Datasets, _draw: bool) -> Result<ItemOutput> {
        let loaded = data.load(item.dataset, item.file)?;
        let motion = &loaded.motion;
        let file = motion.source.clone().unwrap_or_default();
        let root = motion
            .point_index(&self.section.root)
            .map_err(|e| e.in_file(&file).under_field("segment_stats.root"))?;
        let cache = FeatureCache::new();
        let mut rows = Vec::new();
        for (name, s) in &self.segmenters {
            let out = s
                .segment(motion, &cache)
                .map_err(|e| e.in_file(&file).under_field(format!("segmenter {name}")))?;
            for (k, (start, end)) in
                segments(&out.candidates, motion.n_frames()).into_iter().enumerate()
            {
                let label = self
                    .classifier
                    .label(motion, start, end)
                    .map_err(|e| e.in_file(&file).under_field("classifier"))?;
                let rate = motion.frame_rate().hz();
                let duration_s = (end - start) as f64 / rate;
                let path_length_mm = path_length_mm(motion, root, start, end);
                rows.push(SegmentRow {
                    sequence: loaded.name.clone(),
                    method: name.clone(),
                    segment: k,
                    start_frame: start,
                    end_frame: end,
                    start_s: start as f64 / rate,
                    end_s: end as f64 / rate,
                    duration_s,
                    path_length_mm,
                    mean_speed_mm_per_s: path_length_mm / duration_s,
                    label,
                });
            }
        }
        Ok(ItemOutput::new(ItemData::encode(&rows)?, Vec::new()))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        _data: &Datasets,
        _draw: bool,
    ) -> Result<Output> {
        let mut rows: Vec<SegmentRow> = Vec::new();
        for (_, value) in items {
            rows.extend(value.decode::<Vec<SegmentRow>>()?);
        }
        let mut labels: Vec<LabelRow> = Vec::new();
        for r in &rows {
            match labels.iter_mut().find(|l| l.method == r.method && l.label == r.label) {
                Some(l) => {
                    l.segments += 1;
                    l.total_duration_s += r.duration_s;
                }
                None => labels.push(LabelRow {
                    method: r.method.clone(),
                    label: r.label.clone(),
                    segments: 1,
                    total_duration_s: r.duration_s,
                }),
            }
        }
        let mut out = Output::default();
        out.tables.push(Table::from_records(
            "segment_stats",
            "Each segment: frames, seconds, root path length and mean speed, label",
            &rows,
        )?);
        out.tables.push(Table::from_records(
            "segment_labels",
            "Segments per method and label",
            &labels,
        )?);
        Ok(out)
    }
}

/// `[start, end)` frame ranges cut at the candidates (sorted, deduplicated, inside the motion).
pub fn segments(candidates: &[usize], n_frames: usize) -> Vec<(usize, usize)> {
    let mut cuts: Vec<usize> =
        candidates.iter().copied().filter(|&c| c > 0 && c < n_frames).collect();
    cuts.sort_unstable();
    cuts.dedup();
    let starts = std::iter::once(0).chain(cuts.iter().copied());
    let ends = cuts.iter().copied().chain(std::iter::once(n_frames));
    starts.zip(ends).filter(|(s, e)| e > s).collect()
}

/// The length of a point's path over frames `start..end`, mm: the sum of frame-to-frame
/// displacements whose two samples are present.
pub fn path_length_mm(motion: &Motion, point: usize, start: usize, end: usize) -> f64 {
    (start + 1..end)
        .filter(|&f| !motion.is_missing(f - 1, point) && !motion.is_missing(f, point))
        .map(|f| {
            let (a, b) = (motion.position(f - 1, point), motion.position(f, point));
            ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::{Axis, FrameRate, PointKind};

    #[test]
    fn segments_cover_the_motion_between_candidates() {
        assert_eq!(segments(&[30, 10, 10, 0, 50], 40), vec![(0, 10), (10, 30), (30, 40)]);
        assert_eq!(segments(&[], 5), vec![(0, 5)]);
    }

    #[test]
    fn path_length_sums_present_steps_of_a_known_path() {
        // A 3-4-5 step each frame, the step into frame 3 missing.
        let positions: Vec<[f64; 3]> = (0..5)
            .map(|f| if f == 3 { [f64::NAN; 3] } else { [3.0 * f as f64, 4.0 * f as f64, 0.0] })
            .collect();
        let m = Motion::new(
            "line",
            FrameRate::new(10.0).unwrap(),
            Axis::Z,
            PointKind::Marker,
            vec!["root".into()],
            positions,
        )
        .unwrap();
        // Steps 0→1, 1→2 present (5 mm each); 2→3 and 3→4 touch the missing frame.
        assert_eq!(path_length_mm(&m, 0, 0, 5), 10.0);
        assert_eq!(path_length_mm(&m, 0, 1, 3), 5.0);
    }
}
