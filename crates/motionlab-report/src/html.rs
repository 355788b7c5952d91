//! Static HTML: one page per run, an index of every experiment with the papers' published
//! numbers beside ours, and run comparisons.
//!
//! Pages are rendered with minijinja templates (HTML-escaped automatically) from the same
//! Polars DataFrames the CSV files come from. No JavaScript, no network: figures are the run's
//! own SVG files, styles are inline, links are relative.

use std::path::{Path, PathBuf};

use minijinja::value::Serde;
use minijinja::{Environment, Value, context};
use polars::prelude::DataFrame;
use serde::Serialize;

use motionlab_core::{ColumnValues, Error, ErrorKind, Location, Result, Table};

use crate::tables::{formatted_rows, to_dataframe};

const RUN_TEMPLATE: &str = include_str!("../templates/run.html");
const INDEX_TEMPLATE: &str = include_str!("../templates/index.html");
const COMPARE_TEMPLATE: &str = include_str!("../templates/compare.html");
const COMPARISON_PARTIAL: &str = include_str!("../templates/comparison.html");
const CEILING_PARTIAL: &str = include_str!("../templates/ceiling.html");
const STYLE: &str = include_str!("../templates/style.css");

fn env() -> Result<Environment<'static>> {
    let mut env = Environment::new();
    for (name, src) in [
        ("run.html", RUN_TEMPLATE),
        ("index.html", INDEX_TEMPLATE),
        ("compare.html", COMPARE_TEMPLATE),
        ("comparison.html", COMPARISON_PARTIAL),
        ("ceiling.html", CEILING_PARTIAL),
    ] {
        env.add_template(name, src).map_err(template_error)?;
    }
    Ok(env)
}

fn template_error(e: minijinja::Error) -> Error {
    Error::new(ErrorKind::Report, format!("HTML template: {e}"))
}

/// A column header split into name and unit (`speed_mm_per_s` → `speed`, `mm/s`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Header {
    pub name: String,
    pub unit: String,
    pub numeric: bool,
}

// Splitting a unit suffix off a column name is shared with workflows' figure labels.
pub use motionlab_core::table::split_unit;

/// A table ready for HTML.
#[derive(Clone, Debug, Serialize)]
pub struct HtmlTable {
    pub name: String,
    pub title: String,
    pub headers: Vec<Header>,
    pub rows: Vec<Vec<String>>,
    /// Relative links to the CSV / Parquet / Markdown files.
    pub csv: String,
    /// None where only CSV and Markdown are kept (runs of record).
    pub parquet: Option<String>,
    pub markdown: String,
    /// Rows omitted from the page (long per-frame tables are linked, not printed).
    pub omitted_rows: usize,
}

/// Most rows printed in a page; longer tables are summarised by their first rows and linked.
pub const MAX_HTML_ROWS: usize = 25;

impl HtmlTable {
    pub fn from_table(table: &Table, dir_prefix: &str) -> Result<Self> {
        let df = to_dataframe(table)?;
        Ok(Self::from_dataframe(&df, &table.name, &table.title, dir_prefix))
    }
    pub fn from_dataframe(df: &DataFrame, name: &str, title: &str, dir_prefix: &str) -> Self {
        let headers = df
            .columns()
            .iter()
            .map(|c| {
                let (n, u) = split_unit(c.name());
                Header { name: n, unit: u, numeric: c.dtype().is_primitive_numeric() }
            })
            .collect();
        let mut rows = formatted_rows(df);
        let omitted_rows = rows.len().saturating_sub(MAX_HTML_ROWS);
        rows.truncate(MAX_HTML_ROWS);
        let file = motionlab_core::paths::safe_file_name(name);
        HtmlTable {
            name: name.to_string(),
            title: title.to_string(),
            headers,
            rows,
            csv: format!("{dir_prefix}{file}.csv"),
            parquet: Some(format!("{dir_prefix}{file}.parquet")),
            markdown: format!("{dir_prefix}{file}.md"),
            omitted_rows,
        }
    }
}

