//! Sonoda et al.'s pipeline on CMU 86_01 stage by stage — the same work as the `pipeline` bench's
//! `whole_pipeline` at 1× (fresh `FeatureCache` per run, default parameters, one thread) — with
//! the fastest of `runs` runs (default 100) per stage, and a fixed workload for counting
//! instructions, which do not drift with the machine's load as times do:
//!
//! ```text
//! cargo build --profile bench -p motionlab-segment --example pipeline_stages
//! $CARGO_TARGET_DIR/release/examples/pipeline_stages 100
//! valgrind --tool=callgrind --toggle-collect='*Segmenter*segment*' --toggle-collect='*Fuser*fuse*' \
//!     $CARGO_TARGET_DIR/release/examples/pipeline_stages 5
//! ```
//!
//! callgrind's "I refs" divided by 5 × 4579 is the instructions per frame quoted in
//! `crates/motionlab-segment/benches/README.md`.

use motionlab_core::registry::{build_fuser, build_segmenter};
use motionlab_core::{FeatureCache, FrameRate, MethodCandidates};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/cmu86");
    let motion = motionlab_io::asf_amc::load_asf_amc(
        &dir.join("86_01.amc.gz"),
        &dir.join("86.asf"),
        FrameRate::new(120.0)?,
    )?;
    let runs: usize = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(100);
    let empty = toml::Value::Table(Default::default());
    // Name something in this crate so it is linked and its plugins are registered.
    let _ = motionlab_segment::union_merge::cumulative_path_mm(std::iter::empty());
    let names = ["fastest_marker_speed", "direction_change", "hull_volume_change"];
    let segmenters =
        names.iter().map(|n| build_segmenter(n, &empty)).collect::<Result<Vec<_>, _>>()?;
    let fuser = build_fuser("union_merge", &empty)?;
    let mut fastest_ms = [f64::INFINITY; 4];
    let mut fused = 0;
    for _ in 0..runs {
        let cache = FeatureCache::new();
        let mut found = Vec::new();
        for (k, s) in segmenters.iter().enumerate() {
            let t = std::time::Instant::now();
            let candidates = s.segment(&motion, &cache)?.candidates;
            fastest_ms[k] = fastest_ms[k].min(t.elapsed().as_secs_f64() * 1e3);
            found.push(candidates);
        }
        let t = std::time::Instant::now();
        let inputs: Vec<MethodCandidates> = names
            .iter()
            .zip(&found)
            .map(|(method, frames)| MethodCandidates { method, frames })
            .collect();
        fused = fuser.fuse(&motion, &inputs)?.len();
        fastest_ms[3] = fastest_ms[3].min(t.elapsed().as_secs_f64() * 1e3);
    }
    let [speed, direction, hull, fuse] = fastest_ms;
    println!(
        "{runs} runs, {fused} fused boundaries; fastest per stage (ms): speed {speed:.3}, direction {direction:.3}, hull {hull:.3}, fusion {fuse:.3}; sum {:.3} = {:.2} M frames/s",
        speed + direction + hull + fuse,
        motion.n_frames() as f64 / (speed + direction + hull + fuse) / 1e3
    );
    Ok(())
}
