//! # motionlab-parquet
//!
//! Parquet channel files for the `channels` loader of `motionlab-io`: one column per channel,
//! the column names as the header, integer and floating-point columns with nulls as missing
//! samples. The crate registers a [`ColumnFormat`] for the `parquet` extension; the loader,
//! its parameters (`rate_hz`, `time_column`, `columns`, `names`) and its errors are the
//! `channels` loader's own, so a Parquet file and a CSV of the same columns load the same
//! motion.
//!
//! **Why a crate of its own.** Reading Parquet means polars (already built for the result
//! tables) or a second Arrow stack; `motionlab-io`, which the algorithm crates' tests and the
//! fuzz targets build, stays free of both. A program that reads Parquet names this crate (the
//! CLI and the Python package do), so the linker keeps its registration.
//!
//! **Bounded.** The file is read within the input limit like every other (its bytes), and the
//! decoded table is bounded by the same limit before anything is decompressed: rows × columns
//! × 8 bytes, from the file's metadata.
//!
//! **Page headers checked first.** polars sizes its buffers by each data page's value count
//! (a signed 32-bit field it casts to `usize`): a corrupt or crafted header can make it request
//! exabytes, and a failed allocation aborts the process — no `catch_unwind` stops it. Before
//! polars decodes, every page header of every column chunk is read (polars' own page reader)
//! and each data page must hold at most its chunk's value count, each chunk at most its row
//! group's rows, each page at most the input limit uncompressed; anything else is an error
//! naming the file. Panics polars raises on other corrupt content are caught and reported the
//! same way.

use std::io::Cursor;
use std::path::Path;

use motionlab_core::{Error, ErrorKind, Result};
use motionlab_io::channel_file::{ColumnFormat, ColumnTable};
use polars::prelude::{DataType, ParquetReader, PolarsError, SerReader};
use polars_buffer::Buffer;
use polars_parquet::parquet::error::ParquetError;
use polars_parquet::parquet::metadata::FileMetadata;
use polars_parquet::parquet::page::CompressedPage;
use polars_parquet::parquet::read::get_page_iterator;

/// How many plugins this crate registers: none — it adds a format to the `channels` loader.
pub const PLUGIN_COUNT: usize = 0;

motionlab_core::inventory::submit! {
    ColumnFormat { extension: "parquet", parse: parse_parquet }
}

/// Parses a Parquet file's bytes into sample-major columns (see the crate docs); errors name
/// `origin` and, for a column of the wrong type, the column.
///
/// polars' reader panics on some corrupt files (a page header or dictionary that lies): the
/// panic is caught here and reported as the file's error, so a malformed file is an error and
/// never a crash (`corrupt_files_are_errors_never_panics`).
pub fn parse_parquet(bytes: Vec<u8>, origin: &Path, limit: u64) -> Result<ColumnTable> {
    // One shared buffer: polars' reader and the page-header check below read it without a copy.
    let bytes = Buffer::from(bytes);
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read_columns(&bytes, origin, limit)))
        .unwrap_or_else(|panic| {
            let reason = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(Error::new(
                ErrorKind::Syntax,
                format!("not a readable Parquet file: the reader failed on its content ({reason})"),
            )
            .in_file(origin))
        })
}

/// Every page header against the footer's counts (see the crate docs); `metadata` is the
/// footer polars' reader has already read.
fn check_page_headers(
    metadata: &FileMetadata,
    bytes: &Buffer<u8>,
    origin: &Path,
    limit: u64,
) -> Result<()> {
    let unreadable = |e: ParquetError| {
        Error::new(ErrorKind::Syntax, format!("not a readable Parquet file: {e}")).in_file(origin)
    };
    let lies = |what: String| {
        Error::new(ErrorKind::Syntax, format!("not a readable Parquet file: {what}"))
            .in_file(origin)
    };
    let max_page = usize::try_from(limit).unwrap_or(usize::MAX);
    for (g, group) in metadata.row_groups.iter().enumerate() {
        for chunk in group.parquet_columns() {
            let name = &chunk.descriptor().path_in_schema;
            let values = usize::try_from(chunk.num_values())
                .ok()
                .filter(|&n| n <= group.num_rows())
                .ok_or_else(|| {
                    lies(format!(
                        "column {name:?} of row group {g} says it holds {} values in {} rows",
                        chunk.num_values(),
                        group.num_rows()
                    ))
                })?;
            for page in get_page_iterator(chunk, Cursor::new(bytes.clone()), Vec::new(), max_page)
                .map_err(unreadable)?
            {
                if let CompressedPage::Data(page) = page.map_err(unreadable)?
                    && (page.num_values() > values || page.uncompressed_size() > max_page)
                {
                    // `num_values` is the header's i32 cast to usize: shown as the header has it.
                    let msg = format!(
                        "a page of column {name:?} says it holds {} values ({} bytes uncompressed) in a column chunk of {values} values",
                        page.num_values() as i64,
                        page.uncompressed_size()
                    );
                    return Err(lies(msg));
                }
            }
        }
    }
    Ok(())
}

