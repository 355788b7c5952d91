//! Walk analysis and control on real data: joint angles, gait cycles, waveform parameters,
//! change rates, synthesis and leave-one-subject-out (numbers in benches/README.md).
//!
//! `cargo bench -p motionlab-gait --bench gait`

use std::path::PathBuf;
use std::sync::OnceLock;

use divan::counter::ItemsCount;
use divan::{Bencher, black_box};
use motionlab_core::Motion;
use motionlab_core::registry::ParamGuard;
use motionlab_features::gait_cycles::{C3dEventsParams, HeelHeightParams};
use motionlab_features::joint_angles::{AbsentMarkers, IsbJointAngles, IsbJointAnglesParams};
use motionlab_features::waveform::WaveformParametersParams;
use motionlab_features::{GaitCycleDetector, WaveformAnalyzer};
use motionlab_gait::WalkSynthesizer;
use motionlab_gait::change_rates::ChangeRatesParams;
use motionlab_gait::loso::leave_one_subject_out;
use motionlab_gait::study::{AnalysedWalk, SubjectWalk, Walk, study_of};
use motionlab_gait::synthesis::{FeatureChannelControl, Interpolation};

fn main() {
    divan::main();
}

fn angles() -> IsbJointAngles {
    IsbJointAnglesParams { absent_markers: AbsentMarkers::Nan, ..Default::default() }
        .check()
        .unwrap()
}

/// Every Schreiber & Moissenet trial (36 × ~170 frames × 52 markers).
fn motions() -> &'static [Motion] {
    static M: OnceLock<Vec<Motion>> = OnceLock::new();
    M.get_or_init(|| {
        let root = motionlab_testkit::data_path("schreiber2019");
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&root)
            .unwrap()
            .filter_map(|d| std::fs::read_dir(d.ok()?.path().join("dynamic")).ok())
            .flatten()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .collect();
        paths.sort();
        paths
            .iter()
            .map(|p| {
                motionlab_io::c3d::parse_c3d(
                    &motionlab_io::read::read_bytes(p).unwrap(),
                    p,
                    &Default::default(),
                )
                .unwrap()
            })
            .collect()
    })
}

fn walks() -> &'static [SubjectWalk] {
    static W: OnceLock<Vec<SubjectWalk>> = OnceLock::new();
    W.get_or_init(|| {
        let (a, d, w) = (
            angles(),
            C3dEventsParams::default(),
            WaveformParametersParams::default().check().unwrap(),
        );
        motions()
            .iter()
            .map(|m| {
                let curves = a.angle_curves(m).unwrap();
                let cycles = d.cycles(m).unwrap();
                let parameters = w.parameters(&curves, &cycles).unwrap();
                let mut parts = m.name.split('_');
                SubjectWalk {
                    subject: parts.next().unwrap().into(),
                    condition: parts.next().unwrap().into(),
                    analysed: AnalysedWalk { walk: Walk { curves, cycles }, parameters },
                }
            })
            .collect()
    })
}

fn total_frames() -> usize {
    motions().iter().map(Motion::n_frames).sum()
}

/// 45 Cardan channels of 36 trials (frames counted).
#[divan::bench]
fn isb_joint_angles_36_trials(bencher: Bencher) {
    let (a, m) = (angles(), motions());
    bencher.counter(ItemsCount::new(total_frames())).bench(|| {
        m.iter().map(|m| a.angle_curves(black_box(m)).unwrap().values.len()).sum::<usize>()
    });
}

#[divan::bench]
fn heel_height_cycles_36_trials(bencher: Bencher) {
    let (d, m) = (HeelHeightParams::default().check().unwrap(), motions());
    bencher
        .counter(ItemsCount::new(total_frames()))
        .bench(|| m.iter().map(|m| d.cycles(black_box(m)).unwrap().len()).sum::<usize>());
}

#[divan::bench]
fn waveform_parameters_36_trials(bencher: Bencher) {
    let (w, walks) = (WaveformParametersParams::default().check().unwrap(), walks());
    bencher.counter(ItemsCount::new(total_frames())).bench(|| {
        walks
            .iter()
            .map(|s| {
                w.parameters(black_box(&s.analysed.walk.curves), &s.analysed.walk.cycles)
                    .unwrap()
                    .dc
                    .len()
            })
            .sum::<usize>()
    });
}

/// K, μ, σ, CV and features for 18 subjects × 45 channels × 2 components.
#[divan::bench]
fn change_rates_18_subjects(bencher: Bencher) {
    let study = study_of("C4", walks());
    let rates = ChangeRatesParams::default().check().unwrap();
    bencher.bench(|| rates.analyse(black_box(&study)).unwrap().conditions.len());
}

#[divan::bench(args = [Interpolation::Linear, Interpolation::Cubic])]
fn feature_channel_control_36_trials(bencher: Bencher, interpolation: Interpolation) {
    let walks = walks();
    let changes = ChangeRatesParams::default()
        .check()
        .unwrap()
        .analyse(&study_of("C4", walks))
        .unwrap()
        .conditions[0]
        .walk_changes();
    let stage = FeatureChannelControl { interpolation, ..Default::default() };
    bencher.counter(ItemsCount::new(total_frames())).bench(|| {
        walks
            .iter()
            .filter(|w| w.analysed.parameters.dc.iter().all(|v| v.is_finite()))
            .map(|w| {
                stage
                    .synthesize(
                        black_box(&w.analysed.walk.curves),
                        &w.analysed.walk.cycles,
                        &changes,
                    )
                    .unwrap()
                    .n_frames()
            })
            .sum::<usize>()
    });
}

/// 18 folds: estimate from 17 subjects, synthesise, compare 45 channels (RMS + DTW of 101-point cycles).
#[divan::bench(sample_count = 20)]
fn leave_one_subject_out_18(bencher: Bencher) {
    let (walks, rates) = (walks(), ChangeRatesParams::default().check().unwrap());
    bencher.bench(|| {
        leave_one_subject_out(
            black_box(walks),
            "C4",
            "C5",
            &rates,
            &FeatureChannelControl::default(),
            101,
        )
        .unwrap()
        .subjects
        .len()
    });
}
