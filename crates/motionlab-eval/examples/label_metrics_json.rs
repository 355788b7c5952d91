//! motionlab's label metrics (AMI, ARI, NMI) on cases read as JSON from stdin, for the
//! cross-check `bench/label_metrics_vs_sklearn.py` (no polars, no files).
//!
//! Input: a JSON array of cases `{ "truth": [labels], "found": [labels] }` (integers). Output:
//! a JSON array, per case `{ "ami", "ari", "nmi" }`.
//!
//! `cargo run -p motionlab-eval --example label_metrics_json < cases.json`

use std::io::Read;

use motionlab_eval::label_metrics::{ami, ari, nmi};
use serde::Deserialize;
use serde_json::{Value, json};

#[derive(Deserialize)]
struct Case {
    truth: Vec<i64>,
    found: Vec<i64>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut text = String::new();
    std::io::stdin().read_to_string(&mut text)?;
    let cases: Vec<Case> = serde_json::from_str(&text)?;
    let out = cases
        .iter()
        .map(|c| {
            Ok(json!({
                "ami": ami(&c.truth, &c.found)?,
                "ari": ari(&c.truth, &c.found)?,
                "nmi": nmi(&c.truth, &c.found)?,
            }))
        })
        .collect::<motionlab_core::Result<Vec<Value>>>()?;
    println!("{}", Value::Array(out));
    Ok(())
}
