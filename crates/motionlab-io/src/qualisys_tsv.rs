//! The Qualisys TSV loader plugin `qualisys_tsv` — the text export of Qualisys Track Manager
//! that the MoCap Toolbox reads (`mcread`).
//!
//! Written by hand: no crate reads this format, and the generic TSV/CSV crates would still
//! leave the header grammar, the NaN convention and the line-numbered errors to us. The file
//! is split into lines once and each value is parsed in place with `fast-float2` (the number
//! parser the text formats share; 1.4× faster than `str::parse::<f64>` on these values, see
//! `benches/README-binary-formats.md`) into one preallocated position buffer (no per-sample
//! allocation).
//!
//! ## Missing samples
//!
//! QTM writes an occluded marker as `NaN` in its X, Y and Z columns (`mct/walk1.tsv` has 27
//! such samples). Any case is accepted (`NaN`, `nan`, `NAN`); a sample with any NaN
//! coordinate is flagged in the motion's missing mask and stored as NaN — never dropped,
//! never zero-filled. Infinities are not a missing-data convention of the format and are an
//! error.

use std::iter::Peekable;
use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::units::{Axis, FrameRate, Seconds};
use motionlab_core::{Error, ErrorKind, Event, Loader, Motion, PointKind, Result};

/// Reads Qualisys TSV marker exports (QTM's text format, the MoCap Toolbox's input).
///
/// Format: header lines `KEY<TAB>value…` — `NO_OF_FRAMES`, `NO_OF_MARKERS`, `FREQUENCY`,
/// `DATA_INCLUDED` (must be `3D`), `MARKER_NAMES` (required), `EVENT<TAB>name<TAB>frame<TAB>time`
/// (kept as events; other keys such as `NO_OF_CAMERAS`, `TIME_STAMP`, `FILE_VERSION` are
/// ignored) — then one row per frame of X Y Z per marker, in mm. Newer QTM exports announce
/// extra columns with a column-header row (`Frame<TAB>Time<TAB>Head_FL X<TAB>…`); the marker
/// columns are then found by name (`<marker> X|Y|Z`) and the others (frame, time, SMPTE,
/// trajectory type) skipped. Blank lines are skipped; CRLF and a BOM are accepted.
///
/// Events (`EVENT` lines) get time = the stated time in seconds and the fractional frame
/// index `time × FREQUENCY + 1 − first frame number` (the first row's `Frame` column, else 1):
/// time 0 is frame 1, as in C3D.
///
/// Missing samples: `NaN` (any case) in a coordinate marks the whole sample missing; it is
/// flagged in the missing mask and stored as NaN, never dropped or zero-filled. ±inf is an
/// error.
///
/// Errors name the file and line: a row with the wrong number of values (found N, expected
/// 3 × M), a value that is not a number, fewer rows than `NO_OF_FRAMES` (`Truncated`),
/// no `MARKER_NAMES`, a repeated marker name, `NO_OF_MARKERS` ≠ the number of names.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct QualisysTsvParams {
    /// The axis of the lab frame that points up (Qualisys labs, including the shipped MoCap
    /// Toolbox recordings, are Z-up).
    #[serde(default = "default_up_axis")]
    pub up_axis: Axis,
}

fn default_up_axis() -> Axis {
    Axis::Z
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct QualisysTsvLoader {
    up_axis: Axis,
}

impl ParamGuard for QualisysTsvParams {
    type Checked = QualisysTsvLoader;
    fn check(self) -> Result<QualisysTsvLoader> {
        Ok(QualisysTsvLoader { up_axis: self.up_axis })
    }
}

impl Loader for QualisysTsvLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["tsv"]
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let text = crate::read::read_text(path)?;
        parse_qualisys_tsv(&text, path, self.up_axis)
    }
}

motionlab_core::register_plugin!(Loader, QualisysTsvParams, "qualisys_tsv");

/// A header value and the 1-based line it was on.
#[derive(Clone, Copy)]
struct Keyed<T> {
    value: T,
    line: usize,
}

/// Which coordinate a column holds, from the column-header row.
#[derive(Clone, Copy)]
enum Column {
    Coordinate { marker: usize, axis: usize },
    Other,
}

