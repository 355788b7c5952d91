//! Assembling the HTML pages: each run's `index.html`, a run of record, and the reproduction
//! index `reports/index.html` (every experiment, its latest run, headline numbers, and the
//! papers' published numbers beside ours, read from the experiment files' `[[published]]`
//! tables).

use std::path::{Path, PathBuf};

use motionlab_core::paths::safe_file_name;
use motionlab_core::{ColumnValues, Error, ErrorKind, Result, Table};

use crate::html::{
    HtmlFigure, HtmlTable, IndexEntry, RunPage, ceiling_bars, compare_published, viewer_links,
    write_index, write_run_page,
};
use crate::output::{FigureEntry, Written};
use motionlab_experiment::spec::{ExperimentFile, Headline};

/// Writes a finished run's page: `<run_dir>/index.html` from its tables, the figures of
/// `outputs` (in that order; also saved as `figures/index.json`, which a run of record reads)
/// and the provenance already in `run_dir`. `config_toml` is the resolved experiment shown on
/// the page.
pub fn write_run_html(
    run_dir: &Path,
    file: &ExperimentFile,
    config_toml: &str,
    tables: &[Table],
    outputs: &[&Written],
    run_id: &str,
) -> Result<PathBuf> {
    let listing: Vec<FigureEntry> =
        outputs.iter().flat_map(|w| w.listing.iter().cloned()).collect();
    let index = run_dir.join("figures").join("index.json");
    let json = serde_json::to_vec_pretty(&listing)
        .map_err(|e| Error::new(ErrorKind::Report, format!("cannot write JSON: {e}")))?;
    std::fs::write(&index, json).map_err(|e| Error::io(&index, e))?;
    write_page(run_dir, file, config_toml, tables, &listing, run_id, false)
}

