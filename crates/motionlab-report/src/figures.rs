//! Figures: plain data specs ([`Figure`]) rendered with plotters to PNG and SVG.
//!
//! Workflows describe *what* to draw (series, candidate bars, thresholds, stick figures); this
//! module is the only place that knows plotters. Every figure has a title and axis labels with
//! units. Text uses the bundled DejaVu Sans (plotters' `ttf` feature would need the system's
//! fontconfig), registered once per process; text with Japanese characters falls back to the
//! bundled Noto Sans CJK JP subset ([`crate::fonts`]).

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use motionlab_core::{Error, ErrorKind, Location, Result};

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn ensure_font() {
    REGISTER.call_once(|| {
        // Registration only fails for an unparsable font; the bundled one parses (tested).
        let _ = register_font("sans-serif", FontStyle::Normal, FONT);
        let _ = register_font(crate::fonts::CJK_FAMILY, FontStyle::Normal, crate::fonts::CJK_FONT);
    });
}

// The specs are plain data in `motionlab-figure` (so workflows build them without plotters);
// this module renders them.
pub use motionlab_figure::{
    BarRow, Chart, CriticalDifference, Figure, FigureKind, Pose, RankedMethod, RefLine, Series,
    StickRow, StickStrip, TimelinePoses,
};

/// The font family for a text: DejaVu Sans, or — only for text with CJK characters, which it
/// lacks — the bundled Noto Sans CJK JP subset (which also draws Latin), so figures without
/// Japanese text are drawn exactly as before.
fn family(text: &str) -> &'static str {
    if crate::fonts::needs_cjk(text) { crate::fonts::CJK_FAMILY } else { "sans-serif" }
}

/// Pixel size of rendered figures.
const SIZE: (u32, u32) = (1100, 560);

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Renders a figure to `<dir>/<name>.png` and `<dir>/<name>.svg`; returns both paths.
pub fn render(figure: &Figure, dir: &Path) -> Result<Vec<PathBuf>> {
    ensure_font();
    let stem = motionlab_core::paths::safe_file_name(&figure.name);
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let size = match &figure.figure {
        FigureKind::Chart(c) if c.lines.is_empty() && c.points.is_empty() => {
            (SIZE.0, (90 + 34 * c.bar_rows.len() as u32).max(160))
        }
        FigureKind::Sticks(s) => (SIZE.0, 90 + 230 * s.rows.len().max(1) as u32),
        FigureKind::TimelinePoses(t) => {
            (1400, (90 + 34 * t.timeline.bar_rows.len() as u32).max(160) + 2 * POSE_ROW_PX + 30)
        }
        FigureKind::CriticalDifference(c) => (1000, cd_layout(c).height),
        _ => SIZE,
    };
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        draw(figure, &root).map_err(|e| draw_error(&png, e))?;
        root.present().map_err(|e| draw_error(&png, e))?;
    }
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw(figure, &root).map_err(|e| draw_error(&svg, e))?;
        root.present().map_err(|e| draw_error(&svg, e))?;
    }
    finish_svg(&svg)?;
    Ok(vec![png, svg])
}

/// Makes a rendered SVG valid and self-contained: characters XML forbids are replaced, and an
/// SVG shown through `<img>` cannot use its page's fonts, so when its text has CJK characters
/// the bundled CJK font goes into the SVG itself (other SVGs are left byte-identical).
fn finish_svg(path: &Path) -> Result<()> {
    let mut text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    // plotters escapes `<`, `&` and quotes in text, but writes control characters as they are,
    // and XML forbids them: a name holding one (an experiment's method name, a file name)
    // would make the whole SVG unreadable. They become U+FFFD, as an HTML parser shows them.
    if text.contains(is_invalid_in_xml) {
        text = text.replace(is_invalid_in_xml, "\u{fffd}");
        if !crate::fonts::needs_cjk(&text) {
            return std::fs::write(path, text).map_err(|e| Error::io(path, e));
        }
    }
    if !crate::fonts::needs_cjk(&text) {
        return Ok(());
    }
    let Some(open_end) = text.find("<svg").and_then(|i| text[i..].find('>').map(|j| i + j + 1))
    else {
        return Ok(());
    };
    let style = crate::fonts::css_font_face()
        .replace("<style>", "<defs><style><![CDATA[")
        .replace("</style>", "]]></style></defs>");
    let out = [&text[..open_end], "\n", &style, &text[open_end..]].concat();
    std::fs::write(path, out).map_err(|e| Error::io(path, e))
}