#[derive(Default)]
struct Header<'t> {
    frames: Option<Keyed<usize>>,
    markers: Option<Keyed<usize>>,
    frequency: Option<Keyed<f64>>,
    names: Option<Keyed<Vec<&'t str>>>,
    /// (name, frame number, time s, line)
    events: Vec<(&'t str, f64, f64, usize)>,
    /// The column-header row's columns and its line.
    columns: Option<(Vec<&'t str>, usize)>,
}

/// A header key: upper-case ASCII letters, digits and `_`, starting with a letter, and not a
/// number (`NAN`, `INF` would otherwise qualify — a row may start with a missing marker).
fn is_key(token: &str) -> bool {
    let b = token.as_bytes();
    !b.is_empty()
        && b[0].is_ascii_uppercase()
        && b.iter().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == b'_')
        && token.parse::<f64>().is_err()
}

/// Fields of a line: tab-separated, each trimmed of spaces; trailing empty fields (a tab at
/// the end of the line) dropped.
fn fields(line: &str) -> impl Iterator<Item = &str> {
    line.trim_end_matches(['\t', ' ', '\r']).split('\t').map(str::trim)
}

/// Parses a Qualisys TSV text; `origin` names it in errors and in the motion.
pub fn parse_qualisys_tsv(text: &str, origin: &Path, up_axis: Axis) -> Result<Motion> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .peekable();
    let header = read_header(&mut lines, origin)?;
    let first_data_line = lines.peek().map_or_else(|| text.split('\n').count(), |(n, _)| *n);
    let (names, frequency) = header.markers_and_rate(first_data_line, origin)?;
    let layout = ColumnLayout::of(&header, &names, origin)?;
    let rows =
        read_rows(lines, &header, &layout, &names.value, first_data_line, text.len(), origin)?;

    let rate =
        FrameRate::new(frequency.value).map_err(|e| e.in_file(origin).with_line(frequency.line))?;
    let names: Vec<String> = names.value.iter().map(|s| s.to_string()).collect();
    let mut motion = Motion::new(
        crate::read::stem(origin),
        rate,
        up_axis,
        PointKind::Marker,
        names,
        rows.positions,
    )
    .map_err(|e| e.in_file(origin))?
    .with_source(origin, "qualisys_tsv");
    motion.events = header
        .events
        .iter()
        .map(|&(name, _frame_number, time, _line)| Event {
            label: name.to_string(),
            context: String::new(),
            time: Seconds(time),
            frame: rate.seconds_to_frames(Seconds(time)) + 1.0 - rows.first_frame_number,
        })
        .collect();
    motion.events.sort_by(|a, b| a.time.0.total_cmp(&b.time.0));
    Ok(motion)
}

/// The header lines (`KEY<TAB>value…`, blank lines, and the column-header row once the marker
/// names are known), read up to the first line that is none of these: the first data row,
/// left in `lines`.
fn read_header<'t>(
    lines: &mut Peekable<impl Iterator<Item = (usize, &'t str)>>,
    origin: &Path,
) -> Result<Header<'t>> {
    let mut header = Header::default();
    while let Some(&(line_no, line)) = lines.peek() {
        if line.trim().is_empty() {
            lines.next();
            continue;
        }
        let mut f = fields(line);
        let key = f.next().unwrap_or("");
        if key.eq_ignore_ascii_case("frame") && header.columns.is_none() && header.names.is_some() {
            header.columns = Some((fields(line).collect(), line_no));
            lines.next();
            continue;
        }
        if !is_key(key) {
            break;
        }
        header.key_line(key, f.next().unwrap_or(""), line, line_no, origin)?;
        lines.next();
    }
    Ok(header)
}