/// A figure reference for HTML (relative paths).
#[derive(Clone, Debug, Serialize)]
pub struct HtmlFigure {
    pub name: String,
    pub title: String,
    pub svg: String,
    pub png: String,
}

/// Published numbers beside ours: one row per published row.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub table: String,
    pub source: String,
    pub note: String,
    /// Key columns (text values that identify a row) then, per number, `published` and `ours`.
    pub key_columns: Vec<String>,
    pub value_columns: Vec<String>,
    pub rows: Vec<ComparisonRow>,
}

#[derive(Clone, Debug, Serialize)]
pub struct ComparisonRow {
    pub keys: Vec<String>,
    /// (published, ours) per value column; `ours` empty when no row of ours matches.
    pub values: Vec<(String, String)>,
}

/// Matches published rows to rows of our table: a row matches when every text value of the
/// published row equals our row's cell in that column. Numbers are then shown side by side.
pub fn compare_published(
    table_name: &str,
    source: &str,
    note: &str,
    published: &[toml::Table],
    ours: Option<&Table>,
) -> Comparison {
    let mut key_columns: Vec<String> = Vec::new();
    let mut value_columns: Vec<String> = Vec::new();
    for row in published {
        for (k, v) in row {
            let list = if v.is_str() { &mut key_columns } else { &mut value_columns };
            if !list.contains(k) {
                list.push(k.clone());
            }
        }
    }
    let rows = published
        .iter()
        .map(|p| {
            let keys: Vec<String> = key_columns
                .iter()
                .map(|k| p.get(k).and_then(|v| v.as_str()).unwrap_or("").to_string())
                .collect();
            let found = ours.and_then(|t| {
                (0..t.n_rows()).find(|&r| {
                    key_columns.iter().zip(&keys).all(|(k, want)| match t.column(k) {
                        Some(ColumnValues::Str(v)) => v[r].as_deref() == Some(want.as_str()),
                        Some(other) => other.cell(r) == *want,
                        None => want.is_empty(),
                    })
                })
            });
            let values = value_columns
                .iter()
                .map(|k| {
                    let published = p.get(k).map(toml_number).unwrap_or_default();
                    let ours = match (found, ours.and_then(|t| t.column(k))) {
                        (Some(r), Some(ColumnValues::F64(v))) => crate::figures::fmt_num(v[r]),
                        (Some(r), Some(c)) => c.cell(r),
                        _ => String::new(),
                    };
                    (published, ours)
                })
                .collect();
            ComparisonRow { keys, values }
        })
        .collect();
    Comparison {
        table: table_name.to_string(),
        source: source.to_string(),
        note: note.to_string(),
        key_columns,
        value_columns,
        rows,
    }
}

fn toml_number(v: &toml::Value) -> String {
    match v {
        toml::Value::Float(f) => crate::figures::fmt_num(*f),
        toml::Value::Integer(i) => i.to_string(),
        other => other.to_string(),
    }
}

/// One method's pooled F1 between the chance floor and the annotators' agreement (a pooled
/// row of `human_agreement`'s `human_ceiling` table), with the three as percentages of the
/// 0–1 scale for the bar drawn beside it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CeilingBar {
    pub method: String,
    pub tolerance: String,
    pub chance_f1: String,
    pub f1: String,
    pub human_f1: String,
    pub fraction_of_ceiling: String,
    /// `40` or `12.5`: a CSS percentage without its `%`.
    pub chance_pct: String,
    pub f1_pct: String,
    pub human_pct: String,
}

