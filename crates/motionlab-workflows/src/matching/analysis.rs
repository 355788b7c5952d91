//! What the matches say beyond the evaluators: the warping paths' out-of-step markers and the
//! paper's (a)/(b)/(c) timing test.

use serde::Serialize;

use motionlab_match::judgement::{Scores, ranks, scores};

use super::ItemResult;

/// Mean matched target frame of each model frame on a path (model frames without a pair: NaN).
pub(super) fn mean_target_frames(path: &[(usize, usize)], model_frames: usize) -> Vec<f64> {
    let mut sum = vec![0.0; model_frames];
    let mut count = vec![0usize; model_frames];
    for &(i, j) in path {
        if i < model_frames {
            sum[i] += j as f64;
            count[i] += 1;
        }
    }
    sum.iter().zip(&count).map(|(s, &c)| if c == 0 { f64::NAN } else { s / c as f64 }).collect()
}

/// The two points whose matched frames at the examined model frames differ most (summed).
pub(super) fn most_out_of_step(
    paths: &[Vec<(usize, usize)>],
    frames: &[usize],
    model_frames: usize,
) -> Option<(usize, usize)> {
    let u: Vec<Vec<f64>> = paths.iter().map(|p| mean_target_frames(p, model_frames)).collect();
    let at = |l: usize, i: usize| u[l].get(i).copied().unwrap_or(f64::NAN);
    let mut best: Option<(f64, usize, usize)> = None;
    for l1 in 0..u.len() {
        for l2 in l1 + 1..u.len() {
            let d: f64 = frames
                .iter()
                .map(|&i| (at(l1, i) - at(l2, i)).abs())
                .filter(|v| v.is_finite())
                .sum();
            if best.is_none_or(|(b, _, _)| d > b) {
                best = Some((d, l1, l2));
            }
        }
    }
    best.map(|(_, a, b)| (a, b))
}

/// A row of `timing_ranks`.
#[derive(Serialize)]
pub(super) struct TimingRank {
    take: String,
    repetition: String,
    group: String,
    pair: Option<String>,
    #[serde(rename = "H_mm")]
    h_mm: f64,
    #[serde(rename = "R_frames2")]
    r_frames2: f64,
    #[serde(rename = "H_norm")]
    h_norm: f64,
    #[serde(rename = "R_norm")]
    r_norm: f64,
    score: f64,
    rank_score: usize,
    #[serde(rename = "rank_H")]
    rank_h: usize,
    #[serde(rename = "rank_R")]
    rank_r: usize,
}

/// A row of `timing_verdict`.
#[derive(Serialize)]
pub(super) struct Verdict {
    take: String,
    check: String,
    held: bool,
    detail: String,
}

pub(super) fn fmt(v: f64) -> String {
    motionlab_core::table::fmt_num(v)
}

