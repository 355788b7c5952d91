//! The channel-file loader plugin `channels`: multichannel signals that are not marker
//! positions — a TSSB series (one value per line), the columns of a CSV or whitespace-separated
//! text, a NumPy `.npy` array, a Parquet table — loaded as a motion with [`Channels`] and no
//! points, for the segmenters that read channels.
//!
//! Parquet is read by the crate `motionlab-parquet`, which registers a [`ColumnFormat`] for it:
//! a Parquet reader means polars (or a second Arrow stack), and this crate — which every
//! algorithm crate's tests and the fuzz targets build — stays free of it. The `channels` loader
//! is one loader for every channel format all the same; in a program that does not link
//! `motionlab-parquet` a `.parquet` file is a clear error saying so.
//!
//! Written by hand rather than with the `csv` crate alone: the same loader reads one-value
//! lines, whitespace columns and CSV with or without a header, finds the rate in a time column,
//! and must name the line of every bad value; `.npy` is a 10-line header plus raw numbers
//! (the `npy` crates on crates.io target ndarray and add nothing here).

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Channels, DataKind, Error, ErrorKind, FrameRate, Loader, Motion, Result};

/// Loads a file of sampled channels — the columns of a text table or a NumPy array — as a
/// motion with channels and no marker positions, for the segmenters that read channels
/// (`clasp`, `kernel_cpd`, `bocpd`, `floss`, `window`).
///
/// Formats, by extension (`.gz` read transparently):
/// - **text** (`.txt`, `.csv`, `.tsv`, `.dat`): one sample per line; values separated by
///   commas when the first data line has one, else by tabs or spaces (a TSSB series: one value
///   per line). A first line that is not all numbers is the header: the channel names. Blank
///   lines are skipped. `NaN`, `nan`, `NA` and an empty field are missing samples.
/// - **NumPy** (`.npy`): a little-endian float64, float32, int32 or int64 array of shape
///   `(samples,)` or `(samples, channels)`, C or Fortran order.
/// - **Parquet** (`.parquet`): one channel per column, the column names as the header;
///   integer and floating-point columns (nulls are missing samples); a column of any other
///   type is an error naming it. Errors about samples name the row (1-based) in place of a line.
///
/// Channel names: the header's, else `names`, else `value` for a single column and `ch0`,
/// `ch1`, … for several. The rate: `rate_hz` when given; otherwise read from the `time_column`
/// (seconds, not a channel) as `(n - 1) / (t_last - t_first)` over its `n` times. Its steps must
/// be equal, which for printed times means equal to within their rounding: every step may
/// differ from the median step by one rounding unit `10^-k`, `k` the most decimals written in
/// the column (`0.000000, 0.008333, 0.016667` — 120 Hz rounded to microseconds — steps by
/// 0.008333 or 0.008334: equal; the unit counts at most a quarter of the step, so a dropped
/// sample never passes), or by 1e-6 of the step where that is larger (times written in full,
/// binary Parquet times). A larger difference — a dropped or repeated sample, a
/// decreasing time — is an error naming the line. A file with neither is an error. Units: as
/// the file has them (unknown to motionlab: empty).
///
/// Missing samples are kept as NaN; each segmenter says how it treats them. Errors name the
/// file and line (text, Parquet's row) or the header field (`.npy`): a row with another number of values
/// than the header, a value that is not a number, an empty file, an unsupported dtype.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ChannelFileParams {
    /// Samples per second (Hz). A series without time (TSSB) gets 1, so times in seconds are
    /// sample indices.
    #[serde(default)]
    #[schemars(extend("x-default" = "from `time_column`"))]
    pub rate_hz: Option<f64>,
    /// The header name of the column giving each sample's time in seconds; it is not a channel.
    #[serde(default = "default_time_column")]
    pub time_column: String,
    /// The channels to keep, by name, in this order.
    #[serde(default)]
    #[schemars(extend("x-default" = "every column but the time column"))]
    pub columns: Option<Vec<String>>,
    /// Names for the columns of a file without header (`.npy`, or text without one).
    #[serde(default)]
    #[schemars(extend("x-default" = "`value` for one column, `ch0`, `ch1`, … for several"))]
    pub names: Option<Vec<String>>,
}

