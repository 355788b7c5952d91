//! Published per-series scores of several methods, as benchmarks release them (TSSB's
//! `segmentation_covering_unknown.csv`): a header `dataset,MethodA,MethodB,…`, then one row per
//! series — its name, then one score per method.
//!
//! ```text
//! dataset,ESPRESSO,BOCD,Window,PELT,BinSeg,FLOSS,ClaSP
//! Adiac,0.408,0.303,0.303,0.303,0.303,0.809,0.816
//! ```
//!
//! The first column names the series (any header text); every other header cell names a
//! method (unique, non-empty). Cells are numbers; an empty cell or `nan` is a missing score
//! (NaN). Series names are unique. Parsed with the `csv` crate (quoting, CRLF, `#` comment
//! lines); errors name the file, the line and the column.

use std::path::Path;

use motionlab_core::{Error, ErrorKind, Location, Result};

/// A parsed scores file.
#[derive(Clone, Debug, PartialEq)]
pub struct PublishedScores {
    /// Method names, in column order.
    pub methods: Vec<String>,
    /// Per series: its name and one score per method (NaN where missing).
    pub series: Vec<(String, Vec<f64>)>,
}

impl PublishedScores {
    /// The scores of series `name`, if listed.
    pub fn series(&self, name: &str) -> Option<&[f64]> {
        self.series.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }
    /// The column of method `name`, if listed.
    pub fn method_index(&self, name: &str) -> Option<usize> {
        self.methods.iter().position(|m| m == name)
    }
}

/// Parses a scores file's text (`path` names it in errors).
pub fn parse_scores_csv(text: &str, path: &Path) -> Result<PublishedScores> {
    let at = |line: u64, column: Option<&str>| {
        let loc = Location::file(path).line(line as usize);
        match column {
            Some(c) => loc.field(c.to_string()),
            None => loc,
        }
    };
    // Comment lines blanked rather than skipped by the reader, so its positions give the file's lines.
    let text = crate::text::blank_comment_lines(text);
    let line_of = |p: Option<&csv::Position>| crate::text::csv_record_line(&text, p) as u64;
    let mut reader = csv::ReaderBuilder::new().flexible(true).from_reader(text.as_bytes());
    let header = reader
        .headers()
        .map_err(|e| {
            Error::new(ErrorKind::Syntax, format!("cannot read the header: {e}"))
                .with_location(Location::file(path))
        })?
        .clone();
    let header_line = line_of(header.position());
    if header.len() < 2 {
        return Err(Error::new(
            ErrorKind::Syntax,
            format!(
                "the header has {} column(s); expected the series name, then one column per method",
                header.len()
            ),
        )
        .with_location(at(header_line, None)));
    }
    let methods: Vec<String> = header.iter().skip(1).map(|h| h.trim().to_string()).collect();
    for (i, m) in methods.iter().enumerate() {
        if m.is_empty() {
            return Err(Error::new(
                ErrorKind::Syntax,
                format!("header column {} is empty; expected a method name", i + 2),
            )
            .with_location(at(header_line, None)));
        }
        if methods[..i].contains(m) {
            return Err(Error::new(
                ErrorKind::DuplicateName,
                format!("method {m:?} is named twice in the header"),
            )
            .with_location(at(header_line, Some(m))));
        }
    }
    let mut series: Vec<(String, Vec<f64>)> = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            Error::new(ErrorKind::Syntax, format!("cannot read the row: {e}"))
                .with_location(at(line_of(e.position()), None))
        })?;
        let line = line_of(record.position());
        if record.iter().all(|c| c.trim().is_empty()) {
            continue;
        }
        if record.len() != header.len() {
            return Err(Error::new(
                ErrorKind::Syntax,
                format!(
                    "found {} cells, expected {} (the series name and one score per method)",
                    record.len(),
                    header.len()
                ),
            )
            .with_location(at(line, None)));
        }
        let name = record[0].trim().to_string();
        if name.is_empty() {
            return Err(Error::new(ErrorKind::Syntax, "the series name is empty")
                .with_location(at(line, Some(&header[0]))));
        }
        if series.iter().any(|(n, _)| *n == name) {
            return Err(Error::new(
                ErrorKind::DuplicateName,
                format!("series {name:?} is listed twice"),
            )
            .with_location(at(line, Some(&header[0]))));
        }
        let scores = methods
            .iter()
            .enumerate()
            .map(|(j, m)| {
                let cell = record[j + 1].trim();
                if cell.is_empty() || cell.eq_ignore_ascii_case("nan") {
                    return Ok(f64::NAN);
                }
                cell.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                    Error::new(ErrorKind::Syntax, format!("{cell:?} is not a number; expected a score (empty or `nan` when missing)")).with_location(at(line, Some(m)))
                })
            })
            .collect::<Result<Vec<f64>>>()?;
        series.push((name, scores));
    }
    if series.is_empty() {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "lists no series; expected one row per series",
        )
        .with_location(Location::file(path)));
    }
    Ok(PublishedScores { methods, series })
}