impl<'t> Header<'t> {
    /// One header line `key<TAB>value…` (`line`, number `line_no`).
    fn key_line(
        &mut self,
        key: &str,
        value: &str,
        line: &'t str,
        line_no: usize,
        origin: &Path,
    ) -> Result<()> {
        let at = |kind: ErrorKind, msg: String| Error::at_line(kind, origin, line_no, msg);
        let parse_count = |what: &str| -> Result<usize> {
            value.parse::<usize>().map_err(|_| {
                at(ErrorKind::Syntax, format!("{what} is {value:?}; expected a whole number"))
            })
        };
        let once = |seen: bool| -> Result<()> {
            if seen {
                Err(at(
                    ErrorKind::DuplicateName,
                    format!("{key} is given twice; expected one {key} line"),
                ))
            } else {
                Ok(())
            }
        };
        match key {
            "NO_OF_FRAMES" => {
                once(self.frames.is_some())?;
                self.frames = Some(Keyed { value: parse_count(key)?, line: line_no });
            }
            "NO_OF_MARKERS" => {
                once(self.markers.is_some())?;
                self.markers = Some(Keyed { value: parse_count(key)?, line: line_no });
            }
            "FREQUENCY" => {
                once(self.frequency.is_some())?;
                let hz =
                    value.parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0).ok_or_else(
                        || {
                            at(
                                ErrorKind::OutOfRange,
                                format!("FREQUENCY is {value:?}; expected a frame rate > 0 Hz"),
                            )
                        },
                    )?;
                self.frequency = Some(Keyed { value: hz, line: line_no });
            }
            "DATA_INCLUDED" if !value.eq_ignore_ascii_case("3D") => {
                return Err(at(
                    ErrorKind::OutOfRange,
                    format!("DATA_INCLUDED is {value:?}; only 3D marker exports can be read"),
                ));
            }
            "MARKER_NAMES" => {
                once(self.names.is_some())?;
                let names: Vec<&str> = fields(line).skip(1).collect();
                // A map, not a scan of the names before each one: a corrupt line of 10⁵ names
                // must not take 10¹⁰ comparisons.
                let mut first_column: std::collections::HashMap<&str, usize> =
                    std::collections::HashMap::with_capacity(names.len());
                for (i, n) in names.iter().enumerate() {
                    if n.is_empty() {
                        return Err(at(
                            ErrorKind::Syntax,
                            format!("marker name {} is empty; expected a name", i + 1),
                        )
                        .with_field("MARKER_NAMES"));
                    }
                    if let Some(j) = first_column.insert(n, i) {
                        return Err(at(
                            ErrorKind::DuplicateName,
                            format!(
                                "marker {n:?} is named twice (columns {} and {})",
                                j + 2,
                                i + 2
                            ),
                        )
                        .with_field(n.to_string()));
                    }
                }
                self.names = Some(Keyed { value: names, line: line_no });
            }
            "EVENT" => {
                let rest: Vec<&str> = fields(line).skip(1).collect();
                let num = |s: Option<&&str>| {
                    s.and_then(|s| s.parse::<f64>().ok()).filter(|v| v.is_finite())
                };
                match (rest.first(), num(rest.get(1)), num(rest.get(2))) {
                    (Some(name), Some(frame), Some(time)) => {
                        self.events.push((name, frame, time, line_no))
                    }
                    _ => {
                        return Err(at(
                            ErrorKind::Syntax,
                            "EVENT line needs a name, a frame number and a time in seconds".into(),
                        ));
                    }
                }
            }
            _ => {} // NO_OF_CAMERAS, TIME_STAMP, DESCRIPTION, FILE_VERSION, …: not needed.
        }
        Ok(())
    }

    /// The marker names and the frame rate, which the data cannot be read without, checked
    /// against `NO_OF_MARKERS`; `first_data_line` is where an error about a missing one points.
    #[allow(clippy::type_complexity)]
    fn markers_and_rate(
        &self,
        first_data_line: usize,
        origin: &Path,
    ) -> Result<(Keyed<Vec<&'t str>>, Keyed<f64>)> {
        let at = |line: usize, kind: ErrorKind, msg: &str| {
            Error::at_line(kind, origin, line, msg.to_string())
        };
        let Some(names) = self.names.clone() else {
            return Err(at(
                first_data_line,
                ErrorKind::MissingKey,
                "no MARKER_NAMES line before the data; expected the marker names",
            )
            .with_field("MARKER_NAMES"));
        };
        let Some(frequency) = self.frequency else {
            return Err(at(
                first_data_line,
                ErrorKind::MissingKey,
                "no FREQUENCY line before the data; expected the frame rate",
            )
            .with_field("FREQUENCY"));
        };
        let m = names.value.len();
        if m == 0 {
            return Err(at(names.line, ErrorKind::EmptySequence, "MARKER_NAMES lists no marker")
                .with_field("MARKER_NAMES"));
        }
        if let Some(declared) = self.markers
            && declared.value != m
        {
            let msg = format!(
                "MARKER_NAMES lists {m} markers but NO_OF_MARKERS (line {}) says {}",
                declared.line, declared.value
            );
            return Err(at(names.line, ErrorKind::WrongValueCount, &msg));
        }
        Ok((names, frequency))
    }
}

