//! The `boundaries_csv` annotation format: boundaries or segments a user marked, one row each
//! (the ground-truth plugin that reads it into a [`motionlab_core::Segmentation`] is
//! `boundaries_csv` in `motionlab-eval`, next to the annotator consensus it can apply).
//!
//! # Format
//!
//! A header row, then one row per boundary **or** one row per segment. Columns (any order,
//! names case-insensitive; `#` starts a comment line; the delimiter is `,`, or `;` / tab when
//! the header has no comma):
//!
//! | column | |
//! |---|---|
//! | `sequence` | optional: the motion file's stem (`86_01` for `86_01.amc.gz`); without it every row belongs to the one motion read |
//! | `frame` **or** `time_s` (or both) | one row per boundary: a frame (fractional allowed) or seconds from the motion's first frame; with both, `frame` is the boundary and `time_s` must agree with it to within half a frame (the files motionlab writes carry both) |
//! | `start_frame` + `end_frame` **or** `start_s` + `end_s` | one row per segment |
//! | `label` | optional segment label |
//! | `annotator` | optional: who marked it; several annotators feed a consensus or are evaluated one at a time |
//!
//! Points and segments do not mix: a header with a point column and a segment column (`frame`
//! with `start_s`), or with frames and seconds of segments (`start_frame` with `start_s`), is
//! an error, as is a header naming none, a segment start without its end, an unknown or
//! repeated column. Cells: numbers ≥ 0 (`12`, `12.5`, `1e3`); `start ≤ end`.
//!
//! ```text
//! sequence,start_s,end_s,label,annotator
//! dance1,2.10,3.05,step,ana
//! dance1,3.05,3.90,turn,ana
//! dance1,2.00,3.10,step,ben
//! ```
//!
//! Parsed with the `csv` crate (quoting, CRLF, comment lines); errors name the file, the line
//! and the column. [`write_boundaries_csv`] writes a [`SequenceTiers`] in this format (one row
//! per mark: `sequence,frame,time_s,label,annotator`).

use std::path::Path;

use motionlab_core::{Error, ErrorKind, Result};

use super::annotations::{AnnotatedItem, AnnotatorTrack, parse_instant, start_after_end};
use super::tiers::SequenceTiers;

/// The unit of the time columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsvUnit {
    Frames,
    Seconds,
}

/// One data row.
#[derive(Clone, Debug, PartialEq)]
pub struct CsvRow {
    pub sequence: Option<String>,
    pub annotator: Option<String>,
    pub item: AnnotatedItem,
    /// The row's `time_s` when the file gives it beside `frame` (the reader, which knows the
    /// motion's rate, checks that the two agree).
    pub time_s: Option<f64>,
}

/// A parsed file.
#[derive(Clone, Debug, PartialEq)]
pub struct CsvAnnotations {
    pub unit: CsvUnit,
    /// One row per segment (else per boundary).
    pub segments: bool,
    pub has_sequence: bool,
    /// 1-based line of the header.
    pub header_line: usize,
    pub rows: Vec<CsvRow>,
}

const TIME_COLUMNS: [&str; 6] = ["frame", "time_s", "start_frame", "end_frame", "start_s", "end_s"];
const OTHER_COLUMNS: [&str; 3] = ["sequence", "label", "annotator"];

