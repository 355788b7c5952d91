//! The OpenSim TRC loader plugin `trc` (marker trajectories as OpenSim, Pose2Sim, OpenCap,
//! Mokka, Vicon and Cortex exporters write them), and the TRC writer `motionlab convert` uses.
//!
//! Written by hand: the format is five header lines and TAB-separated rows, and every writer
//! bends it a little (see `data/formats/README.md`); what OpenSim's own `TRCFileAdapter` reads
//! is the reference (`tests/trc_mot_conformance.rs` compares each shipped file with its
//! `references.csv`, and CI compares with OpenSim 4.6's Python API directly).

use std::io::Write;
use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::units::{Axis, FrameRate, LengthUnit};
use motionlab_core::{Error, ErrorKind, LoadNotes, Loader, Motion, PointKind, Result};

/// Reads OpenSim TRC marker files (`.trc`): marker positions with the header's `Units` and
/// `DataRate`.
///
/// Layout: line 1 `PathFileType 4 (X/Y/Z) <name>`; line 2 the header keys (`DataRate`,
/// `CameraRate`, `NumFrames`, `NumMarkers`, `Units`, `OrigDataRate`, `OrigDataStartFrame`,
/// `OrigNumFrames`) and line 3 their values, matched by name; line 4 `Frame#`, `Time` and one
/// label per marker (every third column); line 5 `X1 Y1 Z1 …`; then, after optional blank
/// lines, one row per frame: Frame#, time in seconds, X Y Z per marker.
///
/// The unit is the header's `Units` (`mm`, `cm`, `m`, `in`; positions are converted to mm);
/// the rate is `DataRate` (fractional rates such as 119.88012 kept), else `CameraRate`.
/// OpenSim's lab frame is Y-up (`up_axis`).
///
/// Quirks read as OpenSim reads them, each one said in the motion's load notes (`motionlab
/// inspect` prints them as `repaired` lines, a run's provenance lists them):
/// - `NumFrames` (or `NumMarkers`) not matching the rows (labels) present: the rows and labels
///   present are read;
/// - `Frame#` not starting at 1 or time not at 0: frame 0 of the motion is the first row;
/// - duplicate marker labels: the second gets `#2` appended;
/// - empty cells (a marker not seen, whole rows of them in Mokka files) are missing samples
///   (NaN in the missing mask), never zero; a sample with one empty coordinate is missing;
/// - trailing TABs after the last value or on header lines, spaces around values (`   151`),
///   a line 1 mixing spaces and TABs, E notation (`-2.73E-01`), CRLF and a BOM.
///
/// Errors name the file and line: a header shorter than five lines, no `DataRate`/`CameraRate`
/// or `Units`, an unknown unit, a row with more non-empty cells than `2 + 3 × markers` or
/// fewer cells than that, a value that is not a number (naming the marker and axis), no rows.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TrcParams {
    /// The axis of the lab frame that points up (OpenSim's convention, and every shipped TRC:
    /// Y).
    #[serde(default = "default_up_axis")]
    pub up_axis: Axis,
}

fn default_up_axis() -> Axis {
    Axis::Y
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct TrcLoader {
    up_axis: Axis,
}

impl ParamGuard for TrcParams {
    type Checked = TrcLoader;
    fn check(self) -> Result<TrcLoader> {
        Ok(TrcLoader { up_axis: self.up_axis })
    }
}

impl Loader for TrcLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["trc"]
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let text = crate::read::read_text(path)?;
        let trc = parse_trc(&text, path)?;
        trc.into_motion(path, self.up_axis)
    }
}

motionlab_core::register_plugin!(Loader, TrcParams, "trc");