/// What each column of a data row holds, and which column numbers the frames (if any).
struct ColumnLayout {
    columns: Vec<Column>,
    frame_column: Option<usize>,
    /// How many values a row has, as errors state it (`3 × 28 markers = 84`).
    expected_text: String,
}

impl ColumnLayout {
    /// X, Y, Z per marker in name order without a column-header row; else each marker's
    /// columns found by their titles (`<marker> X|Y|Z`) and the others skipped.
    fn of(header: &Header<'_>, names: &Keyed<Vec<&str>>, origin: &Path) -> Result<Self> {
        let m = names.value.len();
        let (columns, frame_column): (Vec<Column>, Option<usize>) = match &header.columns {
            None => (
                (0..3 * m).map(|k| Column::Coordinate { marker: k / 3, axis: k % 3 }).collect(),
                None,
            ),
            Some((titles, line)) => {
                let mut cols = vec![Column::Other; titles.len()];
                let mut found = vec![[false; 3]; m];
                for (c, title) in titles.iter().enumerate() {
                    let Some((marker, axis)) = title.rsplit_once(' ') else { continue };
                    let axis = match axis {
                        "X" | "x" => 0,
                        "Y" | "y" => 1,
                        "Z" | "z" => 2,
                        _ => continue,
                    };
                    if let Some(k) = names.value.iter().position(|n| *n == marker) {
                        cols[c] = Column::Coordinate { marker: k, axis };
                        found[k][axis] = true;
                    }
                }
                if let Some(k) = found.iter().position(|f| !f.iter().all(|x| *x)) {
                    return Err(Error::at_line(
                        ErrorKind::MissingKey,
                        origin,
                        *line,
                        format!(
                            "column-header row has no X, Y and Z columns for marker {:?}",
                            names.value[k]
                        ),
                    )
                    .with_field(names.value[k].to_string()));
                }
                let frame_col = titles.iter().position(|t| t.eq_ignore_ascii_case("frame"));
                (cols, frame_col)
            }
        };
        let expected = columns.len();
        let extra = expected - 3 * m;
        let expected_text = if extra == 0 {
            format!("3 × {m} markers = {expected}")
        } else {
            format!("3 × {m} markers + {extra} other columns = {expected}")
        };
        Ok(ColumnLayout { columns, frame_column, expected_text })
    }
}

/// The data rows as read.
struct Rows {
    /// Frame-major, one sample per marker per row (NaN: missing).
    positions: Vec<[f64; 3]>,
    /// The first row's `Frame` column, else 1.
    first_frame_number: f64,
}

