//! # motionlab-figure
//!
//! Figure specs as plain data: what to draw (series, thresholds, rows of candidate bars, stick
//! figures), never how. Workflows build them without knowing any drawing library;
//! `motionlab-report` renders them with plotters to PNG and SVG. Every figure has a title and
//! axis labels with units.
//!
//! Depends on serde only (no polars, plotters or clap), so algorithm-side crates may use it.

use serde::{Deserialize, Serialize};

/// A data series: `x[i], y[i]` pairs, optionally with a label per point.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Series {
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Per-point annotations (scatter plots); empty for none.
    #[serde(default)]
    pub point_labels: Vec<String>,
}

impl Series {
    pub fn new(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series { label: label.into(), x, y, point_labels: Vec::new() }
    }
}

/// A horizontal reference line (a threshold).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RefLine {
    pub label: String,
    pub value: f64,
}

/// One row of vertical bars under a chart (candidate frames of a method), optionally with
/// shaded bands (ground-truth windows).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BarRow {
    pub label: String,
    pub marks: Vec<f64>,
    #[serde(default)]
    pub bands: Vec<(f64, f64)>,
}

/// A 2-D chart: lines, scatter points, thresholds, and rows of candidate bars beneath it.
/// With no lines and no points it is a pure timeline of bar rows.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub lines: Vec<Series>,
    pub points: Vec<Series>,
    pub hlines: Vec<RefLine>,
    pub bar_rows: Vec<BarRow>,
    /// Same scale on both axes (floor-plane paths).
    #[serde(default)]
    pub equal_aspect: bool,
    /// Optional fixed x range.
    #[serde(default)]
    pub x_range: Option<(f64, f64)>,
    /// Optional fixed y range.
    #[serde(default)]
    pub y_range: Option<(f64, f64)>,
}

/// A stick figure: 2-D projected points and the bones joining them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub label: String,
    pub points: Vec<[f64; 2]>,
}

/// One row of poses drawn side by side (a strip of snapshots).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StickRow {
    pub label: String,
    pub poses: Vec<Pose>,
}

/// Strips of stick figures (the papers' snapshot figures), all rows at one scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StickStrip {
    pub title: String,
    /// Index pairs into each pose's points.
    pub bones: Vec<(usize, usize)>,
    pub rows: Vec<StickRow>,
    /// What the drawing's axes are (`side view, x–z, mm`).
    pub caption: String,
}

/// Something to draw.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FigureKind {
    Chart(Chart),
    Sticks(StickStrip),
    TimelinePoses(TimelinePoses),
    CriticalDifference(CriticalDifference),
}

/// A critical-difference diagram (Demšar 2006, as the TSSB and ClaSP papers draw it): an axis
/// of mean ranks (1 = best, on the left), each method's mean rank marked and labelled — the
/// better half on the left, the rest on the right — a bar as long as the critical difference,
/// and a thick line under each clique of methods whose ranks do not differ significantly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CriticalDifference {
    pub title: String,
    /// The methods, in any order.
    pub methods: Vec<RankedMethod>,
    /// The critical difference, in ranks (NaN: none drawn).
    pub critical_difference: f64,
    /// Groups of methods (indices into `methods`) not significantly different.
    pub cliques: Vec<Vec<usize>>,
    pub caption: String,
}

/// One method of a [`CriticalDifference`] diagram.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RankedMethod {
    pub label: String,
    pub mean_rank: f64,
    /// Drawn in a second colour (published scores beside computed ones).
    #[serde(default)]
    pub secondary: bool,
}

/// A timeline of bar rows (ground truth, each method) with a stick-figure pose drawn under each
/// marked instant, on the same time axis (Sonoda et al.'s Figs 10 and 11 in one picture).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimelinePoses {
    /// The timeline: bar rows only (its lines and points are ignored).
    pub timeline: Chart,
    /// Index pairs into each pose's points.
    pub bones: Vec<(usize, usize)>,
    /// (time in the timeline's x unit, pose) pairs, in time order.
    pub poses: Vec<(f64, Pose)>,
    pub caption: String,
}

/// A named figure; `name` becomes the file stem.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    pub name: String,
    pub figure: FigureKind,
}

impl Figure {
    pub fn chart(name: impl Into<String>, chart: Chart) -> Self {
        Figure { name: name.into(), figure: FigureKind::Chart(chart) }
    }
    pub fn sticks(name: impl Into<String>, strip: StickStrip) -> Self {
        Figure { name: name.into(), figure: FigureKind::Sticks(strip) }
    }
    pub fn title(&self) -> &str {
        match &self.figure {
            FigureKind::Chart(c) => &c.title,
            FigureKind::Sticks(s) => &s.title,
            FigureKind::TimelinePoses(t) => &t.timeline.title,
            FigureKind::CriticalDifference(c) => &c.title,
        }
    }
}
