//! `motionlab export`: a segmentation run's ground truth and every method's candidates as
//! annotation files — one ELAN `.eaf` (or `boundaries_csv` file) per sequence, one tier (or
//! annotator) per method plus `truth` — to correct beside the video in ELAN and read back as
//! ground truth (`elan_eaf` with `tier = "…"`, `boundaries_csv` with `annotator = "…"`).

use std::path::{Path, PathBuf};

use motionlab_core::{Error, ErrorKind, Location, Result};
use motionlab_io::labels::boundaries_csv::write_boundaries_csv;
use motionlab_io::labels::elan_eaf::write_eaf;
use motionlab_io::labels::tiers::RunBoundaries;

/// The file formats `export` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
    /// ELAN `.eaf`: one tier per method plus `truth`, times in ms.
    Eaf,
    /// `boundaries_csv`: `sequence,frame,time_s,label,annotator`, the method (or `truth`) as annotator.
    Csv,
}

/// Writes one file per sequence of the run into `out` (default `<run_dir>/export/`); returns
/// their paths.
pub fn export(run_dir: &Path, format: ExportFormat, out: Option<&Path>) -> Result<Vec<PathBuf>> {
    let path = run_dir.join("files").join(RunBoundaries::FILE_NAME);
    let text = std::fs::read(&path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::new(
                ErrorKind::Io,
                format!("no files/{} in {}: export reads a segmentation run (its base combination) made by this version of motionlab", RunBoundaries::FILE_NAME, run_dir.display()),
            )
            .with_location(Location::file(&path))
        } else {
            Error::io(&path, e)
        }
    })?;
    let run: RunBoundaries = serde_json::from_slice(&text).map_err(|e| {
        Error::at_line(
            ErrorKind::Syntax,
            &path,
            e.line(),
            format!("not a segmentation run's boundaries: {e}"),
        )
    })?;
    if run.format != RunBoundaries::FORMAT {
        return Err(Error::new(
            ErrorKind::Mismatch,
            format!("format {:?}; expected {:?}", run.format, RunBoundaries::FORMAT),
        )
        .with_location(Location::file(&path).field("format")));
    }
    // The document's date is the run's (exporting a run twice gives the same files).
    let date = std::fs::read(run_dir.join("provenance.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| v.get("finished_utc").and_then(|d| d.as_str()).map(str::to_string))
        .unwrap_or_else(|| motionlab_engine::rundir::utc_iso(std::time::SystemTime::now()));
    let dir = out.map_or_else(|| run_dir.join("export"), Path::to_path_buf);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let mut written = Vec::with_capacity(run.sequences.len());
    for seq in &run.sequences {
        let stem = motionlab_experiment::workflow::sanitize(&seq.name);
        let (file, body) = match format {
            ExportFormat::Eaf => (dir.join(format!("{stem}.eaf")), write_eaf(seq, &date)?),
            ExportFormat::Csv => (dir.join(format!("{stem}.csv")), write_boundaries_csv(seq)),
        };
        std::fs::write(&file, body).map_err(|e| Error::io(&file, e))?;
        written.push(file);
    }
    Ok(written)
}
