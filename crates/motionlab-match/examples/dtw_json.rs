//! Our DP kernels as a JSON filter, for `bench/dtw_crosscheck.py`.
//!
//! stdin: a JSON array of cases `{"model": [[x, y, z], …], "target": [[x, y, z], …], "end": b}`
//! (`end` optional, default the target's last frame). stdout: one JSON object per case with the
//! full DTW (`full_cost`, `full_path`), the free-start/free-end subsequence DP
//! (`sub_cost`, `sub_start`, `sub_end`, `sub_path`, `end_costs` = h(j) for every j) and the
//! backward pass anchored at `end` (`start_costs` = cost of every start a ≤ end).
//!
//! `cargo run --release -p motionlab-match --example dtw_json < cases.json`

use std::io::Read;

use motionlab_match::dp::{
    Euclidean3, Trajectory3, Workspace, anchored_costs, dtw_full_with, subsequence_match,
};
use serde::{Deserialize, Serialize};

#[derive(Deserialize)]
struct Case {
    model: Vec<[f64; 3]>,
    target: Vec<[f64; 3]>,
    end: Option<usize>,
}

#[derive(Serialize)]
struct Answer {
    full_cost: f64,
    full_path: Vec<(usize, usize)>,
    sub_cost: f64,
    sub_start: usize,
    sub_end: usize,
    sub_path: Vec<(usize, usize)>,
    end_costs: Vec<f64>,
    end: usize,
    start_costs: Vec<f64>,
}

fn answer(case: &Case, ws: &mut Workspace) -> motionlab_core::Result<Answer> {
    let (s, t) = (Trajectory3::from_points(&case.model), Trajectory3::from_points(&case.target));
    let d = Euclidean3::new(&s, &t);
    let (full_cost, full_path) = dtw_full_with(&d, ws)?;
    let sub = subsequence_match(&d, ws)?;
    let end = case.end.unwrap_or(t.len().saturating_sub(1));
    let start_costs = anchored_costs(&d, end)?;
    Ok(Answer {
        full_cost,
        full_path,
        sub_cost: sub.cost,
        sub_start: sub.start,
        sub_end: sub.end,
        sub_path: sub.path,
        end_costs: sub.end_costs,
        end,
        start_costs,
    })
}

fn main() {
    let mut input = String::new();
    if let Err(e) = std::io::stdin().read_to_string(&mut input) {
        eprintln!("dtw_json: cannot read stdin: {e}");
        std::process::exit(2);
    }
    let cases: Vec<Case> = match serde_json::from_str(&input) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("dtw_json: expected a JSON array of {{model, target, end?}} cases: {e}");
            std::process::exit(2);
        }
    };
    let mut ws = Workspace::new();
    let mut out = Vec::with_capacity(cases.len());
    for (k, case) in cases.iter().enumerate() {
        match answer(case, &mut ws) {
            Ok(a) => out.push(a),
            Err(e) => {
                eprintln!("dtw_json: case {k}: {e}");
                std::process::exit(1);
            }
        }
    }
    match serde_json::to_string(&out) {
        Ok(s) => println!("{s}"),
        Err(e) => {
            eprintln!("dtw_json: cannot write JSON: {e}");
            std::process::exit(1);
        }
    }
}