/// The bars of a `human_ceiling` table's pooled rows (none for any other table).
pub fn ceiling_bars(table: &Table) -> Vec<CeilingBar> {
    if table.name != "human_ceiling" {
        return Vec::new();
    }
    let text = |c: &str, r: usize| table.column(c).map(|v| v.cell(r)).unwrap_or_default();
    let num = |c: &str, r: usize| match table.column(c) {
        Some(ColumnValues::F64(v)) => v[r],
        Some(ColumnValues::I64(v)) => v[r] as f64,
        Some(other) => other.cell(r).parse().unwrap_or(f64::NAN),
        None => f64::NAN,
    };
    let pct = |v: f64| {
        format!("{}", if v.is_finite() { (v.clamp(0.0, 1.0) * 1000.0).round() / 10.0 } else { 0.0 })
    };
    let shown = |v: f64| if v.is_finite() { format!("{v:.3}") } else { "—".into() };
    (0..table.n_rows())
        .filter(|&r| text("sequence", r) == "pooled")
        .map(|r| CeilingBar {
            method: text("method", r),
            tolerance: text("tolerance", r),
            chance_f1: shown(num("chance_f1", r)),
            f1: shown(num("f1", r)),
            human_f1: shown(num("human_f1", r)),
            fraction_of_ceiling: shown(num("fraction_of_ceiling", r)),
            chance_pct: pct(num("chance_f1", r)),
            f1_pct: pct(num("f1", r)),
            human_pct: pct(num("human_f1", r)),
        })
        .collect()
}

/// Everything on a run's page.
#[derive(Clone, Debug, Serialize)]
pub struct RunPage {
    pub experiment: String,
    pub description: String,
    pub paper: String,
    pub run_id: String,
    pub config_toml: String,
    /// Provenance as key → value text, in file order.
    pub provenance: Vec<(String, String)>,
    pub inputs: Vec<(String, String, String)>,
    pub tables: Vec<HtmlTable>,
    pub figures: Vec<HtmlFigure>,
    pub comparisons: Vec<Comparison>,
    /// Link back to the reproduction index, relative to the run directory.
    pub index_link: String,
    pub screenshot: Option<String>,
    /// Interactive viewer pages of the run (`viewers/<sequence>.html`), relative links.
    pub viewers: Vec<ViewerLink>,
    /// Each method between chance and the annotators' agreement, when the run measured it.
    pub ceiling: Vec<CeilingBar>,
    /// The external programs the experiment names: (place in the experiment, plugin, command
    /// line), from the provenance (which also says who allowed them).
    pub external_commands: Vec<(String, String, String)>,
}

/// A link to a viewer page.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct ViewerLink {
    /// The sequence it shows.
    pub name: String,
    pub href: String,
}

