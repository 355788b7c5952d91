//! Cost of the `fill_gaps` preprocessor on a real recording (divan, one core).
//!
//! `cargo bench -p motionlab-features --bench gap_fill` — results in `benches/README.md`.

use divan::counter::ItemsCount;
use divan::{Bencher, black_box};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Loader, Motion, TimeSpan};
use motionlab_features::gap_fill::{EdgeFill, FillGapsParams, GapFillMethod};
use motionlab_io::qualisys_tsv::QualisysTsvParams;

fn main() {
    divan::main();
}

/// mct/dance1 (1500 frames at 60 Hz, 28 markers) with every marker losing 12 frames (0.2 s)
/// every 68 frames: 17 % of all samples missing, in 606 gaps.
fn damaged_dance() -> Motion {
    let loader = QualisysTsvParams { up_axis: motionlab_core::Axis::Z }.check().unwrap();
    let mut motion = loader.load(&motionlab_testkit::data_path("mct/dance1.tsv.gz")).unwrap();
    let (n, m) = (motion.n_frames(), motion.n_points());
    for k in 0..m {
        let mut start = 10 + (k * 7) % 68;
        while start + 22 < n {
            for f in start..start + 12 {
                motion.positions_mut()[f * m + k] = [f64::NAN; 3];
            }
            start += 68;
        }
    }
    motion.refresh_missing();
    motion
}

fn bench_method(bencher: Bencher, method: GapFillMethod) {
    let motion = damaged_dance();
    let stage = FillGapsParams {
        max_gap: TimeSpan::Seconds(0.2),
        method,
        support: 4,
        edges: EdgeFill::Leave,
    }
    .check()
    .unwrap();
    bencher
        .counter(ItemsCount::new(motion.n_frames() * motion.n_points()))
        .bench(|| stage.fill(black_box(&motion)).len());
}

#[divan::bench]
fn cubic(bencher: Bencher) {
    bench_method(bencher, GapFillMethod::Cubic);
}

#[divan::bench]
fn linear(bencher: Bencher) {
    bench_method(bencher, GapFillMethod::Linear);
}

/// The same recording without gaps: the cost of scanning the mask when there is nothing to do.
#[divan::bench]
fn complete_recording(bencher: Bencher) {
    let loader = QualisysTsvParams { up_axis: motionlab_core::Axis::Z }.check().unwrap();
    let motion = loader.load(&motionlab_testkit::data_path("mct/dance1.tsv.gz")).unwrap();
    let stage = FillGapsParams {
        max_gap: TimeSpan::Seconds(0.2),
        method: GapFillMethod::Cubic,
        support: 4,
        edges: EdgeFill::Leave,
    }
    .check()
    .unwrap();
    bencher
        .counter(ItemsCount::new(motion.n_frames() * motion.n_points()))
        .bench(|| stage.fill(black_box(&motion)).len());
}
