//! Viewer pages on real data: a five-minute 120 fps take stays under 10 MB.
//!
//! The four CMU takes in `data/` (86_01, 13_29, 13_30, 13_31: 38 joint points at 120 Hz) laid
//! end to end, then again time-reversed, then mirrored, make 36 000 frames — the 5-minute take, with
//! more points than its 31 — rendered with a candidate lane and a trace lane. (A take simply
//! repeated would flatter the size: gzip finds a repeat within its 32 KB window.) `MOTIONLAB_VIEWER_OUT=DIR` keeps the page (for `tests/browser/check_viewer.py`,
//! which measures its open time).

use motionlab_core::viewer::{EventKind, EventLane, Lane, TraceLane, ViewerMotion, ViewerSpec};
use motionlab_core::{Motion, Point3, Trace, registry};

use motionlab_io as _;

#[test]
fn a_five_minute_real_take_gives_a_viewer_under_ten_megabytes() {
    let params = toml::Value::Table(toml::Table::new());
    let loader = registry::build_loader("asf_amc", &params).unwrap();
    let takes: Vec<Motion> = [
        "cmu86/86_01.amc.gz",
        "mocap6/amc/13_29.amc.gz",
        "mocap6/amc/13_30.amc.gz",
        "mocap6/amc/13_31.amc.gz",
    ]
    .iter()
    .map(|f| loader.load(&motionlab_testkit::data_path(f)).unwrap())
    .collect();
    let take = &takes[0];
    let names = take.point_names().to_vec();
    let takes: Vec<Motion> = takes.iter().map(|t| t.select_points(&names).unwrap()).collect();
    let n = 36_000;
    let mut positions: Vec<Point3> = Vec::with_capacity(n * names.len());
    for (reversed, mirrored) in [(false, false), (true, false), (false, true)] {
        for t in &takes {
            for f in 0..t.n_frames() {
                let frame = t.frame(if reversed { t.n_frames() - 1 - f } else { f });
                positions
                    .extend(frame.iter().map(|p| if mirrored { [-p[0], p[1], p[2]] } else { *p }));
            }
        }
    }
    assert!(positions.len() >= n * names.len(), "only {} frames", positions.len() / names.len());
    positions.truncate(n * names.len());
    let long = Motion::new(
        "cmu_x8",
        take.frame_rate(),
        take.up_axis(),
        take.point_kind(),
        names.clone(),
        positions,
    )
    .unwrap();
    let mut motion = ViewerMotion::from_motion(&long, &[], Some("root")).unwrap();
    motion.bones = take.skeleton.as_ref().map(|s| s.skeleton.bones()).unwrap_or_default();
    assert!(!motion.bones.is_empty());
    let root = long.point_index("root").unwrap();
    let speed: Vec<f64> = (0..n)
        .map(|f| {
            let (a, b) = (long.position(f.saturating_sub(1), root), long.position(f, root));
            ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt() * 120.0
        })
        .collect();
    let mut spec = ViewerSpec::new(
        "cmu_5_min",
        "CMU 86_01, 13_29–13_31 forward and reversed: 5 minutes at 120 Hz",
        motion,
    );
    let every_2_s: Vec<usize> = (0..n).step_by(240).collect();
    spec.lanes.push(Lane::Events(EventLane::new("candidates", EventKind::Fused, &every_2_s)));
    spec.lanes.extend(
        TraceLane::from_traces("root", &[Trace::new("root_speed_mm_per_s", "mm/s", speed)], &[], n)
            .into_iter()
            .map(Lane::Trace),
    );
    let dir = match std::env::var_os("MOTIONLAB_VIEWER_OUT") {
        Some(d) => std::path::PathBuf::from(d),
        None => std::env::temp_dir().join(format!("mlab-viewer-{}", std::process::id())),
    };
    let path = motionlab_report::viewer::write_with_back_link(&dir, &spec, None).unwrap();
    let bytes = std::fs::metadata(&path).unwrap().len();
    eprintln!("{}: {bytes} bytes for {n} frames × {} points", path.display(), take.n_points());
    assert!(bytes < 10_000_000, "{bytes} bytes");
    if std::env::var_os("MOTIONLAB_VIEWER_OUT").is_none() {
        std::fs::remove_dir_all(&dir).ok();
    }
}