/// Characters XML 1.0 does not allow in a document (C0 controls but tab, newline and carriage
/// return; U+FFFE and U+FFFF).
fn is_invalid_in_xml(c: char) -> bool {
    (c < ' ' && !matches!(c, '\t' | '\n' | '\r')) || matches!(c, '\u{fffe}' | '\u{ffff}')
}

fn draw_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::new(ErrorKind::Report, format!("cannot draw figure: {e}"))
        .with_location(Location::file(path))
}

type DrawResult<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn draw<DB: DrawingBackend>(figure: &Figure, root: &DrawingArea<DB, Shift>) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    match &figure.figure {
        FigureKind::Chart(c) => draw_chart(c, root),
        FigureKind::Sticks(s) => draw_sticks(s, root),
        FigureKind::TimelinePoses(t) => draw_timeline_poses(t, root),
        FigureKind::CriticalDifference(c) => draw_critical_difference(c, root),
    }
}

/// Pixel layout of a critical-difference diagram.
struct CdLayout {
    /// y of the rank axis.
    axis_y: i32,
    /// y of the first label row under the cliques.
    first_row_y: i32,
    height: u32,
}

const CD_ROW_PX: i32 = 24;
const CD_MARGIN_PX: i32 = 250;

fn cd_layout(c: &CriticalDifference) -> CdLayout {
    let axis_y = 104;
    let rows = c.methods.len().div_ceil(2) as i32;
    let first_row_y = axis_y + 22 + 7 * c.cliques.len() as i32;
    let height = (first_row_y + rows * CD_ROW_PX + 40).max(200) as u32;
    CdLayout { axis_y, first_row_y, height }
}

/// Demšar's diagram as Orange's `graph_ranks` lays it out: rank 1 on the left; the better
/// half of the methods labelled on the left (best on top), the rest on the right (worst on
/// top); the critical difference above the axis, each clique a thick line under it.
fn draw_critical_difference<DB: DrawingBackend>(
    c: &CriticalDifference,
    root: &DrawingArea<DB, Shift>,
) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let (w, _) = root.dim_in_pixel();
    let layout = cd_layout(c);
    root.draw(&Text::new(c.title.clone(), (12, 8), (family(&c.title), 22)))?;
    let k = c.methods.len().max(2);
    let (left, right) = (CD_MARGIN_PX, w as i32 - CD_MARGIN_PX);
    let x_of =
        |rank: f64| left + ((rank - 1.0) / (k as f64 - 1.0) * (right - left) as f64).round() as i32;
    let axis = layout.axis_y;
    let black = BLACK.stroke_width(1);
    root.draw(&PathElement::new(vec![(left, axis), (right, axis)], black))?;
    let centred = |size: u32, text: &str| {
        TextStyle::from((family(text), size).into_font()).pos(Pos::new(HPos::Center, VPos::Bottom))
    };
    for r in 1..=k {
        let x = x_of(r as f64);
        root.draw(&PathElement::new(vec![(x, axis - 8), (x, axis)], black))?;
        root.draw(&Text::new(r.to_string(), (x, axis - 10), centred(14, "1")))?;
        if r < k {
            let h = x_of(r as f64 + 0.5);
            root.draw(&PathElement::new(vec![(h, axis - 4), (h, axis)], black))?;
        }
    }
    if c.critical_difference.is_finite() && c.critical_difference > 0.0 {
        let (a, b) = (x_of(1.0), x_of(1.0 + c.critical_difference));
        let y = axis - 44;
        root.draw(&PathElement::new(vec![(a, y), (b, y)], BLACK.stroke_width(2)))?;
        root.draw(&PathElement::new(vec![(a, y - 4), (a, y + 4)], black))?;
        root.draw(&PathElement::new(vec![(b, y - 4), (b, y + 4)], black))?;
        let label = format!("CD = {}", fmt_num(c.critical_difference));
        root.draw(&Text::new(label.clone(), ((a + b) / 2, y - 6), centred(14, &label)))?;
    }
    let mut order: Vec<usize> = (0..c.methods.len()).collect();
    order.sort_by(|&a, &b| {
        c.methods[a].mean_rank.total_cmp(&c.methods[b].mean_rank).then(a.cmp(&b))
    });
    let n_left = c.methods.len().div_ceil(2);
    let secondary = RGBColor(31, 119, 180);
    for (pos, &m) in order.iter().enumerate() {
        let method = &c.methods[m];
        let colour = if method.secondary { secondary } else { BLACK };
        let x = x_of(method.mean_rank);
        let (row, on_left) =
            if pos < n_left { (pos, true) } else { (c.methods.len() - 1 - pos, false) };
        let y = layout.first_row_y + row as i32 * CD_ROW_PX;
        let end = if on_left { left - 10 } else { right + 10 };
        root.draw(&PathElement::new(vec![(x, axis), (x, y), (end, y)], colour.stroke_width(1)))?;
        let label = format!("{} ({})", method.label, fmt_num(method.mean_rank));
        let anchor = if on_left { HPos::Right } else { HPos::Left };
        let style = TextStyle::from((family(&label), 14).into_font())
            .pos(Pos::new(anchor, VPos::Center))
            .color(&colour);
        root.draw(&Text::new(label, (if on_left { end - 4 } else { end + 4 }, y), style))?;
    }
    for (j, clique) in c.cliques.iter().enumerate() {
        let ranks = clique.iter().filter_map(|&i| c.methods.get(i)).map(|m| m.mean_rank);
        let (lo, hi) =
            ranks.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| (a.min(r), b.max(r)));
        if lo.is_finite() {
            let y = axis + 12 + 7 * j as i32;
            root.draw(&PathElement::new(
                vec![(x_of(lo) - 4, y), (x_of(hi) + 4, y)],
                BLACK.stroke_width(4),
            ))?;
        }
    }
    let caption_y = layout.height as i32 - 22;
    root.draw(&Text::new(c.caption.clone(), (12, caption_y), (family(&c.caption), 13)))?;
    Ok(())
}