/// The paper's (a)/(b)/(c) test on every explicit take whose repetitions carry groups.
pub(super) fn timing_test(results: &[ItemResult]) -> (Vec<TimingRank>, Vec<Verdict>) {
    let mut ranks_out = Vec::new();
    let mut verdicts = Vec::new();
    for r in results.iter().filter(|r| r.repetitions.iter().any(|rep| rep.group.is_some())) {
        let reps = &r.repetitions;
        let h: Vec<f64> = reps.iter().map(|x| x.total_distance).collect();
        let rr: Vec<f64> = reps.iter().map(|x| x.sync_total).collect();
        // The judgement rule itself (§4.1), and its ranking applied to H and R alone.
        let Scores { h_norm: hn, r_norm: rn, score } = scores(&h, &rr);
        let (rank_s, rank_h, rank_r) = (ranks(&score), ranks(&h), ranks(&rr));
        let group = |k: usize| reps[k].group.clone().unwrap_or_default();
        for k in 0..reps.len() {
            ranks_out.push(TimingRank {
                take: r.take.clone(),
                repetition: reps[k].label.clone(),
                group: group(k),
                pair: reps[k].pair.clone(),
                h_mm: h[k],
                r_frames2: rr[k],
                h_norm: hn[k],
                r_norm: rn[k],
                score: score[k],
                rank_score: rank_s[k],
                rank_h: rank_h[k],
                rank_r: rank_r[k],
            });
        }
        let of = |g: &str| -> Vec<usize> { (0..reps.len()).filter(|&k| group(k) == g).collect() };
        let (a, b, c) = (of("a"), of("b"), of("c"));
        let list = |ks: &[usize], v: &[f64]| {
            ks.iter()
                .map(|&k| format!("{} {}", reps[k].label, fmt(v[k])))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let mut add = |check: &str, held: bool, detail: String| {
            verdicts.push(Verdict { take: r.take.clone(), check: check.to_string(), held, detail });
        };
        if !a.is_empty() && !b.is_empty() {
            let pairs: Vec<(usize, usize)> = b
                .iter()
                .filter_map(|&kb| {
                    let p = reps[kb].pair.as_ref()?;
                    a.iter().find(|&&ka| reps[ka].pair.as_ref() == Some(p)).map(|&ka| (ka, kb))
                })
                .collect();
            if !pairs.is_empty() {
                let held = pairs.iter().all(|&(ka, kb)| rr[kb] > rr[ka]);
                let detail = pairs
                    .iter()
                    .map(|&(ka, kb)| {
                        format!(
                            "{}: R(a) {} → R(b) {}",
                            reps[ka].pair.clone().unwrap_or_default(),
                            fmt(rr[ka]),
                            fmt(rr[kb])
                        )
                    })
                    .collect::<Vec<_>>()
                    .join("; ");
                add(
                    "R: each timing-shifted (b) is less synchronised than the (a) it was made from",
                    held,
                    detail,
                );
            }
            let max_a = a.iter().map(|&k| rr[k]).fold(f64::NEG_INFINITY, f64::max);
            let min_b = b.iter().map(|&k| rr[k]).fold(f64::INFINITY, f64::min);
            add(
                "R: every (b) is less synchronised than every (a)",
                min_b > max_a,
                format!("R of (a): {}; R of (b): {}", list(&a, &rr), list(&b, &rr)),
            );
        }
        let first = |rank: &[usize]| rank.iter().position(|&x| x == 1).unwrap_or(0);
        if !a.is_empty() {
            let top = first(&rank_s);
            add(
                "score: the most similar repetition is an (a)",
                group(top) == "a",
                format!(
                    "most similar: {} ({}), score {}",
                    reps[top].label,
                    group(top),
                    fmt(score[top])
                ),
            );
            let top_h = first(&rank_h);
            add(
                "H alone: the most similar repetition is an (a)",
                group(top_h) == "a",
                format!(
                    "least H: {} ({}), H {} mm",
                    reps[top_h].label,
                    group(top_h),
                    fmt(h[top_h])
                ),
            );
        }
        if !a.is_empty() && !c.is_empty() {
            let max_a = a.iter().map(|&k| score[k]).fold(f64::NEG_INFINITY, f64::max);
            let min_c = c.iter().map(|&k| score[k]).fold(f64::INFINITY, f64::min);
            add(
                "score: every wrong-motion (c) is less similar than every (a)",
                min_c > max_a,
                format!("score of (a): {}; score of (c): {}", list(&a, &score), list(&c, &score)),
            );
        }
        if !b.is_empty() || !c.is_empty() {
            let worst = rank_s.iter().position(|&x| x == reps.len()).unwrap_or(0);
            add(
                "score: the most dissimilar repetition is a (b) or a (c)",
                matches!(group(worst).as_str(), "b" | "c"),
                format!(
                    "most dissimilar: {} ({}), score {}",
                    reps[worst].label,
                    group(worst),
                    fmt(score[worst])
                ),
            );
        }
    }
    (ranks_out, verdicts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::matching::RepetitionRecord;

    #[test]
    fn mean_target_frames_average_runs_and_leave_gaps_nan() {
        // Model frame 1 matched to target frames 3, 4, 5; frame 3 never reached.
        let path = [(0, 2), (1, 3), (1, 4), (1, 5), (2, 6)];
        let u = mean_target_frames(&path, 4);
        assert_eq!(&u[..3], &[2.0, 4.0, 6.0]);
        assert!(u[3].is_nan());
    }

    #[test]
    fn the_most_out_of_step_pair_is_found() {
        let diag = |shift: usize| (0..10).map(|i| (i, i + shift)).collect::<Vec<_>>();
        let paths = vec![diag(0), diag(1), diag(5), diag(2)];
        assert_eq!(most_out_of_step(&paths, &[2, 5, 8], 10), Some((0, 2)));
        assert_eq!(most_out_of_step(&paths[..1], &[2], 10), None);
    }

    fn rep(label: &str, group: &str, pair: &str, h: f64, r: f64) -> RepetitionRecord {
        RepetitionRecord {
            label: label.into(),
            group: Some(group.into()),
            pair: (!pair.is_empty()).then(|| pair.to_string()),
            peaks: vec![],
            window_start: 0,
            window_end: 10,
            start: 0,
            end: 9,
            point_distances: vec![h],
            total_distance: h,
            sync_frames: vec![5],
            section_values: vec![r],
            sync_total: r,
        }
    }

    fn take(reps: Vec<RepetitionRecord>) -> ItemResult {
        ItemResult {
            take: "t".into(),
            continuous: false,
            frame_rate_hz: 120.0,
            model_frames: 10,
            point_names: vec!["p".into()],
            threshold: None,
            repetitions: reps,
            velocity: None,
        }
    }

    #[test]
    fn the_timing_verdict_states_each_check_and_whether_it_held() {
        // (a) close: small H and R; (b) its delayed copy: same H, larger R; (c) wrong: large H.
        let ok = take(vec![
            rep("a1", "a", "1", 10.0, 1.0),
            rep("b1", "b", "1", 11.0, 4.0),
            rep("c", "c", "", 30.0, 2.0),
        ]);
        let (ranks_rows, v) = timing_test(&[ok]);
        assert_eq!(ranks_rows.len(), 3);
        assert_eq!(ranks_rows.iter().map(|r| r.rank_score).collect::<Vec<_>>(), vec![1, 2, 3]);
        let held: Vec<(&str, bool)> = v.iter().map(|x| (x.check.as_str(), x.held)).collect();
        assert_eq!(held.len(), 6, "{held:?}");
        assert!(held.iter().all(|(_, h)| *h), "{held:?}");
        assert!(v[0].detail.contains("R(a) 1 → R(b) 4"), "{}", v[0].detail);
        // A (b) that is *better* synchronised than its (a), and an (a) ranked last by score.
        let bad = take(vec![
            rep("a1", "a", "1", 10.0, 9.0),
            rep("b1", "b", "1", 10.0, 2.0),
            rep("c", "c", "", 9.0, 1.0),
        ]);
        let (_, v) = timing_test(&[bad]);
        let held: Vec<bool> = v.iter().map(|x| x.held).collect();
        // pairwise R, every-b-vs-every-a R, score top is (a), H top is (a), c worse than a, worst is b/c
        assert_eq!(
            held,
            vec![false, false, false, false, false, false],
            "{:?}",
            v.iter().map(|x| &x.detail).collect::<Vec<_>>()
        );
        // Without groups there is no timing test.
        let mut plain = take(vec![rep("r1", "a", "", 1.0, 1.0)]);
        plain.repetitions[0].group = None;
        assert!(timing_test(&[plain]).1.is_empty());
    }
}
