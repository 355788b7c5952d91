//! Synchroniser `synchronisation`: how much the markers' warping paths disagree (§3.2).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::{Alignment, Synchronisation, Synchroniser};
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, Result};

/// Synchronisation of the markers along a two-stage alignment (Yabe & Tanaka §3.2).
///
/// From marker `l`'s warping path, `u_l(i)` is the target frame matched to model frame `i`.
/// At `k` model frames `i_q` the markers' `u_l(i_q)` are compared:
/// `r_q = (1/L) Σ_l (u_l(i_q) − U_q)²` with `U_q = (1/L) Σ_l u_l(i_q)` (population variance
/// over the L markers, frames²), and `R = Σ_q r_q`. `r_q = 0` when every marker reaches model
/// frame `i_q` at the same target frame; a large `r_q` means the body parts are out of step
/// there.
///
/// The `k` model frames divide the model's frames `0..n−1` into `k + 1` equal sections:
/// `i_q = round(q · (n − 1) / (k + 1))` for `q = 1..k` (halves round up). With the paper's
/// `k = 8` and a model of `n = 10` frames that is frames 1, 2, …, 8; with `n = 120`,
/// frames 13, 26, 40, 53, 66, 79, 93, 106. The model needs at least `k + 2` frames so the
/// `k` frames are distinct.
///
/// **Choice** (the paper is silent): a path may match model frame `i` to several target frames
/// (a run of target steps); `tie` picks their mean, the first or the last.
///
/// Missing samples: none reach this stage — it reads the matcher's paths, and the matchers
/// refuse missing samples. It fails when the matcher kept no paths (`keep_paths = false`).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SynchronisationParams {
    /// `k`: number of model frames examined (they divide the model into `k + 1` equal
    /// sections; the default is the paper's value, §5.2.2).
    #[serde(default = "default_k")]
    pub k: usize,
    /// Which target frame stands for model frame `i` when the path matches it to several:
    /// `"mean"` (their mean, fractional), `"first"` or `"last"`.
    #[serde(default)]
    pub tie: TieRule,
}

fn default_k() -> usize {
    8
}

/// How `u_l(i)` is read from a path that matches model frame `i` to several target frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum TieRule {
    /// The mean of the matched target frames.
    #[default]
    Mean,
    /// The earliest matched target frame.
    First,
    /// The latest matched target frame.
    Last,
}

/// The validated stage.
#[derive(Clone, Copy, Debug)]
pub struct SynchronisationStage {
    k: usize,
    tie: TieRule,
}

impl ParamGuard for SynchronisationParams {
    type Checked = SynchronisationStage;
    fn check(self) -> Result<SynchronisationStage> {
        if self.k == 0 {
            return Err(Error::new(
                ErrorKind::OutOfRange,
                "expected at least one model frame to examine (k >= 1), found 0",
            )
            .with_field("k"));
        }
        Ok(SynchronisationStage { k: self.k, tie: self.tie })
    }
}

/// The `k` model frames dividing frames `0..n−1` into `k + 1` equal sections:
/// `round(q · (n − 1) / (k + 1))`, `q = 1..k`.
pub fn division_frames(n: usize, k: usize) -> Result<Vec<usize>> {
    if k == 0 || n < k + 2 {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("dividing a model of {n} frames into k + 1 = {} sections needs at least k + 2 = {} frames", k + 1, k + 2),
        )
        .with_field("k"));
    }
    let step = (n - 1) as f64 / (k + 1) as f64;
    // step >= 1, so consecutive rounded values differ by at least one frame.
    Ok((1..=k).map(|q| (q as f64 * step).round() as usize).collect())
}

/// `u(i)` for each requested model frame (sorted ascending) from one warping path.
///
/// Fails when the path does not cover a requested frame or is not ordered by model frame.
pub fn matched_target_frames(
    path: &[(usize, usize)],
    model_frames: &[usize],
    tie: TieRule,
) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(model_frames.len());
    let mut pos = 0;
    for &want in model_frames {
        // Skip to the first pair of model frame `want`; paths are sorted by model frame.
        while pos < path.len() && path[pos].0 < want {
            pos += 1;
        }
        let run = path[pos..].iter().take_while(|&&(i, _)| i == want);
        let (mut first, mut last, mut sum, mut count) = (None, 0usize, 0.0, 0usize);
        for &(_, j) in run {
            first.get_or_insert(j);
            last = j;
            sum += j as f64;
            count += 1;
        }
        let Some(first) = first else {
            return Err(Error::new(
                ErrorKind::Mismatch,
                format!(
                    "the warping path never reaches model frame {want}; expected a path over every model frame"
                ),
            ));
        };
        out.push(match tie {
            TieRule::Mean => sum / count as f64,
            TieRule::First => first as f64,
            TieRule::Last => last as f64,
        });
        pos += count;
    }
    Ok(out)
}

/// Population variance (divides by the count).
pub fn population_variance(values: &[f64]) -> f64 {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n
}

impl Synchroniser for SynchronisationStage {
    fn synchronise(&self, alignment: &Alignment, model_frames: usize) -> Result<Synchronisation> {
        if alignment.paths.is_empty() {
            return Err(Error::new(
                ErrorKind::InvalidParameter,
                "synchronisation needs the matcher's warping paths, but the alignment has none; \
                 set keep_paths = true on the matcher",
            ));
        }
        let frames = division_frames(model_frames, self.k)?;
        let per_marker: Vec<Vec<f64>> = alignment
            .paths
            .iter()
            .map(|p| matched_target_frames(p, &frames, self.tie))
            .collect::<Result<_>>()?;
        let section_values: Vec<f64> = (0..frames.len())
            .map(|q| population_variance(&per_marker.iter().map(|u| u[q]).collect::<Vec<_>>()))
            .collect();
        let total = section_values.iter().sum();
        Ok(Synchronisation { model_frames: frames, section_values, total })
    }
}

