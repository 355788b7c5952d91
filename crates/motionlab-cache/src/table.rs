//! The cached form of result tables (an evaluator's output): MessagePack of a mirror of
//! [`Table`], numbers as f64 / i64 bits exactly.

use serde::{Deserialize, Serialize};

use motionlab_core::{Column, ColumnValues, Error, ErrorKind, Result, Table};

#[derive(Serialize, Deserialize)]
enum Values {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    Str(Vec<Option<String>>),
}

#[derive(Serialize, Deserialize)]
struct TableRecord {
    name: String,
    title: String,
    columns: Vec<(String, Values)>,
}

/// Encodes tables.
pub fn encode(tables: &[Table]) -> Result<Vec<u8>> {
    let records: Vec<TableRecord> = tables
        .iter()
        .map(|t| TableRecord {
            name: t.name.clone(),
            title: t.title.clone(),
            columns: t
                .columns
                .iter()
                .map(|c| {
                    let v = match &c.values {
                        ColumnValues::F64(v) => Values::F64(v.clone()),
                        ColumnValues::I64(v) => Values::I64(v.clone()),
                        ColumnValues::Bool(v) => Values::Bool(v.clone()),
                        ColumnValues::Str(v) => Values::Str(v.clone()),
                    };
                    (c.name.clone(), v)
                })
                .collect(),
        })
        .collect();
    rmp_serde::to_vec(&records).map_err(|e| {
        Error::new(ErrorKind::Report, format!("cannot encode tables for the cache: {e}"))
    })
}

/// Decodes what [`encode`] wrote.
pub fn decode(bytes: &[u8]) -> Result<Vec<Table>> {
    let records: Vec<TableRecord> = rmp_serde::from_slice(bytes)
        .map_err(|e| Error::new(ErrorKind::Mismatch, format!("cached tables: {e}")))?;
    Ok(records
        .into_iter()
        .map(|r| Table {
            name: r.name,
            title: r.title,
            columns: r
                .columns
                .into_iter()
                .map(|(name, v)| Column {
                    name,
                    values: match v {
                        Values::F64(v) => ColumnValues::F64(v),
                        Values::I64(v) => ColumnValues::I64(v),
                        Values::Bool(v) => ColumnValues::Bool(v),
                        Values::Str(v) => ColumnValues::Str(v),
                    },
                })
                .collect(),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_every_bit() {
        let mut t = Table::new("t", "a table");
        t.push_column("x", ColumnValues::F64(vec![0.1, f64::NAN, -0.0, 1e308])).unwrap();
        t.push_column("n", ColumnValues::I64(vec![1, -2, i64::MAX, 0])).unwrap();
        t.push_column("b", ColumnValues::Bool(vec![true, false, true, false])).unwrap();
        t.push_column(
            "s",
            ColumnValues::Str(vec![Some("a".into()), None, Some(String::new()), Some("é".into())]),
        )
        .unwrap();
        let back = decode(&encode(std::slice::from_ref(&t)).unwrap()).unwrap();
        assert_eq!(back.len(), 1);
        let bits = |t: &Table| match &t.columns[0].values {
            ColumnValues::F64(v) => v.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            _ => vec![],
        };
        assert_eq!(bits(&back[0]), bits(&t));
        assert_eq!(back[0].columns[1..], t.columns[1..]);
        assert_eq!((back[0].name.as_str(), back[0].title.as_str()), ("t", "a table"));
    }
}
