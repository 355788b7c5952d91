//! A fixed workload for counting the two-stage matcher's instructions, which — unlike times on a
//! shared machine — do not drift: the bench's data (31 markers, model 120 frames against a
//! 600-frame window, `benches/multistream.rs`) through `two_stage` with paths, `passes` times
//! (default 1), then `[a, b]` and `H` (so two versions can be checked to do the same work).
//!
//! ```text
//! cargo build --release -p motionlab-match --example multistream_instructions
//! valgrind --tool=callgrind --toggle-collect='motionlab_match::multistream::two_stage' \
//!     $CARGO_TARGET_DIR/release/examples/multistream_instructions 1
//! ```
//!
//! callgrind's "I refs" divided by 4 106 880 (the DP cells of one match) is the instructions
//! per cell quoted in `benches/README.md`. valgrind does not run AVX-512: under it the kernels
//! take their AVX2 level.

use motionlab_match::dp::Trajectory3;
use motionlab_match::multistream::two_stage;

/// Position of marker `l` at (fractional) frame `j` (mm) — the bench's formula.
fn position(j: f64, l: usize) -> [f64; 3] {
    let l = l as f64;
    [
        300.0 * (0.05 * j + 0.3 * l).sin() + 20.0 * l,
        200.0 * (0.037 * j + 0.7 * l).cos(),
        150.0 * (0.021 * j - l).sin() + 900.0,
    ]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (markers, model_frames, window) = (31, 120, 600);
    let model: Vec<Trajectory3> = (0..markers)
        .map(|l| {
            Trajectory3::from_points(
                &(0..model_frames).map(|i| position(240.0 + 1.1 * i as f64, l)).collect::<Vec<_>>(),
            )
        })
        .collect();
    let target: Vec<Trajectory3> = (0..markers)
        .map(|l| {
            Trajectory3::from_points(
                &(0..window).map(|j| position(j as f64, l)).collect::<Vec<_>>(),
            )
        })
        .collect();
    let passes: usize = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(1);
    for _ in 0..passes {
        let r = two_stage(&model, &target, true)?;
        let a = r.alignment;
        println!(
            "[a, b] = [{}, {}], H = {:?} mm, {} paths",
            a.start,
            a.end,
            a.total_distance,
            a.paths.len()
        );
    }
    Ok(())
}