/// Height of one row of poses under a timeline, pixels.
const POSE_ROW_PX: u32 = 150;

/// The timeline on top; underneath, each pose centred on its instant. Poses that would overlap
/// their left neighbour drop to a second row, so every one stays readable.
fn draw_timeline_poses<DB: DrawingBackend>(
    t: &TimelinePoses,
    root: &DrawingArea<DB, Shift>,
) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    let (w, h) = root.dim_in_pixel();
    let pose_h = 2 * POSE_ROW_PX + 30;
    let (top, bottom) = root.split_vertically(h as i32 - pose_h as i32);
    let mut timeline = t.timeline.clone();
    timeline.lines.clear();
    timeline.points.clear();
    let xs =
        timeline.bar_rows.iter().flat_map(|b| b.marks.iter()).chain(t.poses.iter().map(|p| &p.0));
    let (x0, x1) = timeline.x_range.unwrap_or_else(|| range_of(xs, 0.01));
    timeline.x_range = Some((x0, x1));
    draw_chart(&timeline, &top)?;
    let (poses_area, caption) = bottom.split_vertically(pose_h as i32 - 24);
    caption.draw(&Text::new(t.caption.clone(), (10, 4), (family(&t.caption), 14)))?;
    // The bar rows' plot starts after their label column (`draw_bar_rows`: margin 8, label area
    // 150) and ends 8 px before the right edge: put the poses on the same pixels per second.
    let (left, right) = (8 + 150, w as i32 - 8);
    let px_per_x = (right - left) as f64 / (x1 - x0).max(1e-12);
    let extent = t
        .poses
        .iter()
        .map(|(_, p)| {
            let (yl, yh) = range_of(p.points.iter().map(|q| &q[1]), 0.0);
            let (xl, xh) = range_of(p.points.iter().map(|q| &q[0]), 0.0);
            (yh - yl).max(xh - xl)
        })
        .fold(1.0_f64, f64::max);
    let px_per_mm = (POSE_ROW_PX as f64 - 24.0) / extent;
    let mut last_right = [f64::NEG_INFINITY; 2];
    for (time, pose) in &t.poses {
        let cx = left as f64 + (time - x0) * px_per_x;
        let (pxl, pxh) = range_of(pose.points.iter().map(|q| &q[0]), 0.0);
        let (pyl, pyh) = range_of(pose.points.iter().map(|q| &q[1]), 0.0);
        let half_w = (pxh - pxl) / 2.0 * px_per_mm + 4.0;
        let row = if cx - half_w > last_right[0] {
            0
        } else if cx - half_w > last_right[1] {
            1
        } else {
            0
        };
        last_right[row] = cx + half_w;
        let base = (row as f64 + 1.0) * POSE_ROW_PX as f64 - 18.0;
        let (mx, my) = ((pxl + pxh) / 2.0, pyl);
        let to_px = |q: &[f64; 2]| {
            ((cx + (q[0] - mx) * px_per_mm) as i32, (base - (q[1] - my) * px_per_mm) as i32)
        };
        for (a, b) in &t.bones {
            if let (Some(p), Some(q)) = (pose.points.get(*a), pose.points.get(*b))
                && p.iter().chain(q).all(|v| v.is_finite())
            {
                poses_area
                    .draw(&PathElement::new(vec![to_px(p), to_px(q)], BLACK.stroke_width(1)))?;
            }
        }
        for p in pose.points.iter().filter(|p| p[0].is_finite() && p[1].is_finite()) {
            poses_area.draw(&Circle::new(to_px(p), 1, color(0).filled()))?;
        }
        poses_area.draw(&Text::new(
            pose.label.clone(),
            (cx as i32 - 14, base as i32 + 4),
            (family(&pose.label), 11),
        ))?;
        // A tick from the pose up to the time axis, so each pose reads against its instant.
        poses_area.draw(&PathElement::new(
            vec![(cx as i32, 0), (cx as i32, 6)],
            RGBColor(120, 120, 120),
        ))?;
        let _ = pyh;
    }
    Ok(())
}

