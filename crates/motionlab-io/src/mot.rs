//! The OpenSim motion/storage loader plugin `mot` (`.mot`, `.sto`): joint angles, forces,
//! inverse-kinematics results and any other time series OpenSim writes, as named channels.
//!
//! Written by hand: four header styles are in use (SIMM `name`/`datacolumns`/`datarows`/
//! `range`; the hybrid `nRows=`/`nColumns=` plus a `# SIMM Motion File Header:` block;
//! `version=1`; `version=3` with `DataType=double`), all ending at `endheader`, and what OpenSim
//! 4.6's `STOFileAdapter`/`Storage` read is the reference (`tests/trc_mot_conformance.rs`, and
//! the CI step comparing with OpenSim's Python API).

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{
    Channels, DataKind, Error, ErrorKind, FrameRate, LoadNotes, Loader, Motion, Result,
};

/// Reads OpenSim `.mot` and `.sto` files (joint angles, ground reaction forces, states…) as
/// named channels, one per data column; the first column is time in seconds.
///
/// Header: every line up to `endheader`; `key=value` (`nRows`, `nColumns`, `inDegrees`,
/// `version`, `DataRate`, …) or SIMM's `key value` (`datarows`, `datacolumns`, `range`); other
/// lines (a title, free text, `# SIMM Motion File Header:`) are kept out of the data. Then one
/// line of column labels (TAB-separated; space-separated when the line has no TAB) and one row
/// per sample.
///
/// Units: the angle unit is `inDegrees` as written (`yes`: degrees, `no`: radians); when the
/// header has no `inDegrees`, OpenSim's `Storage` assumes degrees, and so does this loader,
/// saying so. It applies to rotational coordinates only (translations are metres, forces
/// newtons, as OpenSim writes them); the file does not say which columns are which, so
/// channel units are left empty and the angle unit is stated in the load notes (`motionlab
/// inspect` prints it on its `unit` line).
///
/// Rate: the header's `DataRate` when present; else from the time column, `(rows − 1) /
/// (last time − first time)` — OpenSim writes times with few decimals, so single steps are
/// uneven (0.016/0.017 s at 60 Hz) and the mean step is the sampling rate. Times must increase,
/// and no step may differ from the mean by more than half of it (a variable-step simulation's
/// output is not one rate; resample it first).
///
/// Quirks read as OpenSim reads them and said in the load notes: header counts (`nRows`,
/// `nColumns`, `datarows`, `datacolumns`) not matching the file (the data present is read);
/// duplicate column labels (the repeat gets `#2` appended: channels need distinct names);
/// labels padded with spaces, trailing TABs, CRLF, a BOM. `NaN`, `nan` or an empty cell is a
/// missing sample. Missing samples are kept as NaN in their channel (never filled or zeroed):
/// the stages downstream treat them as their own docs say.
///
/// Errors name the file and line: no `endheader`, no column labels, a row with more or fewer
/// values than labels, a value that is not a number (naming the column), times that do not
/// increase, no rows.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MotParams {
    /// The channels to keep, by label (after renaming duplicates), in this order.
    #[serde(default)]
    #[schemars(extend("x-default" = "every column but time"))]
    pub columns: Option<Vec<String>>,
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct MotLoader {
    columns: Option<Vec<String>>,
}

impl ParamGuard for MotParams {
    type Checked = MotLoader;
    fn check(self) -> Result<MotLoader> {
        if self.columns.as_ref().is_some_and(Vec::is_empty) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "lists no channel; expected at least one label",
            )
            .with_field("columns"));
        }
        Ok(MotLoader { columns: self.columns })
    }
}

impl Loader for MotLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["mot", "sto"]
    }
    fn gives(&self) -> DataKind {
        DataKind::Channels
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let text = crate::read::read_text(path)?;
        parse_storage(&text, path)?.into_motion(path, self.columns.as_deref())
    }
}

motionlab_core::register_plugin!(Loader, MotParams, "mot");

/// A MOT/STO file as read.
#[derive(Clone, Debug)]
pub struct StorageFile {
    /// The header's `key=value` / `key value` pairs, in order.
    pub header: Vec<(String, String)>,
    /// `inDegrees` as written (`None`: absent).
    pub in_degrees: Option<bool>,
    /// The data columns' labels (time excluded; duplicates renamed `label#2`).
    pub labels: Vec<String>,
    /// The time column's label as written (`time`).
    pub time_label: String,
    /// Each row's time (s).
    pub times: Vec<f64>,
    /// Sample-major values of the data columns; NaN = missing.
    pub values: Vec<f64>,
    /// The rate: `DataRate`, else the mean step of the time column.
    pub rate_hz: f64,
    /// What the reader did about quirks, one line each.
    pub notes: Vec<String>,
    /// The line `endheader` is on, for errors about the rate.
    endheader_line: usize,
}

