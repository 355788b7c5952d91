//! Per-frame convex-hull volume on real frames, one core: our quickhull rebuilt every frame
//! (`builder`), the temporally coherent tracker (`tracker`, the one `hull_volume` uses) and
//! parry3d-f64's convex hull (`parry`, a general-purpose crate) on the same frames, in one run.
//! Frames: MoCap Toolbox dance1 (1500 × 28 markers, 60 Hz) and CMU 86_01 (4579 × 38 joints,
//! 120 fps). The scipy comparison is `bench/hull_vs_scipy.py`.
//!
//! `cargo bench -p motionlab-features --bench hull` (results in `README.md` beside this file).

use std::sync::LazyLock;

use divan::Bencher;
use divan::counter::ItemsCount;
use motionlab_core::{Axis, FrameRate, Point3};
use motionlab_features::hull::{HullBuilder, HullTracker};

fn main() {
    divan::main();
}

const TAKES: &[&str] = &["mct/dance1.tsv.gz", "cmu86/86_01.amc.gz"];

fn data(relative: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data").join(relative)
}

/// Every frame's valid points, per take.
static FRAMES: LazyLock<Vec<Vec<Vec<Point3>>>> = LazyLock::new(|| {
    TAKES
        .iter()
        .map(|t| {
            let path = data(t);
            let m = if t.contains(".amc") {
                motionlab_io::asf_amc::load_asf_amc(
                    &path,
                    &data("cmu86/86.asf"),
                    FrameRate::new(120.0).unwrap(),
                )
            } else {
                motionlab_io::qualisys_tsv::parse_qualisys_tsv(
                    &motionlab_io::read::read_text(&path).unwrap(),
                    &path,
                    Axis::Z,
                )
            }
            .expect("shipped take loads");
            (0..m.n_frames())
                .map(|i| m.frame(i).iter().copied().filter(|p| p[0].is_finite()).collect())
                .collect()
        })
        .collect()
});

fn frames(take: &str) -> &'static [Vec<Point3>] {
    &FRAMES[TAKES.iter().position(|t| *t == take).unwrap()]
}

#[divan::bench(args = TAKES)]
fn builder(bencher: Bencher, take: &str) {
    let f = frames(take);
    let mut b = HullBuilder::new();
    bencher
        .counter(ItemsCount::new(f.len()))
        .bench_local(|| f.iter().map(|p| b.volume(p).volume_mm3).sum::<f64>());
}

#[divan::bench(args = TAKES)]
fn tracker(bencher: Bencher, take: &str) {
    let f = frames(take);
    let mut t = HullTracker::new();
    bencher.counter(ItemsCount::new(f.len())).bench_local(|| {
        t.reset();
        f.iter().map(|p| t.frame(p).volume_mm3).sum::<f64>()
    });
}

/// The tracker without local repairs (certify unchanged triangles or rebuild: the tracker as it
/// was before repairs), for comparison in the same run.
#[divan::bench(args = TAKES)]
fn tracker_without_repairs(bencher: Bencher, take: &str) {
    let f = frames(take);
    let mut t = HullTracker::without_repairs();
    bencher.counter(ItemsCount::new(f.len())).bench_local(|| {
        t.reset();
        f.iter().map(|p| t.frame(p).volume_mm3).sum::<f64>()
    });
}

#[divan::bench(args = TAKES, sample_count = 10)]
fn parry(bencher: Bencher, take: &str) {
    let f: Vec<Vec<parry3d_f64::math::Vector>> = frames(take)
        .iter()
        .map(|fr| fr.iter().map(|p| parry3d_f64::math::Vector::new(p[0], p[1], p[2])).collect())
        .collect();
    bencher.counter(ItemsCount::new(f.len())).bench_local(|| {
        f.iter()
            .map(|p| {
                parry3d_f64::transformation::try_convex_hull(p).map(|(v, _)| v.len()).unwrap_or(0)
            })
            .sum::<usize>()
    });
}