fn default_time_column() -> String {
    "time_s".into()
}

/// The validated loader.
#[derive(Clone, Debug)]
pub struct ChannelFileLoader {
    rate: Option<FrameRate>,
    time_column: String,
    columns: Option<Vec<String>>,
    names: Option<Vec<String>>,
}

impl ParamGuard for ChannelFileParams {
    type Checked = ChannelFileLoader;
    fn check(self) -> Result<ChannelFileLoader> {
        let rate = match self.rate_hz {
            None => None,
            Some(hz) => Some(FrameRate::new(hz).map_err(|e| e.with_field("rate_hz"))?),
        };
        if self.columns.as_ref().is_some_and(Vec::is_empty) {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "lists no channel; expected at least one name",
            )
            .with_field("columns"));
        }
        if let Some(n) = &self.names {
            let mut seen = std::collections::HashSet::new();
            if let Some(d) = n.iter().find(|x| x.is_empty() || !seen.insert(x.as_str())) {
                return Err(Error::new(
                    ErrorKind::DuplicateName,
                    format!("{d:?} is empty or repeated; expected distinct names"),
                )
                .with_field("names"));
            }
        }
        Ok(ChannelFileLoader {
            rate,
            time_column: self.time_column,
            columns: self.columns,
            names: self.names,
        })
    }
}

impl Loader for ChannelFileLoader {
    fn extensions(&self) -> &'static [&'static str] {
        &["txt", "csv", "dat", "npy", "parquet"]
    }
    fn gives(&self) -> DataKind {
        DataKind::Channels
    }
    fn load(&self, path: &Path) -> Result<Motion> {
        let extension = crate::read::format_extension(path);
        let table = match extension.as_deref() {
            Some("npy") => parse_npy(&crate::read::read_bytes(path)?, path)?,
            Some(ext) if ext == "parquet" || registered_format(ext).is_some() => {
                let format = registered_format(ext).ok_or_else(|| {
                    Error::new(
                        ErrorKind::UnknownPlugin,
                        "reading Parquet needs the crate motionlab-parquet, which this program does not link (the motionlab CLI and the Python package do)",
                    )
                    .in_file(path)
                })?;
                let limit = motionlab_core::limits::max_input_bytes()?;
                (format.parse)(crate::read::read_bytes_within(path, limit)?, path, limit)?
            }
            _ => parse_text_columns(&crate::read::read_text(path)?, path)?,
        };
        self.motion(table, path)
    }
}

/// A channel-file format read by another crate (Parquet by `motionlab-parquet`), registered
/// with `motionlab_core::inventory::submit!` and chosen by the file's extension.
pub struct ColumnFormat {
    /// The file extension it reads, lowercase, without the dot (`parquet`).
    pub extension: &'static str,
    /// Parses the file's bytes (already read within the input limit) into columns; `limit` is
    /// that input limit in bytes, for a format whose content decompresses further. Errors name
    /// `origin`.
    pub parse: fn(bytes: Vec<u8>, origin: &Path, limit: u64) -> Result<ColumnTable>,
}

motionlab_core::inventory::collect!(ColumnFormat);

/// The registered format reading files with this extension, if a linked crate registers one.
pub fn registered_format(extension: &str) -> Option<&'static ColumnFormat> {
    motionlab_core::inventory::iter::<ColumnFormat>.into_iter().find(|f| f.extension == extension)
}

motionlab_core::register_plugin!(Loader, ChannelFileParams, "channels");

/// Columns as read: names when the file has a header, sample-major values, and for text the
/// line of each sample (Parquet: its row, 1-based), for errors about the time column.
#[derive(Debug)]
pub struct ColumnTable {
    pub header: Option<Vec<String>>,
    pub n_columns: usize,
    /// Sample-major: `values[sample * n_columns + column]`; NaN is a missing sample.
    pub values: Vec<f64>,
    pub lines: Vec<usize>,
    /// Text only: per column, the most decimals any of its values is written with (the
    /// rounding unit of printed times, `10^-k`); empty for binary formats.
    pub decimals: Vec<u32>,
}