impl StorageFile {
    pub fn n_rows(&self) -> usize {
        self.times.len()
    }
    /// The angle unit as OpenSim reads it: `degrees` (`inDegrees=yes`, or absent: Storage's
    /// assumption) or `radians`.
    pub fn angle_unit(&self) -> &'static str {
        if self.in_degrees == Some(false) { "radians" } else { "degrees" }
    }
    /// How the angle unit was known, for people.
    pub fn angle_unit_from(&self) -> String {
        match self.in_degrees {
            Some(true) => "angles in degrees (inDegrees=yes)".into(),
            Some(false) => "angles in radians (inDegrees=no)".into(),
            None => {
                "angles in degrees: no inDegrees in the header, OpenSim's Storage assumes degrees"
                    .into()
            }
        }
    }

    /// The motion: one channel per data column, optionally only `keep`, in its order.
    pub fn into_motion(self, origin: &Path, keep: Option<&[String]>) -> Result<Motion> {
        let rate = FrameRate::new(self.rate_hz)
            .map_err(|e| e.in_file(origin).with_line(self.endheader_line))?;
        let unit_from = self.angle_unit_from();
        let d = self.labels.len();
        let all = Channels::new(self.labels, vec![String::new(); d], self.values)
            .map_err(|e| e.in_file(origin))?;
        let channels = match keep {
            Some(k) => all.select(k).map_err(|e| e.in_file(origin).with_field("columns"))?,
            None => all,
        };
        let mut motion = Motion::from_channels(crate::read::stem(origin), rate, channels)
            .map_err(|e| e.in_file(origin))?
            .with_source(origin, "mot");
        motion.load_notes =
            LoadNotes { length_unit: None, length_unit_from: unit_from, repairs: self.notes };
        Ok(motion)
    }
}

/// The cells of a line: TAB-separated (space-separated when it has no TAB), trimmed, the
/// empty ones at the end dropped.
fn cells(line: &str) -> Vec<&str> {
    let mut c: Vec<&str> = if line.contains('\t') {
        line.split('\t').map(str::trim).collect()
    } else {
        line.split_ascii_whitespace().collect()
    };
    while c.last().is_some_and(|s| s.is_empty()) {
        c.pop();
    }
    c
}

fn value(cell: &str) -> Option<f64> {
    match cell {
        "" | "NaN" | "nan" | "NAN" | "-nan" => Some(f64::NAN),
        c => fast_float2::parse::<f64, _>(c).ok().filter(|v: &f64| v.is_finite()),
    }
}

