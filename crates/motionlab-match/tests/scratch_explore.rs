use motionlab_core::registry::{build_loader, default_params};
use motionlab_io as _;
use motionlab_match as _;

#[test]
fn explore() {
    let m = build_loader("qualisys_tsv", &default_params()).unwrap().load(&motionlab_testkit::data_path("mct/walk1.tsv.gz")).unwrap();
    println!("{} frames {} pts missing {} rate {} up {:?}", m.n_frames(), m.n_points(), m.missing_count(), m.frame_rate(), m.up_axis());
    for k in 0..m.n_points() { let c = (0..m.n_frames()).filter(|&i| m.is_missing(i,k)).count(); if c>0 { println!("{} {} first {:?}", m.point_names()[k], c, (0..m.n_frames()).find(|&i| m.is_missing(i,k))); } }
}