/// Links to the viewer pages in `<run_dir>/viewers/`, by name, relative to `prefix` (the run
/// directory as seen from the linking page: empty for the run's own page).
pub fn viewer_links(run_dir: &Path, prefix: &str) -> Vec<ViewerLink> {
    let mut names: Vec<String> = std::fs::read_dir(run_dir.join("viewers"))
        .map(|r| {
            r.filter_map(|e| e.ok())
                .filter_map(|e| {
                    e.file_name().to_str().and_then(|n| n.strip_suffix(".html")).map(str::to_string)
                })
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
        .into_iter()
        .map(|n| ViewerLink { href: format!("{prefix}viewers/{n}.html"), name: n })
        .collect()
}

/// Writes `<run_dir>/index.html`.
pub fn write_run_page(run_dir: &Path, page: &RunPage) -> Result<PathBuf> {
    let html = env()?
        .get_template("run.html")
        .and_then(|t| t.render(context! { page => Value::from(Serde(page)), style => STYLE }))
        .map_err(template_error)?;
    let path = run_dir.join("index.html");
    std::fs::write(&path, crate::fonts::with_cjk_font(html)).map_err(|e| Error::io(&path, e))?;
    Ok(path)
}

/// One experiment on the reproduction index.
#[derive(Clone, Debug, Serialize)]
pub struct IndexEntry {
    pub name: String,
    pub description: String,
    pub paper: String,
    /// Relative link to the page of the run shown — the latest, or the run of record (its id is
    /// then `record`); empty when never run.
    pub latest_link: String,
    pub latest_id: String,
    pub finished_utc: String,
    /// Runs made on this machine (the run of record not counted).
    pub runs: usize,
    /// A few headline numbers (label, value).
    pub headline: Vec<(String, String)>,
    pub comparisons: Vec<Comparison>,
    /// Viewer pages of the run shown.
    pub viewers: Vec<ViewerLink>,
    /// Each method between chance and the annotators' agreement, when the run measured it.
    pub ceiling: Vec<CeilingBar>,
}

/// Writes `<reports>/index.html`.
pub fn write_index(
    reports: &Path,
    entries: &[IndexEntry],
    screenshot: Option<&str>,
) -> Result<PathBuf> {
    let html = env()?
        .get_template("index.html")
        .and_then(|t| t.render(context! { entries => Value::from(Serde(entries)), style => STYLE, screenshot => screenshot }))
        .map_err(template_error)?;
    let path = reports.join("index.html");
    std::fs::write(&path, crate::fonts::with_cjk_font(html)).map_err(|e| Error::io(&path, e))?;
    Ok(path)
}

/// A comparison of two runs of one experiment.
#[derive(Clone, Debug, Serialize)]
pub struct ComparePage {
    pub experiment: String,
    pub run_a: String,
    pub run_b: String,
    /// (key path, value in A, value in B).
    pub parameters: Vec<(String, String, String)>,
    pub metrics: Vec<MetricDiff>,
}

#[derive(Clone, Debug, Serialize)]
pub struct MetricDiff {
    pub table: String,
    pub row: String,
    pub column: String,
    pub a: String,
    pub b: String,
    pub delta: String,
}

pub fn write_compare_page(path: &Path, page: &ComparePage) -> Result<()> {
    let html = env()?
        .get_template("compare.html")
        .and_then(|t| t.render(context! { page => Value::from(Serde(page)), style => STYLE }))
        .map_err(template_error)?;
    std::fs::write(path, crate::fonts::with_cjk_font(html))
        .map_err(|e| Error::io(path, e).with_location(Location::file(path)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_are_split_from_column_names() {
        assert_eq!(split_unit("V_mm_per_s"), ("V".into(), "mm/s".into()));
        assert_eq!(split_unit("hausdorff_s"), ("hausdorff".into(), "s".into()));
        assert_eq!(split_unit("volume_mm3"), ("volume".into(), "mm³".into()));
        assert_eq!(split_unit("precision"), ("precision".into(), "".into()));
        assert_eq!(split_unit("_s"), (" s".into(), "".into()));
    }

    #[derive(serde::Serialize)]
    struct CeilingRow {
        sequence: &'static str,
        method: &'static str,
        tolerance: &'static str,
        f1: f64,
        chance_f1: f64,
        human_f1: f64,
        fraction_of_ceiling: f64,
    }

    fn ceiling_table() -> Table {
        let row = |sequence, f1| CeilingRow {
            sequence,
            method: "fused",
            tolerance: "0.5 s",
            f1,
            chance_f1: 0.1,
            human_f1: 0.8,
            fraction_of_ceiling: (f1 - 0.1) / 0.7,
        };
        Table::from_records("human_ceiling", "", &[row("86_01", 0.25), row("pooled", 0.4)]).unwrap()
    }

    #[test]
    fn ceiling_bars_are_the_pooled_rows_on_a_zero_to_one_scale() {
        let bars = ceiling_bars(&ceiling_table());
        assert_eq!(bars.len(), 1);
        assert_eq!(
            (bars[0].chance_pct.as_str(), bars[0].f1_pct.as_str(), bars[0].human_pct.as_str()),
            ("10", "40", "80")
        );
        assert_eq!((bars[0].f1.as_str(), bars[0].fraction_of_ceiling.as_str()), ("0.400", "0.429"));
        let mut other = ceiling_table();
        other.name = "table1_precision_recall".into();
        assert!(ceiling_bars(&other).is_empty());
    }

    #[derive(serde::Serialize)]
    struct Row {
        method: &'static str,
        precision: f64,
        recall: f64,
    }

    #[test]
    fn published_rows_match_ours_by_text_columns() {
        let ours = Table::from_records(
            "table1",
            "",
            &[
                Row { method: "speed", precision: 0.5, recall: 0.25 },
                Row { method: "fused", precision: 0.7, recall: 0.9 },
            ],
        )
        .unwrap();
        let published: Vec<toml::Table> = vec![
            toml::from_str("method = \"fused\"\nprecision = 0.72\nrecall = 0.85").unwrap(),
            toml::from_str("method = \"hull\"\nprecision = 0.74\nrecall = 0.52").unwrap(),
        ];
        let c = compare_published("table1", "Table 1", "", &published, Some(&ours));
        assert_eq!(c.key_columns, vec!["method"]);
        assert_eq!(c.value_columns, vec!["precision", "recall"]);
        assert_eq!(
            c.rows[0].values,
            vec![("0.72".into(), "0.7".into()), ("0.85".into(), "0.9".into())]
        );
        assert_eq!(c.rows[1].values[0].1, "");
    }

    #[test]
    fn run_page_escapes_text_and_links_files() {
        let t = Table::from_records(
            "t1",
            "A <b>table</b>",
            &[Row { method: "x<y", precision: 1.0, recall: 0.0 }],
        )
        .unwrap();
        let page = RunPage {
            experiment: "e".into(),
            description: "d & e".into(),
            paper: String::new(),
            run_id: "r".into(),
            config_toml: "[experiment]\nname = \"e\"".into(),
            provenance: vec![("git_revision".into(), "abc".into())],
            inputs: vec![],
            tables: vec![HtmlTable::from_table(&t, "tables/").unwrap()],
            figures: vec![HtmlFigure {
                name: "f".into(),
                title: "F".into(),
                svg: "figures/f.svg".into(),
                png: "figures/f.png".into(),
            }],
            comparisons: vec![],
            index_link: "../../index.html".into(),
            screenshot: None,
            viewers: vec![ViewerLink { name: "86_01".into(), href: "viewers/86_01.html".into() }],
            ceiling: ceiling_bars(&ceiling_table()),
            external_commands: vec![(
                "segmentation.segmenter[1]".into(),
                "external".into(),
                "sh -c \"echo <b>\"".into(),
            )],
        };
        let dir = std::env::temp_dir().join(format!("mlab-html-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = write_run_page(&dir, &page).unwrap();
        let html = std::fs::read_to_string(p).unwrap();
        assert!(html.contains("x&lt;y") && html.contains("d &amp; e"), "escaping");
        assert!(
            html.contains("External programs") && html.contains("echo &lt;b&gt;"),
            "external commands listed, escaped"
        );
        // minijinja escapes `/` as `&#x2f;` in attributes; browsers decode it back.
        let unescaped = html.replace("&#x2f;", "/");
        assert!(
            unescaped.contains("href=\"tables/t1.csv\"")
                && unescaped.contains("src=\"figures/f.svg\""),
            "{html}"
        );
        assert!(unescaped.contains("href=\"viewers/86_01.html\""), "viewer link");
        // The fused method's pooled F1 0.4 between chance 0.1 and the humans' 0.8.
        assert!(html.contains("Between chance and the annotators"), "ceiling section");
        assert!(
            html.contains("left:40%") && html.contains("width:10%") && html.contains("left:80%"),
            "{html}"
        );
        assert!(!html.contains("http://") && !html.contains("https://"), "no network references");
        std::fs::remove_dir_all(&dir).ok();
    }
}