impl ChannelFileLoader {
    fn motion(&self, table: ColumnTable, path: &Path) -> Result<Motion> {
        let d = table.n_columns;
        let names: Vec<String> = match (&table.header, &self.names) {
            (Some(h), _) => h.clone(),
            (None, Some(n)) if n.len() == d => n.clone(),
            (None, Some(n)) => {
                return Err(Error::new(
                    ErrorKind::WrongValueCount,
                    format!("names lists {} names for {d} columns", n.len()),
                )
                .in_file(path)
                .with_field("names"));
            }
            (None, None) if d == 1 => vec!["value".into()],
            (None, None) => (0..d).map(|k| format!("ch{k}")).collect(),
        };
        let all = Channels::new(names, vec![String::new(); d], table.values)
            .map_err(|e| e.in_file(path))?;
        let time = all.names().iter().position(|n| *n == self.time_column);
        let rate = match (self.rate, time) {
            (Some(r), _) => r,
            (None, Some(k)) => {
                let decimals = table.decimals.get(k).copied();
                rate_from_times(&all.channel(k).collect::<Vec<_>>(), decimals, &table.lines, path)?
            }
            (None, None) => {
                return Err(Error::new(
                    ErrorKind::MissingKey,
                    format!("no rate: the file has no {:?} column; give the loader `rate_hz` (samples per second)", self.time_column),
                )
                .in_file(path)
                .with_field("rate_hz"));
            }
        };
        let keep: Vec<String> = match &self.columns {
            Some(c) => c.clone(),
            None => all
                .names()
                .iter()
                .enumerate()
                .filter(|(k, _)| Some(*k) != time)
                .map(|(_, n)| n.clone())
                .collect(),
        };
        if keep.is_empty() {
            return Err(Error::new(
                ErrorKind::EmptySequence,
                format!("no channel besides the time column {:?}", self.time_column),
            )
            .in_file(path));
        }
        let channels = all.select(&keep).map_err(|e| e.in_file(path).with_field("columns"))?;
        if channels.n_samples() == 0 {
            return Err(Error::new(ErrorKind::EmptySequence, "no samples").in_file(path));
        }
        let name = motionlab_core::paths::stem(path);
        Ok(Motion::from_channels(name, rate, channels)?.with_source(path, "channels"))
    }
}

/// The rate of equally spaced times (seconds) written with at most `decimals` decimals (none:
/// binary): `(n - 1) / (t_last - t_first)`. Printed times are multiples of the rounding unit
/// `10^-decimals`, and so are their steps; a true step rounds to two neighbouring multiples
/// (0.008333 or 0.008334 for 1/120 s), so every step may differ from the median step by one
/// unit (never by more than a quarter of the step), or by 1e-6 of the step where larger. A
/// larger difference is an error naming the line.
fn rate_from_times(
    times: &[f64],
    decimals: Option<u32>,
    lines: &[usize],
    path: &Path,
) -> Result<FrameRate> {
    if times.len() < 2 {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "a time column of fewer than 2 samples gives no rate; give `rate_hz`",
        )
        .in_file(path));
    }
    let n = times.len();
    let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    // The median step: a dropped sample or a stray time cannot move it, as it would the mean.
    let mut sorted = steps.clone();
    sorted.sort_unstable_by(f64::total_cmp);
    // The lower median: of two steps, the smaller (a dropped sample makes a step larger).
    let median = sorted[(sorted.len() - 1) / 2];
    let unit = decimals.map_or(0.0, |k| 10f64.powi(-(k.min(300) as i32)));
    // Steps are whole units apart: half a unit more than one absorbs the float error of the
    // subtraction; capped at a quarter step, so coarse rounding never lets a double step pass.
    let rounding = (1.5 * unit).min(median.abs() / 4.0);
    let float_error = 4.0 * f64::EPSILON * times[0].abs().max(times[n - 1].abs());
    let tolerance = rounding.max(1e-6 * median.abs()) + float_error;
    for (i, d) in steps.drain(..).enumerate() {
        if !(d.is_finite() && d > 0.0 && (d - median).abs() <= tolerance) {
            let line = lines.get(i + 1).copied().unwrap_or(0);
            let allowed = match decimals {
                Some(k) => format!("one rounding unit of the {k} decimals written, {unit:e} s"),
                None => "1e-6 of it".to_string(),
            };
            return Err(Error::at_line(
                ErrorKind::OutOfRange,
                path,
                line,
                format!(
                    "time step {d} s after {} s; expected equally spaced, increasing times (the median step is {median} s; a step may differ from it by {allowed})",
                    times[i]
                ),
            ));
        }
    }
    let span = times[n - 1] - times[0];
    FrameRate::new((n - 1) as f64 / span).map_err(|e| e.in_file(path))
}