/// Reads the header and rows (see the module docs).
pub fn parse_boundaries_csv(text: &str, origin: &Path) -> Result<CsvAnnotations> {
    // Comment lines blanked (not removed) so line numbers stay those of the file: the csv
    // crate's own positions skip comment lines.
    let text = crate::text::blank_comment_lines(crate::text::strip_bom(text));
    let text = text.as_str();
    let header_line = text
        .lines()
        .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .unwrap_or("");
    let delimiter = if header_line.contains(',') {
        b','
    } else if header_line.contains('\t') {
        b'\t'
    } else if header_line.contains(';') {
        b';'
    } else {
        b','
    };
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .delimiter(delimiter)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let line_at = |p: Option<&csv::Position>| crate::text::csv_record_line(text, p);
    let csv_error = |e: csv::Error| {
        let line = line_at(e.position());
        Error::at_line(ErrorKind::Syntax, origin, line, format!("not readable as CSV: {e}"))
    };
    let mut records = reader.records();
    let Some(header) = records.next().transpose().map_err(csv_error)? else {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            1,
            "empty file; expected a header like `sequence,frame` or `sequence,start_s,end_s,label`",
        ));
    };
    let hline = line_at(header.position());
    let names: Vec<String> = header.iter().map(|c| c.to_ascii_lowercase()).collect();
    for (i, n) in names.iter().enumerate() {
        if !TIME_COLUMNS.contains(&n.as_str()) && !OTHER_COLUMNS.contains(&n.as_str()) {
            return Err(Error::at_line(
                ErrorKind::UnknownKey,
                origin,
                hline,
                format!(
                    "unknown column {n:?}; expected sequence, annotator, label and one of frame | time_s | start_frame + end_frame | start_s + end_s"
                ),
            )
            .with_field(header.get(i).unwrap_or(n)));
        }
        if names[..i].contains(n) {
            return Err(Error::at_line(
                ErrorKind::DuplicateName,
                origin,
                hline,
                format!("column {n:?} appears twice"),
            )
            .with_field(n.as_str()));
        }
    }
    let col = |n: &str| names.iter().position(|c| c == n);
    let present: Vec<&str> = TIME_COLUMNS.iter().copied().filter(|n| col(n).is_some()).collect();
    let (unit, start_name, end_name) = match present.as_slice() {
        ["frame"] | ["frame", "time_s"] => (CsvUnit::Frames, "frame", None),
        ["time_s"] => (CsvUnit::Seconds, "time_s", None),
        ["start_frame", "end_frame"] => (CsvUnit::Frames, "start_frame", Some("end_frame")),
        ["start_s", "end_s"] => (CsvUnit::Seconds, "start_s", Some("end_s")),
        [] => {
            return Err(Error::at_line(
                ErrorKind::MissingKey,
                origin,
                hline,
                "no time column; expected frame, time_s, start_frame + end_frame or start_s + end_s",
            )
            .with_field("frame"));
        }
        [one @ ("start_frame" | "end_frame" | "start_s" | "end_s")] => {
            let missing = match *one {
                "start_frame" => "end_frame",
                "end_frame" => "start_frame",
                "start_s" => "end_s",
                _ => "start_s",
            };
            return Err(Error::at_line(
                ErrorKind::MissingKey,
                origin,
                hline,
                format!("column {one:?} needs {missing:?} beside it (one row per segment)"),
            )
            .with_field(missing));
        }
        mixed => {
            return Err(Error::at_line(
                ErrorKind::InvalidParameter,
                origin,
                hline,
                format!(
                    "mixed formats: columns {}; expected exactly one of frame | time_s | start_frame + end_frame | start_s + end_s",
                    mixed.join(", ")
                ),
            )
            .with_field(mixed[1]));
        }
    };
    let (start_col, end_col) = (col(start_name), end_name.and_then(col));
    // `time_s` beside `frame`: kept for the reader's check.
    let time_col = if start_name == "frame" { col("time_s") } else { None };
    let (seq_col, ann_col, label_col) = (col("sequence"), col("annotator"), col("label"));
    let mut rows = Vec::new();
    for record in records {
        let record = record.map_err(csv_error)?;
        let line = line_at(record.position());
        if record.iter().all(str::is_empty) {
            continue;
        }
        if record.len() != names.len() {
            return Err(Error::at_line(
                ErrorKind::WrongValueCount,
                origin,
                line,
                format!(
                    "{} cells; expected {} (one per header column: {})",
                    record.len(),
                    names.len(),
                    names.join(",")
                ),
            ));
        }
        let cell = |c: Option<usize>| c.and_then(|i| record.get(i));
        let name_cell = |c: Option<usize>, what: &str| -> Result<Option<String>> {
            match cell(c) {
                None => Ok(None),
                Some("") => Err(Error::at_line(
                    ErrorKind::Syntax,
                    origin,
                    line,
                    format!("empty; expected a {what}"),
                )
                .with_field(what)),
                Some(s) => Ok(Some(s.to_string())),
            }
        };
        let sequence = name_cell(seq_col, "sequence")?;
        let annotator = name_cell(ann_col, "annotator")?;
        let start = parse_instant(cell(start_col).unwrap_or(""), origin, line, start_name)?;
        let end = match (end_name, end_col) {
            (Some(n), Some(c)) => {
                let end = parse_instant(record.get(c).unwrap_or(""), origin, line, n)?;
                if start > end {
                    return Err(start_after_end(origin, line, n, start, end));
                }
                Some((n.to_string(), end))
            }
            _ => None,
        };
        let label = cell(label_col).unwrap_or("").to_string();
        let time_s = time_col
            .map(|c| parse_instant(record.get(c).unwrap_or(""), origin, line, "time_s"))
            .transpose()?;
        rows.push(CsvRow {
            sequence,
            annotator,
            item: AnnotatedItem { line, start_field: start_name.into(), start, end, label },
            time_s,
        });
    }
    Ok(CsvAnnotations {
        unit,
        segments: end_name.is_some(),
        has_sequence: seq_col.is_some(),
        header_line: hline,
        rows,
    })
}

