//! Building the `[gait]` workflow: its stages, the datasets' roles (trials by condition, the
//! control walk) and every check of the section against the datasets.

use std::any::TypeId;
use std::collections::{BTreeMap, HashSet};

use motionlab_core::registry;
use motionlab_core::{Error, ErrorKind, FeatureExtractor, Result};
use motionlab_experiment::Datasets;
use motionlab_experiment::build_stage;
use motionlab_experiment::workflow::{BuildContext, WorkflowPlugin, build_evaluators};
use motionlab_features::{GaitCycleDetector, WaveformAnalyzer};
use motionlab_gait::WalkSynthesizer;
use motionlab_gait::change_rates::ChangeRateAnalysis;

use super::{
    BuiltControl, ControlSection, GaitSection, GaitWorkflow, Role, TABLE_POSTURE, TABLE_SIZE,
    ViewerChoice,
};

impl WorkflowPlugin for GaitWorkflow {
    type Section = GaitSection;
    fn build(section: GaitSection, cx: &BuildContext<'_>) -> Result<Self> {
        // Joint angles and the floor plane need depth.
        cx.require_3d_unless("the gait workflow", false, &cx.root)?;
        let stages = TrialStages::build(&section, cx)?;
        let evaluators = build_evaluators(cx.source, cx.combo, motionlab_gait::gait_study())?;
        // Tables 2–3, the control and the leave-one-out build on the change-rate analysis: one
        // evaluator must hand it over (found by the type of its analysis, not by its name).
        if !evaluators
            .iter()
            .any(|(_, e)| e.analysis_type() == Some(TypeId::of::<ChangeRateAnalysis>()))
        {
            return Err(cx.locate(
                Error::new(
                    ErrorKind::MissingKey,
                    "the [gait] workflow needs an `[[evaluate]] type = \"change_rates\"`: its change rates feed Tables 2–3, the control and the leave-one-out",
                ),
                "gait",
            ));
        }
        let control_dataset = control_dataset(&section, cx)?;
        let (roles, subjects) = dataset_roles(&section, cx, control_dataset)?;
        check_one_trial_per_subject_and_condition(cx, &roles, &subjects)?;
        check_viewer_choice(&section.viewers, cx, &subjects)?;
        let conditions = check_conditions(&section, cx, &roles)?;
        let has_synthesizer = stages.synthesizer.is_some();
        let control = match (&section.control, control_dataset) {
            (Some(c), Some(dataset)) => Some(build_control(
                c,
                dataset,
                cx,
                &section.normal_condition,
                &conditions,
                has_synthesizer,
            )?),
            _ => None,
        };
        if let Some(l) = &section.loso {
            check_target_condition(
                cx,
                "gait.loso.condition",
                &l.condition,
                &section.normal_condition,
                &conditions,
            )?;
            if !has_synthesizer {
                return Err(needs_synthesizer(cx, "gait.loso"));
            }
            if l.points < 2 {
                return Err(cx.locate(
                    Error::new(
                        ErrorKind::OutOfRange,
                        format!("expected at least 2 samples per cycle, found {}", l.points),
                    ),
                    "gait.loso.points",
                ));
            }
        }
        let mut published_channels: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for p in cx
            .combo
            .file
            .published
            .iter()
            .filter(|p| p.table == TABLE_POSTURE || p.table == TABLE_SIZE)
        {
            let list = published_channels.entry(p.table.clone()).or_default();
            list.extend(
                p.rows
                    .iter()
                    .filter_map(|r| r.get("channel").and_then(|v| v.as_str()).map(str::to_string)),
            );
        }
        let TrialStages { angles, detector, analyzer, synthesizer } = stages;
        Ok(GaitWorkflow {
            section,
            roles,
            subjects,
            angles,
            detector,
            analyzer,
            evaluators,
            synthesizer,
            control,
            published_channels,
            combo_index: cx.combo.index,
            locator: cx.locator(),
        })
    }
}

motionlab_experiment::register_workflow!(GaitWorkflow, "gait");

/// The stages `[gait]` names for the trials, and the synthesizer of the control and the
/// leave-one-out.
struct TrialStages {
    angles: Box<dyn FeatureExtractor>,
    detector: Box<dyn GaitCycleDetector>,
    analyzer: Box<dyn WaveformAnalyzer>,
    synthesizer: Option<Box<dyn WalkSynthesizer>>,
}