/// Parses a MOT/STO text; `origin` names it in errors.
pub fn parse_storage(text: &str, origin: &Path) -> Result<StorageFile> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let at = |line: usize, kind: ErrorKind, msg: String| Error::at_line(kind, origin, line, msg);
    let mut lines = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .peekable();
    let mut header: Vec<(String, String)> = Vec::new();
    let mut endheader_line = None;
    let mut last = 1;
    for (n, line) in lines.by_ref() {
        if !line.trim().is_empty() {
            last = n;
        }
        let t = line.trim_matches(|c: char| c == '\t' || c == ' ');
        if t == "endheader" {
            endheader_line = Some(n);
            break;
        }
        if let Some((k, v)) = t.split_once('=') {
            header.push((k.trim().to_string(), v.trim().to_string()));
        } else if let Some((k, v)) = t.split_once([' ', '\t'])
            && matches!(k, "name" | "datacolumns" | "datarows" | "range" | "otherdata")
        {
            header.push((k.to_string(), v.trim().to_string()));
        }
    }
    let Some(endheader_line) = endheader_line else {
        return Err(at(
            last,
            ErrorKind::Truncated,
            "the header has no `endheader` line; expected the header, `endheader`, the column labels and the rows".into(),
        ));
    };
    let key = |k: &str| header.iter().find(|(h, _)| h == k).map(|(_, v)| v.as_str());
    let mut notes = Vec::new();
    let in_degrees = match key("inDegrees") {
        None => None,
        Some(v) if v.eq_ignore_ascii_case("yes") => Some(true),
        Some(v) if v.eq_ignore_ascii_case("no") => Some(false),
        Some(v) => {
            let line = text
                .lines()
                .position(|l| l.contains("inDegrees"))
                .map_or(endheader_line, |i| i + 1);
            return Err(at(
                line,
                ErrorKind::OutOfRange,
                format!("inDegrees is {v:?}; expected yes or no"),
            )
            .with_field("inDegrees"));
        }
    };

    // Column labels: the first non-blank line after `endheader`.
    let (label_line, label_text) = loop {
        match lines.next() {
            Some((_, l)) if l.trim().is_empty() => continue,
            Some(found) => break found,
            None => {
                return Err(at(
                    endheader_line,
                    ErrorKind::Truncated,
                    "nothing after `endheader`; expected a line of column labels".into(),
                ));
            }
        }
    };
    let all_labels = cells(label_text);
    if all_labels.len() < 2 {
        return Err(at(
            label_line,
            ErrorKind::EmptySequence,
            format!(
                "{} column label(s); expected time and at least one data column",
                all_labels.len()
            ),
        ));
    }
    if let Some(k) = all_labels.iter().position(|l| l.is_empty()) {
        return Err(at(label_line, ErrorKind::Syntax, format!("column {} has no label", k + 1)));
    }
    let time_label = all_labels[0].to_string();
    if value(&time_label).is_some() {
        return Err(at(
            label_line,
            ErrorKind::Syntax,
            format!(
                "{time_label:?} is a number; expected the column labels (time first) after `endheader`"
            ),
        ));
    }
    let mut labels: Vec<String> = Vec::with_capacity(all_labels.len() - 1);
    let mut seen = std::collections::HashMap::<&str, usize>::new();
    for l in &all_labels[1..] {
        let n = seen.entry(l).or_insert(0);
        *n += 1;
        if *n > 1 {
            let renamed = format!("{l}#{n}");
            notes.push(format!(
                "column label {l:?} repeats (line {label_line}): the repeat is {renamed:?}"
            ));
            labels.push(renamed);
        } else {
            labels.push(l.to_string());
        }
    }
    let d = labels.len();
    let width = d + 1;
    let mut times = Vec::new();
    let mut values = Vec::new();
    let mut row_lines = Vec::new();
    for (n, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let row = cells(line);
        if row.len() != width {
            return Err(at(
                n,
                ErrorKind::WrongValueCount,
                format!(
                    "found {} values; expected {width} (time and {d} columns, as labelled on line {label_line})",
                    row.len()
                ),
            ));
        }
        for (k, c) in row.iter().enumerate() {
            let v = value(c).ok_or_else(|| {
                at(n, ErrorKind::Syntax, format!("{c:?} in column {}; expected a number", k + 1))
                    .with_field(all_labels[k].to_string())
            })?;
            if k == 0 {
                if v.is_nan() {
                    return Err(at(n, ErrorKind::MissingData, "no time; expected seconds".into())
                        .with_field(time_label.clone()));
                }
                times.push(v);
            } else {
                values.push(v);
            }
        }
        row_lines.push(n);
    }
    let rows = times.len();
    if rows == 0 {
        return Err(at(
            label_line,
            ErrorKind::EmptySequence,
            "no data rows after the column labels".into(),
        ));
    }
    for (what, keys, present) in
        [("rows", ["nRows", "datarows"], rows), ("columns", ["nColumns", "datacolumns"], width)]
    {
        for k in keys {
            if let Some(v) = key(k)
                && v.parse::<usize>().ok() != Some(present)
            {
                notes.push(format!("{k} says {v}; {present} {what} are present: read {present}"));
            }
        }
    }
    let rate_hz = match key("DataRate").and_then(|v| v.parse::<f64>().ok()) {
        Some(hz) => hz,
        None => rate_from_times(&times, &row_lines, origin, &mut notes)?,
    };
    if in_degrees.is_none() {
        notes.push(
            "no inDegrees in the header: angles read as degrees, as OpenSim's Storage assumes"
                .into(),
        );
    }
    Ok(StorageFile {
        header,
        in_degrees,
        labels,
        time_label,
        times,
        values,
        rate_hz,
        notes,
        endheader_line,
    })
}

