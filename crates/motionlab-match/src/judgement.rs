//! Evaluator `judgement`: similar / dissimilar repetitions and the tendency tables (§4).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::MatchingResult;
use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, EvalInput, EvalInputType, Evaluator, Result, Table};

/// Similar/dissimilar judgement of each repetition, and the user's tendencies (§4.1–4.2).
///
/// One set of rows per user take (Yabe & Tanaka §4).
///
/// Judgement (§4.1), over the N repetitions of one take: `H' = H / mean(H)`,
/// `R' = R / mean(R)`, `score = sqrt(H'² + R'²)`; the least score is the most similar
/// repetition (rank 1), the largest the most dissimilar. Ties in score keep repetition order.
/// **Choice**: when every repetition has `H = 0` (or `R = 0`) the mean is 0; all values then
/// equal their mean, so each normalised value is 1.
///
/// Tendency (§4.2): `h'_l` = mean over the repetitions of marker `l`'s distance `h_l` (least =
/// most similar part, largest = least similar part); `r'_q` = mean over the repetitions of
/// section `q`'s synchronisation value `r_q` (least = best synchronised section).
///
/// Tables (units in column names): `judgement` (one row per repetition: `H_mm`,
/// `R_frames2`, `H_norm`, `R_norm`, `score`, `rank`, flags), `tendency_parts` (one row per
/// marker: `h_mean_mm`) and `tendency_sections` (one row per examined model frame:
/// `r_mean_frames2`).
///
/// Missing samples: none reach this stage (the matchers refuse them); a non-finite `H`, `h_l`
/// or `r_q` is an error.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct JudgementParams {}

/// The validated evaluator (it has no parameters).
#[derive(Clone, Copy, Debug, Default)]
pub struct Judgement;

impl ParamGuard for JudgementParams {
    type Checked = Judgement;
    fn check(self) -> Result<Judgement> {
        Ok(Judgement)
    }
}

/// One row of the `judgement` table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RepetitionJudgement {
    pub take: String,
    pub repetition: String,
    /// First frame of the cut window in the take.
    pub window_start_frame: usize,
    /// `a` and `b` as frames of the take (window start + the matcher's indices).
    pub start_frame: usize,
    pub end_frame: usize,
    #[serde(rename = "H_mm")]
    pub h_mm: f64,
    #[serde(rename = "R_frames2")]
    pub r_frames2: f64,
    #[serde(rename = "H_norm")]
    pub h_norm: f64,
    #[serde(rename = "R_norm")]
    pub r_norm: f64,
    pub score: f64,
    /// 1 = most similar.
    pub rank: usize,
    pub most_similar: bool,
    pub most_dissimilar: bool,
}

/// One row of the `tendency_parts` table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PartTendency {
    pub take: String,
    pub point: String,
    /// `h'_l`: mean of the marker's distance over the repetitions.
    pub h_mean_mm: f64,
    pub most_similar_part: bool,
    pub least_similar_part: bool,
}

/// One row of the `tendency_sections` table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SectionTendency {
    pub take: String,
    /// `q`, 1-based as in the paper.
    pub section: usize,
    /// The model frame examined (0-based).
    pub model_frame: usize,
    /// `r'_q`: mean of `r_q` over the repetitions.
    pub r_mean_frames2: f64,
    pub best_synchronised: bool,
    pub worst_synchronised: bool,
}

/// The three record sets of one or more takes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JudgementRecords {
    pub repetitions: Vec<RepetitionJudgement>,
    pub parts: Vec<PartTendency>,
    pub sections: Vec<SectionTendency>,
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// `x / mean(x)`, with every value 1 when the mean is 0 (then all values are 0: equal to their mean).
fn normalise(v: &[f64]) -> Vec<f64> {
    let mu = mean(v);
    if mu == 0.0 { vec![1.0; v.len()] } else { v.iter().map(|x| x / mu).collect() }
}

/// The judgement rule (§4.1) over the repetitions of one take.
#[derive(Clone, Debug, PartialEq)]
pub struct Scores {
    /// `H' = H / mean(H)`.
    pub h_norm: Vec<f64>,
    /// `R' = R / mean(R)`.
    pub r_norm: Vec<f64>,
    /// `sqrt(H'² + R'²)`: the least is the most similar repetition.
    pub score: Vec<f64>,
}