/// Reads and parses a scores file (`.gz` works too).
pub fn read_scores_csv(path: &Path) -> Result<PublishedScores> {
    parse_scores_csv(&crate::read::read_text(path)?, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<PublishedScores> {
        parse_scores_csv(text, Path::new("s.csv"))
    }

    #[test]
    fn parses_scores_and_missing_cells() {
        let s = parse("dataset,A,B\n# a comment\nx,0.5,\ny,1,nan\n").unwrap();
        assert_eq!(s.methods, ["A", "B"]);
        assert_eq!(s.series[0].0, "x");
        assert_eq!(s.series("y").unwrap()[0], 1.0);
        assert!(s.series("x").unwrap()[1].is_nan() && s.series("y").unwrap()[1].is_nan());
        assert_eq!(s.method_index("B"), Some(1));
    }

    #[test]
    fn errors_name_the_line_and_column() {
        let e = parse("dataset,A,B\nx,0.5,0.7\ny,0.1,oops\n").unwrap_err();
        assert_eq!((e.location().line, e.location().field.as_deref()), (Some(3), Some("B")), "{e}");
        assert!(e.to_string().contains("\"oops\" is not a number"), "{e}");
        let e = parse("dataset,A\nx,0.5,0.7\n").unwrap_err();
        assert_eq!(e.location().line, Some(2));
        assert_eq!(parse("dataset,A,A\nx,1,2\n").unwrap_err().kind(), ErrorKind::DuplicateName);
        assert_eq!(parse("dataset,A\nx,1\nx,2\n").unwrap_err().location().line, Some(3));
        assert_eq!(parse("dataset\nx\n").unwrap_err().kind(), ErrorKind::Syntax);
        assert_eq!(parse("dataset,A\n").unwrap_err().kind(), ErrorKind::EmptySequence);
    }

    /// Lines are the file's: a header error names the header's line, and comment or blank
    /// lines before a row are counted.
    #[test]
    fn lines_count_comments_and_blank_lines() {
        assert_eq!(parse("dataset,A,A\nx,1,2\n").unwrap_err().location().line, Some(1));
        assert_eq!(parse("# sheet\n\ndataset\nx\n").unwrap_err().location().line, Some(3));
        assert_eq!(parse("dataset,A\n# note\n\nx,abc\n").unwrap_err().location().line, Some(4));
        assert_eq!(parse("dataset,A\nx,1\n# note\nx,2\n").unwrap_err().location().line, Some(4));
    }

    #[test]
    fn reads_tssbs_published_sheet() {
        let s =
            read_scores_csv(&motionlab_testkit::data_path("tssb/published_covering_unknown.csv"))
                .unwrap();
        assert_eq!(s.methods, ["ESPRESSO", "BOCD", "Window", "PELT", "BinSeg", "FLOSS", "ClaSP"]);
        assert_eq!(s.series.len(), 75);
        // The notebook's means (×100, rounded to 2 decimals): ClaSP 85.47, PELT 58.1.
        let mean = |m: &str| {
            let j = s.method_index(m).unwrap();
            (s.series.iter().map(|(_, v)| v[j]).sum::<f64>() / 75.0 * 1e4).round() / 100.0
        };
        assert_eq!((mean("ClaSP"), mean("PELT"), mean("Window")), (85.47, 58.1, 40.1));
    }
}
