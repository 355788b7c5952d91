//! `motionlab compare RUN_A RUN_B`: which parameters differ between two runs of one experiment
//! and how every shared metric moved.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use motionlab_core::table::ColumnRole;
use motionlab_core::table::fmt_num;
use motionlab_core::{ColumnValues, Error, ErrorKind, Location, Result, Table};
use motionlab_report::html::{ComparePage, MetricDiff, write_compare_page};

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
    let doc: toml::Value = toml::from_str(&text).map_err(|e| {
        Error::new(ErrorKind::Syntax, e.message().to_string()).with_location(Location::file(&p))
    })?;
    let mut out = BTreeMap::new();
    flatten("", &doc, &mut out);
    Ok(out)
}

/// Row keys: the key cells of a row joined (`sequence=pooled, method=fused`); outcome columns
/// (declared by the crates writing them, [`ColumnRole::Outcome`]) left out.
fn row_keys(t: &Table) -> Vec<String> {
    (0..t.n_rows())
        .map(|r| {
            t.columns
                .iter()
                .filter(|c| c.role() == ColumnRole::Key)
                .map(|c| format!("{}={}", c.name, c.values.cell(r)))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect()
}

/// The rows of two tables paired by key: the k-th row of a key in `a` with the k-th row of
/// that key in `b` (several rows may share their text cells — one per truth window, say),
/// then every row left on one side alone, in `a`'s then `b`'s order.
fn paired_rows(a: &[String], b: &[String]) -> Vec<(Option<usize>, Option<usize>)> {
    let mut by_key: BTreeMap<&str, std::collections::VecDeque<usize>> = BTreeMap::new();
    for (rb, k) in b.iter().enumerate() {
        by_key.entry(k).or_default().push_back(rb);
    }
    let mut out: Vec<(Option<usize>, Option<usize>)> = a
        .iter()
        .enumerate()
        .map(|(ra, k)| (Some(ra), by_key.get_mut(k.as_str()).and_then(|q| q.pop_front())))
        .collect();
    let mut rest: Vec<usize> = by_key.into_values().flatten().collect();
    rest.sort_unstable();
    out.extend(rest.into_iter().map(|rb| (None, Some(rb))));
    out
}

/// A numeric cell (integer columns too: counts are metrics); `None` for text.
fn number(values: &ColumnValues, row: usize) -> Option<f64> {
    match values {
        ColumnValues::F64(v) => v.get(row).copied(),
        ColumnValues::I64(v) => v.get(row).map(|&x| x as f64),
        _ => None,
    }
}

/// Compares two runs; returns the page data (also printed by the CLI).
pub fn compare(run_a: &Path, run_b: &Path) -> Result<ComparePage> {
    let (ca, cb) = (read_config(run_a)?, read_config(run_b)?);
    let name =
        |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let exp = ca.get("experiment.name").cloned().unwrap_or_default();
    if cb.get("experiment.name") != ca.get("experiment.name") {
        return Err(Error::new(
            ErrorKind::Mismatch,
            format!(
                "runs of different experiments: {exp} and {}",
                cb.get("experiment.name").cloned().unwrap_or_default()
            ),
        )
        .with_location(Location::file(run_b)));
    }
    let keys: std::collections::BTreeSet<&String> = ca.keys().chain(cb.keys()).collect();
    let parameters = keys
        .into_iter()
        .filter(|k| ca.get(*k) != cb.get(*k))
        .map(|k| {
            (
                k.clone(),
                ca.get(k).cloned().unwrap_or_else(|| "(unset)".into()),
                cb.get(k).cloned().unwrap_or_else(|| "(unset)".into()),
            )
        })
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
        let table =
            a_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let b_path = run_b.join("tables").join(format!("{table}.csv"));
        let (Some(ta), Some(tb)) =
            (read_table_csv(&a_path, &table), read_table_csv(&b_path, &table))
        else {
            continue;
        };
        // Per-frame tables are compared elsewhere; here the summaries people read.
        if ta.n_rows() > 500 {
            continue;
        }
        let (ka, kb) = (row_keys(&ta), row_keys(&tb));
        for (ra, rb) in paired_rows(&ka, &kb) {
            let key = ra
                .or(rb)
                .map(|r| if ra.is_some() { &ka[r] } else { &kb[r] })
                .cloned()
                .unwrap_or_default();
            let (Some(ra), Some(rb)) = (ra, rb) else {
                let (a, b) =
                    if ra.is_some() { ("present", "(absent)") } else { ("(absent)", "present") };
                metrics.push(MetricDiff {
                    table: table.clone(),
                    row: key,
                    column: "(row)".into(),
                    a: a.into(),
                    b: b.into(),
                    delta: String::new(),
                });
                continue;
            };
            for col in &ta.columns {
                if col.role() == ColumnRole::Outcome {
                    let (x, y) = (
                        col.values.cell(ra),
                        tb.column(&col.name).map(|v| v.cell(rb)).unwrap_or_default(),
                    );
                    if x != y {
                        metrics.push(MetricDiff {
                            table: table.clone(),
                            row: key.clone(),
                            column: col.name.clone(),
                            a: x,
                            b: y,
                            delta: String::new(),
                        });
                    }
                    continue;
                }
                let (Some(x), Some(y)) =
                    (number(&col.values, ra), tb.column(&col.name).and_then(|v| number(v, rb)))
                else {
                    continue;
                };
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
            let delta = if m.delta.is_empty() { String::new() } else { format!(" ({})", m.delta) };
            s += &format!("  {} [{}] {}: {} -> {}{delta}\n", m.table, m.row, m.column, m.a, m.b);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    // In a real binary motionlab-eval declares it (chance.rs); this test links no evaluator.
    motionlab_core::declare_outcome_column!("above_chance");

    fn run(dir: &Path, name: &str, csv: &str) -> PathBuf {
        let run = dir.join(name);
        std::fs::create_dir_all(run.join("tables")).unwrap();
        std::fs::write(run.join("config.toml"), "[experiment]\nname = \"e\"\n").unwrap();
        std::fs::write(run.join("tables/t.csv"), csv).unwrap();
        run
    }

    #[test]
    fn rows_sharing_their_text_pair_in_order_and_counts_are_metrics() {
        let dir = tempfile::tempdir().unwrap();
        // Two rows per sequence (one per truth window), an integer and a float column.
        let a = run(
            dir.path(),
            "a",
            "sequence,truth_frame,p,above_chance\nx,100,0.5,no\nx,300,0.25,no\ny,7,1.0,no\n",
        );
        let same = run(
            dir.path(),
            "same",
            "sequence,truth_frame,p,above_chance\nx,100,0.5,no\nx,300,0.25,no\ny,7,1.0,no\n",
        );
        assert!(compare(&a, &same).unwrap().metrics.is_empty(), "identical runs differ in nothing");
        // The second x row's float and the y row's integer moved; a third x row is new; an
        // outcome column changed, which pairs rows no differently.
        let b = run(
            dir.path(),
            "b",
            "sequence,truth_frame,p,above_chance\nx,100,0.5,no\nx,300,0.75,yes\ny,8,1.0,no\nx,500,0.1,no\n",
        );
        let diffs: Vec<(String, String, String, String)> = compare(&a, &b)
            .unwrap()
            .metrics
            .into_iter()
            .map(|m| (m.row, m.column, m.a, m.b))
            .collect();
        assert_eq!(
            diffs,
            [
                ("sequence=x".into(), "p".into(), "0.25".into(), "0.75".into()),
                ("sequence=x".into(), "above_chance".into(), "no".into(), "yes".into()),
                ("sequence=y".into(), "truth_frame".into(), "7".into(), "8".into()),
                ("sequence=x".into(), "(row)".into(), "(absent)".into(), "present".into()),
            ]
        );
    }
}