/// Finite min/max over many slices, padded; a fallback range when nothing is finite.
fn range_of<'a>(values: impl Iterator<Item = &'a f64>, pad_frac: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        let d = if lo.abs() > 1e-12 { lo.abs() * 0.1 } else { 1.0 };
        return (lo - d, hi + d);
    }
    let pad = (hi - lo) * pad_frac;
    (lo - pad, hi + pad)
}

fn draw_chart<DB: DrawingBackend>(c: &Chart, root: &DrawingArea<DB, Shift>) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    let has_plot = !(c.lines.is_empty() && c.points.is_empty());
    let xs = c.lines.iter().chain(&c.points).flat_map(|s| s.x.iter()).chain(
        c.bar_rows
            .iter()
            .flat_map(|b| b.marks.iter().chain(b.bands.iter().flat_map(|(a, z)| [a, z]))),
    );
    let (mut x0, mut x1) = c.x_range.unwrap_or_else(|| range_of(xs, 0.01));
    let root = root.titled(&c.title, (family(&c.title), 22))?;
    let rows = c.bar_rows.len();
    let (plot_area, bar_area) = if !has_plot {
        (None, root.clone())
    } else if rows > 0 {
        let h = root.dim_in_pixel().1 as i32;
        let (a, b) = root.split_vertically(h - (26 * rows as i32 + 40));
        (Some(a), b)
    } else {
        (Some(root.clone()), root.clone())
    };
    let label_area = 150;
    if let Some(area) = plot_area {
        let ys = c
            .lines
            .iter()
            .chain(&c.points)
            .flat_map(|s| s.y.iter())
            .chain(c.hlines.iter().map(|h| &h.value));
        let (mut y0, mut y1) = c.y_range.unwrap_or_else(|| range_of(ys, 0.05));
        if c.equal_aspect {
            // Widen the narrower axis so one mm is the same length on both.
            let (w, h) = area.dim_in_pixel();
            let (pw, ph) = ((w as f64 - label_area as f64).max(1.0), (h as f64 - 60.0).max(1.0));
            let scale = ((x1 - x0) / pw).max((y1 - y0) / ph);
            let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
            (x0, x1) = (cx - scale * pw / 2.0, cx + scale * pw / 2.0);
            (y0, y1) = (cy - scale * ph / 2.0, cy + scale * ph / 2.0);
        }
        let mut chart = ChartBuilder::on(&area)
            .margin(8)
            .margin_left(label_area as i32 - 70)
            .x_label_area_size(if rows > 0 { 20 } else { 42 })
            .y_label_area_size(90)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        let mut mesh = chart.configure_mesh();
        mesh.y_desc(c.y_label.as_str())
            .label_style(("sans-serif", 14))
            .axis_desc_style((family(&format!("{}{}", c.x_label, c.y_label)), 16))
            .x_label_formatter(&|v| fmt_num(*v))
            .y_label_formatter(&|v| fmt_num(*v));
        if rows == 0 {
            mesh.x_desc(c.x_label.as_str());
        }
        mesh.draw()?;
        let mut legend = false;
        for (i, s) in c.lines.iter().enumerate() {
            let col = color(i);
            // plotters joins thick polylines with unbounded miters: on dense, spiky signals
            // they shoot across the figure. Dense series are drawn 1 px wide.
            let width = if s.x.len() > 300 { 1 } else { 2 };
            // Split at non-finite values so undefined stretches are gaps, not zeros.
            let mut segment: Vec<(f64, f64)> = Vec::new();
            let mut first = true;
            for (x, y) in s.x.iter().zip(&s.y).chain(std::iter::once((&f64::NAN, &f64::NAN))) {
                if x.is_finite() && y.is_finite() {
                    segment.push((*x, *y));
                } else if !segment.is_empty() {
                    let series = chart.draw_series(LineSeries::new(
                        std::mem::take(&mut segment),
                        col.stroke_width(width),
                    ))?;
                    if first && !s.label.is_empty() {
                        series.label(s.label.clone()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 18, y)], col.stroke_width(2))
                        });
                        legend = true;
                    }
                    first = false;
                }
            }
        }
        for (i, s) in c.points.iter().enumerate() {
            let col = color(i + c.lines.len());
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(&s.y)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(x, y)| (*x, *y))
                    .collect();
            let series = chart.draw_series(pts.iter().map(|p| Circle::new(*p, 5, col.filled())))?;
            if !s.label.is_empty() {
                series
                    .label(s.label.clone())
                    .legend(move |(x, y)| Circle::new((x + 9, y), 5, col.filled()));
                legend = true;
            }
            for ((x, y), l) in s.x.iter().zip(&s.y).zip(&s.point_labels) {
                if x.is_finite() && y.is_finite() && !l.is_empty() {
                    chart.draw_series(std::iter::once(Text::new(
                        l.clone(),
                        (*x, *y),
                        (family(l), 13),
                    )))?;
                }
            }
        }
        for (i, h) in c.hlines.iter().enumerate() {
            let col = RGBColor(90, 90, 90);
            let style = ShapeStyle { color: col.to_rgba(), filled: false, stroke_width: 1 };
            let series = chart.draw_series(DashedLineSeries::new(
                vec![(x0, h.value), (x1, h.value)],
                8,
                5,
                style,
            ))?;
            if !h.label.is_empty() {
                let lbl = format!("{} = {}", h.label, fmt_num(h.value));
                series
                    .label(lbl)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], col));
                legend = true;
            }
            let _ = i;
        }
        if legend {
            let names: Vec<&str> = c
                .lines
                .iter()
                .chain(&c.points)
                .map(|s| s.label.as_str())
                .chain(c.hlines.iter().map(|h| h.label.as_str()))
                .collect();
            let legend_family = family(&names.concat());
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.3))
                .label_font((legend_family, 14))
                .position(SeriesLabelPosition::UpperRight)
                .draw()?;
        }
    }
    if rows > 0 {
        draw_bar_rows(c, &bar_area, (x0, x1), has_plot, label_area)?;
    }
    Ok(())
}

