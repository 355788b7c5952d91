//! The figures: per take the velocity function (Fig. 2) and two markers' warping paths
//! (Fig. 4), per combination the H–R scatters (Figs. 5 and 6).

use motionlab_core::{Error, ErrorKind, Result};
use motionlab_figure::{BarRow, Chart, Figure, RefLine, Series};
use motionlab_match::PointDetection;
use motionlab_match::judgement::scores;

use super::analysis::{fmt, mean_target_frames, most_out_of_step};
use super::section::MatchingFigure;
use super::{ItemResult, MatchingWorkflow, RepetitionRecord};

impl MatchingWorkflow {
    /// Whether `[matching] figures` asks for `figure`.
    pub(super) fn wants(&self, figure: MatchingFigure) -> bool {
        self.section.figures.contains(&figure)
    }
}

/// Fig. 5 (H–R) and Fig. 6 (H'–R'), one point series per take, labelled by repetition.
pub(super) fn scatter_figures(results: &[ItemResult]) -> Vec<Figure> {
    let mut raw = Vec::new();
    let mut norm = Vec::new();
    for r in results.iter().filter(|r| !r.repetitions.is_empty()) {
        let h: Vec<f64> = r.repetitions.iter().map(|x| x.total_distance).collect();
        let rr: Vec<f64> = r.repetitions.iter().map(|x| x.sync_total).collect();
        let labels: Vec<String> = r.repetitions.iter().map(|x| x.label.clone()).collect();
        let mut s = Series::new(r.take.clone(), h.clone(), rr.clone());
        s.point_labels = labels.clone();
        raw.push(s);
        let normalised = scores(&h, &rr);
        let mut n = Series::new(r.take.clone(), normalised.h_norm, normalised.r_norm);
        n.point_labels = labels;
        norm.push(n);
    }
    if raw.is_empty() {
        return Vec::new();
    }
    let upper = |series: &[Series], pick: fn(&Series) -> &Vec<f64>| {
        series
            .iter()
            .flat_map(|s| pick(s).iter())
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            * 1.15
    };
    let raw_range =
        (Some((0.0, upper(&raw, |s| &s.x).max(1.0))), Some((0.0, upper(&raw, |s| &s.y).max(1.0))));
    let norm_max = upper(&norm, |s| &s.x).max(upper(&norm, |s| &s.y)).max(1.2);
    // The unit circle, score = 1: as far from the origin as a repetition at both means.
    let steps = 90;
    let quarter = |k: usize| k as f64 / steps as f64 * std::f64::consts::FRAC_PI_2;
    let arc = Series::new(
        "score = 1",
        (0..=steps).map(|k| quarter(k).cos()).collect(),
        (0..=steps).map(|k| quarter(k).sin()).collect(),
    );
    // Charts colour points after lines; an empty, unlabelled line (nothing drawn, no legend)
    // gives the H–R chart the same colour per take as the H'–R' chart with its circle.
    let colour_slot = Series::new("", Vec::new(), Vec::new());
    vec![
        Figure::chart(
            "scatter_H_R",
            Chart {
                title: "Distance H and synchronisation R of each repetition (Fig. 5)".into(),
                x_label: "H, distance summed over markers and path (mm)".into(),
                y_label: "R, synchronisation (frames²)".into(),
                lines: vec![colour_slot],
                points: raw,
                x_range: raw_range.0,
                y_range: raw_range.1,
                ..Default::default()
            },
        ),
        Figure::chart(
            "scatter_H_R_normalised",
            Chart {
                title: "Normalised H' = H / mean H and R' = R / mean R per take; score = distance from the origin (Fig. 6)".into(),
                x_label: "H' (dimensionless)".into(),
                y_label: "R' (dimensionless)".into(),
                lines: vec![arc],
                points: norm,
                equal_aspect: true,
                // The plot area is about twice as wide as high: H' gets the room, both from 0.
                x_range: Some((0.0, 2.0 * norm_max)),
                y_range: Some((0.0, norm_max)),
                ..Default::default()
            },
        ),
    ]
}

impl MatchingWorkflow {
    /// The figures of one take: its velocity function (continuous takes) and each repetition's
    /// warping paths, as `[matching] figures` asks.
    pub(super) fn item_figures(
        &self,
        id: &str,
        result: &ItemResult,
        detection: Option<&(PointDetection, usize)>,
        paths: &[Vec<Vec<(usize, usize)>>],
    ) -> Result<Vec<Figure>> {
        let mut figs = Vec::new();
        if self.wants(MatchingFigure::Velocity)
            && let Some((d, offset)) = detection
        {
            figs.push(self.velocity_figure(id, result, d, *offset));
        }
        if self.wants(MatchingFigure::Paths) {
            for (k, (rep, rep_paths)) in result.repetitions.iter().zip(paths).enumerate() {
                if let Some(f) = self.paths_figure(id, result, k, rep, rep_paths)? {
                    figs.push(f);
                }
            }
        }
        Ok(figs)
    }

