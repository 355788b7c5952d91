//! Building the `[gait]` workflow: its stages, the datasets' roles (trials by condition, the
//! control walk) and every check of the section against the datasets.

use std::any::TypeId;
use std::collections::BTreeMap;

use motionlab_core::registry;
use motionlab_core::{Error, ErrorKind, EvalInputType, Result};
use motionlab_experiment::build_stage;
use motionlab_experiment::workflow::{build_evaluators, BuildContext, WorkflowPlugin};
use motionlab_gait::change_rates::ChangeRateAnalysis;

use super::{BuiltControl, GaitSection, GaitWorkflow, Role, ViewerChoice, TABLE_POSTURE, TABLE_SIZE};

impl WorkflowPlugin for GaitWorkflow {
    type Section = GaitSection;
    fn build(section: GaitSection, cx: &BuildContext<'_>) -> Result<Self> {
        let (source, combo, data, root) = (cx.source, cx.combo, cx.data, cx.root.clone());
        let here = |path: &str, err: Error| cx.locate(err, path);
        let angles = build_stage(source, combo, &section.joint_angles, &root.key("joint_angles"), registry::build_feature_extractor)?;
        let detector = build_stage(source, combo, &section.cycles, &root.key("cycles"), registry::build_gait_cycle_detector)?;
        let analyzer = build_stage(source, combo, &section.waveform, &root.key("waveform"), registry::build_waveform_analyzer)?;
        let synthesizer = match &section.synthesizer {
            Some(s) => {
                if s.params.contains_key("channel_map") {
                    return Err(here(
                        "gait.synthesizer.channel_map",
                        Error::new(
                            ErrorKind::InvalidParameter,
                            "the synthesizer works on the trials' channels here; map them to the control walk's in [gait.control] channel_map",
                        ),
                    ));
                }
                Some(build_stage(source, combo, s, &root.key("synthesizer"), registry::build_walk_synthesizer)?)
            }
            None => None,
        };
        let evaluators = build_evaluators(source, combo, EvalInputType::gait())?;
        // Tables 2–3, the control and the leave-one-out build on the change-rate analysis: one
        // evaluator must hand it over (found by the type of its analysis, not by its name).
        if !evaluators.iter().any(|(_, e)| e.analysis_type() == Some(TypeId::of::<ChangeRateAnalysis>())) {
            return Err(here(
                "gait",
                Error::new(
                    ErrorKind::MissingKey,
                    "the [gait] workflow needs an `[[evaluate]] type = \"change_rates\"`: its change rates feed Tables 2–3, the control and the leave-one-out",
                ),
            ));
        }
        // Roles of the datasets: the control walk (by name), else trials (by condition tag).
        let control_dataset = match &section.control {
            Some(c) => Some(data.datasets.iter().position(|d| d.spec.name.as_deref() == Some(c.dataset.as_str())).ok_or_else(|| {
                let names: Vec<String> = data.datasets.iter().filter_map(|d| d.spec.name.clone()).collect();
                here("gait.control.dataset", Error::new(ErrorKind::UnknownName, format!("no [[dataset]] is named {:?} (named datasets: {names:?})", c.dataset)))
            })?),
            None => None,
        };
        let mut roles = Vec::new();
        let mut subjects = Vec::new();
        for d in &data.datasets {
            if Some(d.index) == control_dataset {
                if d.files.len() != 1 {
                    return Err(here(
                        &format!("dataset[{}].files", d.index),
                        Error::new(ErrorKind::WrongValueCount, format!("the control walk's dataset must hold one file, it holds {}", d.files.len())),
                    ));
                }
                roles.push(Role::Control);
                subjects.push(Vec::new());
                continue;
            }
            let Some(condition) = d.tag(&section.condition_tag) else {
                return Err(here(
                    &format!("dataset[{}]", d.index),
                    Error::new(
                        ErrorKind::MissingKey,
                        format!(
                            "this dataset has no `{}` tag and is not the control walk; give its trials a condition (`tags = {{ {} = \"…\" }}`)",
                            section.condition_tag, section.condition_tag
                        ),
                    ),
                ));
            };
            let mut ids = Vec::new();
            for f in &d.files {
                let stem = motionlab_core::paths::stem(f);
                let id = section.subject.subject_of(&stem).ok_or_else(|| {
                    here(
                        "gait.subject",
                        Error::new(
                            ErrorKind::InvalidParameter,
                            format!(
                                "cannot read a subject from {:?}: the stem {stem:?} split at {:?} has no non-empty field {}",
                                f.display().to_string(),
                                section.subject.separator,
                                section.subject.field
                            ),
                        ),
                    )
                })?;
                ids.push(id);
            }
            roles.push(Role::Trials { condition: condition.to_string() });
            subjects.push(ids);
        }
        // One trial per subject and condition: change rates pair them.
        let mut seen: BTreeMap<(String, String), String> = BTreeMap::new();
        for (d, role) in data.datasets.iter().zip(&roles) {
            let Role::Trials { condition } = role else { continue };
            for (f, id) in d.files.iter().zip(&subjects[d.index]) {
                if let Some(other) = seen.insert((id.clone(), condition.clone()), f.display().to_string()) {
                    return Err(here(
                        "gait.subject",
                        Error::new(
                            ErrorKind::DuplicateName,
                            format!("subject {id:?} has two trials in condition {condition:?}: {other} and {}; keep one per subject and condition", f.display()),
                        ),
                    ));
                }
            }
        }
        if let ViewerChoice::Only(list) = &section.viewers {
            for (k, x) in list.iter().enumerate() {
                let known = data.datasets.iter().any(|d| (0..d.files.len()).any(|f| d.sequence_name(f) == *x))
                    || subjects.iter().flatten().any(|s| s == x);
                if !known {
                    return Err(here(
                        &format!("gait.viewers[{k}]"),
                        Error::new(ErrorKind::UnknownName, format!("{x:?} is neither a sequence (`normal/2014001_C4_05`) nor a subject id of this experiment")),
                    ));
                }
            }
        }
        let conditions: Vec<&str> = roles
            .iter()
            .filter_map(|r| match r {
                Role::Trials { condition } => Some(condition.as_str()),
                Role::Control => None,
            })
            .collect();
        if !conditions.contains(&section.normal_condition.as_str()) {
            return Err(here(
                "gait.normal_condition",
                Error::new(ErrorKind::UnknownName, format!("no dataset has `{} = {:?}` (conditions: {conditions:?})", section.condition_tag, section.normal_condition)),
            ));
        }
        if !conditions.iter().any(|c| *c != section.normal_condition) {
            return Err(here(
                "gait.normal_condition",
                Error::new(ErrorKind::EmptySequence, format!("every trial is in the normal condition {:?}; change rates need another condition", section.normal_condition)),
            ));
        }
        let check_target = |path: &str, c: &str| -> Result<()> {
            if c == section.normal_condition || !conditions.contains(&c) {
                let others: Vec<&&str> = conditions.iter().filter(|x| **x != section.normal_condition).collect();
                return Err(here(path, Error::new(ErrorKind::UnknownName, format!("expected a condition other than the normal one, one of {others:?}; found {c:?}"))));
            }
            Ok(())
        };
        let needs_synth = |path: &str| {
            here(path, Error::new(ErrorKind::MissingKey, "needs `[gait] synthesizer = { type = \"feature_channel_control\" }` (or another walk synthesizer)"))
        };
        let control = match (&section.control, control_dataset) {
            (Some(c), Some(dataset)) => {
                check_target("gait.control.condition", &c.condition)?;
                if synthesizer.is_none() {
                    return Err(needs_synth("gait.control"));
                }
                if c.channel_map.is_empty() {
                    return Err(here("gait.control.channel_map", Error::new(ErrorKind::MissingKey, "map at least one trial channel to a walk channel")));
                }
                let mut targets = std::collections::HashSet::new();
                for (from, to) in &c.channel_map {
                    if !targets.insert(to.as_str()) {
                        return Err(here(&format!("gait.control.channel_map.{from}"), Error::new(ErrorKind::DuplicateName, format!("two trial channels map to {to:?}"))));
                    }
                }
                for (ch, o) in &c.offset_deg {
                    if !o.is_finite() || !targets.contains(ch.as_str()) {
                        return Err(here(
                            "gait.control.offset_deg",
                            Error::new(ErrorKind::InvalidParameter, format!("offset of {ch:?} ({o}): expected a finite number for a channel_map target")),
                        ));
                    }
                }
                if c.strip_every_frames == 0 || c.strip_poses < 2 {
                    return Err(here(
                        if c.strip_every_frames == 0 { "gait.control.strip_every_frames" } else { "gait.control.strip_poses" },
                        Error::new(ErrorKind::OutOfRange, "expected strip_every_frames >= 1 and strip_poses >= 2"),
                    ));
                }
                let cr = root.key("control");
                Some(BuiltControl {
                    spec: c.clone(),
                    dataset,
                    angles: build_stage(source, combo, &c.joint_angles, &cr.key("joint_angles"), registry::build_feature_extractor)?,
                    detector: build_stage(source, combo, &c.cycles, &cr.key("cycles"), registry::build_gait_cycle_detector)?,
                })
            }
            _ => None,
        };
        if let Some(l) = &section.loso {
            check_target("gait.loso.condition", &l.condition)?;
            if synthesizer.is_none() {
                return Err(needs_synth("gait.loso"));
            }
            if l.points < 2 {
                return Err(here("gait.loso.points", Error::new(ErrorKind::OutOfRange, format!("expected at least 2 samples per cycle, found {}", l.points))));
            }
        }
        let mut published_channels: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for p in combo.file.published.iter().filter(|p| p.table == TABLE_POSTURE || p.table == TABLE_SIZE) {
            let list = published_channels.entry(p.table.clone()).or_default();
            list.extend(p.rows.iter().filter_map(|r| r.get("channel").and_then(|v| v.as_str()).map(str::to_string)));
        }
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
            combo_index: combo.index,
            source: source.clone(),
            doc: combo.doc.clone(),
        })
    }
}

motionlab_experiment::register_workflow!(GaitWorkflow, "gait");
