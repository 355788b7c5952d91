//! A small column table: what stages and evaluators hand to the report crate.
//!
//! Algorithm crates must not depend on polars, so results travel as [`Table`]s built from
//! plain serde records ([`Table::from_records`]); the report crate is the one place that turns
//! them into Polars DataFrames, CSV, Parquet, Markdown and HTML. Units live in column names
//! (`speed_mm_per_s`, `time_s`, `volume_mm3`) so they survive every export.

use serde::Serialize;
use serde_json::Value;

use crate::{Error, ErrorKind, Result};

/// The values of one column.
#[derive(Clone, Debug, PartialEq)]
pub enum ColumnValues {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    /// Text; also used for mixed or nullable columns (`None` = null).
    Str(Vec<Option<String>>),
}

impl ColumnValues {
    pub fn len(&self) -> usize {
        match self {
            ColumnValues::F64(v) => v.len(),
            ColumnValues::I64(v) => v.len(),
            ColumnValues::Bool(v) => v.len(),
            ColumnValues::Str(v) => v.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The cell as text (for Markdown/HTML and tests); floats with `{}` formatting.
    pub fn cell(&self, row: usize) -> String {
        match self {
            ColumnValues::F64(v) => format!("{}", v[row]),
            ColumnValues::I64(v) => v[row].to_string(),
            ColumnValues::Bool(v) => v[row].to_string(),
            ColumnValues::Str(v) => v[row].clone().unwrap_or_default(),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    pub name: String,
    pub values: ColumnValues,
}

/// What a column of a result table is for, so that a tool reading tables back by name
/// (`motionlab compare`) needs to know no evaluator's columns: rows pair by their key columns,
/// metrics compare as numbers, outcomes as text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColumnRole {
    /// Text naming the row (`sequence`, `method`).
    Key,
    /// A number or a flag (`precision`, `time_s`).
    Metric,
    /// Text that is a result, not an identity: it changes with the parameters compared (how a
    /// row's parameters were chosen, whether it beat chance). Declared by the crate that writes
    /// it, with [`declare_outcome_column!`](crate::declare_outcome_column).
    Outcome,
}

/// A column name that is an [`ColumnRole::Outcome`] in every table that has it.
pub struct OutcomeColumn {
    pub name: &'static str,
    /// The crate that declared it.
    pub crate_name: &'static str,
}

inventory::collect!(OutcomeColumn);

/// Declares a result column's name an outcome ([`ColumnRole::Outcome`]), next to the code that
/// writes it: `motionlab_core::declare_outcome_column!("above_chance");`.
#[macro_export]
macro_rules! declare_outcome_column {
    ($name:literal) => {
        $crate::inventory::submit! {
            $crate::table::OutcomeColumn { name: $name, crate_name: env!("CARGO_PKG_NAME") }
        }
    };
}

impl ColumnRole {
    /// A column's role: a declared outcome name, else text is a key and the rest metrics.
    pub fn of(name: &str, values: &ColumnValues) -> ColumnRole {
        if inventory::iter::<OutcomeColumn>.into_iter().any(|c| c.name == name) {
            ColumnRole::Outcome
        } else if matches!(values, ColumnValues::Str(_)) {
            ColumnRole::Key
        } else {
            ColumnRole::Metric
        }
    }
}

/// A named table of equal-length columns.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// File-name-safe identifier (`table1`, `per_frame_speed`).
    pub name: String,
    /// A human title for reports (`Table 1: precision and recall per method`).
    pub title: String,
    pub columns: Vec<Column>,
}

impl Column {
    /// Its role ([`ColumnRole::of`]).
    pub fn role(&self) -> ColumnRole {
        ColumnRole::of(&self.name, &self.values)
    }
}

impl Table {
    pub fn new(name: impl Into<String>, title: impl Into<String>) -> Self {
        Table { name: name.into(), title: title.into(), columns: Vec::new() }
    }

    /// Builds a table from serde records: one row per record, one column per field (in field
    /// order). Numbers that are all integers become `I64`, other numbers `F64` (a `null` in a
    /// number column becomes NaN), booleans `Bool`, anything else text.
    pub fn from_records<T: Serialize>(
        name: impl Into<String>,
        title: impl Into<String>,
        records: &[T],
    ) -> Result<Self> {
        let mut table = Table::new(name, title);
        let rows: Vec<serde_json::Map<String, Value>> = records
            .iter()
            .map(|r| match serde_json::to_value(r) {
                Ok(Value::Object(m)) => Ok(m),
                Ok(other) => Err(Error::new(
                    ErrorKind::Report,
                    format!("a table record must be a struct, found {other}"),
                )),
                Err(e) => Err(Error::new(
                    ErrorKind::Report,
                    format!("cannot serialise a table record: {e}"),
                )),
            })
            .collect::<Result<_>>()?;
        let Some(first) = rows.first() else { return Ok(table) };
        let names: Vec<String> = first.keys().cloned().collect();
        for name in names {
            let cells: Vec<&Value> =
                rows.iter().map(|r| r.get(&name).unwrap_or(&Value::Null)).collect();
            table.columns.push(Column { values: column_from_json(&cells), name });
        }
        Ok(table)
    }

    pub fn n_rows(&self) -> usize {
        self.columns.first().map(|c| c.values.len()).unwrap_or(0)
    }

    /// Adds a column; its length must match the table's.
    pub fn push_column(&mut self, name: impl Into<String>, values: ColumnValues) -> Result<()> {
        let name = name.into();
        if !self.columns.is_empty() && values.len() != self.n_rows() {
            return Err(Error::new(
                ErrorKind::Report,
                format!(
                    "column {name:?} has {} rows, table {:?} has {}",
                    values.len(),
                    self.name,
                    self.n_rows()
                ),
            ));
        }
        self.columns.push(Column { name, values });
        Ok(())
    }

    /// Prepends a column holding one constant text value (sweep parameters, sequence names).
    pub fn with_constant_column(
        mut self,
        name: impl Into<String>,
        value: impl Into<String>,
    ) -> Self {
        let v = value.into();
        let n = self.n_rows();
        self.columns
            .insert(0, Column { name: name.into(), values: ColumnValues::Str(vec![Some(v); n]) });
        self
    }

    pub fn column(&self, name: &str) -> Option<&ColumnValues> {
        self.columns.iter().find(|c| c.name == name).map(|c| &c.values)
    }

    /// Appends the rows of `other`, which must have the same column names and types. A table
    /// without rows may lack columns (records give no names when there are none), so it
    /// neither blocks nor adds anything.
    pub fn append(&mut self, other: Table) -> Result<()> {
        if other.n_rows() == 0 && other.columns.len() <= self.columns.len() {
            return Ok(());
        }
        if self.n_rows() == 0 {
            self.columns = other.columns;
            return Ok(());
        }
        let names_a: Vec<&str> = self.columns.iter().map(|c| c.name.as_str()).collect();
        let names_b: Vec<&str> = other.columns.iter().map(|c| c.name.as_str()).collect();
        if names_a != names_b {
            return Err(Error::new(
                ErrorKind::Report,
                format!(
                    "cannot append table {:?}: columns {names_b:?} differ from {names_a:?}",
                    self.name
                ),
            ));
        }
        for (a, b) in self.columns.iter_mut().zip(other.columns) {
            a.values =
                match (std::mem::replace(&mut a.values, ColumnValues::Bool(vec![])), b.values) {
                    (ColumnValues::F64(mut x), ColumnValues::F64(y)) => {
                        x.extend(y);
                        ColumnValues::F64(x)
                    }
                    (ColumnValues::I64(mut x), ColumnValues::I64(y)) => {
                        x.extend(y);
                        ColumnValues::I64(x)
                    }
                    (ColumnValues::F64(mut x), ColumnValues::I64(y)) => {
                        x.extend(y.into_iter().map(|v| v as f64));
                        ColumnValues::F64(x)
                    }
                    (ColumnValues::I64(x), ColumnValues::F64(y)) => {
                        ColumnValues::F64(x.into_iter().map(|v| v as f64).chain(y).collect())
                    }
                    (ColumnValues::Bool(mut x), ColumnValues::Bool(y)) => {
                        x.extend(y);
                        ColumnValues::Bool(x)
                    }
                    (x, y) => {
                        let mut s = to_strings(x);
                        s.extend(to_strings(y));
                        ColumnValues::Str(s)
                    }
                };
        }
        Ok(())
    }
}

fn to_strings(v: ColumnValues) -> Vec<Option<String>> {
    match v {
        ColumnValues::Str(s) => s,
        other => (0..other.len()).map(|i| Some(other.cell(i))).collect(),
    }
}

fn column_from_json(cells: &[&Value]) -> ColumnValues {
    let all = |f: fn(&Value) -> bool| cells.iter().all(|v| f(v));
    if all(|v| v.is_i64() || v.is_u64()) {
        ColumnValues::I64(cells.iter().map(|v| v.as_i64().unwrap_or(i64::MAX)).collect())
    } else if all(|v| v.is_number() || v.is_null()) && cells.iter().any(|v| v.is_number()) {
        ColumnValues::F64(cells.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect())
    } else if all(Value::is_boolean) {
        ColumnValues::Bool(cells.iter().map(|v| v.as_bool().unwrap_or(false)).collect())
    } else {
        ColumnValues::Str(
            cells
                .iter()
                .map(|v| match v {
                    Value::Null => None,
                    Value::String(s) => Some(s.clone()),
                    other => Some(other.to_string()),
                })
                .collect(),
        )
    }
}

/// Compact number formatting for labels and tables: up to 4 significant digits, no
/// scientific notation for everyday magnitudes; NaN as `–`, infinities as `∞`/`−∞`.
pub fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            "–".into()
        } else if v > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e7).contains(&a) {
        return format!("{v:.3e}");
    }
    let decimals = if a >= 1000.0 {
        0
    } else if a >= 100.0 {
        1
    } else if a >= 10.0 {
        2
    } else {
        3
    };
    let s = format!("{v:.decimals$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

/// Unit suffixes used in column names, longest first.
const UNITS: &[(&str, &str)] = &[
    ("_mm3_per_frame", "mm³/frame"),
    ("_mm3_per_s", "mm³/s"),
    ("_mm_per_frame", "mm/frame"),
    ("_mm_per_s", "mm/s"),
    ("_steps_per_min", "steps/min"),
    ("_mm3", "mm³"),
    ("_mm", "mm"),
    ("_deg", "°"),
    ("_pct", "%"),
    ("_hz", "Hz"),
    ("_ms", "ms"),
    ("_s", "s"),
];

/// Splits a unit suffix off a column name (`speed_mm_per_s` → `speed`, `mm/s`), for headers
/// and axis labels.
pub fn split_unit(column: &str) -> (String, String) {
    for (suffix, unit) in UNITS {
        if let Some(base) = column.strip_suffix(suffix)
            && !base.is_empty()
        {
            return (base.replace('_', " "), unit.to_string());
        }
    }
    (column.replace('_', " "), String::new())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Row {
        method: &'static str,
        found: usize,
        precision: f64,
        best: bool,
        note: Option<String>,
    }

    #[test]
    fn records_become_typed_columns_in_field_order() {
        let t = Table::from_records(
            "t",
            "T",
            &[
                Row { method: "speed", found: 3, precision: 0.5, best: false, note: None },
                Row {
                    method: "fused",
                    found: 4,
                    precision: f64::NAN,
                    best: true,
                    note: Some("x".into()),
                },
            ],
        )
        .unwrap();
        let names: Vec<&str> = t.columns.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["method", "found", "precision", "best", "note"]);
        assert_eq!(t.column("found"), Some(&ColumnValues::I64(vec![3, 4])));
        // serde_json writes NaN as null; it comes back as NaN in a float column.
        match t.column("precision") {
            Some(ColumnValues::F64(v)) => assert!(v[0] == 0.5 && v[1].is_nan()),
            other => panic!("{other:?}"),
        }
        assert_eq!(t.column("best"), Some(&ColumnValues::Bool(vec![false, true])));
        assert_eq!(t.column("note"), Some(&ColumnValues::Str(vec![None, Some("x".into())])));
    }

    #[test]
    fn append_checks_columns_and_widens_ints() {
        let mut a = Table::new("a", "");
        a.push_column("x", ColumnValues::I64(vec![1])).unwrap();
        let mut b = Table::new("a", "");
        b.push_column("x", ColumnValues::F64(vec![2.5])).unwrap();
        a.append(b).unwrap();
        assert_eq!(a.column("x"), Some(&ColumnValues::F64(vec![1.0, 2.5])));
        let mut c = Table::new("c", "");
        c.push_column("y", ColumnValues::I64(vec![1])).unwrap();
        assert!(a.append(c).is_err());
        // Tables without rows (possibly without columns) neither block nor add.
        let mut empty = Table::new("e", "");
        empty.push_column("only", ColumnValues::I64(vec![])).unwrap();
        empty.append(a.clone()).unwrap();
        assert_eq!(empty, Table { name: "e".into(), title: "".into(), columns: a.columns.clone() });
        a.append(Table::new("z", "")).unwrap();
        assert_eq!(a.n_rows(), 2);
        assert!(a.push_column("z", ColumnValues::I64(vec![1, 2, 3])).is_err());
    }
}