/// A TRC file as read: values in the file's unit, before conversion to a motion.
#[derive(Clone, Debug)]
pub struct TrcFile {
    /// `DataRate` (Hz), else `CameraRate`.
    pub rate_hz: f64,
    /// The `Units` text as written (`mm`, `m`).
    pub units: String,
    pub unit: LengthUnit,
    /// Marker labels in file order (duplicates renamed `label#2`).
    pub labels: Vec<String>,
    /// Frame-major positions in the file's unit; NaN where a cell is empty.
    pub positions: Vec<[f64; 3]>,
    /// Each row's `Frame#` and time (s) as written.
    pub frame_numbers: Vec<f64>,
    pub times: Vec<f64>,
    /// The header's key → value pairs, in order.
    pub header: Vec<(String, String)>,
    /// What the reader did about quirks, one line each.
    pub notes: Vec<String>,
}

impl TrcFile {
    pub fn n_frames(&self) -> usize {
        self.times.len()
    }
    /// A header value by key.
    pub fn header_value(&self, key: &str) -> Option<&str> {
        self.header.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// The motion: positions converted to mm.
    pub fn into_motion(self, origin: &Path, up_axis: Axis) -> Result<Motion> {
        let rate = FrameRate::new(self.rate_hz).map_err(|e| e.in_file(origin).with_line(3))?;
        let mm = self.unit.millimetres_per_unit();
        let positions = self.positions.iter().map(|p| [p[0] * mm, p[1] * mm, p[2] * mm]).collect();
        let mut motion = Motion::new(
            crate::read::stem(origin),
            rate,
            up_axis,
            PointKind::Marker,
            self.labels,
            positions,
        )
        .map_err(|e| e.in_file(origin))?
        .with_source(origin, "trc");
        motion.load_notes = LoadNotes {
            length_unit: Some(self.unit),
            length_unit_from: format!("Units {:?} (line 3)", self.units),
            repairs: self.notes,
        };
        Ok(motion)
    }
}

/// The cells of a line split at TABs, each trimmed of spaces (and the line of `\r`).
fn cells(line: &str) -> Vec<&str> {
    line.trim_end_matches('\r').split('\t').map(|c| c.trim_matches(' ')).collect()
}

/// The cells without the empty ones at the end (trailing TABs).
fn trimmed_cells(line: &str) -> Vec<&str> {
    let mut c = cells(line);
    while c.last().is_some_and(|s| s.is_empty()) {
        c.pop();
    }
    c
}

/// A number of a TRC cell (plain or E notation); `None` when it is not one or not finite.
fn number(cell: &str) -> Option<f64> {
    fast_float2::parse::<f64, _>(cell).ok().filter(|v: &f64| v.is_finite())
}

/// Parses a TRC text; `origin` names it in errors.
pub fn parse_trc(text: &str, origin: &Path) -> Result<TrcFile> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines: Vec<&str> = text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l)).collect();
    let at = |line: usize, kind: ErrorKind, msg: String| Error::at_line(kind, origin, line, msg);
    let line_count = if text.ends_with('\n') { lines.len() - 1 } else { lines.len() };
    if line_count < 5 {
        return Err(at(
            line_count.max(1),
            ErrorKind::Truncated,
            format!(
                "the header ends after {line_count} lines; expected 5 (PathFileType, the header keys, their values, the marker labels, X1 Y1 Z1)"
            ),
        ));
    }
    let first = lines[0].trim_start();
    if !first.starts_with("PathFileType") {
        return Err(at(
            1,
            ErrorKind::Syntax,
            format!(
                "starts with {:?}; expected `PathFileType` (line 1 of a TRC file)",
                first.chars().take(20).collect::<String>()
            ),
        ));
    }
    let mut notes = Vec::new();
    // Header keys and values (lines 2 and 3), matched by name.
    let keys = trimmed_cells(lines[1]);
    let values = trimmed_cells(lines[2]);
    if keys.len() != values.len() {
        notes.push(format!(
            "line 2 names {} header keys, line 3 gives {} values: matched by position",
            keys.len(),
            values.len()
        ));
    }
    let header: Vec<(String, String)> =
        keys.iter().zip(&values).map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let value = |key: &str| header.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
    let rate_of = |key: &str| -> Result<Option<f64>> {
        match value(key) {
            None | Some("") => Ok(None),
            Some(v) => number(v).filter(|hz| *hz > 0.0).map(Some).ok_or_else(|| {
                at(3, ErrorKind::OutOfRange, format!("{key} is {v:?}; expected a rate > 0 Hz"))
                    .with_field(key)
            }),
        }
    };
    let rate_hz = match (rate_of("DataRate")?, rate_of("CameraRate")?) {
        (Some(r), _) => r,
        (None, Some(r)) => {
            notes.push(format!("no DataRate: the rate is CameraRate, {r} Hz"));
            r
        }
        (None, None) => {
            return Err(at(
                3,
                ErrorKind::MissingKey,
                "no DataRate or CameraRate in the header (lines 2–3); expected the frame rate"
                    .into(),
            )
            .with_field("DataRate"));
        }
    };
    let units = value("Units").unwrap_or("").to_string();
    if units.is_empty() {
        return Err(at(
            3,
            ErrorKind::MissingKey,
            "no Units in the header (lines 2–3); expected mm, cm, m or in".into(),
        )
        .with_field("Units"));
    }
    let unit = LengthUnit::from_label(&units).ok_or_else(|| {
        at(3, ErrorKind::OutOfRange, format!("Units is {units:?}; expected mm, cm, m or in"))
            .with_field("Units")
    })?;

    // Marker labels: line 4, `Frame#`, `Time`, then a label every third column.
    let label_cells = cells(lines[3]);
    if label_cells.len() < 3
        || !label_cells[0].eq_ignore_ascii_case("Frame#")
        || !label_cells[1].eq_ignore_ascii_case("Time")
    {
        return Err(at(
            4,
            ErrorKind::Syntax,
            "expected `Frame#`, `Time` and the marker labels (line 4 of a TRC file)".into(),
        ));
    }
    let mut labels: Vec<String> = Vec::new();
    for (k, c) in label_cells[2..].iter().enumerate() {
        if k % 3 == 0 {
            if c.is_empty() {
                // A label cell left empty: trailing TABs, or a writer's gap.
                if label_cells[2 + k..].iter().all(|c| c.is_empty()) {
                    break;
                }
                return Err(at(
                    4,
                    ErrorKind::Syntax,
                    format!(
                        "column {} has no marker label; expected one label per 3 columns",
                        k + 3
                    ),
                ));
            }
            labels.push(c.to_string());
        } else if !c.is_empty() {
            return Err(at(
                4,
                ErrorKind::Syntax,
                format!(
                    "label {c:?} in column {}, between a marker's X and Z columns; expected one label per 3 columns",
                    k + 3
                ),
            ));
        }
    }
    if labels.is_empty() {
        return Err(at(4, ErrorKind::EmptySequence, "no marker label on line 4".into()));
    }
    let mut seen = std::collections::HashMap::<String, usize>::new();
    for l in labels.iter_mut() {
        let n = seen.entry(l.clone()).or_insert(0);
        *n += 1;
        if *n > 1 {
            let renamed = format!("{l}#{n}");
            notes.push(format!("marker label {l:?} repeats (line 4): the repeat is {renamed:?}"));
            *l = renamed;
        }
    }
    let m = labels.len();
    if let Some(declared) = value("NumMarkers")
        && number(declared) != Some(m as f64)
    {
        notes.push(format!("NumMarkers says {declared}; line 4 labels {m} markers: read {m}"));
    }

    // Line 5 `X1 Y1 Z1 …` (checked loosely: some writers leave it blank), then the rows.
    let expected = 2 + 3 * m;
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut frame_numbers = Vec::new();
    let mut times = Vec::new();
    let mut trailing_empty = false;
    let mut last_line = 5;
    for (i, line) in lines.iter().enumerate().skip(5) {
        let line_no = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        last_line = line_no;
        let mut row = cells(line);
        if row.len() > expected {
            if let Some(extra) = row[expected..].iter().position(|c| !c.is_empty()) {
                return Err(at(
                    line_no,
                    ErrorKind::WrongValueCount,
                    format!(
                        "found {} cells, a value in cell {}; expected 2 + 3 × {m} markers = {expected}",
                        row.len(),
                        expected + extra + 1
                    ),
                ));
            }
            trailing_empty = true;
            row.truncate(expected);
        }
        if row.len() < expected {
            return Err(at(
                line_no,
                ErrorKind::WrongValueCount,
                format!("found {} cells; expected 2 + 3 × {m} markers = {expected}", row.len()),
            ));
        }
        let frame = number(row[0]).ok_or_else(|| {
            at(line_no, ErrorKind::Syntax, format!("Frame# is {:?}; expected a number", row[0]))
                .with_field("Frame#")
        })?;
        let time = number(row[1]).ok_or_else(|| {
            at(line_no, ErrorKind::Syntax, format!("Time is {:?}; expected seconds", row[1]))
                .with_field("Time")
        })?;
        frame_numbers.push(frame);
        times.push(time);
        for (k, label) in labels.iter().enumerate() {
            let mut p = [f64::NAN; 3];
            for (axis, v) in p.iter_mut().enumerate() {
                let cell = row[2 + 3 * k + axis];
                if cell.is_empty() || cell.eq_ignore_ascii_case("nan") {
                    continue;
                }
                *v = number(cell).ok_or_else(|| {
                    at(
                        line_no,
                        ErrorKind::Syntax,
                        format!(
                            "{cell:?} in column {}; expected a number or an empty cell (missing)",
                            3 + 3 * k + axis
                        ),
                    )
                    .with_field(format!("{label} {}", ["X", "Y", "Z"][axis]))
                })?;
            }
            if p.iter().any(|c| c.is_nan()) {
                p = [f64::NAN; 3];
            }
            positions.push(p);
        }
    }
    if times.is_empty() {
        return Err(at(
            last_line,
            ErrorKind::EmptySequence,
            "no data rows after the header; expected one row per frame".into(),
        ));
    }
    let n = times.len();
    if let Some(declared) = value("NumFrames")
        && number(declared) != Some(n as f64)
    {
        notes.push(format!("NumFrames says {declared}; {n} rows are present: read {n}"));
    }
    if frame_numbers[0] != 1.0 || times[0] != 0.0 {
        notes.push(format!(
            "the first row is Frame# {} at {} s: it is the motion's frame 0 (time 0)",
            frame_numbers[0], times[0]
        ));
    }
    if trailing_empty {
        notes.push("data rows end with empty cells (trailing TABs): ignored".into());
    }
    let missing = positions.iter().filter(|p| p[0].is_nan()).count();
    if missing > 0 {
        notes.push(format!("{missing} samples are empty cells: read as missing"));
    }
    Ok(TrcFile { rate_hz, units, unit, labels, positions, frame_numbers, times, header, notes })
}