/// `H'`, `R'` and the score of each repetition from its `H` and `R` (the judgement rule, §4.1;
/// also what the timing test of the matching workflow ranks by).
pub fn scores(h: &[f64], r: &[f64]) -> Scores {
    let (h_norm, r_norm) = (normalise(h), normalise(r));
    let score = h_norm.iter().zip(&r_norm).map(|(a, b)| (a * a + b * b).sqrt()).collect();
    Scores { h_norm, r_norm, score }
}

/// 1-based ranks of `v` ascending (1 = least); ties keep their order.
pub fn ranks(v: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&x, &y| v[x].total_cmp(&v[y]).then(x.cmp(&y)));
    let mut rank = vec![0; v.len()];
    for (pos, &k) in order.iter().enumerate() {
        rank[k] = pos + 1;
    }
    rank
}

fn require_finite(v: f64, what: &str, take: &str, rep: &str) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::new(
            ErrorKind::NonFinite,
            format!(
                "{what} of repetition {rep:?} in take {take:?} is {v}; expected a finite number"
            ),
        )
        .with_field(rep.to_string()))
    }
}

/// Positions of the least and the largest value (earliest among ties).
fn extremes(v: &[f64]) -> (usize, usize) {
    let (mut lo, mut hi) = (0, 0);
    for (i, &x) in v.iter().enumerate() {
        if x < v[lo] {
            lo = i;
        }
        if x > v[hi] {
            hi = i;
        }
    }
    (lo, hi)
}

/// Judgement and tendency records for every take.
pub fn judge(results: &[MatchingResult]) -> Result<JudgementRecords> {
    let mut out = JudgementRecords::default();
    for take in results {
        judge_take(take, &mut out)?;
    }
    Ok(out)
}

fn judge_take(take: &MatchingResult, out: &mut JudgementRecords) -> Result<()> {
    let name = take.take.as_str();
    let reps = &take.repetitions;
    if reps.is_empty() {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            format!("take {name:?} has no matched repetitions to judge"),
        ));
    }
    let n_points = take.point_names.len();
    let sections = &reps[0].synchronisation.model_frames;
    let mut h = Vec::with_capacity(reps.len());
    let mut r = Vec::with_capacity(reps.len());
    for rep in reps {
        let label = rep.repetition.as_str();
        if rep.alignment.point_distances.len() != n_points {
            return Err(Error::new(
                ErrorKind::Mismatch,
                format!(
                    "repetition {label:?} of take {name:?} has {} per-point distances but the take names {n_points} points",
                    rep.alignment.point_distances.len()
                ),
            ));
        }
        if &rep.synchronisation.model_frames != sections
            || rep.synchronisation.section_values.len() != sections.len()
        {
            return Err(Error::new(
                ErrorKind::Mismatch,
                format!(
                    "repetition {label:?} of take {name:?} was synchronised at other model frames than the first repetition"
                ),
            ));
        }
        for &v in rep.alignment.point_distances.iter().chain(&rep.synchronisation.section_values) {
            require_finite(v, "a per-point distance or section value", name, label)?;
        }
        h.push(require_finite(rep.alignment.total_distance, "H", name, label)?);
        r.push(require_finite(rep.synchronisation.total, "R", name, label)?);
    }
    let Scores { h_norm: hn, r_norm: rn, score } = scores(&h, &r);
    let rank = ranks(&score);
    for (k, rep) in reps.iter().enumerate() {
        out.repetitions.push(RepetitionJudgement {
            take: name.to_string(),
            repetition: rep.repetition.clone(),
            window_start_frame: rep.window_start,
            start_frame: rep.window_start + rep.alignment.start,
            end_frame: rep.window_start + rep.alignment.end,
            h_mm: h[k],
            r_frames2: r[k],
            h_norm: hn[k],
            r_norm: rn[k],
            score: score[k],
            rank: rank[k],
            most_similar: rank[k] == 1,
            most_dissimilar: rank[k] == reps.len(),
        });
    }
    let part_means: Vec<f64> = (0..n_points)
        .map(|l| mean(&reps.iter().map(|rep| rep.alignment.point_distances[l]).collect::<Vec<_>>()))
        .collect();
    let (best, worst) = extremes(&part_means);
    for (l, point) in take.point_names.iter().enumerate() {
        out.parts.push(PartTendency {
            take: name.to_string(),
            point: point.clone(),
            h_mean_mm: part_means[l],
            most_similar_part: l == best,
            least_similar_part: l == worst,
        });
    }
    let section_means: Vec<f64> = (0..sections.len())
        .map(|q| {
            mean(&reps.iter().map(|rep| rep.synchronisation.section_values[q]).collect::<Vec<_>>())
        })
        .collect();
    let (best, worst) = extremes(&section_means);
    for (q, &frame) in sections.iter().enumerate() {
        out.sections.push(SectionTendency {
            take: name.to_string(),
            section: q + 1,
            model_frame: frame,
            r_mean_frames2: section_means[q],
            best_synchronised: q == best,
            worst_synchronised: q == worst,
        });
    }
    Ok(())
}