/// The mean rate of increasing times, `(n − 1) / (last − first)`; every step within half the
/// mean step of it (else an error naming the line).
fn rate_from_times(
    times: &[f64],
    lines: &[usize],
    origin: &Path,
    notes: &mut Vec<String>,
) -> Result<f64> {
    let n = times.len();
    if n < 2 {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            lines[0],
            "one row and no DataRate in the header give no rate; expected at least 2 rows",
        ));
    }
    let mean = (times[n - 1] - times[0]) / (n - 1) as f64;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, w) in times.windows(2).enumerate() {
        let step = w[1] - w[0];
        if !(step > 0.0 && (step - mean).abs() <= 0.5 * mean) {
            return Err(Error::at_line(
                ErrorKind::OutOfRange,
                origin,
                lines[i + 1],
                format!(
                    "time {} s after {} s; expected increasing times about {mean} s apart (one rate; resample a variable-step file first)",
                    w[1], w[0]
                ),
            ));
        }
        lo = lo.min(step);
        hi = hi.max(step);
    }
    if hi - lo > 1e-9 * mean {
        notes.push(format!(
            "time steps range from {lo:.6} s to {hi:.6} s (times written with few decimals): the rate is (rows − 1) / (last − first time) = {:.6} Hz",
            1.0 / mean
        ));
    }
    Ok(1.0 / mean)
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_loader, default_params};

    const ORIGIN: &str = "hand/made.mot";

    fn parse(text: &str) -> Result<StorageFile> {
        parse_storage(text, Path::new(ORIGIN))
    }

    fn err_at(text: &str, kind: ErrorKind, line: usize) -> Error {
        let e = match parse(text) {
            Ok(t) => panic!("expected {kind:?}, read {} rows", t.n_rows()),
            Err(e) => e,
        };
        assert_eq!((e.kind(), e.location().line), (kind, Some(line)), "{e}");
        assert!(e.to_string().starts_with(&format!("{ORIGIN}:{line}")), "{e}");
        e
    }

    const V1: &str = "Coordinates\nversion=1\nnRows=3\nnColumns=3\ninDegrees=no\nendheader\ntime\ta\tb\n0\t1\t2\n0.01\t3\tNaN\n0.02\t5.5e-1\t6\n";

    #[test]
    fn reads_labels_rows_rate_and_units() {
        let s = parse(V1).unwrap();
        assert_eq!(
            (s.n_rows(), s.labels.clone(), s.angle_unit()),
            (3, vec!["a".to_string(), "b".into()], "radians")
        );
        assert!((s.rate_hz - 100.0).abs() < 1e-9);
        assert_eq!((s.values[0], s.values[1], s.values[2], s.values[4]), (1.0, 2.0, 3.0, 0.55));
        assert!(s.values[3].is_nan());
        assert!(s.notes.is_empty(), "{:?}", s.notes);
        let m = s.into_motion(Path::new(ORIGIN), None).unwrap();
        assert_eq!(m.channels().names(), ["a", "b"]);
        assert_eq!(m.n_frames(), 3);
        assert!(m.load_notes.length_unit_from.contains("radians"));
    }

    #[test]
    fn simm_header_duplicates_wrong_counts_and_uneven_steps_are_said() {
        let text = "name x.mot\t\t\ndatacolumns 9\t\t\ndatarows 4\t\t\nrange 0 1\t\t\nendheader\t\t\n   time\t  f\t  f\t\n0.40\t1\t2\t\n0.417\t1\t2\t\n0.433\t1\t2\t\n";
        let s = parse(text).unwrap();
        assert_eq!(s.labels, ["f", "f#2"]);
        assert_eq!(s.angle_unit(), "degrees");
        assert!((s.rate_hz - 2.0 / 0.033).abs() < 1e-6);
        let said = s.notes.join("\n");
        for phrase in
            ["repeats", "datacolumns says 9", "datarows says 4", "time steps range", "assumes"]
        {
            assert!(said.contains(phrase), "{phrase}: {said}");
        }
    }

    #[test]
    fn data_rate_in_the_header_wins() {
        let s = parse(&V1.replace("version=1", "DataRate=250")).unwrap();
        assert_eq!(s.rate_hz, 250.0);
    }

    #[test]
    fn errors_name_their_line() {
        err_at("version=1\nnRows=2\n", ErrorKind::Truncated, 2);
        err_at("endheader\n", ErrorKind::Truncated, 1);
        let e =
            err_at(&V1.replace("0.01\t3\tNaN", "0.01\t3\tNaN\t7"), ErrorKind::WrongValueCount, 9);
        assert!(e.message().contains("expected 3"), "{e}");
        err_at(&V1.replace("0.01\t3\tNaN", "0.01\t3"), ErrorKind::WrongValueCount, 9);
        let e = err_at(&V1.replace("5.5e-1", "x"), ErrorKind::Syntax, 10);
        assert_eq!(e.location().field.as_deref(), Some("a"));
        err_at(&V1.replace("0.02\t", "0.005\t"), ErrorKind::OutOfRange, 9);
        err_at(&V1.replace("inDegrees=no", "inDegrees=maybe"), ErrorKind::OutOfRange, 5);
        err_at(&V1.replace("time\ta\tb\n", "0\t1\t2\n"), ErrorKind::Syntax, 7);
    }

    #[test]
    fn no_truncation_or_byte_flip_panics() {
        motionlab_testkit::truncations_and_byte_flips(
            V1,
            5,
            b"\t\n\r 0123456789.-e=endheadrNa",
            3000,
            |s| {
                let _ = parse(s);
            },
        );
    }

    #[test]
    fn registered_for_mot_and_sto() {
        let loader = build_loader("mot", &default_params()).unwrap();
        assert_eq!(loader.extensions(), ["mot", "sto"]);
        let entry = motionlab_core::registry::find("mot").unwrap();
        assert!(entry.params().iter().all(|p| p.default.is_some() && !p.description.is_empty()));
        assert!(entry.doc().contains("inDegrees"));
    }
}