fn write_page(
    run_dir: &Path,
    file: &ExperimentFile,
    config_toml: &str,
    tables: &[Table],
    figures: &[FigureEntry],
    run_id: &str,
    png_only: bool,
) -> Result<PathBuf> {
    let prov: serde_json::Value = std::fs::read(run_dir.join("provenance.json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or(serde_json::Value::Null);
    let mut provenance = Vec::new();
    let mut inputs = Vec::new();
    let mut external_commands = Vec::new();
    if let serde_json::Value::Object(m) = &prov {
        for (k, v) in m {
            match (k.as_str(), v) {
                // Listed in a section of their own, escaped like every other text.
                ("external_commands", serde_json::Value::Array(a)) => {
                    for c in a {
                        let text = |key: &str| {
                            c.get(key).and_then(|x| x.as_str()).unwrap_or_default().to_string()
                        };
                        let args: Vec<String> = c
                            .get("command")
                            .and_then(|x| x.as_array())
                            .map(|a| {
                                a.iter()
                                    .map(|x| {
                                        x.as_str()
                                            .map(str::to_string)
                                            .unwrap_or_else(|| x.to_string())
                                    })
                                    .collect()
                            })
                            .unwrap_or_default();
                        external_commands.push((
                            text("at"),
                            text("plugin"),
                            motionlab_core::programs::command_line(&args),
                        ));
                    }
                }
                ("inputs", serde_json::Value::Array(a)) => {
                    for f in a {
                        let g = |key: &str| {
                            f.get(key)
                                .map(|x| {
                                    x.as_str().map(str::to_string).unwrap_or_else(|| x.to_string())
                                })
                                .unwrap_or_default()
                        };
                        inputs.push((g("path"), g("bytes"), g("sha256")));
                    }
                }
                ("tables" | "figures", _) => {}
                // The per-input record is for provenance.json; the page shows where and how much.
                ("cache", serde_json::Value::Object(c)) => {
                    let dir = c.get("dir").and_then(|d| d.as_str()).unwrap_or("none (--no-cache)");
                    provenance.push((
                        k.clone(),
                        format!(
                            "{dir}; stages {}",
                            c.get("totals").map(|t| t.to_string()).unwrap_or_default()
                        ),
                    ))
                }
                (_, serde_json::Value::Array(a)) => provenance.push((
                    k.clone(),
                    a.iter()
                        .map(|x| x.as_str().map(str::to_string).unwrap_or_else(|| x.to_string()))
                        .collect::<Vec<_>>()
                        .join(" "),
                )),
                (_, serde_json::Value::String(s)) => provenance.push((k.clone(), s.clone())),
                (_, other) => provenance.push((k.clone(), other.to_string())),
            }
        }
    }
    let html_tables =
        tables.iter().map(|t| HtmlTable::from_table(t, "tables/")).collect::<Result<Vec<_>>>()?;
    let html_figures = figures
        .iter()
        .map(|f| {
            let file = safe_file_name(&f.name);
            HtmlFigure {
                name: f.name.clone(),
                title: f.title.clone(),
                svg: format!("figures/{file}.{}", if png_only { "png" } else { "svg" }),
                png: format!("figures/{file}.png"),
            }
        })
        .collect();
    let comparisons = file
        .published
        .iter()
        .map(|p| {
            compare_published(
                &p.table,
                &p.source,
                &p.note,
                &p.rows,
                tables.iter().find(|t| t.name == p.table),
            )
        })
        .collect();
    let page = RunPage {
        experiment: file.experiment.name.clone(),
        description: file.experiment.description.clone(),
        paper: file.experiment.paper.clone().unwrap_or_default(),
        run_id: run_id.to_string(),
        config_toml: config_toml.to_string(),
        provenance,
        inputs,
        tables: html_tables
            .into_iter()
            .map(|mut t| {
                if png_only {
                    // The record keeps CSV and Markdown, not Parquet.
                    t.parquet = None;
                }
                t
            })
            .collect(),
        figures: html_figures,
        comparisons,
        index_link: "../../index.html".into(),
        screenshot: None,
        // Whatever viewer pages the run wrote (`viewers/<sequence>.html`).
        viewers: viewer_links(run_dir, ""),
        ceiling: tables.iter().flat_map(ceiling_bars).collect(),
        external_commands,
    };
    write_run_page(run_dir, &page)
}

/// `*`-wildcard match of a whole name.
fn wildcard(pattern: &str, name: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == name;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !name.starts_with(first) || !name.ends_with(last) || name.len() < first.len() + last.len() {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for mid in &parts[1..parts.len() - 1] {
        match rest.find(mid) {
            Some(i) => rest = &rest[i + mid.len()..],
            None => return false,
        }
    }
    true
}

/// Writes the run of record `dest` from a finished run: the tables (CSV and Markdown; all, or
/// those `record_tables` names), the figures the experiment lists in `record_figures` (PNG), the
/// provenance and configuration, and a page of its own. `dest` is replaced: the record is a deliberate, committed copy.
pub fn write_record(run: &Path, dest: &Path, file: &ExperimentFile) -> Result<()> {
    let io = |p: &Path, e| motionlab_core::Error::io(p, e);
    if dest.exists() {
        std::fs::remove_dir_all(dest).map_err(|e| io(dest, e))?;
    }
    let tables_dir = dest.join("tables");
    let figures_dir = dest.join("figures");
    std::fs::create_dir_all(&tables_dir).map_err(|e| io(&tables_dir, e))?;
    std::fs::create_dir_all(&figures_dir).map_err(|e| io(&figures_dir, e))?;
    let mut tables = Vec::new();
    let mut names: Vec<PathBuf> = std::fs::read_dir(run.join("tables"))
        .map_err(|e| io(&run.join("tables"), e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    names.sort();
    let stem_of =
        |p: &Path| p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    // A pattern that keeps no table is a typo; dropping tables silently would hide it.
    if let Some(patterns) = &file.experiment.record_tables {
        let stems: Vec<String> = names.iter().map(|p| stem_of(p)).collect();
        if let Some(p) = patterns.iter().find(|p| !stems.iter().any(|s| wildcard(p, s))) {
            return Err(motionlab_core::Error::new(
                motionlab_core::ErrorKind::UnknownName,
                format!(
                    "record_tables pattern {p:?} matches no table of the run; its tables are: {}",
                    stems.join(", ")
                ),
            )
            .with_field("experiment.record_tables"));
        }
    }
    for csv in names {
        let stem = stem_of(&csv);
        if let Some(patterns) = &file.experiment.record_tables
            && !patterns.iter().any(|p| wildcard(p, &stem))
        {
            continue;
        }
        for ext in ["csv", "md"] {
            let from = run.join("tables").join(format!("{stem}.{ext}"));
            std::fs::copy(&from, tables_dir.join(format!("{stem}.{ext}")))
                .map_err(|e| io(&from, e))?;
        }
        if let Some(mut t) = read_table_csv(&csv, &stem) {
            // The Markdown's heading is the table's title.
            if let Ok(md) = std::fs::read_to_string(run.join("tables").join(format!("{stem}.md"))) {
                t.title = md.lines().next().unwrap_or("").trim_start_matches("### ").to_string();
            }
            tables.push(t);
        }
    }
    let entries: Vec<FigureEntry> = std::fs::read(run.join("figures").join("index.json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    let kept: Vec<FigureEntry> = entries
        .into_iter()
        .filter(|f| file.experiment.record_figures.iter().any(|p| wildcard(p, &f.name)))
        .collect();
    for f in &kept {
        let file = format!("{}.png", safe_file_name(&f.name));
        let from = run.join("figures").join(&file);
        std::fs::copy(&from, figures_dir.join(&file)).map_err(|e| io(&from, e))?;
    }
    for name in ["provenance.json", "config.toml"] {
        let from = run.join(name);
        if from.is_file() {
            std::fs::copy(&from, dest.join(name)).map_err(|e| io(&from, e))?;
        }
    }
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap_or_default();
    let run_id = format!(
        "record of {}",
        run.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
    );
    write_page(dest, file, &config, &tables, &kept, &run_id, true)?;
    Ok(())
}

/// Reads a result table back from a run's CSV (for the index and `compare`).
pub fn read_table_csv(path: &Path, name: &str) -> Option<Table> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines();
    let header = split_csv_line(lines.next()?);
    let rows: Vec<Vec<String>> = lines.map(split_csv_line).collect();
    let mut t = Table::new(name, name);
    for (c, h) in header.iter().enumerate() {
        let cells: Vec<&str> =
            rows.iter().map(|r| r.get(c).map(String::as_str).unwrap_or("")).collect();
        let nums: Option<Vec<f64>> = cells
            .iter()
            .map(|s| if s.is_empty() { Some(f64::NAN) } else { s.parse::<f64>().ok() })
            .collect();
        let values = match nums {
            Some(v) if cells.iter().any(|s| !s.is_empty()) => ColumnValues::F64(v),
            _ => ColumnValues::Str(cells.iter().map(|s| Some(s.to_string())).collect()),
        };
        t.push_column(h.clone(), values).ok()?;
    }
    Some(t)
}

/// Splits one CSV line (RFC 4180 quoting, as Polars writes it).
fn split_csv_line(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            (c, _) => cur.push(c),
        }
    }
    out.push(cur);
    out
}

/// The value of one headline cell in a run.
fn headline_value(run: &Path, h: &Headline) -> Option<String> {
    let t = read_table_csv(
        &run.join("tables").join(format!("{}.csv", safe_file_name(&h.table))),
        &h.table,
    )?;
    let row = (0..t.n_rows())
        .find(|&r| h.filter.iter().all(|(k, v)| t.column(k).is_some_and(|c| c.cell(r) == *v)))?;
    Some(match t.column(&h.column)? {
        ColumnValues::F64(v) => motionlab_core::table::fmt_num(v[row]),
        other => other.cell(row),
    })
}

/// Rebuilds `reports/index.html` from the experiment files and the runs under `reports/`: each
/// experiment links its latest run, or — with `prefer_record`, or when it never ran here — its
/// committed run of record (`reports/<name>/record/`), so the committed index works on a fresh
/// clone.
pub fn write_reproduction_index(
    experiments_dir: &Path,
    reports: &Path,
    prefer_record: bool,
) -> Result<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(experiments_dir)
        .map_err(|e| motionlab_core::Error::io(experiments_dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let mut entries = Vec::new();
    for f in files {
        // Bounded like any experiment file: the folder may hold one from someone else.
        let Ok(motionlab_experiment::Source { text, .. }) = motionlab_experiment::Source::read(&f)
        else {
            continue;
        };
        // Only the fixed part of the schema: the workflow section is the workflow's own.
        let Ok(doc) = toml::from_str::<toml::Table>(&text) else { continue };
        let Ok(file) =
            toml::Value::Table(ExperimentFile::fixed_part(&doc)).try_into::<ExperimentFile>()
        else {
            continue;
        };
        let exp_dir = reports.join(&file.experiment.name);
        let latest = std::fs::read_to_string(exp_dir.join("latest"))
            .ok()
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty());
        // Fall back to the committed run of record when nothing ran on this machine.
        let record = Some(exp_dir.join("record")).filter(|p| p.is_dir());
        let latest_run = latest.clone().map(|l| exp_dir.join(l)).filter(|p| p.is_dir());
        let run = if prefer_record { record.or(latest_run) } else { latest_run.or(record) };
        let runs = std::fs::read_dir(&exp_dir)
            .map(|r| {
                // Runs made on this machine: not hidden (in-progress) folders, not the record.
                r.filter_map(|e| e.ok())
                    .filter(|e| {
                        e.path().is_dir()
                            && !e.file_name().to_string_lossy().starts_with('.')
                            && e.file_name() != "record"
                    })
                    .count()
            })
            .unwrap_or(0);
        let viewers = run.as_ref().map(|r| {
            let id = r.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            viewer_links(r, &format!("{}/{id}/", file.experiment.name))
        });
        let ceiling = run
            .as_ref()
            .and_then(|r| {
                read_table_csv(&r.join("tables").join("human_ceiling.csv"), "human_ceiling")
            })
            .map(|t| ceiling_bars(&t))
            .unwrap_or_default();
        let (latest_link, latest_id, finished_utc, headline, comparisons) = match &run {
            Some(run) => {
                let id =
                    run.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                let finished = std::fs::read(run.join("provenance.json"))
                    .ok()
                    .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
                    .and_then(|v| {
                        v.get("finished_utc").and_then(|x| x.as_str()).map(str::to_string)
                    })
                    .unwrap_or_default();
                let headline = file
                    .experiment
                    .headline
                    .iter()
                    .filter_map(|h| Some((h.label.clone(), headline_value(run, h)?)))
                    .collect();
                let comparisons = file
                    .published
                    .iter()
                    .map(|p| {
                        let ours = read_table_csv(
                            &run.join("tables").join(format!("{}.csv", safe_file_name(&p.table))),
                            &p.table,
                        );
                        compare_published(&p.table, &p.source, &p.note, &p.rows, ours.as_ref())
                    })
                    .collect();
                (
                    format!("{}/{id}/index.html", file.experiment.name),
                    id,
                    finished,
                    headline,
                    comparisons,
                )
            }
            None => (String::new(), String::new(), String::new(), Vec::new(), Vec::new()),
        };
        entries.push(IndexEntry {
            name: file.experiment.name.clone(),
            description: file.experiment.description.clone(),
            paper: file.experiment.paper.clone().unwrap_or_default(),
            latest_link,
            latest_id,
            finished_utc,
            runs,
            headline,
            comparisons,
            viewers: viewers.unwrap_or_default(),
            ceiling,
        });
    }
    write_index(reports, &entries, None)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: the index parsed whole experiment files as `ExperimentFile`, which rejects
    /// the workflow section since workflows own their sections, and so listed nothing.
    #[test]
    fn the_index_lists_experiments_with_a_workflow_section() {
        let root = std::env::temp_dir().join(format!("mlab-index-{}", std::process::id()));
        let (experiments, reports) = (root.join("experiments"), root.join("reports"));
        std::fs::create_dir_all(&experiments).unwrap();
        std::fs::create_dir_all(&reports).unwrap();
        let toml = "[experiment]\nname = \"listed_here\"\n\n[[dataset]]\nfiles = [\"x.bvh\"]\nloader = { type = \"bvh\" }\n\n[features]\nextractors = [{ type = \"marker_speed\" }]\n";
        std::fs::write(experiments.join("listed.toml"), toml).unwrap();
        let index = write_reproduction_index(&experiments, &reports, false).unwrap();
        let html = std::fs::read_to_string(index).unwrap();
        std::fs::remove_dir_all(&root).unwrap();
        assert!(html.contains("listed_here"), "the index does not list the experiment");
    }

    #[test]
    fn wildcards_match_whole_names() {
        assert!(wildcard("86_01_*", "86_01_speed"));
        assert!(wildcard("*_timeline", "13_29_timeline"));
        assert!(wildcard("*speed*", "86_01_speed_zoom"));
        assert!(!wildcard("86_01_*", "13_29_speed"));
        assert!(wildcard("precision_recall", "precision_recall"));
        assert!(!wildcard("a*b", "ab_"));
    }

    #[test]
    fn csv_lines_split_with_quotes() {
        assert_eq!(split_csv_line(r#"a,"b,c","d""e",,"#), vec!["a", "b,c", "d\"e", "", ""]);
    }
}
