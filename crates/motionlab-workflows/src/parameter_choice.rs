//! The `parameters_chosen` column of the segmentation workflow's evaluation tables: for every
//! (sequence, method) row, whether the method's parameters were chosen on the data the row
//! reports — so a precision or recall never reads as held-out when it is not.
//!
//! A method's parameters are, in this run's combination:
//!
//! - **swept** — a key of this combination's sweep belongs to it (`segmentation.segmenter[NAME].…`
//!   or, for the fuser, `segmentation.fuser.…`): the row is one point of a grid, and the best
//!   point of it, picked on these sequences, is an oracle;
//! - **set in the experiment** — the stage's table sets a parameter to something other than
//!   the plugin's default (how that value was chosen is the experiment's to say);
//! - **plugin defaults** — every parameter at its default. A plugin whose defaults were tuned on
//!   data lists those inputs' SHA-256 in its schema ([`registry::DEFAULTS_TUNED_ON_KEY`]); a
//!   sequence whose input file is one of them is **tuned on this sequence (oracle)**, any other
//!   is **held-out**.
//!
//! The fused method depends on its own parameters and on the segmenters it fuses: its label is
//! the most oracle-like of theirs (swept, then tuned on this sequence, then set in the
//! experiment, then held-out defaults, then untuned defaults). A pooled row gets its
//! sequences' label when they agree, else the count of sequences tuned on.

use motionlab_core::registry;
use motionlab_core::{ColumnValues, Table};
use motionlab_experiment::spec::StageSpec;

// How a row's parameters were chosen changes with the parameters compared: a result, not a
// row name (`motionlab compare`).
motionlab_core::declare_outcome_column!("parameters_chosen");

/// The column's name. Its texts hold no comma, so even a naive split of the CSV lines up.
pub const COLUMN: &str = "parameters_chosen";

/// How one stage's parameters were chosen in one combination (before looking at the sequence).
#[derive(Clone, Debug, PartialEq)]
pub enum StageChoice {
    Swept,
    Experiment,
    /// Every parameter at the plugin's default; the inputs (SHA-256, lower-case hex) those
    /// defaults were tuned on, if any.
    Defaults {
        tuned_on: Vec<String>,
    },
}

impl StageChoice {
    /// The stage `spec`, whose table is at one of `places` (`segmentation.segmenter[speed]`,
    /// `segmentation.segmenter[0]`, `segmentation.fuser`), in a combination whose swept key
    /// paths are `swept_keys`.
    pub fn of(spec: &StageSpec, places: &[String], swept_keys: &[String]) -> StageChoice {
        if swept_keys.iter().any(|k| {
            places.iter().any(|p| {
                k.strip_prefix(p.as_str())
                    .is_some_and(|rest| rest.is_empty() || rest.starts_with('.'))
            })
        }) {
            return StageChoice::Swept;
        }
        let Ok(entry) = registry::find(&spec.kind) else { return StageChoice::Experiment };
        let schema = (entry.schema)();
        let defaults = schema.as_value().get("properties");
        let toml::Value::Table(set) = spec.plugin_params() else { return StageChoice::Experiment };
        let at_default = set.iter().all(|(k, v)| {
            let default = defaults.and_then(|p| p.get(k)).and_then(|p| p.get("default"));
            default.is_some_and(|d| serde_json::to_value(v).is_ok_and(|v| same_value(&v, d)))
        });
        if at_default {
            StageChoice::Defaults { tuned_on: registry::defaults_tuned_on(&schema) }
        } else {
            StageChoice::Experiment
        }
    }
}

/// JSON equality with numbers compared as numbers (`100` = `100.0`).
fn same_value(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    use serde_json::Value::{Array, Number, Object};
    match (a, b) {
        (Number(x), Number(y)) => x.as_f64() == y.as_f64(),
        (Array(x), Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same_value(p, q))
        }
        (Object(x), Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same_value(v, w)))
        }
        _ => a == b,
    }
}

/// One row's label, most oracle-like first (the order a fused method takes the worst of).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Label {
    Swept,
    TunedOnThis,
    Experiment,
    HeldOutDefaults,
    Defaults,
}

