//! The stages chained as an experiment workflow runs them — preprocessor → point detector on the
//! user's take → matcher per window → synchroniser → judgement — on a constructed take holding
//! the paper's three kinds of repetition: (a) close to the model, (b) timing-shifted, (c) wrong.

use motionlab_core::registry::{build_evaluator, build_preprocessor, default_params};
use motionlab_core::{ColumnValues, EvalInput, Point3};
use motionlab_match as _;
use motionlab_match::build_matcher;
use motionlab_match::build_point_detector;
use motionlab_match::build_synchroniser;
use motionlab_match::{MatchingResult, RepetitionResult};
use motionlab_testkit::{Rng, motion_from_fn};

const MARKERS: usize = 4;
const MODEL_FRAMES: usize = 60;

/// Takeback then swing, as in the paper's tennis strokes: 0 → 1 slowly over the first 60 % of
/// the phase, back 1 → 0 fast over the last 40 % (so the speed has one tall hump per repetition,
/// at phase 0.8, and a 1.5× lower one during the takeback).
fn stroke(phase: f64) -> f64 {
    use std::f64::consts::PI;
    if phase < 0.6 {
        (1.0 - (PI * phase / 0.6).cos()) / 2.0
    } else {
        (1.0 + (PI * (phase - 0.6) / 0.4).cos()) / 2.0
    }
}

/// A swing: marker `k` moves out and back along its own direction, farthest for the "hand"
/// (marker 0). `t` in model frames (may be fractional or out of range).
fn swing(t: f64, k: usize) -> Point3 {
    let phase = (t / (MODEL_FRAMES - 1) as f64).clamp(0.0, 1.0);
    let reach = [600.0, 300.0, 250.0, 150.0][k] * stroke(phase);
    let dir = [[1.0, 0.0, 0.2], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8], [0.0, 0.5, 1.0]][k];
    let base =
        [[0.0, 0.0, 1000.0], [200.0, 0.0, 1400.0], [-200.0, 0.0, 1400.0], [0.0, 0.0, 900.0]][k];
    [base[0] + reach * dir[0], base[1] + reach * dir[1], base[2] + reach * dir[2]]
}

/// A different movement with the same hand speed profile (so the detector still finds it):
/// the hand strokes sideways and the other markers circle.
fn wrong(t: f64, k: usize) -> Point3 {
    let phase = (t / (MODEL_FRAMES - 1) as f64).clamp(0.0, 1.0);
    let s = std::f64::consts::TAU * phase;
    let base = swing(0.0, k);
    match k {
        0 => [base[0], base[1] + 600.0 * stroke(phase), base[2]],
        _ => [
            base[0] + 200.0 * s.sin(),
            base[1] + 200.0 * (1.0 - s.cos()),
            base[2] - 100.0 * s.sin(),
        ],
    }
}

#[test]
fn the_close_repetition_is_judged_most_similar_and_the_shifted_one_least_synchronised() {
    let model = motion_from_fn(MODEL_FRAMES, 60.0, MARKERS, |i, k| swing(i as f64, k));
    // The take: rest, (a), rest, (b), rest, (c), rest — each repetition 66 frames (10 % slower
    // than the model), 40 frames of rest between, 1 mm noise everywhere. In (b) markers 2 and 3
    // lag 8 frames behind markers 0 and 1; in (c) the movement is the other one.
    let (rest, rep) = (40usize, 66usize);
    let starts = [rest, 2 * rest + rep, 3 * rest + 2 * rep];
    let frames = 4 * rest + 3 * rep;
    let mut rng = Rng::new(5);
    let noise: Vec<f64> = (0..frames * MARKERS * 3).map(|_| rng.normal()).collect();
    let take = motion_from_fn(frames, 60.0, MARKERS, |j, k| {
        let which = starts.iter().rposition(|&s| j >= s).unwrap_or(0);
        let t = (j as f64 - starts[which] as f64) * (MODEL_FRAMES - 1) as f64 / (rep - 1) as f64;
        let p = match which {
            1 if k >= 2 => swing(t - 8.0, k),
            2 => wrong(t, k),
            _ => swing(t, k),
        };
        let e = &noise[(j * MARKERS + k) * 3..];
        [p[0] + e[0], p[1] + e[1], p[2] + e[2]]
    });

    let pre = build_preprocessor("initial_pose_normalisation", &default_params()).unwrap();
    let (model, take) = (pre.apply(model).unwrap(), pre.apply(take).unwrap());
    let detector = build_point_detector(
        "velocity_peaks",
        &toml::from_str(
            "marker = \"m0\"\ncount = 3\nbefore = { frames = 60 }\nafter = { frames = 30 }\nsmoothing = { frames = 5 }",
        )
        .unwrap(),
    )
    .unwrap();
    let points = detector.detect(&take).unwrap();
    // The hand is fastest in each repetition's swing (phase 0.8: frame 52 of 66).
    for (p, s) in points.peaks.iter().zip(starts) {
        assert!(p.abs_diff(s + 52) <= 2, "peaks {:?}", points.peaks);
    }
    let matcher = build_matcher("multistream_two_stage", &default_params()).unwrap();
    let sync = build_synchroniser("synchronisation", &default_params()).unwrap();
    let repetitions: Vec<RepetitionResult> = points
        .windows
        .iter()
        .zip(["(a) close", "(b) shifted", "(c) wrong"])
        .map(|(&(s, e), label)| {
            let alignment = matcher.align(&model, &take.slice_frames(s, e).unwrap()).unwrap();
            let synchronisation = sync.synchronise(&alignment, model.n_frames()).unwrap();
            RepetitionResult {
                repetition: label.into(),
                window_start: s,
                alignment,
                synchronisation,
            }
        })
        .collect();
    // (a) is matched to its repetition; (b) too, but its common end waits for the lagging
    // markers (8 model frames = 9 take frames later).
    let span = |r: &RepetitionResult| {
        (r.window_start + r.alignment.start, r.window_start + r.alignment.end)
    };
    let ((a0, b0), (a1, b1)) = (span(&repetitions[0]), span(&repetitions[1]));
    assert!(
        a0.abs_diff(starts[0]) <= 3 && b0.abs_diff(starts[0] + rep - 1) <= 3,
        "(a) [{a0}, {b0}]"
    );
    assert!(
        a1.abs_diff(starts[1]) <= 3
            && (0..=12).contains(&(b1 as i64 - (starts[1] + rep - 1) as i64)),
        "(b) [{a1}, {b1}]"
    );
    let (ra, rb) = (repetitions[0].synchronisation.total, repetitions[1].synchronisation.total);
    assert!(rb > 10.0 * ra.max(1.0), "R(a) = {ra}, R(b) = {rb}");
    let result = MatchingResult {
        take: "constructed".into(),
        point_names: model.point_names().to_vec(),
        repetitions,
    };
    let tables = build_evaluator("judgement", &default_params())
        .unwrap()
        .evaluate(EvalInput::new(&vec![result]))
        .unwrap();
    assert_eq!(
        tables[0].column("rank"),
        Some(&ColumnValues::I64(vec![1, 2, 3])),
        "{:?}",
        tables[0]
    );
    assert_eq!(
        tables[0].column("most_similar"),
        Some(&ColumnValues::Bool(vec![true, false, false]))
    );
}