/// Every data row from `lines` on (the header read), checked against `NO_OF_FRAMES` and the
/// column layout; `text_len` bounds the allocation a corrupt `NO_OF_FRAMES` could ask for.
fn read_rows<'t>(
    lines: impl Iterator<Item = (usize, &'t str)>,
    header: &Header<'_>,
    layout: &ColumnLayout,
    names: &[&str],
    first_data_line: usize,
    text_len: usize,
    origin: &Path,
) -> Result<Rows> {
    let at = |line: usize, kind: ErrorKind, msg: String| Error::at_line(kind, origin, line, msg);
    let m = names.len();
    let expected = layout.columns.len();
    // Bounded by what the text can hold (each value takes ≥ 2 bytes), so a corrupt NO_OF_FRAMES
    // cannot request a huge allocation.
    let capacity = header.frames.map_or(0, |f| f.value.min(text_len / (2 * expected) + 1)) * m;
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(capacity);
    let mut sample = vec![[f64::NAN; 3]; m];
    let mut n_rows = 0usize;
    let mut last_line = first_data_line;
    let mut first_frame_number = 1.0;
    for (line_no, line) in lines {
        last_line = line_no;
        if line.trim().is_empty() {
            continue;
        }
        if let Some(declared) = header.frames
            && n_rows == declared.value
        {
            return Err(at(
                line_no,
                ErrorKind::WrongValueCount,
                format!(
                    "row beyond the {} frames NO_OF_FRAMES (line {}) declares",
                    declared.value, declared.line
                ),
            ));
        }
        // Counting tabs is a cheap first pass, so a row of the wrong length is reported as
        // such before any of its values is parsed.
        let row = line.trim_end_matches(['\t', ' ', '\r']);
        let found = row.bytes().filter(|b| *b == b'\t').count() + 1;
        if found != expected {
            return Err(at(
                line_no,
                ErrorKind::WrongValueCount,
                format!("found {found} values, expected {}", layout.expected_text),
            ));
        }
        for (c, (token, column)) in
            row.split('\t').map(|t| t.trim_matches(' ')).zip(&layout.columns).enumerate()
        {
            match *column {
                Column::Coordinate { marker, axis } => {
                    let v = fast_float2::parse::<f64, _>(token).map_err(|_| {
                        at(
                            line_no,
                            ErrorKind::Syntax,
                            format!("expected a number or NaN, found {token:?} (column {})", c + 1),
                        )
                        .with_field(format!(
                            "{} {}",
                            names[marker],
                            ["X", "Y", "Z"][axis]
                        ))
                    })?;
                    if v.is_infinite() {
                        return Err(at(
                            line_no,
                            ErrorKind::NonFinite,
                            format!(
                                "{token:?} in column {}; expected a number or NaN (missing)",
                                c + 1
                            ),
                        )
                        .with_field(format!(
                            "{} {}",
                            names[marker],
                            ["X", "Y", "Z"][axis]
                        )));
                    }
                    sample[marker][axis] = v;
                }
                Column::Other => {
                    if n_rows == 0 && Some(c) == layout.frame_column {
                        first_frame_number = token.parse::<f64>().map_err(|_| {
                            at(
                                line_no,
                                ErrorKind::Syntax,
                                format!(
                                    "expected a frame number, found {token:?} (column {})",
                                    c + 1
                                ),
                            )
                            .with_field("Frame")
                        })?;
                    }
                }
            }
        }
        positions.extend_from_slice(&sample);
        n_rows += 1;
    }
    if let Some(declared) = header.frames
        && n_rows < declared.value
    {
        return Err(at(
            last_line,
            ErrorKind::Truncated,
            format!(
                "file ends after {n_rows} data rows, but NO_OF_FRAMES (line {}) declares {}",
                declared.line, declared.value
            ),
        ));
    }
    if n_rows == 0 {
        return Err(at(
            last_line,
            ErrorKind::EmptySequence,
            "no data rows after the header; expected one row per frame".into(),
        ));
    }
    Ok(Rows { positions, first_frame_number })
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_loader, default_params};

    const ORIGIN: &str = "hand/made.tsv";

    fn parse(text: &str) -> Result<Motion> {
        parse_qualisys_tsv(text, Path::new(ORIGIN), Axis::Z)
    }

    fn err_at(text: &str, kind: ErrorKind, line: usize) -> Error {
        let e = match parse(text) {
            Ok(m) => panic!("expected {kind:?}, loaded {} frames", m.n_frames()),
            Err(e) => e,
        };
        assert_eq!((e.kind(), e.location().line), (kind, Some(line)), "{e}");
        assert!(e.to_string().starts_with(&format!("{ORIGIN}:{line}")), "{e}");
        e
    }

    const HEADER: &str = "NO_OF_FRAMES\t3\nNO_OF_CAMERAS\t8\nNO_OF_MARKERS\t2\nFREQUENCY\t60\nDATA_INCLUDED\t3D\nMARKER_NAMES\ta\tb\n";

    fn file(rows: &str) -> String {
        format!("{HEADER}{rows}")
    }

    const ROWS: &str = "1\t2\t3\t4\t5\t6\n1.5\t2.5\t3.5\tNaN\tnan\tNAN\n2\t3\t4\t-4.25\t5e1\t6\n";

    #[test]
    fn reads_positions_names_rate_and_nan_as_missing() {
        let m = parse(&file(ROWS)).unwrap();
        assert_eq!((m.n_frames(), m.n_points(), m.frame_rate().hz()), (3, 2, 60.0));
        assert_eq!(m.point_names(), ["a", "b"]);
        assert_eq!(m.position(0, 1), [4.0, 5.0, 6.0]);
        assert_eq!(m.position(2, 1), [-4.25, 50.0, 6.0]);
        assert!(m.is_missing(1, 1) && m.position(1, 1)[2].is_nan());
        assert_eq!(m.missing_count(), 1);
        assert_eq!(
            (m.name.as_str(), m.format.as_str(), m.up_axis()),
            ("made", "qualisys_tsv", Axis::Z)
        );
    }

    #[test]
    fn one_nan_coordinate_makes_the_sample_missing() {
        let m = parse(&file("1\t2\t3\t4\t5\t6\n1\tNaN\t3\t4\t5\t6\n1\t2\t3\t4\t5\t6\n")).unwrap();
        assert!(m.is_missing(1, 0) && m.position(1, 0)[0].is_nan());
        assert_eq!(m.missing_count(), 1);
    }

    #[test]
    fn crlf_bom_trailing_tabs_and_blank_lines_are_accepted() {
        let text = format!("\u{feff}{}", file(ROWS).replace('\n', "\t\r\n")) + "\r\n\r\n";
        let m = parse(&text).unwrap();
        assert_eq!(m.position(2, 1), [-4.25, 50.0, 6.0]);
        assert_eq!(m.n_frames(), 3);
    }

    #[test]
    fn frame_and_time_columns_of_newer_exports_are_skipped_by_name() {
        let text = "NO_OF_FRAMES\t2\nNO_OF_MARKERS\t2\nFREQUENCY\t100\nDATA_INCLUDED\t3D\nEVENT\tFoot Strike\t12\t0.11\nMARKER_NAMES\ta\tb\n\
                    Frame\tTime\tb X\tb Y\tb Z\ta X\ta Y\ta Z\n\
                    11\t0.100\t4\t5\t6\t1\t2\t3\n12\t0.110\t7\t8\t9\tNaN\tNaN\tNaN\n";
        let m = parse(text).unwrap();
        // Columns are matched by name, so b's values land on b although b comes first.
        assert_eq!(m.position(0, 0), [1.0, 2.0, 3.0]);
        assert_eq!(m.position(1, 1), [7.0, 8.0, 9.0]);
        assert!(m.is_missing(1, 0));
        // Time 0.11 s at 100 Hz = frame number 12 = index 1 when the first row is frame 11.
        assert_eq!(m.events.len(), 1);
        assert!((m.events[0].frame - 1.0).abs() < 1e-9, "{}", m.events[0].frame);
        let e = err_at(&text.replace("11\t0.100", "11\t0.100\t0"), ErrorKind::WrongValueCount, 8);
        assert!(e.message().contains("+ 2 other columns = 8"), "{e}");
    }

    #[test]
    fn a_short_row_is_an_error_with_its_line_and_counts() {
        let e = err_at(
            &file("1\t2\t3\t4\t5\t6\n1\t2\t3\t4\t5\n1\t2\t3\t4\t5\t6\n"),
            ErrorKind::WrongValueCount,
            8,
        );
        assert!(e.message().contains("found 5 values, expected 3 × 2 markers = 6"), "{e}");
        let e = err_at(&file("1\t2\t3\t4\t5\t6\t7\n"), ErrorKind::WrongValueCount, 7);
        assert!(e.message().contains("found 7"), "{e}");
    }

    #[test]
    fn a_non_number_is_a_syntax_error_naming_marker_and_axis() {
        let e = err_at(&file("1\t2\t3\t4\t5\t6\n1\t2\t3\t4\t5,5\t6\n"), ErrorKind::Syntax, 8);
        assert_eq!(e.location().field.as_deref(), Some("b Y"));
        assert!(e.message().contains("\"5,5\""), "{e}");
    }

    #[test]
    fn infinity_is_an_error_not_missing() {
        let e = err_at(&file("1\t2\t3\t4\t5\t6\n1\t2\tinf\t4\t5\t6\n"), ErrorKind::NonFinite, 8);
        assert_eq!(e.location().field.as_deref(), Some("a Z"));
    }

    #[test]
    fn fewer_rows_than_declared_is_truncated() {
        let e = err_at(&file("1\t2\t3\t4\t5\t6\n1\t2\t3\t4\t5\t6\n"), ErrorKind::Truncated, 9);
        assert!(
            e.message().contains("after 2 data rows") && e.message().contains("declares 3"),
            "{e}"
        );
        let e = err_at(&file(&format!("{ROWS}1\t2\t3\t4\t5\t6\n")), ErrorKind::WrongValueCount, 10);
        assert!(e.message().contains("beyond the 3 frames"), "{e}");
    }

    #[test]
    fn missing_marker_names_frequency_and_duplicates_are_errors() {
        let e =
            err_at(&format!("NO_OF_FRAMES\t3\nFREQUENCY\t60\n{ROWS}"), ErrorKind::MissingKey, 3);
        assert_eq!(e.location().field.as_deref(), Some("MARKER_NAMES"));
        err_at(&format!("NO_OF_FRAMES\t3\nMARKER_NAMES\ta\tb\n{ROWS}"), ErrorKind::MissingKey, 3);
        let e = err_at(
            &file(ROWS).replace("MARKER_NAMES\ta\tb", "MARKER_NAMES\ta\ta"),
            ErrorKind::DuplicateName,
            6,
        );
        assert_eq!(e.location().field.as_deref(), Some("a"));
        err_at(
            &file(ROWS).replace("NO_OF_MARKERS\t2", "NO_OF_MARKERS\t3"),
            ErrorKind::WrongValueCount,
            6,
        );
        err_at(&file(ROWS).replace("FREQUENCY\t60", "FREQUENCY\t0"), ErrorKind::OutOfRange, 4);
        err_at(
            &file(ROWS).replace("DATA_INCLUDED\t3D", "DATA_INCLUDED\t6D"),
            ErrorKind::OutOfRange,
            5,
        );
        err_at(&file(ROWS).replace("NO_OF_FRAMES\t3", "NO_OF_FRAMES\tthree"), ErrorKind::Syntax, 1);
    }

    #[test]
    fn header_only_is_an_empty_sequence() {
        let e = parse(&HEADER.replace("NO_OF_FRAMES\t3\n", "")).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::EmptySequence);
        assert_eq!(parse(HEADER).unwrap_err().kind(), ErrorKind::Truncated);
    }

    #[test]
    fn a_row_starting_with_nan_is_data_not_a_header_key() {
        let m =
            parse(&file("NAN\tNaN\tnan\t4\t5\t6\n1\t2\t3\t4\t5\t6\n1\t2\t3\t4\t5\t6\n")).unwrap();
        assert!(m.is_missing(0, 0));
        assert_eq!(m.n_frames(), 3);
    }

    #[test]
    fn no_truncation_or_byte_flip_panics() {
        motionlab_testkit::truncations_and_byte_flips(
            &file(ROWS),
            7,
            b"\t\n\r 0123456789.-eNaXYZ_AMRKE",
            3000,
            |s| {
                let _ = parse(s);
            },
        );
    }

    #[test]
    fn registered_for_the_tsv_extension() {
        let loader = build_loader("qualisys_tsv", &default_params()).unwrap();
        assert_eq!(loader.extensions(), ["tsv"]);
        let entry = motionlab_core::registry::find("qualisys_tsv").unwrap();
        assert!(entry.params().iter().all(|p| p.default.is_some() && !p.description.is_empty()));
        assert!(entry.doc().contains("NaN"));
    }
}