impl Label {
    fn text(self) -> &'static str {
        match self {
            Label::Swept => {
                "swept: one point of this run's grid (its best point picked on these sequences is an oracle)"
            }
            Label::TunedOnThis => "plugin defaults tuned on this sequence (oracle)",
            Label::Experiment => "set in the experiment",
            Label::HeldOutDefaults => "plugin defaults tuned on other data (held-out)",
            Label::Defaults => "plugin defaults",
        }
    }

    fn of(choice: &StageChoice, input_sha256: &str) -> Label {
        match choice {
            StageChoice::Swept => Label::Swept,
            StageChoice::Experiment => Label::Experiment,
            StageChoice::Defaults { tuned_on } if tuned_on.is_empty() => Label::Defaults,
            StageChoice::Defaults { tuned_on } if tuned_on.iter().any(|h| h == input_sha256) => {
                Label::TunedOnThis
            }
            StageChoice::Defaults { .. } => Label::HeldOutDefaults,
        }
    }
}

/// Each method's stages: a segmenter's own, or the fuser's and those of the segmenters it
/// fuses.
pub struct MethodChoices {
    pub methods: Vec<(String, Vec<StageChoice>)>,
}

impl MethodChoices {
    /// The label of `method` on a sequence whose input file has SHA-256 `input_sha256` (hex);
    /// `None` for a method not listed.
    fn label(&self, method: &str, input_sha256: &str) -> Option<Label> {
        let (_, stages) = self.methods.iter().find(|(m, _)| m == method)?;
        stages.iter().map(|c| Label::of(c, input_sha256)).min()
    }

    /// Adds the column after `method` to every table with (text) `sequence` and `method`
    /// columns. `inputs` maps each sequence name to its input file's SHA-256; a `pooled` row
    /// (or any other sequence not in `inputs`) pools the method's labels over all of them.
    pub fn annotate(&self, tables: &mut [Table], inputs: &[(String, String)]) {
        for table in tables {
            let (Some(ColumnValues::Str(sequences)), Some(ColumnValues::Str(methods))) =
                (table.column("sequence"), table.column("method"))
            else {
                continue;
            };
            let cells: Vec<Option<String>> = sequences
                .iter()
                .zip(methods)
                .map(|(s, m)| {
                    let (s, m) = (s.as_deref()?, m.as_deref()?);
                    match inputs.iter().find(|(name, _)| name == s) {
                        Some((_, sha)) => self.label(m, sha).map(|l| l.text().to_string()),
                        None => self.pooled(m, inputs),
                    }
                })
                .collect();
            if cells.iter().all(Option::is_none) {
                continue;
            }
            let at = table
                .columns
                .iter()
                .position(|c| c.name == "method")
                .map_or(table.columns.len(), |i| i + 1);
            table.columns.insert(
                at,
                motionlab_core::Column {
                    name: COLUMN.to_string(),
                    values: ColumnValues::Str(cells),
                },
            );
        }
    }