impl TrialStages {
    fn build(section: &GaitSection, cx: &BuildContext<'_>) -> Result<Self> {
        let (source, combo, root) = (cx.source, cx.combo, &cx.root);
        let angles = build_stage(
            source,
            combo,
            &section.joint_angles,
            &root.key("joint_angles"),
            registry::build_feature_extractor,
        )?;
        let detector = build_stage(
            source,
            combo,
            &section.cycles,
            &root.key("cycles"),
            motionlab_features::build_gait_cycle_detector,
        )?;
        let analyzer = build_stage(
            source,
            combo,
            &section.waveform,
            &root.key("waveform"),
            motionlab_features::build_waveform_analyzer,
        )?;
        let synthesizer = match &section.synthesizer {
            Some(s) => {
                if s.params.contains_key("channel_map") {
                    return Err(cx.locate(
                        Error::new(
                            ErrorKind::InvalidParameter,
                            "the synthesizer works on the trials' channels here; map them to the control walk's in [gait.control] channel_map",
                        ),
                        "gait.synthesizer.channel_map",
                    ));
                }
                Some(build_stage(
                    source,
                    combo,
                    s,
                    &root.key("synthesizer"),
                    motionlab_gait::build_walk_synthesizer,
                )?)
            }
            None => None,
        };
        Ok(TrialStages { angles, detector, analyzer, synthesizer })
    }
}

/// The index of the dataset `[gait.control] dataset` names, if there is a control section.
fn control_dataset(section: &GaitSection, cx: &BuildContext<'_>) -> Result<Option<usize>> {
    let Some(c) = &section.control else { return Ok(None) };
    let data = cx.data;
    data.datasets
        .iter()
        .position(|d| d.spec.name.as_deref() == Some(c.dataset.as_str()))
        .map(Some)
        .ok_or_else(|| {
            let names: Vec<String> =
                data.datasets.iter().filter_map(|d| d.spec.name.clone()).collect();
            cx.locate(
                Error::new(
                    ErrorKind::UnknownName,
                    format!("no [[dataset]] is named {:?} (named datasets: {names:?})", c.dataset),
                ),
                "gait.control.dataset",
            )
        })
}

/// Roles of the datasets — the control walk (by name), else trials (by condition tag) — and the
/// subject of each file of each trial dataset (none for the control dataset).
fn dataset_roles(
    section: &GaitSection,
    cx: &BuildContext<'_>,
    control_dataset: Option<usize>,
) -> Result<(Vec<Role>, Vec<Vec<String>>)> {
    let mut roles = Vec::new();
    let mut subjects = Vec::new();
    for d in &cx.data.datasets {
        if Some(d.index) == control_dataset {
            if d.files.len() != 1 {
                return Err(cx.locate(
                    Error::new(
                        ErrorKind::WrongValueCount,
                        format!(
                            "the control walk's dataset must hold one file, it holds {}",
                            d.files.len()
                        ),
                    ),
                    format!("dataset[{}].files", d.index),
                ));
            }
            roles.push(Role::Control);
            subjects.push(Vec::new());
            continue;
        }
        let Some(condition) = d.tag(&section.condition_tag) else {
            return Err(cx.locate(
                Error::new(
                    ErrorKind::MissingKey,
                    format!(
                        "this dataset has no `{}` tag and is not the control walk; give its trials a condition (`tags = {{ {} = \"…\" }}`)",
                        section.condition_tag, section.condition_tag
                    ),
                ),
                format!("dataset[{}]", d.index),
            ));
        };
        let mut ids = Vec::new();
        for f in &d.files {
            let stem = motionlab_core::paths::stem(f);
            let id = section.subject.subject_of(&stem).ok_or_else(|| {
                cx.locate(
                    Error::new(
                        ErrorKind::InvalidParameter,
                        format!(
                            "cannot read a subject from {:?}: the stem {stem:?} split at {:?} has no non-empty field {}",
                            f.display().to_string(),
                            section.subject.separator,
                            section.subject.field
                        ),
                    ),
                    "gait.subject",
                )
            })?;
            ids.push(id);
        }
        roles.push(Role::Trials { condition: condition.to_string() });
        subjects.push(ids);
    }
    Ok((roles, subjects))
}

/// One trial per subject and condition: change rates pair them.
fn check_one_trial_per_subject_and_condition(
    cx: &BuildContext<'_>,
    roles: &[Role],
    subjects: &[Vec<String>],
) -> Result<()> {
    let mut seen: BTreeMap<(String, String), String> = BTreeMap::new();
    for (d, role) in cx.data.datasets.iter().zip(roles) {
        let Role::Trials { condition } = role else { continue };
        for (f, id) in d.files.iter().zip(&subjects[d.index]) {
            if let Some(other) =
                seen.insert((id.clone(), condition.clone()), f.display().to_string())
            {
                return Err(cx.locate(
                    Error::new(
                        ErrorKind::DuplicateName,
                        format!("subject {id:?} has two trials in condition {condition:?}: {other} and {}; keep one per subject and condition", f.display()),
                    ),
                    "gait.subject",
                ));
            }
        }
    }
    Ok(())
}