/// The decimals a number is written with: digits after the point, less a written exponent
/// (`0.008333` → 6, `8.333e-3` → 6, `12` → 0).
fn written_decimals(field: &str) -> u32 {
    let (mantissa, exponent) = match field.find(['e', 'E']) {
        Some(at) => (&field[..at], field[at + 1..].parse::<i64>().unwrap_or(0)),
        None => (field, 0),
    };
    let after_point = mantissa.find('.').map_or(0, |at| mantissa.len() - at - 1) as i64;
    (after_point - exponent).clamp(0, 400) as u32
}

/// A value of a text table: a number, or missing.
fn parse_value(field: &str) -> Option<f64> {
    match field {
        "" | "NaN" | "nan" | "NAN" | "NA" => Some(f64::NAN),
        f => fast_float2::parse::<f64, _>(f).ok().filter(|v: &f64| v.is_finite()),
    }
}

/// Parses a text table (see [`ChannelFileParams`] for the format).
pub fn parse_text_columns(text: &str, origin: &Path) -> Result<ColumnTable> {
    let mut lines = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r').trim()))
        .filter(|(_, l)| !l.is_empty());
    let Some((first_no, first)) = lines.next() else {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            1,
            "no samples; expected one sample per line",
        ));
    };
    let comma = first.contains(',');
    let split = move |l: &'_ str| -> Vec<String> {
        if comma {
            l.split(',').map(|f| f.trim().to_string()).collect()
        } else {
            l.split_ascii_whitespace().map(str::to_string).collect()
        }
    };
    let first_fields = split(first);
    let is_header = first_fields.iter().any(|f| parse_value(f).is_none());
    let n_columns = first_fields.len();
    let mut table = ColumnTable {
        header: None,
        n_columns,
        values: Vec::new(),
        lines: Vec::new(),
        decimals: vec![0; n_columns],
    };
    let push_row = |line: usize, fields: Vec<String>, table: &mut ColumnTable| -> Result<()> {
        if fields.len() != n_columns {
            return Err(Error::at_line(
                ErrorKind::WrongValueCount,
                origin,
                line,
                format!("found {} values, expected {n_columns} (one per column)", fields.len()),
            ));
        }
        for (k, f) in fields.iter().enumerate() {
            let v = parse_value(f).ok_or_else(|| {
                Error::at_line(
                    ErrorKind::Syntax,
                    origin,
                    line,
                    format!("column {}: {f:?} is not a number", k + 1),
                )
            })?;
            table.values.push(v);
            if v.is_finite() {
                table.decimals[k] = table.decimals[k].max(written_decimals(f));
            }
        }
        table.lines.push(line);
        Ok(())
    };
    if is_header {
        let mut seen = std::collections::HashSet::new();
        if let Some(d) = first_fields.iter().find(|f| f.is_empty() || !seen.insert(f.as_str())) {
            return Err(Error::at_line(
                ErrorKind::DuplicateName,
                origin,
                first_no,
                format!("header name {d:?} is empty or repeated"),
            ));
        }
        table.header = Some(first_fields);
    } else {
        push_row(first_no, first_fields, &mut table)?;
    }
    for (no, l) in lines {
        push_row(no, split(l), &mut table)?;
    }
    if table.lines.is_empty() {
        return Err(Error::at_line(
            ErrorKind::EmptySequence,
            origin,
            first_no,
            "a header and no samples",
        ));
    }
    Ok(table)
}

