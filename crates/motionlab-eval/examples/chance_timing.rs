//! Cost of the chance baseline per (sequence, method) at the sizes of `sonoda_table1`
//! (`boundary_pr` runs it once per method and sequence, so once per sweep combination too):
//! CMU 86_01 at 120 Hz (4 579 frames), 6 truths, tolerance 0.5 s (60 frames), 2 000 draws,
//! for 2 … 278 candidates. Fastest of 5 runs.
//!
//! `cargo run --release -p motionlab-eval --example chance_timing`

use std::time::Instant;

use motionlab_eval::boundaries::TruthWindow;
use motionlab_eval::chance::chance_counts;

fn main() {
    let truths = [400usize, 1100, 1900, 2600, 3300, 4100];
    let windows: Vec<TruthWindow> = truths.iter().map(|&t| TruthWindow::around(t, 60.0)).collect();
    println!("| candidates | draws | time per (sequence, method) |");
    println!("|---:|---:|---:|");
    for k in [2usize, 11, 44, 122, 278] {
        let best = (0..5)
            .map(|_| {
                let t = Instant::now();
                let c = chance_counts(k, &windows, 0..4579, 2000, 16);
                std::hint::black_box(&c);
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        println!("| {k} | 2000 | {:.2} ms |", best * 1e3);
    }
}
