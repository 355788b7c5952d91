//! A fixed workload for counting the hull tracker's instructions, which — unlike times on a
//! shared machine — do not drift: every frame of CMU 86_01 (4579 frames, 38 joints) through one
//! `HullTracker`, `passes` times (default 10), then the sum of the volumes and the tracker's
//! statistics (so two versions can be checked to do the same work).
//!
//! ```text
//! cargo build --profile bench -p motionlab-features --example hull_instructions
//! valgrind --tool=callgrind --toggle-collect='*HullTracker*frame*' \
//!     $CARGO_TARGET_DIR/release/examples/hull_instructions 10
//! ```
//!
//! callgrind's "I refs" divided by 45 790 (10 × 4579) is the instructions per frame quoted in
//! `crates/motionlab-features/benches/README.md`.

use motionlab_core::FrameRate;
use motionlab_features::hull::HullTracker;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/cmu86");
    let motion = motionlab_io::asf_amc::load_asf_amc(
        &dir.join("86_01.amc.gz"),
        &dir.join("86.asf"),
        FrameRate::new(120.0)?,
    )?;
    let passes: usize = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(10);
    let mut tracker = HullTracker::new();
    let mut sum = 0.0;
    for _ in 0..passes {
        tracker.reset();
        for i in 0..motion.n_frames() {
            sum += tracker.frame(motion.frame(i)).volume_mm3;
        }
    }
    println!(
        "{passes} passes over {} frames: Σ volume = {sum} mm³, {:?}",
        motion.n_frames(),
        tracker.stats()
    );
    Ok(())
}