/// Parses a NumPy `.npy` array (format versions 1–3) of one or two dimensions.
pub fn parse_npy(bytes: &[u8], origin: &Path) -> Result<ColumnTable> {
    let bad = |field: &str, msg: String| {
        Error::new(ErrorKind::Syntax, msg).in_file(origin).with_field(field.to_string())
    };
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad("magic", "not a NumPy .npy file (no \\x93NUMPY magic)".into()));
    }
    let (header_len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => {
            (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12)
        }
        v => return Err(bad("version", format!("format version {v}; expected 1, 2 or 3"))),
    };
    let header = bytes
        .get(start..start + header_len)
        .ok_or_else(|| bad("header", "the header is cut short".into()))?;
    let header =
        std::str::from_utf8(header).map_err(|_| bad("header", "the header is not text".into()))?;
    let value_of = |key: &str| -> Result<&str> {
        let at = header
            .find(&format!("'{key}'"))
            .ok_or_else(|| bad(key, format!("the header has no '{key}'")))?;
        let rest = header[at + key.len() + 2..]
            .trim_start()
            .strip_prefix(':')
            .ok_or_else(|| bad(key, format!("'{key}' has no value")))?;
        Ok(rest.trim_start())
    };
    let descr = value_of("descr")?;
    let descr = descr.get(1..).and_then(|d| d.split('\'').next()).unwrap_or_default();
    let (width, kind) = match descr {
        "<f8" | "=f8" => (8, 'f'),
        "<f4" | "=f4" => (4, 'f'),
        "<i8" | "=i8" => (8, 'i'),
        "<i4" | "=i4" => (4, 'i'),
        other => {
            return Err(bad(
                "descr",
                format!("dtype {other:?}; expected little-endian float64, float32, int64 or int32"),
            ));
        }
    };
    let fortran = value_of("fortran_order")?.starts_with("True");
    let shape_text = value_of("shape")?;
    let shape_text = shape_text
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| bad("shape", "the shape is not a tuple".into()))?;
    let shape: Vec<usize> = shape_text
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>().map_err(|_| bad("shape", format!("{s:?} is not a dimension"))))
        .collect::<Result<_>>()?;
    let (n, d) = match shape.as_slice() {
        [n] => (*n, 1),
        [n, d] => (*n, *d),
        _ => {
            return Err(bad(
                "shape",
                format!("shape {shape:?}; expected (samples,) or (samples, channels)"),
            ));
        }
    };
    let data = &bytes[start + header_len..];
    let count = n.checked_mul(d).ok_or_else(|| bad("shape", "the shape overflows".into()))?;
    if data.len() != count.saturating_mul(width) {
        return Err(Error::new(
            ErrorKind::Truncated,
            format!(
                "{} data bytes for shape ({n}, {d}) of {width}-byte values; expected {}",
                data.len(),
                count * width
            ),
        )
        .in_file(origin));
    }
    let raw: Vec<f64> = data
        .chunks_exact(width)
        .map(|c| match (kind, width) {
            ('f', 8) => f64::from_le_bytes(c.try_into().unwrap_or([0; 8])),
            ('f', _) => f32::from_le_bytes(c.try_into().unwrap_or([0; 4])) as f64,
            (_, 8) => i64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f64,
            _ => i32::from_le_bytes(c.try_into().unwrap_or([0; 4])) as f64,
        })
        .collect();
    // Fortran order stores channel-major: transpose to sample-major.
    let values = if fortran && d > 1 {
        (0..n).flat_map(|s| (0..d).map(move |k| (s, k))).map(|(s, k)| raw[k * n + s]).collect()
    } else {
        raw
    };
    if n == 0 || d == 0 {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!("the array has shape ({n}, {d}): no samples"),
        )
        .in_file(origin));
    }
    Ok(ColumnTable {
        header: None,
        n_columns: d,
        values,
        lines: (1..=n).collect(),
        decimals: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(params: &str, name: &str, bytes: &[u8]) -> Result<Motion> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let p: ChannelFileParams = motionlab_core::registry::parse_params(
            &toml::from_str::<toml::Value>(params).unwrap(),
        )?;
        p.check()?.load(&path)
    }

    #[test]
    fn a_tssb_series_is_one_channel_at_the_declared_rate() {
        let m = load("rate_hz = 1.0", "Adiac.txt", b"1.5\n-2\n\n3e1\n").unwrap();
        assert_eq!((m.n_frames(), m.n_points()), (3, 0));
        assert_eq!(m.channels().names(), ["value"]);
        assert_eq!(m.channels().values(), &[1.5, -2.0, 30.0]);
        assert_eq!(m.frame_rate().hz(), 1.0);
        assert_eq!(m.name, "Adiac");
        // The shipped TSSB file reads whole.
        let m = ChannelFileParams {
            rate_hz: Some(1.0),
            time_column: default_time_column(),
            columns: None,
            names: None,
        }
        .check()
        .unwrap()
        .load(&motionlab_testkit::data_path("tssb/datasets/ArrowHead.txt"))
        .unwrap();
        assert_eq!(m.n_frames(), 1506);
    }

    #[test]
    fn csv_with_a_time_column_gives_the_rate_and_the_header_names() {
        let csv = "time_s,lhand,rfoot\n0.00,1,2\n0.01,3,\n0.02,5,NaN\n";
        let m = load("", "take.csv", csv.as_bytes()).unwrap();
        assert_eq!(m.channels().names(), ["lhand", "rfoot"]);
        assert!((m.frame_rate().hz() - 100.0).abs() < 1e-9);
        assert_eq!(m.channels().missing_count(), 2);
        let m = load("columns = [\"rfoot\"]", "take.csv", csv.as_bytes()).unwrap();
        assert_eq!(m.channels().names(), ["rfoot"]);
        // Whitespace columns without a header: ch0, ch1.
        let m = load("rate_hz = 50.0", "x.dat", b"1 2\n3\t4\n").unwrap();
        assert_eq!(m.channels().names(), ["ch0", "ch1"]);
        assert_eq!(m.channels().values(), &[1.0, 2.0, 3.0, 4.0]);
    }

    /// Times rounded to microseconds (120 Hz: 0.008333, 0.016667, … steps of 0.008333 or
    /// 0.008334) are equally spaced; the rate is (n - 1) / (t_last - t_first). A time off by
    /// three rounding units, or a dropped sample, is refused naming its line.
    #[test]
    fn times_rounded_to_their_printed_decimals_are_equally_spaced() {
        let csv = |times: &[String]| {
            let mut s = "time_s,a,b,c,d\n".to_string();
            for (i, t) in times.iter().enumerate() {
                s += &format!("{t},{i},1,2,3\n");
            }
            s
        };
        let times: Vec<String> = (0..1000).map(|i| format!("{:.6}", i as f64 / 120.0)).collect();
        assert_eq!((&times[1][..], &times[2][..]), ("0.008333", "0.016667"));
        let m = load("", "limbs.csv", csv(&times).as_bytes()).unwrap();
        assert_eq!(m.n_frames(), 1000);
        assert_eq!(m.channels().names(), ["a", "b", "c", "d"]);
        // t_last is written 8.325000: exactly 999/120.
        assert!((m.frame_rate().hz() - 120.0).abs() < 1e-9, "{}", m.frame_rate().hz());
        // The same at 3 decimals with 100 Hz: steps of exactly 0.010.
        let times3: Vec<String> = (0..50).map(|i| format!("{:.3}", i as f64 / 100.0)).collect();
        let m = load("", "x.csv", csv(&times3).as_bytes()).unwrap();
        assert!((m.frame_rate().hz() - 100.0).abs() < 1e-9);
        // One time off by three units: refused at its line (the header is line 1).
        let mut off = times.clone();
        off[49] = format!("{:.6}", 49.0 / 120.0 + 3e-6);
        let e = load("", "off.csv", csv(&off).as_bytes()).unwrap_err().to_string();
        assert!(e.contains("off.csv:51") && e.contains("the 6 decimals written"), "{e}");
        // A dropped sample: a double step.
        let mut dropped = times.clone();
        dropped.remove(500);
        let e = load("", "drop.csv", csv(&dropped).as_bytes()).unwrap_err().to_string();
        assert!(e.contains("drop.csv:502") && e.contains("equally spaced"), "{e}");
        // Coarse rounding never hides a dropped sample: integer seconds, one missing.
        let e = load("", "int.csv", b"time_s,a\n0,1\n1,2\n2,3\n4,4\n").unwrap_err();
        assert!(e.to_string().contains("int.csv:5"), "{e}");
        assert_eq!(written_decimals("0.008333"), 6);
        assert_eq!(written_decimals("8.333e-3"), 6);
        assert_eq!(written_decimals("8.333E+1"), 2);
        assert_eq!(written_decimals("12"), 0);
    }

    #[test]
    fn npy_arrays_in_either_order_and_dtype() {
        fn npy(descr: &str, fortran: bool, shape: &str, data: &[u8]) -> Vec<u8> {
            let mut h = format!(
                "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
                if fortran { "True" } else { "False" }
            );
            while (10 + h.len() + 1) % 64 != 0 {
                h.push(' ');
            }
            h.push('\n');
            let mut b = b"\x93NUMPY\x01\x00".to_vec();
            b.extend((h.len() as u16).to_le_bytes());
            b.extend(h.as_bytes());
            b.extend(data);
            b
        }
        let f8: Vec<u8> =
            [1.0f64, 2.0, 3.0, 4.0, 5.0, 6.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        let c = load("rate_hz = 10.0", "a.npy", &npy("<f8", false, "(3, 2)", &f8)).unwrap();
        assert_eq!(c.channels().values(), &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let f = load("rate_hz = 10.0", "a.npy", &npy("<f8", true, "(3, 2)", &f8)).unwrap();
        assert_eq!(
            f.channels().values(),
            &[1.0, 4.0, 2.0, 5.0, 3.0, 6.0],
            "Fortran order is channel-major"
        );
        let i4: Vec<u8> = [7i32, -8].iter().flat_map(|v| v.to_le_bytes()).collect();
        let m = load("rate_hz = 10.0\nnames = [\"x\"]", "b.npy", &npy("<i4", false, "(2,)", &i4))
            .unwrap();
        assert_eq!(
            (m.channels().names(), m.channels().values()),
            (&["x".to_string()][..], &[7.0, -8.0][..])
        );
        let e = load("rate_hz = 10.0", "c.npy", &npy(">f8", false, "(3, 2)", &f8)).unwrap_err();
        assert!(e.to_string().contains("descr") && e.to_string().contains("c.npy"), "{e}");
        let e = load("rate_hz = 10.0", "c.npy", &npy("<f8", false, "(4, 2)", &f8)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Truncated);
    }

    #[test]
    fn bad_files_are_one_error_naming_the_line() {
        let e = load("rate_hz = 1.0", "s.txt", b"1\n2\nx\n").unwrap_err();
        assert!(e.to_string().contains("s.txt:3") && e.to_string().contains("\"x\""), "{e}");
        let e = load("rate_hz = 1.0", "s.csv", b"a,b\n1,2\n3\n").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::WrongValueCount);
        assert!(e.to_string().contains("s.csv:3"), "{e}");
        let e = load("", "s.csv", b"a,b\n1,2\n").unwrap_err();
        assert!(e.to_string().contains("rate_hz"), "{e}");
        let e = load("", "t.csv", b"time_s,a\n0,1\n0.1,2\n0.3,3\n").unwrap_err();
        assert!(
            e.to_string().contains("t.csv:4") && e.to_string().contains("equally spaced"),
            "{e}"
        );
        assert_eq!(
            load("rate_hz = 1.0", "e.txt", b"\n\n").unwrap_err().kind(),
            ErrorKind::EmptySequence
        );
        assert_eq!(
            load("rate_hz = 1.0", "h.csv", b"a,b\n").unwrap_err().kind(),
            ErrorKind::EmptySequence
        );
        assert_eq!(
            load("rate_hz = 0.0", "h.csv", b"1\n").unwrap_err().kind(),
            ErrorKind::OutOfRange
        );
        let e = load("rate_hz = 1.0\ncolumns = [\"c\"]", "h.csv", b"a,b\n1,2\n").unwrap_err();
        assert!(e.to_string().contains("no channel named \"c\""), "{e}");
    }
}