fn read_columns(bytes: &Buffer<u8>, origin: &Path, limit: u64) -> Result<ColumnTable> {
    let polars_error = |e: PolarsError| {
        Error::new(ErrorKind::Syntax, format!("not a readable Parquet file: {e}")).in_file(origin)
    };
    let mut reader = ParquetReader::new(Cursor::new(bytes.clone()));
    let n_rows = reader.num_rows().map_err(polars_error)?;
    let n_columns = reader.schema().map_err(polars_error)?.len();
    let decoded = (n_rows as u128) * (n_columns as u128) * 8;
    if decoded > u128::from(limit) {
        let what =
            format!("decodes to {n_rows} rows × {n_columns} columns ({decoded} bytes of float64)");
        return Err(motionlab_core::limits::too_large(origin, &what, limit));
    }
    if n_columns == 0 {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "a Parquet file with no column; expected one column per channel",
        )
        .in_file(origin));
    }
    if n_rows == 0 {
        return Err(Error::new(ErrorKind::EmptySequence, "a header and no samples (0 rows)")
            .in_file(origin));
    }
    let metadata = reader.get_metadata().map_err(polars_error)?.clone();
    check_page_headers(&metadata, bytes, origin, limit)?;
    let frame = reader.finish().map_err(polars_error)?;
    let mut header = Vec::with_capacity(n_columns);
    let mut values = vec![0.0; n_rows * n_columns];
    for (k, column) in frame.columns().iter().enumerate() {
        let name = column.name().to_string();
        let dtype = column.dtype();
        if !dtype.is_primitive_numeric() {
            let msg = format!(
                "column {name:?} holds {dtype}; expected integer or floating-point numbers (one column per channel)"
            );
            return Err(Error::new(ErrorKind::WrongType, msg).in_file(origin).with_field(name));
        }
        let as_f64 = column.cast(&DataType::Float64).map_err(polars_error)?;
        let chunked = as_f64.f64().map_err(polars_error)?;
        for (i, v) in chunked.iter().enumerate() {
            values[i * n_columns + k] = v.unwrap_or(f64::NAN);
        }
        header.push(name);
    }
    let lines = (1..=n_rows).collect();
    Ok(ColumnTable { header: Some(header), n_columns, values, lines, decimals: Vec::new() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::registry::{build_loader, default_params};
    use motionlab_testkit::data_path;

    fn fixture(name: &str) -> std::path::PathBuf {
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(name)
    }

    fn load(path: &Path, params: &str) -> Result<motionlab_core::Motion> {
        let params: toml::Value = toml::from_str(params).unwrap();
        build_loader("channels", &params)?.load(path)
    }

    /// pyarrow's Parquet file of TSSB's ArrowHead series (written by `tests/fixtures/make.py`,
    /// snappy-compressed, float64) loads exactly the values of the series' text file.
    #[test]
    fn a_pyarrow_file_loads_the_series_text_values() {
        let text =
            build_loader("channels", &toml::from_str::<toml::Value>("rate_hz = 1.0").unwrap())
                .unwrap()
                .load(&data_path("tssb/datasets/ArrowHead.txt"))
                .unwrap();
        let parquet = load(&fixture("ArrowHead.parquet"), "rate_hz = 1.0").unwrap();
        let (a, b) = (text.channels(), parquet.channels());
        assert_eq!(b.names(), ["value"]);
        assert_eq!(a.n_samples(), b.n_samples());
        let bits =
            |c: &motionlab_core::Channels| c.channel(0).map(f64::to_bits).collect::<Vec<_>>();
        assert_eq!(bits(a), bits(b));
        assert_eq!(parquet.format, "channels");
    }

    /// The mixed-type fixture: a `time_s` column gives the rate (100 Hz), float32, int64 and
    /// nullable columns become float64 channels, nulls NaN, in the file's order.
    #[test]
    fn types_nulls_and_the_time_column() {
        let m = load(&fixture("mixed.parquet"), "").unwrap();
        assert_eq!(m.frame_rate().hz(), 100.0);
        let c = m.channels();
        assert_eq!(c.names(), ["speed_f32", "count_i64", "angle_with_nulls"]);
        assert_eq!(c.channel(0).collect::<Vec<_>>(), [0.5, 1.25, -2.0, 3.5, 0.0]);
        assert_eq!(c.channel(1).collect::<Vec<_>>(), [1.0, 2.0, 3.0, -4.0, 5.0]);
        let angle: Vec<f64> = c.channel(2).collect();
        assert_eq!((angle[0], angle[2], angle[4]), (10.0, 30.0, 50.0));
        assert!(angle[1].is_nan() && angle[3].is_nan());
        let picked =
            load(&fixture("mixed.parquet"), "columns = [\"angle_with_nulls\", \"speed_f32\"]")
                .unwrap();
        assert_eq!(picked.channels().names(), ["angle_with_nulls", "speed_f32"]);
    }

    #[test]
    fn a_text_column_is_an_error_naming_it() {
        let e = load(&fixture("with_text.parquet"), "rate_hz = 10.0").unwrap_err().to_string();
        assert!(
            e.contains("with_text.parquet")
                && e.contains("column \"label\" holds str")
                && e.contains("expected integer or floating-point"),
            "{e}"
        );
    }

    /// Unequal time steps name the row, as a text file's name the line.
    #[test]
    fn uneven_times_name_the_row() {
        let e = load(&fixture("uneven_time.parquet"), "").unwrap_err().to_string();
        assert!(
            e.contains("uneven_time.parquet:4") && e.contains("expected equally spaced"),
            "{e}"
        );
    }

    /// The decoded size is bounded before decoding: a limit below rows × columns × 8 refuses
    /// the file and names it, whatever its (compressed) size on disk.
    #[test]
    fn the_decoded_table_is_bounded_by_the_input_limit() {
        let path = fixture("mixed.parquet");
        let bytes = std::fs::read(&path).unwrap();
        let e = parse_parquet(bytes.clone(), &path, 100).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::TooLarge);
        assert!(e.to_string().contains("5 rows × 4 columns (160 bytes of float64)"), "{e}");
        assert!(parse_parquet(bytes, &path, 160).is_ok());
    }

    #[test]
    fn not_parquet_is_a_clear_error() {
        let path = Path::new("/x/a.parquet");
        let e = parse_parquet(b"PAR1 but nothing else".to_vec(), path, 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(e.contains("/x/a.parquet") && e.contains("not a readable Parquet file"), "{e}");
    }

    #[test]
    fn the_loader_lists_the_extension() {
        assert!(
            build_loader("channels", &default_params()).unwrap().extensions().contains(&"parquet")
        );
    }

    /// Truncations of a fixture at every length and 2,000 random byte mutations: each is a
    /// result (an error naming the file, or a table) — never a panic out of the parser.
    #[test]
    fn corrupt_files_are_errors_never_panics() {
        let path = fixture("mixed.parquet");
        let bytes = std::fs::read(&path).unwrap();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut mutated = |b: &mut Vec<u8>, k: usize| {
            for _ in 0..1 + k % 4 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let i = (state as usize) % b.len();
                b[i] = (state >> 32) as u8;
            }
        };
        let mut errors = 0;
        for trial in 0..bytes.len() + 2000 {
            let mut b = bytes.clone();
            if trial < bytes.len() {
                b.truncate(trial);
            } else {
                mutated(&mut b, trial);
            }
            let outcome = std::panic::catch_unwind(|| parse_parquet(b, &path, 1 << 30));
            let result = outcome.unwrap_or_else(|_| panic!("trial {trial}: the parser panicked"));
            if let Err(e) = result {
                assert!(e.to_string().contains("mixed.parquet"), "{e}");
                errors += 1;
            }
        }
        // Every truncation is an error (the footer is at the end).
        assert!(errors >= bytes.len(), "{errors}");
    }
}
