//! Running the `[gait]` workflow: each walk analysed (angles → cycles → waveform parameters),
//! then per combination the study, its evaluators, the paper's tables, the control and the
//! leave-one-subject-out.

use motionlab_core::{Error, ErrorKind, EvalInput, FeatureCache, FeatureExtractor, Motion, Result};
use motionlab_experiment::Datasets;
use motionlab_experiment::workflow::{ItemData, ItemOutput, Output, WorkItem, Workflow};
use motionlab_features::GaitCycleDetector;
use motionlab_features::joint_angles::angle_curves_from_features;
use motionlab_gait::change_rates::ChangeRateAnalysis;
use motionlab_gait::loso::leave_one_subject_out;
use motionlab_gait::study::{AnalysedWalk, SubjectWalk, Walk, study_of};

use super::analysis::{loso_verdict, trials_table};
use super::figures::{conditions_in_order, frequency_figures, loso_figure, mean_cycle_figure};
use super::{GaitWorkflow, Role, WalkRecord};

impl GaitWorkflow {
    /// An error about the configuration at key `path` (file, line, key path).
    pub(super) fn config_error(&self, path: &str, err: Error) -> Error {
        self.locator.locate(err, path)
    }

    /// Angles → cycles → parameters of one walk; errors name the stage.
    pub(super) fn analyse(
        &self,
        motion: &Motion,
        angles: &dyn FeatureExtractor,
        detector: &dyn GaitCycleDetector,
        prefix: &str,
    ) -> Result<AnalysedWalk> {
        let features = angles
            .extract(motion, &FeatureCache::new())
            .map_err(|e| e.under_field(format!("{prefix}.joint_angles")))?;
        let curves = angle_curves_from_features(&features, motion.frame_rate())
            .map_err(|e| e.under_field(format!("{prefix}.joint_angles")))?;
        let cycles =
            detector.cycles(motion).map_err(|e| e.under_field(format!("{prefix}.cycles")))?;
        let parameters = self
            .analyzer
            .parameters(&curves, &cycles)
            .map_err(|e| e.under_field("gait.waveform"))?;
        Ok(AnalysedWalk { walk: Walk { curves, cycles }, parameters })
    }
}

impl Workflow for GaitWorkflow {
    fn run_item(&self, item: &WorkItem, data: &Datasets, _draw: bool) -> Result<ItemOutput> {
        let loaded = data.load(item.dataset, item.file)?;
        let (subject, condition, control, analysed) = match &self.roles[item.dataset] {
            Role::Trials { condition } => {
                let a = self.analyse(
                    &loaded.motion,
                    self.angles.as_ref(),
                    self.detector.as_ref(),
                    "gait",
                )?;
                (self.subjects[item.dataset][item.file].clone(), condition.clone(), false, a)
            }
            Role::Control => {
                let c = self.control.as_ref().ok_or_else(|| {
                    Error::new(ErrorKind::Mismatch, "control dataset without [gait.control]")
                })?;
                let a = self.analyse(
                    &loaded.motion,
                    c.angles.as_ref(),
                    c.detector.as_ref(),
                    "gait.control",
                )?;
                (String::new(), c.spec.condition.clone(), true, a)
            }
        };
        let record = WalkRecord {
            sequence: loaded.name.clone(),
            subject,
            condition,
            control,
            n_frames: loaded.motion.n_frames(),
            curves: analysed.walk.curves,
            cycles: analysed.walk.cycles,
            parameters: analysed.parameters,
        };
        Ok(ItemOutput::new(ItemData::encode(&record)?, Vec::new()))
    }

    fn finish(
        &self,
        items: &[(WorkItem, ItemData)],
        data: &Datasets,
        draw: bool,
    ) -> Result<Output> {
        let mut trials: Vec<WalkRecord> = Vec::new();
        let mut control_walk: Option<WalkRecord> = None;
        let mut viewers = Vec::new();
        for (item, value) in items {
            let r: WalkRecord = value.decode()?;
            if draw && self.section.viewers.wants(&r.sequence, &r.subject) {
                viewers.push(self.viewer(item, &r, data)?);
            }
            if r.control {
                control_walk = Some(r);
            } else {
                trials.push(r);
            }
        }
        let normal = self.section.normal_condition.clone();
        let walks: Vec<SubjectWalk> = trials
            .iter()
            .map(|r| SubjectWalk {
                subject: r.subject.clone(),
                condition: r.condition.clone(),
                analysed: AnalysedWalk {
                    walk: Walk { curves: r.curves.clone(), cycles: r.cycles.clone() },
                    parameters: r.parameters.clone(),
                },
            })
            .collect();
        let study = study_of(&normal, &walks);
        let mut out = Output { viewers, ..Output::default() };
        out.tables.push(trials_table(&trials)?);
        let mut change_rates: Option<Box<ChangeRateAnalysis>> = None;
        for (name, e) in &self.evaluators {
            let evaluation = e
                .evaluate_with_analysis(EvalInput::new(&study))
                .map_err(|err| err.under_field(format!("evaluate {name}")))?;
            out.tables.extend(evaluation.tables);
            if change_rates.is_none() {
                change_rates =
                    evaluation.analysis.and_then(|a| a.downcast::<ChangeRateAnalysis>().ok());
            }
        }
        let ChangeRateAnalysis { rates, changes: analysis } = *change_rates.ok_or_else(|| {
            self.config_error(
                "gait",
                Error::new(ErrorKind::MissingKey, "no evaluator produced the change-rate analysis"),
            )
        })?;
        out.tables.extend(self.paper_tables(&analysis, rates.max_abs_cv_pct)?);
        if draw {
            for (k, ch) in self.section.figure_channels.iter().enumerate() {
                let figure =
                    mean_cycle_figure(&trials, ch, &normal, &conditions_in_order(&trials, &normal))
                        .map_err(|e| self.config_error(&format!("gait.figure_channels[{k}]"), e))?;
                out.figures.push(figure);
            }
            out.figures.extend(frequency_figures(&analysis)?);
        }
        if let (Some(c), Some(walk)) = (&self.control, control_walk) {
            self.control_walk(c, &walk, &analysis, data, draw, &mut out)?;
        }
        if let Some(l) = &self.section.loso {
            let synth = self.synthesizer.as_deref().ok_or_else(|| {
                Error::new(ErrorKind::MissingKey, "[gait.loso] needs a synthesizer")
            })?;
            let loso =
                leave_one_subject_out(&walks, &normal, &l.condition, &rates, synth, l.points)
                    .map_err(|e| e.under_field("gait.loso"))?;
            out.tables.extend(loso.tables()?);
            out.tables.push(loso_verdict(&loso, &normal)?);
            if draw {
                out.figures.push(loso_figure(&loso, &normal));
            }
        }
        Ok(out)
    }
}
