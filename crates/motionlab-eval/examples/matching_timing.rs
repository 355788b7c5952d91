//! Times the two maximum-matching algorithms on an instance written by
//! `bench/matching_vs_scipy.py`, which times scipy's Hopcroft–Karp on the same graph in the
//! same run and checks that all three find matchings of the same size.
//!
//! Instance file: line 1 the tolerance (frames), line 2 the found frames, line 3 the truth
//! frames (space-separated). Output, one line: `pairs_sweep pairs_hk best_us_sweep best_us_hk`
//! (best of the repeats; the sweep includes its sorting, Hopcroft–Karp gets a prebuilt
//! adjacency like scipy gets a prebuilt sparse matrix).
//!
//! `cargo run --release -p motionlab-eval --example matching_timing -- instance.txt [repeats]`

use std::time::Instant;

use motionlab_eval::boundaries::{TruthWindow, max_matching_graph, max_matching_windows};

fn numbers(line: Option<&str>) -> Vec<f64> {
    line.unwrap_or("").split_whitespace().filter_map(|t| t.parse().ok()).collect()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: matching_timing <instance.txt> [repeats]");
        std::process::exit(2);
    };
    let repeats: usize = args.next().and_then(|r| r.parse().ok()).unwrap_or(20);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(1);
        }
    };
    let mut lines = text.lines();
    let tol = numbers(lines.next()).first().copied().unwrap_or(0.0);
    let found: Vec<usize> = numbers(lines.next()).into_iter().map(|v| v as usize).collect();
    let truth: Vec<usize> = numbers(lines.next()).into_iter().map(|v| v as usize).collect();
    let windows: Vec<TruthWindow> = truth.iter().map(|&r| TruthWindow::around(r, tol)).collect();

    let mut order: Vec<usize> = (0..truth.len()).collect();
    order.sort_by_key(|&j| truth[j]);
    let sorted: Vec<usize> = order.iter().map(|&j| truth[j]).collect();
    let adjacency: Vec<Vec<usize>> = found
        .iter()
        .map(|&a| {
            let lo = sorted.partition_point(|&r| (r as f64) < a as f64 - tol);
            let hi = sorted.partition_point(|&r| (r as f64) <= a as f64 + tol);
            order[lo..hi].to_vec()
        })
        .collect();

    let best = |f: &mut dyn FnMut() -> usize| {
        let mut best = f64::INFINITY;
        let mut pairs = 0;
        for _ in 0..repeats {
            let t = Instant::now();
            pairs = std::hint::black_box(f());
            best = best.min(t.elapsed().as_secs_f64() * 1e6);
        }
        (pairs, best)
    };
    let (pairs_sweep, us_sweep) = best(&mut || max_matching_windows(&found, &windows).len());
    let (pairs_hk, us_hk) = best(&mut || max_matching_graph(truth.len(), &adjacency).len());
    println!("{pairs_sweep} {pairs_hk} {us_sweep:.3} {us_hk:.3}");
}