/// Every sequence or subject `[gait] viewers` lists is one of the experiment's.
fn check_viewer_choice(
    viewers: &ViewerChoice,
    cx: &BuildContext<'_>,
    subjects: &[Vec<String>],
) -> Result<()> {
    let ViewerChoice::Only(list) = viewers else { return Ok(()) };
    let data: &Datasets = cx.data;
    for (k, x) in list.iter().enumerate() {
        let known =
            data.datasets.iter().any(|d| (0..d.files.len()).any(|f| d.sequence_name(f) == *x))
                || subjects.iter().flatten().any(|s| s == x);
        if !known {
            return Err(cx.locate(
                Error::new(ErrorKind::UnknownName, format!("{x:?} is neither a sequence (`normal/2014001_C4_05`) nor a subject id of this experiment")),
                format!("gait.viewers[{k}]"),
            ));
        }
    }
    Ok(())
}

/// The trials' conditions (one per trial dataset), checked: the normal one is among them, and
/// at least one other.
fn check_conditions<'a>(
    section: &GaitSection,
    cx: &BuildContext<'_>,
    roles: &'a [Role],
) -> Result<Vec<&'a str>> {
    let conditions: Vec<&str> = roles
        .iter()
        .filter_map(|r| match r {
            Role::Trials { condition } => Some(condition.as_str()),
            Role::Control => None,
        })
        .collect();
    if !conditions.contains(&section.normal_condition.as_str()) {
        return Err(cx.locate(
            Error::new(
                ErrorKind::UnknownName,
                format!(
                    "no dataset has `{} = {:?}` (conditions: {conditions:?})",
                    section.condition_tag, section.normal_condition
                ),
            ),
            "gait.normal_condition",
        ));
    }
    if !conditions.iter().any(|c| *c != section.normal_condition) {
        return Err(cx.locate(
            Error::new(ErrorKind::EmptySequence, format!("every trial is in the normal condition {:?}; change rates need another condition", section.normal_condition)),
            "gait.normal_condition",
        ));
    }
    Ok(conditions)
}

/// The condition at `path` (of the control or the leave-one-out) is a trial condition other
/// than the normal one.
fn check_target_condition(
    cx: &BuildContext<'_>,
    path: &str,
    condition: &str,
    normal: &str,
    conditions: &[&str],
) -> Result<()> {
    if condition == normal || !conditions.contains(&condition) {
        let others: Vec<&&str> = conditions.iter().filter(|x| **x != normal).collect();
        return Err(cx.locate(Error::new(ErrorKind::UnknownName, format!("expected a condition other than the normal one, one of {others:?}; found {condition:?}")), path));
    }
    Ok(())
}

fn needs_synthesizer(cx: &BuildContext<'_>, path: &str) -> Error {
    cx.locate(Error::new(ErrorKind::MissingKey, "needs `[gait] synthesizer = { type = \"feature_channel_control\" }` (or another walk synthesizer)"), path)
}

/// `[gait.control]` checked against the trials' conditions, with its own stages built.
fn build_control(
    c: &ControlSection,
    dataset: usize,
    cx: &BuildContext<'_>,
    normal: &str,
    conditions: &[&str],
    has_synthesizer: bool,
) -> Result<BuiltControl> {
    check_target_condition(cx, "gait.control.condition", &c.condition, normal, conditions)?;
    if !has_synthesizer {
        return Err(needs_synthesizer(cx, "gait.control"));
    }
    if c.channel_map.is_empty() {
        return Err(cx.locate(
            Error::new(ErrorKind::MissingKey, "map at least one trial channel to a walk channel"),
            "gait.control.channel_map",
        ));
    }
    let mut targets = HashSet::new();
    for (from, to) in &c.channel_map {
        if !targets.insert(to.as_str()) {
            return Err(cx.locate(
                Error::new(ErrorKind::DuplicateName, format!("two trial channels map to {to:?}")),
                format!("gait.control.channel_map.{from}"),
            ));
        }
    }
    for (ch, o) in &c.offset_deg {
        if !o.is_finite() || !targets.contains(ch.as_str()) {
            return Err(cx.locate(
                Error::new(
                    ErrorKind::InvalidParameter,
                    format!(
                        "offset of {ch:?} ({o}): expected a finite number for a channel_map target"
                    ),
                ),
                "gait.control.offset_deg",
            ));
        }
    }
    if c.strip_every_frames == 0 || c.strip_poses < 2 {
        return Err(cx.locate(
            Error::new(
                ErrorKind::OutOfRange,
                "expected strip_every_frames >= 1 and strip_poses >= 2",
            ),
            if c.strip_every_frames == 0 {
                "gait.control.strip_every_frames"
            } else {
                "gait.control.strip_poses"
            },
        ));
    }
    let cr = cx.root.key("control");
    Ok(BuiltControl {
        spec: c.clone(),
        dataset,
        angles: build_stage(
            cx.source,
            cx.combo,
            &c.joint_angles,
            &cr.key("joint_angles"),
            registry::build_feature_extractor,
        )?,
        detector: build_stage(
            cx.source,
            cx.combo,
            &c.cycles,
            &cr.key("cycles"),
            motionlab_features::build_gait_cycle_detector,
        )?,
    })
}