impl CsvAnnotations {
    /// The sequences named, in order of first appearance.
    pub fn sequences(&self) -> Vec<&str> {
        let mut v: Vec<&str> = Vec::new();
        for s in self.rows.iter().filter_map(|r| r.sequence.as_deref()) {
            if !v.contains(&s) {
                v.push(s);
            }
        }
        v
    }

    /// The rows of `sequence` (every row when the file has no `sequence` column), grouped by
    /// annotator in order of first appearance; the annotator is `""` without that column.
    pub fn tracks(&self, sequence: &str) -> Vec<AnnotatorTrack> {
        let mut tracks: Vec<AnnotatorTrack> = Vec::new();
        for r in self
            .rows
            .iter()
            .filter(|r| !self.has_sequence || r.sequence.as_deref() == Some(sequence))
        {
            let who = r.annotator.clone().unwrap_or_default();
            match tracks.iter_mut().find(|t| t.annotator == who) {
                Some(t) => t.items.push(r.item.clone()),
                None => tracks.push(AnnotatorTrack { annotator: who, items: vec![r.item.clone()] }),
            }
        }
        tracks
    }

    /// The first row naming `sequence` (for error messages).
    pub fn first_line_of(&self, sequence: &str) -> Option<usize> {
        self.rows.iter().find(|r| r.sequence.as_deref() == Some(sequence)).map(|r| r.item.line)
    }
}