    /// Fig. 2: the detector's velocity function with its threshold, the peaks numbered by
    /// repetition, the cut windows and the matched stretches (seconds in the file: the cut
    /// `offset` added back).
    fn velocity_figure(
        &self,
        id: &str,
        result: &ItemResult,
        d: &PointDetection,
        offset: usize,
    ) -> Figure {
        let rate = result.frame_rate_hz;
        let marker = self
            .section
            .point_detector
            .as_ref()
            .and_then(|s| s.params.get("marker"))
            .and_then(|m| m.as_str())
            .unwrap_or("the detector's marker");
        let t = |f: usize| (f + offset) as f64 / rate;
        let time: Vec<f64> = (0..d.velocity.values.len()).map(t).collect();
        let mut peaks = Series::new(
            "peaks",
            d.peaks.iter().map(|&p| t(p)).collect(),
            d.peaks
                .iter()
                .map(|&p| d.velocity.values.get(p).copied().unwrap_or(f64::NAN))
                .collect(),
        );
        let per = self.section.peaks_per_repetition;
        peaks.point_labels = (0..d.peaks.len()).map(|k| format!("{}", k / per + 1)).collect();
        let reps = &result.repetitions;
        let s = |f: usize| f as f64 / rate;
        Figure::chart(
            format!("{id}_velocity"),
            Chart {
                title: format!(
                    "{} — velocity function of {marker}, threshold, peaks by repetition, windows (Fig. 2)",
                    result.take
                ),
                x_label: "time in the file (s)".into(),
                y_label: format!("v = |s(i) − s(i+1)| ({})", d.velocity.unit),
                lines: vec![Series::new(format!("v ({marker})"), time, d.velocity.values.clone())],
                points: vec![peaks],
                hlines: vec![RefLine { label: "threshold".into(), value: d.threshold }],
                bar_rows: vec![
                    BarRow {
                        label: "cut windows".into(),
                        marks: vec![],
                        bands: reps
                            .iter()
                            .map(|r| (s(r.window_start), s(r.window_end.saturating_sub(1))))
                            .collect(),
                    },
                    BarRow {
                        label: "matched [a, b]".into(),
                        marks: reps
                            .iter()
                            .flat_map(|r| [s(r.window_start + r.start), s(r.window_start + r.end)])
                            .collect(),
                        bands: reps
                            .iter()
                            .map(|r| (s(r.window_start + r.start), s(r.window_start + r.end)))
                            .collect(),
                    },
                ],
                ..Default::default()
            },
        )
    }

    /// Fig. 4 for repetition `k`: the warping paths of the `path_markers` (or of the two most
    /// out of step) with their mean matched frames at the examined model frames; none when the
    /// repetition has fewer than two paths or no pair stands out.
    fn paths_figure(
        &self,
        id: &str,
        result: &ItemResult,
        k: usize,
        rep: &RepetitionRecord,
        rep_paths: &[Vec<(usize, usize)>],
    ) -> Result<Option<Figure>> {
        if rep_paths.len() < 2 {
            return Ok(None);
        }
        let pair = match &self.section.path_markers {
            Some([m1, m2]) => {
                let find = |m: &str| {
                    result.point_names.iter().position(|n| n == m).ok_or_else(|| {
                        self.locator.locate(
                            Error::new(
                                ErrorKind::UnknownName,
                                format!("path marker {m:?} is not among the matched points"),
                            ),
                            "matching.path_markers",
                        )
                    })
                };
                (find(m1)?, find(m2)?)
            }
            None => match most_out_of_step(rep_paths, &rep.sync_frames, result.model_frames) {
                Some(p) => p,
                None => return Ok(None),
            },
        };
        let mut lines = Vec::new();
        let mut points = Vec::new();
        for l in [pair.0, pair.1] {
            let name = result.point_names.get(l).cloned().unwrap_or_default();
            let path = &rep_paths[l];
            lines.push(Series::new(
                format!(
                    "{name} (h = {} mm)",
                    fmt(rep.point_distances.get(l).copied().unwrap_or(f64::NAN))
                ),
                path.iter().map(|&(i, _)| i as f64).collect(),
                path.iter().map(|&(_, j)| (rep.window_start + j) as f64).collect(),
            ));
            let u = mean_target_frames(path, result.model_frames);
            points.push(Series::new(
                format!("{name} at the examined model frames"),
                rep.sync_frames.iter().map(|&i| i as f64).collect(),
                rep.sync_frames
                    .iter()
                    .map(|&i| u.get(i).copied().unwrap_or(f64::NAN) + rep.window_start as f64)
                    .collect(),
            ));
        }
        let rate = result.frame_rate_hz;
        Ok(Some(Figure::chart(
            format!("{id}_paths_{}", k + 1),
            Chart {
                title: format!(
                    "{} — {}: warping paths of two markers, R = {} frames² (Fig. 4)",
                    result.take,
                    rep.label,
                    fmt(rep.sync_total)
                ),
                x_label: format!("model frame i (frames at {} Hz)", fmt(rate)),
                y_label: format!("matched frame j of the file (frames at {} Hz)", fmt(rate)),
                lines,
                points,
                ..Default::default()
            },
        )))
    }
}
