//! `motionlab convert IN OUT`: a motion file to another format, chosen by the output's
//! extension — marker or skeleton motions (joint positions) to OpenSim TRC or CSV, channel
//! motions (MOT/STO, channel files) to CSV.

use std::path::Path;

use motionlab_core::{Error, ErrorKind, LengthUnit, Result};
use motionlab_io::trc::{write_positions_csv, write_trc};

/// What `convert` wrote, for its one-line report.
pub struct Converted {
    pub frames: usize,
    pub columns: usize,
    pub what: &'static str,
}

/// Reads `input` with the loader for its extension (at its defaults) and writes `output` by
/// its extension: `.trc` (positions in `unit`), `.csv` (positions in mm, or the channels).
pub fn convert(input: &Path, output: &Path, unit: LengthUnit) -> Result<Converted> {
    let (_, loader) = crate::inspect::loader_for(input)?;
    let motion = loader.load(input).map_err(|e| e.in_file(input))?;
    let ext = motionlab_core::paths::format_extension(output).unwrap_or_default();
    let io = |e: std::io::Error| Error::io(output, e);
    let mut bytes = Vec::new();
    let converted = match ext.as_str() {
        "trc" => {
            if motion.n_points() == 0 {
                return Err(Error::new(
                    ErrorKind::Mismatch,
                    format!(
                        "{} holds channels and no marker or joint positions; TRC holds positions (write .csv instead)",
                        input.display()
                    ),
                )
                .in_file(input));
            }
            if motion.dimensionality() == motionlab_core::Dimensionality::Two {
                return Err(Error::new(
                    ErrorKind::Mismatch,
                    format!(
                        "{} holds 2-D image positions (px), and TRC holds 3-D positions in a length unit (write .csv instead)",
                        input.display()
                    ),
                )
                .in_file(input));
            }
            let name = output.file_name().and_then(|n| n.to_str()).unwrap_or("motion.trc");
            write_trc(&motion, unit, name, &mut bytes).map_err(io)?;
            Converted { frames: motion.n_frames(), columns: motion.n_points(), what: "points" }
        }
        "csv" if motion.n_points() > 0 => {
            write_positions_csv(&motion, &mut bytes).map_err(io)?;
            Converted { frames: motion.n_frames(), columns: motion.n_points(), what: "points" }
        }
        "csv" => {
            write_channels_csv(&motion, &mut bytes).map_err(io)?;
            Converted {
                frames: motion.n_frames(),
                columns: motion.channels().n_channels(),
                what: "channels",
            }
        }
        other => {
            return Err(Error::new(
                ErrorKind::UnknownKey,
                format!("cannot write .{other} files; convert writes .trc and .csv"),
            )
            .in_file(output));
        }
    };
    std::fs::write(output, bytes).map_err(io)?;
    Ok(converted)
}

/// Channels as CSV: `time_s,<channel>,…`, missing samples as empty fields.
fn write_channels_csv(
    motion: &motionlab_core::Motion,
    out: &mut impl std::io::Write,
) -> std::io::Result<()> {
    let ch = motion.channels();
    let quote = |s: &str| {
        if s.contains([',', '"', '\n']) {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s.to_string()
        }
    };
    write!(out, "time_s")?;
    for n in ch.names() {
        write!(out, ",{}", quote(n))?;
    }
    writeln!(out)?;
    let hz = motion.frame_rate().hz();
    let d = ch.n_channels();
    for s in 0..ch.n_samples() {
        write!(out, "{}", s as f64 / hz)?;
        for v in &ch.values()[s * d..(s + 1) * d] {
            if v.is_nan() { write!(out, ",")? } else { write!(out, ",{v}")? }
        }
        writeln!(out)?;
    }
    Ok(())
}