/// Writes `motion`'s points as an OpenSim TRC file (TAB-separated, `Units` = `unit`, Frame#
/// from 1, time from 0). Missing samples are written `NaN`, as OpenSim's own writer does: empty
/// cells would read the same here, but OpenSim's reader drops empty cells at the end of a row
/// and then refuses the row as short. Values are written with Rust's
/// shortest round-trip formatting, so reading the file back gives the same `f64` in that unit.
pub fn write_trc(
    motion: &Motion,
    unit: LengthUnit,
    file_name: &str,
    out: &mut impl Write,
) -> std::io::Result<()> {
    let unit_text = match unit {
        LengthUnit::Millimetre => "mm",
        LengthUnit::Centimetre => "cm",
        LengthUnit::Metre => "m",
        LengthUnit::Inch => "in",
        LengthUnit::CmuUnit => {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "TRC cannot state the CMU unit; write mm, cm, m or in",
            ));
        }
    };
    if motion.dimensionality() == motionlab_core::Dimensionality::Two {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "TRC holds 3-D positions in a length unit, not 2-D image positions (px); write .csv",
        ));
    }
    let per_mm = 1.0 / unit.millimetres_per_unit();
    let hz = motion.frame_rate().hz();
    let (f, m) = (motion.n_frames(), motion.n_points());
    writeln!(out, "PathFileType\t4\t(X/Y/Z)\t{file_name}")?;
    writeln!(
        out,
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames"
    )?;
    writeln!(out, "{hz}\t{hz}\t{f}\t{m}\t{unit_text}\t{hz}\t1\t{f}")?;
    write!(out, "Frame#\tTime")?;
    for name in motion.point_names() {
        write!(out, "\t{name}\t\t")?;
    }
    writeln!(out)?;
    write!(out, "\t")?;
    for k in 1..=m {
        write!(out, "\tX{k}\tY{k}\tZ{k}")?;
    }
    writeln!(out)?;
    writeln!(out)?;
    for frame in 0..f {
        write!(out, "{}\t{}", frame + 1, frame as f64 / hz)?;
        for (p, gone) in motion.frame(frame).iter().zip(motion.frame_missing(frame)) {
            if *gone {
                write!(out, "\tNaN\tNaN\tNaN")?;
            } else {
                write!(out, "\t{}\t{}\t{}", p[0] * per_mm, p[1] * per_mm, p[2] * per_mm)?;
            }
        }
        writeln!(out)?;
    }
    Ok(())
}

