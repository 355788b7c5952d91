//! `motionlab compare RUN_A RUN_B`: which parameters differ between two runs of one experiment
//! and how every shared metric moved.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use motionlab_core::{ColumnValues, Error, ErrorKind, Location, Result, Table};
use motionlab_core::table::fmt_num;
use motionlab_report::html::{write_compare_page, ComparePage, MetricDiff};

use motionlab_report::pages::read_table_csv;

/// Flattens a TOML document into `key.path = value` pairs.
fn flatten(prefix: &str, v: &toml::Value, out: &mut BTreeMap<String, String>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                let p = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                flatten(&p, x, out);
            }
        }
        toml::Value::Array(a) if a.iter().any(|x| x.is_table()) => {
            for (i, x) in a.iter().enumerate() {
                flatten(&format!("{prefix}[{i}]"), x, out);
            }
        }
        other => {
            out.insert(prefix.to_string(), other.to_string());
        }
    }
}

fn read_config(run: &Path) -> Result<BTreeMap<String, String>> {
    let p = run.join("config.toml");
    let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&p, e))?;
    let doc: toml::Value = toml::from_str(&text).map_err(|e| Error::new(ErrorKind::Syntax, e.message().to_string()).with_location(Location::file(&p)))?;
    let mut out = BTreeMap::new();
    flatten("", &doc, &mut out);
    Ok(out)
}

/// Row keys: the text cells of a row joined (`sequence=pooled, method=fused`).
fn row_keys(t: &Table) -> Vec<String> {
    (0..t.n_rows())
        .map(|r| {
            t.columns
                .iter()
                .filter(|c| matches!(c.values, ColumnValues::Str(_)))
                .map(|c| format!("{}={}", c.name, c.values.cell(r)))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect()
}

/// Compares two runs; returns the page data (also printed by the CLI).
pub fn compare(run_a: &Path, run_b: &Path) -> Result<ComparePage> {
    let (ca, cb) = (read_config(run_a)?, read_config(run_b)?);
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let exp = ca.get("experiment.name").cloned().unwrap_or_default();
    if cb.get("experiment.name") != ca.get("experiment.name") {
        return Err(Error::new(
            ErrorKind::Mismatch,
            format!("runs of different experiments: {exp} and {}", cb.get("experiment.name").cloned().unwrap_or_default()),
        )
        .with_location(Location::file(run_b)));
    }
    let keys: std::collections::BTreeSet<&String> = ca.keys().chain(cb.keys()).collect();
    let parameters = keys
        .into_iter()
        .filter(|k| ca.get(*k) != cb.get(*k))
        .map(|k| (k.clone(), ca.get(k).cloned().unwrap_or_else(|| "(unset)".into()), cb.get(k).cloned().unwrap_or_else(|| "(unset)".into())))
        .collect();
    let mut metrics = Vec::new();
    let tables_a = run_a.join("tables");
    let mut csvs: Vec<PathBuf> = std::fs::read_dir(&tables_a)
        .map_err(|e| Error::io(&tables_a, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    csvs.sort();
    for a_path in csvs {
        let table = a_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let b_path = run_b.join("tables").join(format!("{table}.csv"));
        let (Some(ta), Some(tb)) = (read_table_csv(&a_path, &table), read_table_csv(&b_path, &table)) else { continue };
        // Per-frame tables are compared elsewhere; here the summaries people read.
        if ta.n_rows() > 500 {
            continue;
        }
        let (ka, kb) = (row_keys(&ta), row_keys(&tb));
        for (ra, key) in ka.iter().enumerate() {
            let Some(rb) = kb.iter().position(|k| k == key) else { continue };
            for col in &ta.columns {
                let (ColumnValues::F64(va), Some(ColumnValues::F64(vb))) = (&col.values, tb.column(&col.name)) else { continue };
                let (x, y) = (va[ra], vb[rb]);
                let same = (x.is_nan() && y.is_nan()) || x == y;
                if !same {
                    metrics.push(MetricDiff {
                        table: table.clone(),
                        row: key.clone(),
                        column: col.name.clone(),
                        a: fmt_num(x),
                        b: fmt_num(y),
                        delta: fmt_num(y - x),
                    });
                }
            }
        }
    }
    Ok(ComparePage { experiment: exp, run_a: name(run_a), run_b: name(run_b), parameters, metrics })
}

/// Writes the comparison page next to the runs (`reports/<experiment>/compare-A-vs-B.html`).
pub fn write_compare(run_a: &Path, run_b: &Path, page: &ComparePage) -> Result<PathBuf> {
    let dir = run_b.parent().unwrap_or_else(|| Path::new("."));
    let path = dir.join(format!("compare-{}-vs-{}.html", page.run_a, page.run_b));
    let _ = run_a;
    write_compare_page(&path, page)?;
    Ok(path)
}

/// The comparison as text.
pub fn compare_text(page: &ComparePage) -> String {
    let mut s = format!("{}: {} vs {}\n", page.experiment, page.run_a, page.run_b);
    if page.parameters.is_empty() {
        s += "parameters: identical\n";
    } else {
        s += "parameters that differ:\n";
        for (k, a, b) in &page.parameters {
            s += &format!("  {k}: {a} -> {b}\n");
        }
    }
    if page.metrics.is_empty() {
        s += "metrics: identical\n";
    } else {
        s += "metrics that differ:\n";
        for m in &page.metrics {
            s += &format!("  {} [{}] {}: {} -> {} ({})\n", m.table, m.row, m.column, m.a, m.b, m.delta);
        }
    }
    s
}
