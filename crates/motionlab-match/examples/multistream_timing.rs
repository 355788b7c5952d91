//! Times our two-stage multistream DP on data given as JSON, for `bench/multistream_vs_peers.py`
//! (so our numbers and the peers' come from one run of that script).
//!
//! stdin: `{"model": [marker][frame][xyz], "target": [marker][frame][xyz], "repeats": R,
//! "keep_paths": true}`. stdout: `{"times_s": [R wall times of the whole two-stage match],
//! "forward_times_s": [R wall times of stage 1 alone: every marker's forward pass and G],
//! "start", "end", "total_distance", "point_distances"}`.
//!
//! `cargo run --release -p motionlab-match --example multistream_timing < data.json`

use std::io::Read;
use std::time::Instant;

use motionlab_match::dp::Trajectory3;
use motionlab_match::multistream::{end_costs, two_stage};
use serde::{Deserialize, Serialize};

#[derive(Deserialize)]
struct Input {
    model: Vec<Vec<[f64; 3]>>,
    target: Vec<Vec<[f64; 3]>>,
    repeats: usize,
    keep_paths: bool,
}

#[derive(Serialize)]
struct Output {
    times_s: Vec<f64>,
    forward_times_s: Vec<f64>,
    start: usize,
    end: usize,
    total_distance: f64,
    point_distances: Vec<f64>,
}

fn fail(msg: String) -> ! {
    eprintln!("multistream_timing: {msg}");
    std::process::exit(1);
}

fn main() {
    let mut text = String::new();
    std::io::stdin()
        .read_to_string(&mut text)
        .unwrap_or_else(|e| fail(format!("cannot read stdin: {e}")));
    let input: Input =
        serde_json::from_str(&text).unwrap_or_else(|e| fail(format!("bad JSON input: {e}")));
    let model: Vec<Trajectory3> = input.model.iter().map(|p| Trajectory3::from_points(p)).collect();
    let target: Vec<Trajectory3> =
        input.target.iter().map(|p| Trajectory3::from_points(p)).collect();
    let mut times_s = Vec::with_capacity(input.repeats);
    let mut last = None;
    for _ in 0..input.repeats.max(1) {
        let t0 = Instant::now();
        let r =
            two_stage(&model, &target, input.keep_paths).unwrap_or_else(|e| fail(e.to_string()));
        times_s.push(t0.elapsed().as_secs_f64());
        last = Some(r);
    }
    let Some(r) = last else { fail("no run".into()) };
    // Stage 1 alone, as two_stage runs it: h_l(j) per marker summed into G(j).
    let mut forward_times_s = Vec::with_capacity(input.repeats);
    for _ in 0..input.repeats.max(1) {
        let t0 = Instant::now();
        let g = end_costs(&model, &target).unwrap_or_else(|e| fail(e.to_string()));
        forward_times_s.push(t0.elapsed().as_secs_f64());
        std::hint::black_box(&g);
    }
    let a = r.alignment;
    let out = Output {
        times_s,
        forward_times_s,
        start: a.start,
        end: a.end,
        total_distance: a.total_distance,
        point_distances: a.point_distances,
    };
    println!("{}", serde_json::to_string(&out).unwrap_or_else(|e| fail(e.to_string())));
}
