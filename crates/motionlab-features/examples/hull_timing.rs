//! Times the per-frame convex-hull volume on a real recording and dumps the exact input points
//! and our volumes, so `bench/hull_vs_scipy.py` can time `scipy.spatial.ConvexHull` on the very
//! same frames and check the volumes agree.
//!
//! ```text
//! cargo run --release -p motionlab-features --example hull_timing -- <motion> [<points.f64> <volumes.f64>]
//! ```
//!
//! `<motion>`: `*.amc[.gz]` (ASF found next to it or in `../asf/`, 120 fps) or `*.tsv[.gz]`
//! (Qualisys). Prints one JSON line: frames, points, and µs per frame for the from-scratch
//! quickhull (`HullBuilder`, every frame rebuilt) and for the coherent `HullTracker` (median of
//! repeated passes over the whole sequence, one core, thread CPU time), plus how often the tracker re-used the
//! previous frame's hull. `<points.f64>`: little-endian f64, `[frames, points]` then
//! `frames × points × 3` coordinates (NaN = missing); `<volumes.f64>`: one f64 per frame.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use motionlab_core::{Axis, FrameRate, Motion, Point3};
use motionlab_features::hull::{HullBuilder, HullTracker};

fn load(path: &Path) -> motionlab_core::Result<Motion> {
    let name = path.to_string_lossy();
    if name.ends_with(".amc") || name.ends_with(".amc.gz") {
        let asf = motionlab_io::asf_amc::asf_candidates(path)
            .into_iter()
            .find(|p| p.exists())
            .unwrap_or_default();
        motionlab_io::asf_amc::load_asf_amc(path, &asf, FrameRate::new(120.0)?)
    } else {
        let text = motionlab_io::read::read_text(path)?;
        motionlab_io::qualisys_tsv::parse_qualisys_tsv(&text, path, Axis::Z)
    }
}

/// CPU time of this thread (ns) from Linux's scheduler statistics: unlike wall time it does not
/// grow when other processes compete for the cores. None elsewhere (then wall time is used).
fn thread_cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Median time per frame (µs) of `pass` over the whole sequence, repeated for ~`budget_s` of wall
/// time; thread CPU time when the platform offers it. Each sample runs enough passes to last
/// ≥ 20 ms, well above the scheduler-tick granularity at which the thread CPU time can advance.
fn time_per_frame(frames: usize, budget_s: f64, mut pass: impl FnMut() -> f64) -> f64 {
    let t = Instant::now();
    black_box(pass());
    let passes = (0.02 / t.elapsed().as_secs_f64().max(1e-6)).ceil().clamp(1.0, 10_000.0) as usize;
    let mut samples = Vec::new();
    let start = Instant::now();
    while samples.len() < 5 || (start.elapsed().as_secs_f64() < budget_s && samples.len() < 1000) {
        let (t, c) = (Instant::now(), thread_cpu_ns());
        for _ in 0..passes {
            black_box(pass());
        }
        let ns = match (c, thread_cpu_ns()) {
            (Some(a), Some(b)) => (b - a) as f64,
            _ => t.elapsed().as_secs_f64() * 1e9,
        };
        samples.push(ns / 1e3 / (frames * passes) as f64);
    }
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(input) = args.first() else {
        return Err("usage: hull_timing <motion> [<points.f64> <volumes.f64>]".into());
    };
    let motion = load(&PathBuf::from(input))?;
    let (f, m) = (motion.n_frames(), motion.n_points());
    let frames: Vec<Vec<Point3>> = (0..f).map(|i| motion.frame(i).to_vec()).collect();
    let valid: Vec<Vec<Point3>> = frames
        .iter()
        .map(|fr| fr.iter().copied().filter(|p| p.iter().all(|c| c.is_finite())).collect())
        .collect();

    let mut builder = HullBuilder::new();
    let scratch_us =
        time_per_frame(f, 2.0, || valid.iter().map(|p| builder.volume(p).volume_mm3).sum());
    let mut tracker = HullTracker::new();
    let tracker_us = time_per_frame(f, 2.0, || {
        tracker.reset();
        frames.iter().map(|p| tracker.frame(p).volume_mm3).sum()
    });
    let mut tracker = HullTracker::new();
    let volumes: Vec<f64> = frames.iter().map(|p| tracker.frame(p).volume_mm3).collect();
    let stats = tracker.stats();

    if let [_, points_out, volumes_out] = &args[..] {
        let mut bytes = Vec::with_capacity((2 + f * m * 3) * 8);
        for v in [f as f64, m as f64].into_iter().chain(frames.iter().flatten().flatten().copied())
        {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        std::fs::write(points_out, bytes)?;
        std::fs::write(
            volumes_out,
            volumes.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>(),
        )?;
    }
    println!(
        "{{\"file\": {input:?}, \"frames\": {f}, \"points\": {m}, \"scratch_us_per_frame\": {scratch_us:.4}, \
         \"tracker_us_per_frame\": {tracker_us:.4}, \"reused\": {}, \"rebuilt\": {}, \"degenerate\": {}}}",
        stats.reused, stats.rebuilt, stats.degenerate
    );
    Ok(())
}