motionlab_core::register_custom_plugin!(
    crate::Synchroniser,
    SynchronisationParams,
    "synchronisation",
    kind = "synchroniser"
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_synchroniser;

    fn alignment(paths: Vec<Vec<(usize, usize)>>) -> Alignment {
        let l = paths.len();
        Alignment { start: 0, end: 0, point_distances: vec![0.0; l], total_distance: 0.0, paths }
    }

    #[test]
    fn division_frames_split_the_model_into_equal_sections() {
        assert_eq!(division_frames(10, 8).unwrap(), (1..=8).collect::<Vec<_>>());
        assert_eq!(division_frames(120, 8).unwrap(), vec![13, 26, 40, 53, 66, 79, 93, 106]);
        // 0..=6 into 4 sections: 1.5, 3, 4.5 -> 2, 3, 5 (halves round up).
        assert_eq!(division_frames(7, 3).unwrap(), vec![2, 3, 5]);
        let e = division_frames(9, 8).unwrap_err();
        assert!(e.to_string().contains("at least k + 2 = 10"), "{e}");
    }

    #[test]
    fn the_papers_figure_4_example() {
        // Fig. 4: n = 7, m = 5 (1-based there). T1: t1 t2 t3 t3 t3 t4 t5; T2: t1 t2 t3 t4 t5 t5 t5.
        let p1: Vec<(usize, usize)> =
            [0, 1, 2, 2, 2, 3, 4].iter().enumerate().map(|(i, &j)| (i, j)).collect();
        let p2: Vec<(usize, usize)> =
            [0, 1, 2, 3, 4, 4, 4].iter().enumerate().map(|(i, &j)| (i, j)).collect();
        let frames: Vec<usize> = (0..7).collect();
        let u1 = matched_target_frames(&p1, &frames, TieRule::Mean).unwrap();
        let u2 = matched_target_frames(&p2, &frames, TieRule::Mean).unwrap();
        let r: Vec<f64> = (0..7).map(|i| population_variance(&[u1[i], u2[i]])).collect();
        // From the table: the same element at s1, s2, s3, s7 (variance 0); s4 and s6 differ by
        // one frame (variance 1/4); s5 (t3 vs t5) differs most, by two (variance 1), as the
        // paper says. (Its text lists "s1, s2, s3, s5" as synchronised: a typo for s7, since
        // it then names s5 as the least synchronised element.)
        assert_eq!(r, vec![0.0, 0.0, 0.0, 0.25, 1.0, 0.25, 0.0]);
    }

    #[test]
    fn r_is_zero_when_every_marker_shares_one_path() {
        let path = vec![
            (0, 3),
            (1, 3),
            (1, 4),
            (2, 5),
            (3, 5),
            (4, 6),
            (5, 8),
            (6, 9),
            (7, 9),
            (8, 10),
            (9, 12),
        ];
        let stage = SynchronisationParams { k: 8, tie: TieRule::Mean }.check().unwrap();
        let s = stage.synchronise(&alignment(vec![path.clone(); 5]), 10).unwrap();
        assert_eq!(s.model_frames, (1..=8).collect::<Vec<_>>());
        assert_eq!(s.section_values, vec![0.0; 8]);
        assert_eq!(s.total, 0.0);
    }

    #[test]
    fn known_variances_and_tie_rules() {
        // Model frame 1 matched to target frames 1..=3 by marker A, to 4 by marker B.
        let a = vec![(0, 0), (1, 1), (1, 2), (1, 3), (2, 4)];
        let b = vec![(0, 0), (1, 4), (2, 4)];
        let run = |tie| {
            let stage = SynchronisationParams { k: 1, tie }.check().unwrap();
            stage.synchronise(&alignment(vec![a.clone(), b.clone()]), 3).unwrap()
        };
        // k = 1 on 3 frames: the middle frame 1. u_A = 2 (mean), 1 (first), 3 (last); u_B = 4.
        assert_eq!(run(TieRule::Mean).section_values, vec![1.0]); // (2-3)^2, (4-3)^2 over 2
        assert_eq!(run(TieRule::First).section_values, vec![2.25]); // mean 2.5, (1.5^2 * 2) / 2
        assert_eq!(run(TieRule::Last).section_values, vec![0.25]);
    }

    #[test]
    fn without_paths_or_with_a_short_path_it_fails_clearly() {
        let stage =
            build_synchroniser("synchronisation", &motionlab_core::registry::default_params())
                .unwrap();
        let e = stage.synchronise(&alignment(vec![]), 20).unwrap_err();
        assert!(e.to_string().contains("keep_paths"), "{e}");
        let short = vec![(0, 0), (1, 1), (2, 2)];
        let e = stage.synchronise(&alignment(vec![short]), 20).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Mismatch);
        let zero: toml::Value = toml::from_str("k = 0").unwrap();
        assert_eq!(
            build_synchroniser("synchronisation", &zero).err().unwrap().location().field.as_deref(),
            Some("k")
        );
        let tie: toml::Value = toml::from_str("tie = \"median\"").unwrap();
        assert!(build_synchroniser("synchronisation", &tie).is_err());
    }
}
