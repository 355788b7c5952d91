//! The `[features]` workflow: per-frame features of each sequence as a table and a figure.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry;
use motionlab_core::{
    ColumnValues, FeatureCache, FeatureExtractor, LabelTrace, Result, Table, Trace,
};
use motionlab_figure::{Chart, Figure, Series};

use motionlab_experiment::Datasets;
use motionlab_experiment::build_named_stages;
use motionlab_experiment::spec::StageSpec;
use motionlab_experiment::workflow::{
    BuildContext, ItemData, ItemOutput, Output, WorkItem, Workflow, WorkflowPlugin, sanitize,
};

pub struct FeaturesWorkflow {
    extractors: Vec<(String, Box<dyn FeatureExtractor>)>,
}

#[derive(Serialize, Deserialize)]
struct ItemResult {
    sequence: String,
    frame_rate_hz: f64,
    traces: Vec<Trace>,
    labels: Vec<LabelTraceRecord>,
}

#[derive(Serialize, Deserialize)]
struct LabelTraceRecord {
    name: String,
    values: Vec<String>,
}

impl From<LabelTrace> for LabelTraceRecord {
    fn from(l: LabelTrace) -> Self {
        LabelTraceRecord { name: l.name, values: l.values }
    }
}

/// Per-frame features of each sequence: one table per sequence (`<sequence>_features`: frame,
/// time and every extractor's traces and labels) and one figure per extractor and unit.
///
/// `[features] extractors = [{ type = "marker_speed" }]`. Missing samples: as each extractor
/// treats them (NaN where a trace is undefined).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FeaturesSection {
    /// The feature extractors, in column order (`{ type = "<extractor>", … }`; `name = "…"`
    /// labels one in tables and figures, and names must be unique). Required.
    pub extractors: Vec<StageSpec>,
}

impl WorkflowPlugin for FeaturesWorkflow {
    type Section = FeaturesSection;
    fn build(section: FeaturesSection, cx: &BuildContext<'_>) -> Result<Self> {
        let extractors = build_named_stages(
            cx,
            &section.extractors,
            &cx.root.key("extractors"),
            "extractors",
            registry::build_feature_extractor,
        )?;
        for (k, ((_, x), spec)) in extractors.iter().zip(&section.extractors).enumerate() {
            let at = cx.root.key("extractors").index(k).key("type");
            cx.require_3d_unless(&spec.kind, x.accepts_2d(), at)?;
        }
        Ok(FeaturesWorkflow { extractors })
    }
}

motionlab_experiment::register_workflow!(FeaturesWorkflow, "features");

impl Workflow for FeaturesWorkflow {
    fn run_item(&self, item: &WorkItem, data: &Datasets, draw_figures: bool) -> Result<ItemOutput> {
        let loaded = data.load(item.dataset, item.file)?;
        let motion = &loaded.motion;
        let cache = FeatureCache::new();
        let rate = motion.frame_rate();
        let time: Vec<f64> =
            (0..motion.n_frames()).map(|i| rate.frame_to_seconds(i).value()).collect();
        let mut traces = Vec::new();
        let mut labels = Vec::new();
        let mut figures = Vec::new();
        for (name, x) in &self.extractors {
            let set = x
                .extract(motion, &cache)
                .map_err(|e| e.in_file(motion.source.clone().unwrap_or_default()))?;
            if draw_figures {
                // One panel per unit so mm/s and mm³ never share an axis.
                let mut units: Vec<&str> = set.traces.iter().map(|t| t.unit.as_str()).collect();
                units.dedup();
                for unit in units {
                    let lines: Vec<Series> = set
                        .traces
                        .iter()
                        .filter(|t| t.unit == unit)
                        .take(8)
                        .map(|t| {
                            Series::new(
                                crate::drawing::label_of(&t.name),
                                time.clone(),
                                t.values.clone(),
                            )
                        })
                        .collect();
                    let suffix = if unit.is_empty() { String::new() } else { format!(" ({unit})") };
                    figures.push(Figure::chart(
                        format!(
                            "{}_{}{}",
                            item.id,
                            sanitize(name),
                            if units_count(&set.traces) > 1 {
                                format!("_{}", sanitize(unit))
                            } else {
                                String::new()
                            }
                        ),
                        Chart {
                            title: format!("{} — {name}", loaded.name),
                            x_label: "time (s)".into(),
                            y_label: format!(
                                "{}{suffix}",
                                lines.first().map(|l| l.label.as_str()).unwrap_or("value")
                            ),
                            lines,
                            ..Default::default()
                        },
                    ));
                }
            }
            traces.extend(set.traces);
            labels.extend(set.labels.into_iter().map(LabelTraceRecord::from));
        }
        let result =
            ItemResult { sequence: loaded.name.clone(), frame_rate_hz: rate.hz(), traces, labels };
        Ok(ItemOutput::new(ItemData::encode(&result)?, figures))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        _data: &Datasets,
        _draw: bool,
    ) -> Result<Output> {
        let mut out = Output::default();
        for (item, value) in items {
            let r: ItemResult = value.decode()?;
            let n = r
                .traces
                .first()
                .map(|t| t.values.len())
                .or_else(|| r.labels.first().map(|l| l.values.len()))
                .unwrap_or(0);
            let mut t = Table::new(
                format!("{}_features", item.id),
                format!("Per-frame features of {}", r.sequence),
            );
            t.push_column("frame", ColumnValues::I64((0..n as i64).collect()))?;
            t.push_column(
                "time_s",
                ColumnValues::F64((0..n).map(|i| i as f64 / r.frame_rate_hz).collect()),
            )?;
            for tr in r.traces {
                t.push_column(tr.name, ColumnValues::F64(tr.values))?;
            }
            for l in r.labels {
                t.push_column(l.name, ColumnValues::Str(l.values.into_iter().map(Some).collect()))?;
            }
            out.tables.push(t);
        }
        Ok(out)
    }
}

fn units_count(traces: &[Trace]) -> usize {
    let mut u: Vec<&str> = traces.iter().map(|t| t.unit.as_str()).collect();
    u.sort();
    u.dedup();
    u.len()
}