    fn pooled(&self, method: &str, inputs: &[(String, String)]) -> Option<String> {
        let labels: Vec<Label> =
            inputs.iter().filter_map(|(_, sha)| self.label(method, sha)).collect();
        let first = *labels.first()?;
        if labels.iter().all(|l| *l == first) {
            return Some(match first {
                Label::TunedOnThis => {
                    "plugin defaults tuned on every one of these sequences (oracle)".to_string()
                }
                l => l.text().to_string(),
            });
        }
        let tuned = labels.iter().filter(|l| **l == Label::TunedOnThis).count();
        Some(if tuned > 0 {
            format!(
                "plugin defaults tuned on {tuned} of these {} sequences (partly oracle)",
                labels.len()
            )
        } else {
            labels.iter().min().map_or("", |l| l.text()).to_string()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(kind: &str, params: &str) -> StageSpec {
        let mut t: toml::Table = toml::from_str(params).unwrap();
        t.insert("type".into(), toml::Value::String(kind.into()));
        toml::Value::Table(t).try_into().unwrap()
    }

    #[test]
    fn stages_are_swept_set_or_at_their_defaults() {
        // Linked so the registry holds the segmenters.
        use motionlab_segment as _;
        let swept = ["segmentation.segmenter[speed].v_low.fraction_of_p90".to_string()];
        let places =
            ["segmentation.segmenter[speed]".to_string(), "segmentation.segmenter[0]".to_string()];
        let speed = spec("fastest_marker_speed", "name = \"speed\"");
        assert_eq!(StageChoice::of(&speed, &places, &swept), StageChoice::Swept);
        assert_eq!(
            StageChoice::of(&speed, &places, &["segmentation.segmenter[0].v_low".to_string()]),
            StageChoice::Swept
        );
        // `speed_minima` is another segmenter, not a key below `speed`.
        assert_ne!(
            StageChoice::of(
                &speed,
                &places,
                &["segmentation.segmenter[speed_minima].v_low".to_string()]
            ),
            StageChoice::Swept
        );
        assert!(
            matches!(StageChoice::of(&speed, &places, &[]), StageChoice::Defaults { ref tuned_on } if tuned_on.len() == 7)
        );
        // A value other than the default is the experiment's; the default written out is not.
        let set = spec("fastest_marker_speed", "v_low = { fraction_of_p90 = 0.123 }");
        assert_eq!(StageChoice::of(&set, &places, &[]), StageChoice::Experiment);
        let entry = registry::find("union_merge").unwrap();
        let merge =
            entry.params().into_iter().find(|p| p.name == "merge_mm").unwrap().default.unwrap();
        let written = spec("union_merge", &format!("merge_mm = {}", merge.trim_end_matches(".0")));
        let fuser = ["segmentation.fuser".to_string()];
        assert!(
            matches!(StageChoice::of(&written, &fuser, &[]), StageChoice::Defaults { .. }),
            "{merge}"
        );
        // Swept keys of another stage do not count.
        assert!(matches!(StageChoice::of(&written, &fuser, &swept), StageChoice::Defaults { .. }));
        assert_eq!(
            StageChoice::of(&written, &fuser, &["segmentation.fuser.merge_mm".to_string()]),
            StageChoice::Swept
        );
    }

    #[test]
    fn rows_get_the_most_oracle_like_label_of_their_stages() {
        let tuned = StageChoice::Defaults { tuned_on: vec!["aa".into()] };
        let choices = MethodChoices {
            methods: vec![
                ("speed".into(), vec![tuned.clone()]),
                ("mine".into(), vec![StageChoice::Experiment]),
                (
                    "fused".into(),
                    vec![
                        StageChoice::Defaults { tuned_on: vec![] },
                        tuned,
                        StageChoice::Experiment,
                    ],
                ),
            ],
        };
        let seqs = |n: usize| {
            ColumnValues::Str(
                ["a", "b", "pooled"].iter().cycle().take(n).map(|s| Some(s.to_string())).collect(),
            )
        };
        let meths = |m: &[&str]| ColumnValues::Str(m.iter().map(|s| Some(s.to_string())).collect());
        let mut t = Table::new("t", "t");
        t.push_column("sequence", seqs(9)).unwrap();
        t.push_column(
            "method",
            meths(&["speed", "speed", "speed", "mine", "mine", "mine", "fused", "fused", "fused"]),
        )
        .unwrap();
        let mut tables = [t, Table::new("no_columns", "")];
        choices.annotate(&mut tables, &[("a".into(), "aa".into()), ("b".into(), "bb".into())]);
        let col = tables[0].column(COLUMN).unwrap();
        let cell = |r: usize| col.cell(r);
        assert_eq!(tables[0].columns[2].name, COLUMN);
        assert_eq!(cell(0), "plugin defaults tuned on this sequence (oracle)");
        assert_eq!(cell(1), "plugin defaults tuned on other data (held-out)");
        assert_eq!(cell(2), "plugin defaults tuned on 1 of these 2 sequences (partly oracle)");
        assert!((3..6).all(|r| cell(r) == "set in the experiment"));
        assert_eq!(cell(6), "plugin defaults tuned on this sequence (oracle)");
        assert_eq!(cell(7), "set in the experiment");
        assert!(tables[1].columns.is_empty());
        let all = [
            Label::Swept,
            Label::TunedOnThis,
            Label::Experiment,
            Label::HeldOutDefaults,
            Label::Defaults,
        ];
        assert!(
            all.iter().all(|l| !l.text().contains(',')) && (0..9).all(|r| !cell(r).contains(','))
        );
    }
}
