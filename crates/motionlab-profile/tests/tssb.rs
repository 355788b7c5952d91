//! `clasp` and `floss` on real TSSB series against the peers' outputs, printed by claspy 0.2.8
//! and stumpy 1.14.1 (`bench/profile_vs_peers.py --series ArrowHead Beef Adiac` runs the same
//! comparison live).

use motionlab_core::ParamGuard;
use motionlab_profile::clasp::WindowWidth;
use motionlab_profile::{ClaspParams, FlossParams};

fn tssb(name: &str) -> Vec<f64> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/tssb/datasets");
    let text = std::fs::read_to_string(format!("{path}/{name}.txt")).expect("TSSB series");
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.trim().parse().expect("float"))
        .collect()
}

#[test]
fn clasp_gives_claspys_change_points_and_windows() {
    let stage = ClaspParams::default().check().unwrap();
    // claspy: BinaryClaSPSegmentation().fit_predict(ts), and its window_size after fit.
    for (name, window, cps) in [
        ("ArrowHead", 16, vec![742]),
        ("Beef", 33, vec![686]),
        ("Adiac", 11, vec![334, 564, 1007, 1224]),
    ] {
        let x = tssb(name);
        assert_eq!(stage.window_width(&x, 1).unwrap(), window, "{name}");
        assert_eq!(stage.segment_values(&x, 1).unwrap().candidates, cps, "{name}");
    }
}

#[test]
fn clasp_profile_matches_claspys_at_its_maximum() {
    // claspy: p = ClaSP(window_size=10).fit(ArrowHead).profile; p.argmax(), p.max(), and the
    // first and last finite split points (−∞ outside: the 50-sample margins, and splits where
    // every window is predicted on one side).
    let x = tssb("ArrowHead");
    let p = ClaspParams::default().check().unwrap().profile(&x, 1, 10).unwrap();
    assert_eq!(p.len(), x.len() - 10 + 1);
    let first = p.iter().position(|v| v.is_finite()).unwrap();
    let last = p.iter().rposition(|v| v.is_finite()).unwrap();
    assert_eq!((first, last), (70, 1456));
    let (at, max) = p
        .iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
    assert_eq!(at, CLASPY_ARGMAX);
    assert!((max - CLASPY_MAX).abs() < 1e-12, "{max}");
}

#[test]
fn floss_gives_stumpys_regimes() {
    // stumpy: I = stump(ts, m)[:, 1]; fluss(I, L=m, n_regimes, custom_iac=2i(k−i)/k)[1].
    let x = tssb("Adiac");
    let stage = FlossParams {
        window: WindowWidth::Samples(10),
        n_regimes: Some(5),
        cac_threshold: None,
        excl_factor: 5,
    }
    .check()
    .unwrap();
    assert_eq!(stage.segment_values(&x, 1).unwrap().candidates, vec![563, 613, 1008, 1224]);
}

const CLASPY_ARGMAX: usize = 750;
const CLASPY_MAX: f64 = 0.763_665_084_555_594_1;