impl Evaluator for Judgement {
    fn input_type(&self) -> EvalInputType {
        crate::matching_results()
    }
    fn evaluate(&self, input: EvalInput<'_>) -> Result<Vec<Table>> {
        let results: &Vec<MatchingResult> = input.read(crate::matching_results(), "judgement")?;
        let rec = judge(results)?;
        Ok(vec![
            Table::from_records(
                "judgement",
                "Similar/dissimilar judgement per repetition (H', R', score; Yabe & Tanaka §4.1, Fig. 6)",
                &rec.repetitions,
            )?,
            Table::from_records(
                "tendency_parts",
                "Per-part tendency h'_l: mean distance of each marker over the repetitions (§4.2)",
                &rec.parts,
            )?,
            Table::from_records(
                "tendency_sections",
                "Per-section tendency r'_q: mean synchronisation value over the repetitions (§4.2)",
                &rec.sections,
            )?,
        ])
    }
}

motionlab_core::register_plugin!(Evaluator, JudgementParams, "judgement");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Alignment, RepetitionResult, Synchronisation};
    use motionlab_core::ColumnValues;
    use motionlab_core::registry::{build_evaluator, default_params};

    #[test]
    fn scores_and_ranks_follow_the_rule() {
        let s = scores(&[1.0, 3.0], &[0.0, 0.0]);
        assert_eq!(s.h_norm, vec![0.5, 1.5]);
        // R = 0 everywhere: its mean is 0, so each R' is 1.
        assert_eq!(s.r_norm, vec![1.0, 1.0]);
        assert_eq!(s.score, vec![1.25f64.sqrt(), 3.25f64.sqrt()]);
        assert_eq!(ranks(&[3.0, 1.0, 2.0, 1.0]), vec![4, 1, 3, 2]);
    }

    fn rep(label: &str, h: &[f64], r: &[f64]) -> RepetitionResult {
        RepetitionResult {
            repetition: label.into(),
            window_start: 100,
            alignment: Alignment {
                start: 3,
                end: 40,
                point_distances: h.to_vec(),
                total_distance: h.iter().sum(),
                paths: vec![],
            },
            synchronisation: Synchronisation {
                model_frames: vec![10, 20],
                section_values: r.to_vec(),
                total: r.iter().sum(),
            },
        }
    }

    fn take(reps: Vec<RepetitionResult>) -> MatchingResult {
        MatchingResult {
            take: "t".into(),
            point_names: vec!["hand".into(), "foot".into()],
            repetitions: reps,
        }
    }

    #[test]
    fn scores_order_the_constructed_repetitions() {
        // H = 10, 10, 30, 10 (mean 15); R = 2, 6, 6, 2 (mean 4).
        // (a) close: H' 2/3, R' 1/2 -> 0.833; (b) timing-shifted: H' 2/3, R' 3/2 -> 1.641;
        // (c) wrong: H' 2, R' 3/2 -> 2.5; (d) close again: 0.833 (ties keep order).
        let t = take(vec![
            rep("a", &[4.0, 6.0], &[1.0, 1.0]),
            rep("b", &[5.0, 5.0], &[1.0, 5.0]),
            rep("c", &[20.0, 10.0], &[3.0, 3.0]),
            rep("d", &[6.0, 4.0], &[2.0, 0.0]),
        ]);
        let rec = judge(&[t]).unwrap();
        let rows = &rec.repetitions;
        let ranks: Vec<usize> = rows.iter().map(|r| r.rank).collect();
        assert_eq!(ranks, vec![1, 3, 4, 2]);
        assert!((rows[0].score - (4.0f64 / 9.0 + 0.25).sqrt()).abs() < 1e-12);
        assert!((rows[1].score - (4.0f64 / 9.0 + 2.25).sqrt()).abs() < 1e-12);
        assert!((rows[2].score - 2.5).abs() < 1e-12);
        assert_eq!(rows[0].score, rows[3].score);
        assert!(rows[0].most_similar && !rows[3].most_similar && rows[2].most_dissimilar);
        assert_eq!((rows[0].start_frame, rows[0].end_frame), (103, 140));
        // Normalised values average 1.
        assert!((rows.iter().map(|r| r.h_norm).sum::<f64>() - 4.0).abs() < 1e-12);
        assert!((rows.iter().map(|r| r.r_norm).sum::<f64>() - 4.0).abs() < 1e-12);
        // Tendency: hand 35/4, foot 25/4 -> foot most similar; sections 7/4 vs 9/4.
        assert_eq!(rec.parts[0].h_mean_mm, 8.75);
        assert!(rec.parts[1].most_similar_part && rec.parts[0].least_similar_part);
        assert_eq!((rec.sections[0].r_mean_frames2, rec.sections[1].r_mean_frames2), (1.75, 2.25));
        assert!(rec.sections[0].best_synchronised && rec.sections[1].worst_synchronised);
        assert_eq!((rec.sections[1].section, rec.sections[1].model_frame), (2, 20));
    }

    #[test]
    fn zero_means_normalise_to_one_and_tables_have_unit_columns() {
        let t = take(vec![rep("a", &[1.0, 1.0], &[0.0, 0.0]), rep("b", &[2.0, 2.0], &[0.0, 0.0])]);
        let ev = build_evaluator("judgement", &default_params()).unwrap();
        assert_eq!(ev.input_type(), crate::matching_results());
        let tables = ev.evaluate(EvalInput::new(&vec![t])).unwrap();
        let names: Vec<&str> = tables.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["judgement", "tendency_parts", "tendency_sections"]);
        assert_eq!(tables[0].column("R_norm"), Some(&ColumnValues::F64(vec![1.0, 1.0])));
        assert_eq!(tables[0].column("rank"), Some(&ColumnValues::I64(vec![1, 2])));
        assert!(tables[0].column("H_mm").is_some() && tables[1].column("h_mean_mm").is_some());
    }

    #[test]
    fn inconsistent_or_wrong_input_is_an_error() {
        let ev = Judgement;
        let bad = take(vec![rep("a", &[1.0], &[0.0, 0.0])]);
        assert_eq!(
            ev.evaluate(EvalInput::new(&vec![bad])).unwrap_err().kind(),
            ErrorKind::Mismatch
        );
        let nan = take(vec![rep("a", &[f64::NAN, 1.0], &[0.0, 0.0])]);
        assert_eq!(
            ev.evaluate(EvalInput::new(&vec![nan])).unwrap_err().kind(),
            ErrorKind::NonFinite
        );
        assert_eq!(
            ev.evaluate(EvalInput::new(&vec![take(vec![])])).unwrap_err().kind(),
            ErrorKind::EmptySequence
        );
        // Another workflow's results: an error naming what judgement reads.
        let e = ev.evaluate(EvalInput::new(&vec![1_u8])).unwrap_err();
        assert!(
            e.kind() == ErrorKind::Mismatch
                && e.to_string().contains("judgement evaluates matching results"),
            "{e}"
        );
    }
}