fn draw_bar_rows<DB: DrawingBackend>(
    c: &Chart,
    area: &DrawingArea<DB, Shift>,
    (x0, x1): (f64, f64),
    has_plot: bool,
    label_area: u32,
) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    let rows = c.bar_rows.len();
    let mut chart = ChartBuilder::on(area)
        .margin(8)
        .margin_left(if has_plot { label_area as i32 - 70 } else { 8 })
        .x_label_area_size(40)
        .y_label_area_size(if has_plot { 90 } else { label_area })
        .build_cartesian_2d(x0..x1, 0.0..rows as f64)?;
    let labels: Vec<String> = c.bar_rows.iter().map(|b| b.label.clone()).collect();
    chart
        .configure_mesh()
        .disable_y_mesh()
        .x_desc(c.x_label.as_str())
        .x_label_formatter(&|v| fmt_num(*v))
        .y_labels(rows * 2 + 1)
        .y_label_formatter(&|y: &f64| {
            // Label each row at its centre (rows are drawn top to bottom).
            let r = rows as f64 - y - 0.5;
            if (r - r.round()).abs() < 1e-6 && r >= 0.0 && (r.round() as usize) < rows {
                labels[r.round() as usize].clone()
            } else {
                String::new()
            }
        })
        .label_style((family(&labels.concat()), 14))
        .axis_desc_style((family(&c.x_label), 16))
        .draw()?;
    for (r, row) in c.bar_rows.iter().enumerate() {
        let top = (rows - r) as f64 - 0.1;
        let bottom = (rows - r - 1) as f64 + 0.1;
        let col = color(r);
        chart.draw_series(row.bands.iter().map(|(a, b)| {
            Rectangle::new([(*a, bottom), (*b, top)], RGBColor(0, 0, 0).mix(0.18).filled())
        }))?;
        chart.draw_series(
            row.marks
                .iter()
                .filter(|m| m.is_finite())
                .map(|m| PathElement::new(vec![(*m, bottom), (*m, top)], col.stroke_width(2))),
        )?;
    }
    Ok(())
}

