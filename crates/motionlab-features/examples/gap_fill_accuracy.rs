//! How far from the truth does `fill_gaps` put a marker? Removes runs of samples from complete
//! real recordings (MoCap Toolbox walk2, dance1, dance2: 60 Hz, 28 markers, no missing samples),
//! fills them with `linear` and `cubic`, and prints the 3-D error over the removed samples for
//! several gap lengths.
//!
//! `cargo run --release -p motionlab-features --example gap_fill_accuracy`

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Loader, Motion, Preprocessor, TimeSpan};
use motionlab_features::gap_fill::{EdgeFill, FillGapsParams, GapFillMethod};
use motionlab_io::qualisys_tsv::QualisysTsvParams;

/// Removes, in every marker, runs of `len` frames every `period` frames (staggered by marker).
/// Returns the damaged copy and the removed (frame, marker) samples.
fn inject(motion: &Motion, len: usize, period: usize) -> (Motion, Vec<(usize, usize)>) {
    let mut damaged = motion.clone();
    let m = motion.n_points();
    let n = motion.n_frames();
    let mut removed = Vec::new();
    for k in 0..m {
        let mut start = 10 + (k * 7) % period;
        while start + len + 10 < n {
            for f in start..start + len {
                damaged.positions_mut()[f * m + k] = [f64::NAN; 3];
                removed.push((f, k));
            }
            start += period;
        }
    }
    damaged.refresh_missing();
    (damaged, removed)
}

fn main() -> motionlab_core::Result<()> {
    let loader = QualisysTsvParams { up_axis: motionlab_core::Axis::Z }.check()?;
    println!(
        "| recording | gap (frames @ 60 Hz) | gap (s) | method | RMS error (mm) | 95th pct (mm) | max (mm) |"
    );
    println!("|---|---:|---:|---|---:|---:|---:|");
    for name in ["walk2", "dance1", "dance2"] {
        let motion = loader.load(&motionlab_testkit::data_path(&format!("mct/{name}.tsv.gz")))?;
        assert_eq!(motion.missing_count(), 0, "{name} should be complete");
        for len in [3, 6, 12, 18, 30] {
            let (damaged, removed) = inject(&motion, len, 4 * len + 20);
            for method in [GapFillMethod::Linear, GapFillMethod::Cubic] {
                let stage = FillGapsParams {
                    max_gap: TimeSpan::Frames(len as f64),
                    method,
                    support: 4,
                    edges: EdgeFill::Leave,
                }
                .check()?;
                let filled = stage.apply(damaged.clone())?;
                let mut errors: Vec<f64> = removed
                    .iter()
                    .map(|&(f, k)| {
                        let (a, b) = (filled.position(f, k), motion.position(f, k));
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                            .sqrt()
                    })
                    .collect();
                errors.sort_by(f64::total_cmp);
                let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
                let p95 = errors[(errors.len() as f64 * 0.95) as usize];
                let max = errors[errors.len() - 1];
                println!(
                    "| {name} | {len} | {:.3} | {method:?} | {rms:.2} | {p95:.2} | {max:.2} |",
                    len as f64 / motion.frame_rate().hz()
                );
            }
        }
    }
    Ok(())
}
