//! A fixed workload for counting the instructions of the text loaders, which — unlike times on
//! a shared machine — do not drift: the registered loader (read, gunzip, UTF-8 check, parse,
//! forward kinematics) on one shipped file, `passes` times (default 1), then a checksum of the
//! positions (so two versions can be checked to compute the same bits).
//!
//! ```text
//! cargo build --profile bench -p motionlab-io --example load_instructions
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/load.cg \
//!     $CARGO_TARGET_DIR/release/examples/load_instructions amc 1
//! callgrind_annotate --inclusive=yes /tmp/load.cg | head -40
//! ```
//!
//! `amc` loads CMU 86_01 (4579 frames, 31 joints, 38 points), `bvh` loads CMU 131_01 (994
//! frames); a third argument names another file for the same loader (`amc 1
//! data/mocap6/amc/13_29.amc.gz`), which is how the checksums of every shipped take are
//! compared before and after a change. callgrind's "I refs" divided by the frame count (times `passes`) is the
//! instructions per frame quoted in `crates/motionlab-io/benches/README.md`; the inclusive
//! counts of `read_bytes` (gunzip), `parse_amc`/`parse_bvh_channels` (scanner) and
//! `SkeletonMotion::positions` (forward kinematics) split it by step.

use motionlab_core::registry::{build_loader, default_params};
// Links the crate so its loaders register.
use motionlab_io as _;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let which = args.next().unwrap_or_else(|| "amc".to_string());
    let passes: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(1);
    let data = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data");
    let (loader, default_path) = match which.as_str() {
        "amc" => ("asf_amc", data.join("cmu86/86_01.amc.gz")),
        "bvh" => ("bvh", data.join("cmu131/131_01.bvh.gz")),
        other => return Err(format!("unknown workload {other:?}; expected amc or bvh").into()),
    };
    // An optional third argument loads another take (to compare checksums on every shipped file).
    let path = args.next().map_or(default_path, std::path::PathBuf::from);
    let loader = build_loader(loader, &default_params())?;
    let mut checksum = 0u64;
    let mut frames = 0;
    for _ in 0..passes {
        let motion = loader.load(&path)?;
        frames += motion.n_frames();
        // Order-dependent hash of every coordinate's bits: equal iff the positions are equal.
        for p in motion.positions() {
            for c in p {
                checksum = checksum.rotate_left(5) ^ c.to_bits();
            }
        }
    }
    println!("{which}: {passes} passes, {frames} frames, position bits checksum {checksum:016x}");
    Ok(())
}