fn draw_sticks<DB: DrawingBackend>(s: &StickStrip, root: &DrawingArea<DB, Shift>) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    let root = root.titled(&s.title, (family(&s.title), 22))?;
    let (body, caption) = root.split_vertically(root.dim_in_pixel().1 as i32 - 24);
    caption.draw(&Text::new(s.caption.clone(), (10, 4), (family(&s.caption), 14)))?;
    let rows = body.split_evenly((s.rows.len().max(1), 1));
    // One scale for every pose of every row: the largest pose extent.
    let mut extent: f64 = 1.0;
    for row in &s.rows {
        for p in &row.poses {
            let (xl, xh) = range_of(p.points.iter().map(|q| &q[0]), 0.0);
            let (yl, yh) = range_of(p.points.iter().map(|q| &q[1]), 0.0);
            extent = extent.max(xh - xl).max(yh - yl);
        }
    }
    for (row, area) in s.rows.iter().zip(rows) {
        let (label_area, poses_area) = area.split_horizontally(150);
        label_area.draw(&Text::new(
            row.label.clone(),
            (6, (area.dim_in_pixel().1 / 2) as i32),
            (family(&row.label), 15),
        ))?;
        let cells = poses_area.split_evenly((1, row.poses.len().max(1)));
        for (pose, cell) in row.poses.iter().zip(cells) {
            let (cx, cy) = {
                let (xl, xh) = range_of(pose.points.iter().map(|q| &q[0]), 0.0);
                let (yl, yh) = range_of(pose.points.iter().map(|q| &q[1]), 0.0);
                ((xl + xh) / 2.0, (yl + yh) / 2.0)
            };
            let half = extent * 0.55;
            let (body, lbl) = cell.split_vertically(cell.dim_in_pixel().1 as i32 - 20);
            let mut chart = ChartBuilder::on(&body)
                .margin(4)
                .build_cartesian_2d(cx - half..cx + half, cy - half..cy + half)?;
            let pts = &pose.points;
            chart.draw_series(s.bones.iter().filter_map(|(a, b)| {
                let (p, q) = (pts.get(*a)?, pts.get(*b)?);
                (p.iter().chain(q).all(|v| v.is_finite())).then(|| {
                    PathElement::new(vec![(p[0], p[1]), (q[0], q[1])], BLACK.stroke_width(2))
                })
            }))?;
            chart.draw_series(
                pts.iter()
                    .filter(|p| p[0].is_finite() && p[1].is_finite())
                    .map(|p| Circle::new((p[0], p[1]), 2, color(0).filled())),
            )?;
            lbl.draw(&Text::new(pose.label.clone(), (4, 2), (family(&pose.label), 13)))?;
        }
    }
    Ok(())
}

