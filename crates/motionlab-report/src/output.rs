//! The one entry point from a workflow's output to files: [`write`] takes an
//! [`Output`](motionlab_experiment::workflow::Output) — tables, figure specs, other files,
//! viewer specs — and writes it into a run directory (`tables/`, `figures/`, `files/`,
//! `viewers/`), returning what it wrote. The engine hands it every item's and every
//! combination's output and records the returned [`Written`] with the run; it never looks inside.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use motionlab_core::{Error, Result};
use motionlab_experiment::workflow::Output;

use crate::figures::render;
use crate::tables::write_table;

/// A rendered figure as the run page lists it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FigureEntry {
    pub name: String,
    pub title: String,
}

/// What [`write`] put into a run directory, paths relative to it. Serialisable, so an item's
/// record can be persisted with the item and read back by a merge of sharded runs.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Written {
    /// Every table's CSV, Parquet and Markdown file, table by table.
    pub tables: Vec<PathBuf>,
    /// Every figure's PNG and SVG file, figure by figure.
    pub figures: Vec<PathBuf>,
    /// The figures, in output order, for the run page.
    pub listing: Vec<FigureEntry>,
}

/// The written files as provenance lists them (`tables`, `figures`: paths relative to the run
/// directory), gathered from several [`Written`] in order.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FileLists {
    pub tables: Vec<String>,
    pub figures: Vec<String>,
}

impl FileLists {
    pub fn of(written: &Written) -> FileLists {
        let text = |p: &PathBuf| p.to_string_lossy().into_owned();
        FileLists {
            tables: written.tables.iter().map(text).collect(),
            figures: written.figures.iter().map(text).collect(),
        }
    }
}

impl Written {
    /// Several records as one, in the order given.
    pub fn concat<'a>(parts: impl IntoIterator<Item = &'a Written>) -> Written {
        let mut all = Written::default();
        for w in parts {
            all.tables.extend(w.tables.iter().cloned());
            all.figures.extend(w.figures.iter().cloned());
            all.listing.extend(w.listing.iter().cloned());
        }
        all
    }
}

/// Writes a workflow's output into `run_dir`: tables as CSV, Parquet and Markdown under
/// `tables/`, figures rendered to PNG and SVG under `figures/` (in parallel), other files under
/// `files/`, viewer pages under `viewers/`. `tables/` and `figures/` are created even when
/// empty (a run directory always has them); `files/` and `viewers/` only when needed. Every
/// name becomes a file name through [`motionlab_core::paths::safe_file_name`], so no name
/// from the data or the experiment writes outside these folders.
pub fn write(run_dir: &Path, out: &Output) -> Result<Written> {
    let tables_dir = subdir(run_dir, "tables")?;
    let figures_dir = subdir(run_dir, "figures")?;
    let relative = |p: PathBuf| p.strip_prefix(run_dir).map(Path::to_path_buf).unwrap_or(p);
    let mut tables = Vec::new();
    for t in &out.tables {
        let w = write_table(t, &tables_dir)?;
        tables.extend([w.csv, w.parquet, w.markdown].map(relative));
    }
    let rendered: Vec<Vec<PathBuf>> =
        out.figures.par_iter().map(|f| render(f, &figures_dir)).collect::<Result<_>>()?;
    let figures = rendered.into_iter().flatten().map(relative).collect();
    if !out.files.is_empty() {
        let dir = subdir(run_dir, "files")?;
        for (name, bytes) in &out.files {
            let path = dir.join(motionlab_core::paths::safe_file_name(name).as_ref());
            std::fs::write(&path, bytes).map_err(|e| Error::io(&path, e))?;
        }
    }
    if !out.viewers.is_empty() {
        let dir = run_dir.join("viewers");
        out.viewers
            .par_iter()
            .map(|v| crate::viewer::write(&dir, v).map(|_| ()))
            .collect::<Result<Vec<_>>>()?;
    }
    let listing = out
        .figures
        .iter()
        .map(|f| FigureEntry { name: f.name.clone(), title: f.title().to_string() })
        .collect();
    Ok(Written { tables, figures, listing })
}

fn subdir(run_dir: &Path, name: &str) -> Result<PathBuf> {
    let dir = run_dir.join(name);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::{ColumnValues, Table};
    use motionlab_figure::{Chart, Figure, Series};

    /// Every part of an output lands where the run page and provenance say, named relative to
    /// the run directory.
    #[test]
    fn an_output_is_written_and_listed() {
        let dir = std::env::temp_dir().join(format!("mlab-output-{}", std::process::id()));
        let mut t = Table::new("speeds", "Speeds");
        t.push_column("v", ColumnValues::F64(vec![1.0, 2.5])).unwrap();
        let chart = Chart {
            title: "Speed".into(),
            x_label: "frame".into(),
            y_label: "mm/s".into(),
            lines: vec![Series::new("v", vec![0.0, 1.0], vec![1.0, 2.5])],
            ..Default::default()
        };
        let out = Output {
            tables: vec![t],
            figures: vec![Figure::chart("speed", chart)],
            files: vec![("walk.bvh".into(), b"HIERARCHY".to_vec())],
            viewers: vec![],
            ..Output::default()
        };
        let w = write(&dir, &out).unwrap();
        let names =
            |v: &[PathBuf]| v.iter().map(|p| p.to_string_lossy().into_owned()).collect::<Vec<_>>();
        assert_eq!(
            names(&w.tables),
            ["tables/speeds.csv", "tables/speeds.parquet", "tables/speeds.md"]
        );
        assert_eq!(names(&w.figures), ["figures/speed.png", "figures/speed.svg"]);
        assert_eq!(w.listing.len(), 1);
        assert_eq!((w.listing[0].name.as_str(), w.listing[0].title.as_str()), ("speed", "Speed"));
        assert_eq!(
            std::fs::read_to_string(dir.join("tables/speeds.csv")).unwrap(),
            "v\n1.0\n2.5\n"
        );
        assert_eq!(std::fs::read(dir.join("files/walk.bvh")).unwrap(), b"HIERARCHY");
        assert!(dir.join("figures/speed.png").is_file() && !dir.join("viewers").exists());
        let twice = Written::concat([&w, &Written::default(), &w]);
        assert_eq!(twice.listing.len(), 2);
        let lists = FileLists::of(&twice);
        assert_eq!(
            lists.figures,
            ["figures/speed.png", "figures/speed.svg", "figures/speed.png", "figures/speed.svg"]
        );
        assert_eq!(lists.tables.len(), 6);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