/// Writes `motion`'s points as CSV: `frame,time_s,<point>_x_mm,<point>_y_mm,<point>_z_mm,…`,
/// one row per frame, missing samples as empty fields. Names holding a comma or quote are
/// quoted. A 2-D motion (video keypoints) writes `<point>_x_px,<point>_y_px` and, when it has
/// one, `<point>_confidence`.
pub fn write_positions_csv(motion: &Motion, out: &mut impl Write) -> std::io::Result<()> {
    let quote = |s: String| {
        if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s }
    };
    let hz = motion.frame_rate().hz();
    // 2-D image keypoints: x and y in px, and the estimator's confidence when it gave one.
    let two_d = motion.dimensionality() == motionlab_core::Dimensionality::Two;
    let axes: &[&str] = if two_d { &["x", "y"] } else { &["x", "y", "z"] };
    let unit = motion.length_unit();
    let confidence = motion.confidence();
    write!(out, "frame,time_s")?;
    for name in motion.point_names() {
        for axis in axes {
            write!(out, ",{}", quote(format!("{name}_{axis}_{unit}")))?;
        }
        if confidence.is_some() {
            write!(out, ",{}", quote(format!("{name}_confidence")))?;
        }
    }
    writeln!(out)?;
    let m = motion.n_points();
    for frame in 0..motion.n_frames() {
        write!(out, "{frame},{}", frame as f64 / hz)?;
        for (k, (p, gone)) in
            motion.frame(frame).iter().zip(motion.frame_missing(frame)).enumerate()
        {
            for v in &p[..axes.len()] {
                if *gone { write!(out, ",")? } else { write!(out, ",{v}")? }
            }
            if let Some(c) = confidence {
                write!(out, ",{}", c[frame * m + k])?;
            }
        }
        writeln!(out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_loader, default_params};

    const ORIGIN: &str = "hand/made.trc";

    fn parse(text: &str) -> Result<TrcFile> {
        parse_trc(text, Path::new(ORIGIN))
    }

    fn err_at(text: &str, kind: ErrorKind, line: usize) -> Error {
        let e = match parse(text) {
            Ok(t) => panic!("expected {kind:?}, read {} frames", t.n_frames()),
            Err(e) => e,
        };
        assert_eq!((e.kind(), e.location().line), (kind, Some(line)), "{e}");
        assert!(e.to_string().starts_with(&format!("{ORIGIN}:{line}")), "{e}");
        e
    }

    const HEAD: &str = "PathFileType\t4\t(X/Y/Z)\tmade.trc\n\
        DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames\n\
        100\t100\t3\t2\tm\t100\t1\t3\n\
        Frame#\tTime\ta\t\t\tb\t\t\n\
        \t\tX1\tY1\tZ1\tX2\tY2\tZ2\n\n";

    fn file(rows: &str) -> String {
        format!("{HEAD}{rows}")
    }

    const ROWS: &str = "1\t0\t1\t2\t3\t4\t5\t6\n2\t0.01\t1.5\t2.5\t3.5\t\t\t\n3\t0.02\t-2.5E-01\t1e1\t0\t4\t5\t6\n";

    #[test]
    fn reads_labels_rate_unit_and_empty_cells_as_missing() {
        let t = parse(&file(ROWS)).unwrap();
        assert_eq!((t.n_frames(), t.labels.len(), t.rate_hz), (3, 2, 100.0));
        assert_eq!(t.unit, LengthUnit::Metre);
        assert_eq!(t.positions[4], [-0.25, 10.0, 0.0]);
        assert!(t.positions[3][0].is_nan());
        let m = t.into_motion(Path::new(ORIGIN), Axis::Y).unwrap();
        // Metres become millimetres; the empty sample is missing, not zero.
        assert_eq!(m.position(0, 1), [4000.0, 5000.0, 6000.0]);
        assert!(m.is_missing(1, 1) && !m.is_missing(1, 0));
        assert_eq!(m.missing_count(), 1);
        assert_eq!(m.load_notes.length_unit, Some(LengthUnit::Metre));
        assert!(m.load_notes.repairs.iter().any(|r| r.contains("1 samples are empty")));
    }

    #[test]
    fn one_empty_coordinate_makes_the_sample_missing() {
        let t = parse(&file(
            "1\t0\t1\t\t3\t4\t5\t6\n2\t0.01\t1\t2\t3\t4\t5\t6\n3\t0.02\t1\t2\t3\t4\t5\t6\n",
        ))
        .unwrap();
        assert!(t.positions[0].iter().all(|c| c.is_nan()));
    }

    #[test]
    fn quirks_are_read_and_said() {
        // NumFrames 900 for 2 rows, Frame# from 185, fractional rate, trailing TABs, a
        // duplicate label, spaces around values.
        let text = "PathFileType  4\t(X/Y/Z)\tx\t\n\
            DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\t\t\n\
            119.88012\t119.88012\t       900\t2\tmm\t\t\n\
            Frame#\tTime\ta\t\t\ta\t\t\t\t\n\
            \t\tX1\tY1\tZ1\tX2\tY2\tZ2\t\n\n\
            185\t3.067\t1\t2\t3\t4\t5\t6\t\n186\t3.075\t1\t2\t3\t4\t5\t6\t\n";
        let t = parse(text).unwrap();
        assert_eq!((t.n_frames(), t.rate_hz), (2, 119.88012));
        assert_eq!(t.labels, ["a", "a#2"]);
        let said = t.notes.join("\n");
        for phrase in ["NumFrames says 900", "Frame# 185 at 3.067 s", "repeats", "trailing TABs"] {
            assert!(said.contains(phrase), "{phrase}: {said}");
        }
    }

    #[test]
    fn too_many_or_too_few_cells_are_errors_naming_the_line() {
        let e = err_at(&file("1\t0\t1\t2\t3\t4\t5\t6\t7\n"), ErrorKind::WrongValueCount, 7);
        assert!(e.message().contains("expected 2 + 3 × 2 markers = 8"), "{e}");
        err_at(&file("1\t0\t1\t2\t3\t4\t5\n"), ErrorKind::WrongValueCount, 7);
        let e = err_at(&file("1\t0\t1\t2\t3\t4\t5,5\t6\n"), ErrorKind::Syntax, 7);
        assert_eq!(e.location().field.as_deref(), Some("b Y"));
    }

    #[test]
    fn header_errors_name_their_line() {
        err_at("PathFileType\t4\nDataRate\n", ErrorKind::Truncated, 2);
        err_at(&file(ROWS).replace("\tm\t100", "\tfurlong\t100"), ErrorKind::OutOfRange, 3);
        err_at(&file(ROWS).replace("100\t100\t3", "0\t100\t3"), ErrorKind::OutOfRange, 3);
        err_at(&file(ROWS).replace("Frame#", "Frame"), ErrorKind::Syntax, 4);
        err_at(&file(""), ErrorKind::EmptySequence, 5);
        err_at(&file(ROWS).replacen("PathFileType", "Path", 1), ErrorKind::Syntax, 1);
    }

    #[test]
    fn written_trc_reads_back_to_the_same_values() {
        let t = parse(&file(ROWS)).unwrap();
        let m = t.into_motion(Path::new(ORIGIN), Axis::Y).unwrap();
        for unit in [LengthUnit::Millimetre, LengthUnit::Metre] {
            let mut out = Vec::new();
            write_trc(&m, unit, "x.trc", &mut out).unwrap();
            let back = parse_trc(std::str::from_utf8(&out).unwrap(), Path::new("x.trc"))
                .unwrap()
                .into_motion(Path::new("x.trc"), Axis::Y)
                .unwrap();
            assert_eq!(back.point_names(), m.point_names());
            assert_eq!(back.frame_rate().hz(), 100.0);
            assert_eq!(back.missing_mask(), m.missing_mask());
            for (a, b) in back.positions().iter().zip(m.positions()) {
                for k in 0..3 {
                    assert!(
                        (a[k].is_nan() && b[k].is_nan())
                            || (a[k] - b[k]).abs() <= 1e-9 * b[k].abs(),
                        "{a:?} {b:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn csv_has_a_column_per_coordinate_and_empty_missing() {
        let m = parse(&file(ROWS)).unwrap().into_motion(Path::new(ORIGIN), Axis::Y).unwrap();
        let mut out = Vec::new();
        write_positions_csv(&m, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "frame,time_s,a_x_mm,a_y_mm,a_z_mm,b_x_mm,b_y_mm,b_z_mm");
        assert_eq!(lines[1], "0,0,1000,2000,3000,4000,5000,6000");
        assert_eq!(lines[2], "1,0.01,1500,2500,3500,,,");
    }

    #[test]
    fn a_2d_motion_writes_px_and_confidence_to_csv_and_is_refused_by_trc() {
        let m = parse(&file(ROWS))
            .unwrap()
            .into_motion(Path::new(ORIGIN), Axis::Y)
            .unwrap()
            .into_image_2d()
            .with_confidence(vec![0.5, 0.25, 1.0, 0.0, 0.75, 0.125])
            .unwrap();
        let mut out = Vec::new();
        write_positions_csv(&m, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "frame,time_s,a_x_px,a_y_px,a_confidence,b_x_px,b_y_px,b_confidence");
        assert_eq!(lines[1], "0,0,1000,2000,0.5,4000,5000,0.25");
        assert_eq!(lines[2], "1,0.01,1500,2500,1,,,0");
        let e = write_trc(&m, LengthUnit::Millimetre, "x.trc", &mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains("not 2-D image positions"), "{e}");
    }

    #[test]
    fn no_truncation_or_byte_flip_panics() {
        motionlab_testkit::truncations_and_byte_flips(
            &file(ROWS),
            11,
            b"\t\n\r 0123456789.-eEXYZ#",
            3000,
            |s| {
                let _ = parse(s);
            },
        );
    }

    #[test]
    fn registered_for_the_trc_extension() {
        let loader = build_loader("trc", &default_params()).unwrap();
        assert_eq!(loader.extensions(), ["trc"]);
        let entry = motionlab_core::registry::find("trc").unwrap();
        assert!(entry.params().iter().all(|p| p.default.is_some() && !p.description.is_empty()));
        assert!(entry.doc().contains("NumFrames"));
    }
}
