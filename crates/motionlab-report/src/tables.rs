//! Result tables: [`motionlab_core::Table`] → Polars `DataFrame` → CSV, Parquet and Markdown.
//!
//! The DataFrame is the single source of every export, so the CSV, the Parquet file, the
//! Markdown in README and the HTML report always show the same numbers.

use std::fs::File;
use std::path::{Path, PathBuf};

use polars::prelude::*;

use motionlab_core::{ColumnValues, Error, ErrorKind, Location, Result, Table};

use crate::figures::fmt_num;

/// Converts a core table into a Polars DataFrame (same column names and order).
pub fn to_dataframe(table: &Table) -> Result<DataFrame> {
    let columns: Vec<Column> = table
        .columns
        .iter()
        .map(|c| {
            let name = PlSmallStr::from(c.name.as_str());
            match &c.values {
                ColumnValues::F64(v) => Column::new(name, v),
                ColumnValues::I64(v) => Column::new(name, v),
                ColumnValues::Bool(v) => Column::new(name, v),
                ColumnValues::Str(v) => Column::new(name, v),
            }
        })
        .collect();
    DataFrame::new(table.n_rows(), columns).map_err(|e| polars_error(&table.name, e))
}

fn polars_error(what: &str, e: PolarsError) -> Error {
    Error::new(ErrorKind::Report, format!("table {what:?}: {e}"))
}

/// The files one table was written to.
#[derive(Clone, Debug)]
pub struct WrittenTable {
    pub csv: PathBuf,
    pub parquet: PathBuf,
    pub markdown: PathBuf,
}

/// Writes `<dir>/<name>.csv`, `.parquet` and `.md` (the name made a safe file name,
/// [`motionlab_core::paths::safe_file_name`]).
pub fn write_table(table: &Table, dir: &Path) -> Result<WrittenTable> {
    let mut df = to_dataframe(table)?;
    let stem = motionlab_core::paths::safe_file_name(&table.name);
    let csv = dir.join(format!("{stem}.csv"));
    let parquet = dir.join(format!("{stem}.parquet"));
    let markdown = dir.join(format!("{stem}.md"));
    let create = |p: &Path| File::create(p).map_err(|e| Error::io(p, e));
    CsvWriter::new(create(&csv)?)
        .finish(&mut df)
        .map_err(|e| polars_error(&table.name, e).with_location(Location::file(&csv)))?;
    ParquetWriter::new(create(&parquet)?)
        .finish(&mut df)
        .map_err(|e| polars_error(&table.name, e).with_location(Location::file(&parquet)))?;
    let md = format!("### {}\n\n{}", table.title, markdown_of(&df));
    std::fs::write(&markdown, md).map_err(|e| Error::io(&markdown, e))?;
    Ok(WrittenTable { csv, parquet, markdown })
}

/// Formats one cell for humans (Markdown/HTML): floats compactly, nulls empty.
pub fn format_cell(v: &AnyValue<'_>) -> String {
    match v {
        AnyValue::Null => String::new(),
        AnyValue::Float64(x) => fmt_num(*x),
        AnyValue::Float32(x) => fmt_num(*x as f64),
        AnyValue::String(s) => s.to_string(),
        AnyValue::StringOwned(s) => s.to_string(),
        AnyValue::Boolean(b) => if *b { "yes" } else { "no" }.to_string(),
        other => other.to_string(),
    }
}

/// Rows of formatted cells, for Markdown and HTML.
pub fn formatted_rows(df: &DataFrame) -> Vec<Vec<String>> {
    (0..df.height())
        .map(|r| {
            df.columns()
                .iter()
                .map(|c| c.get(r).map(|v| format_cell(&v)).unwrap_or_default())
                .collect()
        })
        .collect()
}

/// A GitHub-flavoured Markdown table of a DataFrame.
pub fn markdown_of(df: &DataFrame) -> String {
    let names: Vec<String> = df.get_column_names().iter().map(|n| n.to_string()).collect();
    let numeric: Vec<bool> =
        df.columns().iter().map(|c| c.dtype().is_primitive_numeric()).collect();
    let mut out = format!("| {} |\n", names.join(" | "));
    out.push_str(&format!(
        "|{}|\n",
        numeric.iter().map(|n| if *n { "---:" } else { "---" }).collect::<Vec<_>>().join("|")
    ));
    for row in formatted_rows(df) {
        // A `|` or a line break inside a cell (a method or annotator name) would break the table.
        let cells: Vec<String> =
            row.into_iter().map(|c| c.replace('|', "\\|").replace(['\n', '\r'], " ")).collect();
        out.push_str(&format!("| {} |\n", cells.join(" | ")));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize)]
    struct Row {
        method: &'static str,
        precision: f64,
        n: i64,
        ok: bool,
    }

    #[test]
    fn csv_parquet_and_markdown_hold_the_same_rows() {
        let t = Table::from_records(
            "table1",
            "Table 1",
            &[
                Row { method: "speed", precision: 0.64, n: 3, ok: true },
                Row { method: "fused|x", precision: f64::NAN, n: 4, ok: false },
            ],
        )
        .unwrap();
        let dir = std::env::temp_dir().join(format!("mlab-tab-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let w = write_table(&t, &dir).unwrap();
        let csv = std::fs::read_to_string(&w.csv).unwrap();
        assert_eq!(csv.lines().next(), Some("method,precision,n,ok"));
        assert!(csv.contains("speed,0.64,3,true"), "{csv}");
        let md = std::fs::read_to_string(&w.markdown).unwrap();
        assert!(md.contains("| speed | 0.64 | 3 | yes |"), "{md}");
        assert!(md.contains("fused\\|x"), "{md}");
        let back = ParquetReader::new(File::open(&w.parquet).unwrap()).finish().unwrap();
        assert_eq!(back.shape(), (2, 4));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Independent recomputations (bench/osafune_check.py recomputes K, μ, σ, CV from the CSV
    /// to 1e-9) need the CSV to hold each double exactly: Polars writes the shortest text that
    /// parses back to the same bits (zmij), which this pins.
    #[test]
    fn csv_floats_parse_back_to_the_same_bits() {
        let xs = [
            0.1 + 0.2,
            1.0 / 3.0,
            -123456.789e-300,
            2f64.sqrt() * 1e17,
            5e-324,
            f64::MAX,
            -0.0,
            10.258403953060842,
            f64::NAN,
            f64::INFINITY,
        ];
        let mut t = Table::new("floats", "floats");
        t.push_column("x", ColumnValues::F64(xs.to_vec())).unwrap();
        let dir = std::env::temp_dir().join(format!("mlab-floats-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let csv = std::fs::read_to_string(write_table(&t, &dir).unwrap().csv).unwrap();
        let back: Vec<f64> = csv
            .lines()
            .skip(1)
            .map(|l| l.parse::<f64>().unwrap_or_else(|e| panic!("{l:?}: {e}")))
            .collect();
        assert_eq!(back.len(), xs.len());
        for (a, b) in xs.iter().zip(&back) {
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{a:e} written as {b:e}\n{csv}"
            );
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
