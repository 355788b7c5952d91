//! Real motions through the `butterworth` preprocessor, as JSON for the scipy cross-check
//! (`tests/butterworth_vs_scipy.py`): per point and coordinate, the raw samples (null where
//! missing) and the filtered ones.
//!
//! `cargo run -p motionlab-features --example butterworth_dump -- ORDER CUTOFF_HZ MAX_POINTS FILE…`
//! (FILE relative to `data/`: `.tsv.gz` read as Qualisys TSV, `.amc.gz` as ASF/AMC).

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Axis, Loader, Motion, Preprocessor};
use motionlab_features::butterworth::ButterworthParams;
use motionlab_io::asf_amc::AsfAmcParams;
use motionlab_io::qualisys_tsv::QualisysTsvParams;
use serde_json::{Value, json};

fn column(m: &Motion, k: usize, c: usize) -> Vec<Value> {
    (0..m.n_frames())
        .map(|i| if m.is_missing(i, k) { Value::Null } else { json!(m.position(i, k)[c]) })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [order, cutoff, max_points, files @ ..] = args.as_slice() else {
        return Err("usage: butterworth_dump ORDER CUTOFF_HZ MAX_POINTS FILE…".into());
    };
    let stage = ButterworthParams { order: order.parse()?, cutoff_hz: cutoff.parse()? }.check()?;
    let max_points: usize = max_points.parse()?;
    let mut out = Vec::new();
    for file in files {
        let path = motionlab_testkit::data_path(file);
        let motion = if file.ends_with(".amc.gz") {
            serde_json::from_value::<AsfAmcParams>(json!({}))?.check()?.load(&path)?
        } else {
            QualisysTsvParams { up_axis: Axis::Z }.check()?.load(&path)?
        };
        let filtered = stage.apply(motion.clone())?;
        let mut series = Vec::new();
        for k in 0..motion.n_points().min(max_points) {
            for c in 0..3 {
                series.push(json!({
                    "point": motion.point_names()[k],
                    "coordinate": c,
                    "raw": column(&motion, k, c),
                    "filtered": column(&filtered, k, c),
                }));
            }
        }
        out.push(json!({ "file": file, "rate_hz": motion.frame_rate().hz(), "series": series }));
    }
    println!("{}", json!({ "order": stage.order, "cutoff_hz": stage.cutoff_hz, "motions": out }));
    Ok(())
}
