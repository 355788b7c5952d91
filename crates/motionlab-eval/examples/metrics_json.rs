//! motionlab's boundary metrics on cases read as JSON from stdin, for the cross-check
//! `tests/metrics_crosscheck.py` (no polars, no files).
//!
//! Input: a JSON array of cases `{ "truth": [frames], "found": [frames], "annotators":
//! [[frames], …], "tolerance_frames": t, "margin_frames": m, "n_frames": n }`. Output: a JSON
//! array, per case `{ "n_matched", "precision", "recall", "f1", "hausdorff_frames",
//! "tcpd_f1", "tcpd_precision", "tcpd_recall", "covering" }` (NaN and ∞ written as null).
//!
//! `cargo run -p motionlab-eval --example metrics_json < cases.json`

use std::io::Read;

use motionlab_core::Boundary;
use motionlab_eval::boundaries::{MatchRule, evaluate_boundaries, hausdorff_frames};
use motionlab_eval::cpd_metrics::{covering, tcpd_f_measure};
use serde::Deserialize;
use serde_json::{Value, json};

#[derive(Deserialize)]
struct Case {
    truth: Vec<usize>,
    found: Vec<usize>,
    annotators: Vec<Vec<usize>>,
    tolerance_frames: f64,
    margin_frames: usize,
    n_frames: usize,
}

fn num(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut text = String::new();
    std::io::stdin().read_to_string(&mut text)?;
    let cases: Vec<Case> = serde_json::from_str(&text)?;
    let out: Vec<Value> = cases
        .iter()
        .map(|c| {
            let truth: Vec<Boundary> =
                c.truth.iter().map(|&frame| Boundary { frame, window: None }).collect();
            let s = evaluate_boundaries(&c.found, &truth, &MatchRule::time(c.tolerance_frames));
            let (f1, p, r) = tcpd_f_measure(&c.annotators, &c.found, c.margin_frames);
            json!({
                "n_matched": s.scores.n_matched,
                "precision": num(s.scores.precision),
                "recall": num(s.scores.recall),
                "f1": num(s.scores.f1),
                "hausdorff_frames": num(hausdorff_frames(&c.found, &c.truth)),
                "tcpd_f1": num(f1),
                "tcpd_precision": num(p),
                "tcpd_recall": num(r),
                "covering": num(covering(&c.annotators, &c.found, c.n_frames)),
            })
        })
        .collect();
    println!("{}", Value::Array(out));
    Ok(())
}