/// Compact number formatting for labels and tables (in `motionlab-core`, beside `Table`).
pub use motionlab_core::table::fmt_num;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_png_and_svg_for_every_kind() {
        let dir = std::env::temp_dir().join(format!("mlab-fig-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let x: Vec<f64> = (0..100).map(|i| i as f64 / 10.0).collect();
        let y: Vec<f64> =
            x.iter().map(|v| if (3.0..3.5).contains(v) { f64::NAN } else { v.sin() }).collect();
        let chart = Chart {
            title: "V with candidates".into(),
            x_label: "time (s)".into(),
            y_label: "speed (mm/s)".into(),
            lines: vec![Series::new("V", x.clone(), y)],
            hlines: vec![RefLine { label: "v_low".into(), value: 0.2 }],
            bar_rows: vec![BarRow { label: "speed".into(), marks: vec![1.0, 4.0], bands: vec![] }],
            ..Default::default()
        };
        let timeline = Chart {
            title: "timeline".into(),
            x_label: "time (s)".into(),
            bar_rows: vec![
                BarRow { label: "truth".into(), marks: vec![2.0], bands: vec![(1.8, 2.2)] },
                BarRow { label: "fused".into(), marks: vec![2.1], bands: vec![] },
            ],
            ..Default::default()
        };
        let sticks = StickStrip {
            title: "poses".into(),
            bones: vec![(0, 1), (1, 2)],
            rows: vec![StickRow {
                label: "recorded".into(),
                poses: vec![Pose {
                    label: "f0".into(),
                    points: vec![[0.0, 0.0], [0.0, 500.0], [200.0, 800.0]],
                }],
            }],
            caption: "side view (x–z, mm)".into(),
        };
        let combined = Figure {
            name: "d".into(),
            figure: FigureKind::TimelinePoses(TimelinePoses {
                timeline: timeline.clone(),
                bones: sticks.bones.clone(),
                poses: vec![
                    (2.1, sticks.rows[0].poses[0].clone()),
                    (2.2, sticks.rows[0].poses[0].clone()),
                ],
                caption: "pose at each fused candidate".into(),
            }),
        };
        let ranked = |label: &str, mean_rank: f64, secondary: bool| RankedMethod {
            label: label.into(),
            mean_rank,
            secondary,
        };
        let cd = Figure {
            name: "e".into(),
            figure: FigureKind::CriticalDifference(CriticalDifference {
                title: "mean rank by covering".into(),
                methods: vec![
                    ranked("clasp", 1.4, false),
                    ranked("ClaSP (published)", 1.5, true),
                    ranked("window", 4.2, false),
                    ranked("pelt", 2.9, false),
                    ranked("bocpd", 4.0, false),
                ],
                critical_difference: 0.9,
                cliques: vec![vec![0, 1], vec![2, 4]],
                caption: "Nemenyi, α = 0.05, 75 series".into(),
            }),
        };
        for f in [
            Figure::chart("a", chart),
            Figure::chart("b", timeline),
            Figure::sticks("c", sticks),
            combined,
            cd,
        ] {
            let paths = render(&f, &dir).unwrap();
            for p in paths {
                let len = std::fs::metadata(&p).unwrap().len();
                assert!(len > 1000, "{} is only {len} bytes", p.display());
            }
        }
        let svg = std::fs::read_to_string(dir.join("a.svg")).unwrap();
        assert!(svg.contains("V with candidates") && svg.contains("speed (mm/s)"));
        // The diagram labels every method with its mean rank, and the critical difference.
        let svg = std::fs::read_to_string(dir.join("e.svg")).unwrap();
        for text in
            ["clasp (1.4)", "ClaSP (published) (1.5)", "window (4.2)", "CD = 0.9", "Nemenyi"]
        {
            assert!(svg.contains(text), "{text} missing");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn japanese_text_is_drawn_with_glyphs_not_boxes() {
        // Missing glyphs all draw the same box: with real glyphs, two titles that differ in one
        // kanji differ in pixels.
        let dir = std::env::temp_dir().join(format!("mlab-fig-jp-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let chart = |title: &str| Chart {
            title: title.into(),
            x_label: "time (s)".into(),
            bar_rows: vec![BarRow { label: "truth".into(), marks: vec![1.0], bands: vec![] }],
            ..Default::default()
        };
        render(&Figure::chart("left", chart("左膝X (left knee X)")), &dir).unwrap();
        render(&Figure::chart("right", chart("右膝X (left knee X)")), &dir).unwrap();
        render(&Figure::chart("plain", chart("knee X")), &dir).unwrap();
        let read = |n: &str| std::fs::read(dir.join(n)).unwrap();
        assert_ne!(read("left.png"), read("right.png"));
        let svg = String::from_utf8(read("left.svg")).unwrap();
        assert!(
            svg.contains("@font-face") && svg.contains(crate::fonts::CJK_FAMILY),
            "the SVG carries its font"
        );
        assert!(
            !String::from_utf8(read("plain.svg")).unwrap().contains("@font-face"),
            "only where needed"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn number_formatting() {
        assert_eq!(fmt_num(0.5), "0.5");
        assert_eq!(fmt_num(12.3456), "12.35");
        assert_eq!(fmt_num(1234.6), "1235");
        assert_eq!(fmt_num(f64::NAN), "–");
        assert_eq!(fmt_num(2.5e-5), "2.500e-5");
    }
}