/// The marks of every tier of `seq` as a `boundaries_csv` file: the header
/// `sequence,frame,time_s,label,annotator`, then one row per mark, tier by tier in order, by
/// frame within a tier. `time_s` is `frame / frame_rate_hz` in the shortest decimal that reads
/// back to the same number; a line break in a label becomes a space (a row is a line); cells
/// holding `,` or `"` are quoted.
pub fn write_boundaries_csv(seq: &SequenceTiers) -> String {
    let mut w =
        csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).from_writer(Vec::new());
    let mut rows: Vec<[String; 5]> =
        vec![["sequence", "frame", "time_s", "label", "annotator"].map(String::from)];
    for tier in &seq.tiers {
        let mut marks: Vec<_> = tier.marks.iter().collect();
        marks.sort_by_key(|m| m.frame);
        for m in marks {
            let time_s = m.frame as f64 / seq.frame_rate_hz;
            let one_line = |t: &str| {
                t.split(['\r', '\n']).filter(|p| !p.is_empty()).collect::<Vec<_>>().join(" ")
            };
            rows.push([
                one_line(&seq.sequence),
                m.frame.to_string(),
                time_s.to_string(),
                one_line(&m.label),
                one_line(&tier.name),
            ]);
        }
    }
    for r in &rows {
        // Writing into a Vec cannot fail.
        let _ = w.write_record(r);
    }
    w.into_inner().map(|bytes| String::from_utf8_lossy(&bytes).into_owned()).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(t: &str) -> Result<CsvAnnotations> {
        parse_boundaries_csv(t, Path::new("a.csv"))
    }

    fn at(e: &Error) -> (ErrorKind, Option<usize>, Option<&str>) {
        (e.kind(), e.location().line, e.location().field.as_deref())
    }

    #[test]
    fn segments_with_annotators_quotes_and_comments() {
        let a = parse("# made by hand\r\nSequence,start_s,end_s,label,annotator\r\nd1,2.1,3,\"step, left\",ana\r\n\r\nd1,3,3.9,turn,ben\r\nd2,0,1,x,ana\r\n").unwrap();
        assert_eq!((a.unit, a.segments, a.has_sequence), (CsvUnit::Seconds, true, true));
        assert_eq!(a.sequences(), vec!["d1", "d2"]);
        let t = a.tracks("d1");
        assert_eq!(t.iter().map(|t| t.annotator.as_str()).collect::<Vec<_>>(), vec!["ana", "ben"]);
        assert_eq!(t[0].items[0].label, "step, left");
        assert_eq!(
            (t[0].items[0].line, t[0].items[0].start, t[0].items[0].end.clone()),
            (3, 2.1, Some(("end_s".into(), 3.0)))
        );
        assert_eq!(t[1].items[0].line, 5);
        // Points without a sequence column, tab-separated.
        let p = parse("frame\tlabel\n10.5\ta\n20\tb\n").unwrap();
        assert_eq!((p.unit, p.segments, p.has_sequence), (CsvUnit::Frames, false, false));
        assert_eq!(p.tracks("whatever")[0].items.len(), 2);
        assert_eq!(p.rows[0].time_s, None);
        // A frame with its time: the frame is the boundary, the time kept for the reader's check.
        let b = parse("time_s,frame\n0.5,60\n").unwrap();
        assert_eq!(
            (b.unit, b.rows[0].item.start, b.rows[0].time_s),
            (CsvUnit::Frames, 60.0, Some(0.5))
        );
    }

    #[test]
    fn written_files_parse_back_to_their_marks_labels_and_annotators() {
        use crate::labels::tiers::{MarkTier, TierMark};
        let mark = |frame, label: &str| TierMark { frame, label: label.into() };
        let seq = SequenceTiers {
            name: "86_01".into(),
            sequence: "86_01".into(),
            input_sha256: String::new(),
            frame_rate_hz: 120.0,
            n_frames: 4579,
            tiers: vec![
                MarkTier {
                    name: "ana".into(),
                    marks: vec![mark(1149, "walk, fast"), mark(549, "jump \"high\"")],
                },
                MarkTier::unlabelled("fused", &[3, 4577]),
            ],
        };
        let text = write_boundaries_csv(&seq);
        assert!(
            text.starts_with(
                "sequence,frame,time_s,label,annotator\n86_01,549,4.575,\"jump \"\"high\"\"\",ana\n"
            ),
            "{text}"
        );
        let back = parse(&text).unwrap();
        let ana = &back.tracks("86_01")[0];
        assert_eq!(ana.annotator, "ana");
        let got: Vec<(f64, &str)> = ana.items.iter().map(|i| (i.start, i.label.as_str())).collect();
        assert_eq!(got, vec![(549.0, "jump \"high\""), (1149.0, "walk, fast")]);
        assert_eq!(back.rows[1].time_s, Some(1149.0 / 120.0));
        assert_eq!(
            back.tracks("86_01")[1].items.iter().map(|i| i.start).collect::<Vec<_>>(),
            vec![3.0, 4577.0]
        );
    }

    #[test]
    fn defects_name_line_and_column() {
        let e = parse("sequence,frame\nd1,12\nd1,x\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::Syntax, Some(3), Some("frame")));
        let e = parse("sequence,start_frame,end_frame\nd1,30,20\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::OutOfRange, Some(2), Some("end_frame")));
        let e = parse("sequence,frame,start_s,end_s\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::InvalidParameter, Some(1), Some("start_s")));
        let e = parse("start_frame,end_frame,start_s,end_s\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::InvalidParameter, Some(1), Some("end_frame")));
        let e = parse("frame,time_s\n12,x\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::Syntax, Some(2), Some("time_s")));
        let e = parse("sequence,label\nd1,x\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::MissingKey, Some(1), Some("frame")));
        let e = parse("sequence,start_s\nd1,1\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::MissingKey, Some(1), Some("end_s")));
        let e = parse("sequence,frames\nd1,1\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::UnknownKey, Some(1), Some("frames")));
        let e = parse("sequence,frame\nd1,1,2\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::WrongValueCount, Some(2), None));
        let e = parse("sequence,frame\n,1\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::Syntax, Some(2), Some("sequence")));
        let e = parse("time_s\n-1\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::OutOfRange, Some(2), Some("time_s")));
        let e = parse("time_s\nNaN\n").unwrap_err();
        assert_eq!(at(&e), (ErrorKind::NonFinite, Some(2), Some("time_s")));
        assert_eq!(parse("").unwrap_err().kind(), ErrorKind::EmptySequence);
    }
}
