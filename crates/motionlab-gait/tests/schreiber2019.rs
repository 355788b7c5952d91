//! Real-data tests on the 36 Schreiber & Moissenet (2019) trials (`data/schreiber2019`):
//! 18 subjects × comfortable (C4, "normal") and fast (C5) walking, 52 ISB markers at 100 Hz,
//! Foot Strike events in the C3D. Run with `--nocapture` to see the numbers.

use std::path::PathBuf;
use std::sync::OnceLock;

use motionlab_core::Motion;
use motionlab_core::registry::ParamGuard;
use motionlab_features::gait_cycles::{C3dEventsParams, HeelHeightParams};
use motionlab_features::joint_angles::{AbsentMarkers, IsbJointAnglesParams};
use motionlab_features::waveform::WaveformParametersParams;
use motionlab_features::{AngleCurves, GaitCycle, GaitCycleDetector, WaveformAnalyzer};
use motionlab_gait::change_rates::{ChangeRatesParams, Component};
use motionlab_gait::loso::leave_one_subject_out;
use motionlab_gait::study::{AnalysedWalk, SubjectWalk, Walk, study_of};
use motionlab_gait::synthesis::FeatureChannelControl;
use motionlab_io::c3d::{C3dOptions, parse_c3d};

struct Trial {
    file: String,
    subject: String,
    condition: String,
    motion: Motion,
    events: Vec<GaitCycle>,
    curves: AngleCurves,
}

fn trials() -> &'static [Trial] {
    static TRIALS: OnceLock<Vec<Trial>> = OnceLock::new();
    TRIALS.get_or_init(|| {
        let root = motionlab_testkit::data_path("schreiber2019");
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&root)
            .expect("data/schreiber2019")
            .filter_map(|d| std::fs::read_dir(d.ok()?.path().join("dynamic")).ok())
            .flatten()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.to_string_lossy().ends_with(".c3d.gz"))
            .collect();
        paths.sort();
        // Two subjects were recorded without the medial knee and ankle markers: their hip, knee
        // and ankle channels are NaN (and excluded, flagged, from the change rates).
        let angles =
            IsbJointAnglesParams { absent_markers: AbsentMarkers::Nan, ..Default::default() }
                .check()
                .unwrap();
        paths
            .iter()
            .map(|p| {
                let bytes = motionlab_io::read::read_bytes(p).unwrap();
                let motion = parse_c3d(&bytes, p, &C3dOptions::default()).unwrap();
                let file =
                    p.file_name().unwrap().to_string_lossy().trim_end_matches(".gz").to_string();
                let mut parts = file.split('_');
                let (subject, condition) =
                    (parts.next().unwrap().to_string(), parts.next().unwrap().to_string());
                let events = C3dEventsParams::default().cycles(&motion).unwrap();
                let curves = angles.angle_curves(&motion).unwrap();
                Trial { file, subject, condition, motion, events, curves }
            })
            .collect()
    })
}

/// `file -> (strideL, strideR)` in seconds, parsed from SOURCE.txt.
fn source_strides() -> Vec<(String, f64, f64, f64)> {
    let text =
        std::fs::read_to_string(motionlab_testkit::data_path("schreiber2019/SOURCE.txt")).unwrap();
    text.lines()
        .filter_map(|l| {
            let mut it = l.split_whitespace();
            let file = it.next()?.to_string();
            if !file.ends_with(".c3d") {
                return None;
            }
            let num = |s: &str, key: &str| {
                s.strip_prefix(key).map(|v| v.trim_end_matches('s').parse::<f64>().unwrap())
            };
            let l = num(it.next()?, "strideL=")?;
            let r = num(it.next()?, "strideR=")?;
            let cadence = num(it.next()?, "cadence=")?;
            Some((file, l, r, cadence))
        })
        .collect()
}

#[test]
fn event_cycles_match_the_stride_times_in_source_txt() {
    let strides = source_strides();
    assert_eq!(strides.len(), 36);
    assert_eq!(trials().len(), 36);
    let mut checked = 0;
    for t in trials() {
        let (_, l, r, _) = strides
            .iter()
            .find(|s| s.0 == t.file)
            .unwrap_or_else(|| panic!("{} not in SOURCE.txt", t.file));
        for (side, listed) in [("Left", l), ("Right", r)] {
            let cycles: Vec<&GaitCycle> = t.events.iter().filter(|c| c.side == side).collect();
            assert_eq!(cycles.len(), 1, "{} {side}: {cycles:?}", t.file);
            let frames = (cycles[0].end - cycles[0].start) as f64;
            let listed_frames = listed * t.motion.frame_rate().hz();
            assert!(
                (frames - listed_frames).abs() <= 1.0,
                "{} {side}: {frames} frames vs {listed} s",
                t.file
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 72);
}

#[test]
fn heel_detector_agrees_with_the_events() {
    let heel = HeelHeightParams::default().check().unwrap();
    let (
        mut strikes,
        mut within1,
        mut within2,
        mut within3,
        mut cycles_found,
        mut durations_within2,
    ) = (0, 0, 0, 0, 0, 0);
    let mut offsets = Vec::new();
    let mut worst_duration = 0usize;
    for t in trials() {
        let found = heel.cycles(&t.motion).unwrap();
        for e in &t.events {
            // Both strikes of each event cycle against the heel detector's strikes of that foot.
            let heel_strikes: Vec<usize> =
                found.iter().filter(|c| c.side == e.side).flat_map(|c| [c.start, c.end]).collect();
            for s in [e.start, e.end] {
                strikes += 1;
                if let Some(d) =
                    heel_strikes.iter().map(|h| *h as i64 - s as i64).min_by_key(|d| d.abs())
                {
                    offsets.push(d);
                    within1 += usize::from(d.abs() <= 1);
                    within2 += usize::from(d.abs() <= 2);
                    within3 += usize::from(d.abs() <= 3);
                }
            }
            if let Some(h) =
                found.iter().find(|h| h.side == e.side && h.start.abs_diff(e.start) <= 5)
            {
                cycles_found += 1;
                let dd = (h.end - h.start).abs_diff(e.end - e.start);
                worst_duration = worst_duration.max(dd);
                durations_within2 += usize::from(dd <= 2);
            }
        }
    }
    offsets.sort();
    let median = offsets[offsets.len() / 2];
    println!(
        "heel_height vs C3D events: {strikes} event strikes; within 1 frame {within1}, 2 frames {within2}, 3 frames {within3}; \
         median offset {median} frames; event cycles also found {cycles_found}/72, duration within 2 frames {durations_within2}, worst {worst_duration}"
    );
    assert_eq!(strikes, 144);
    assert!(within2 >= 120, "{within2}");
    assert!(median.abs() <= 1);
    assert!(
        cycles_found >= 66 && durations_within2 * 10 >= cycles_found * 9,
        "{cycles_found} {durations_within2}"
    );
}

fn at(curves: &AngleCurves, channel: &str, frame: usize) -> f64 {
    curves.values[curves.channel_index(channel).unwrap()][frame]
}

#[test]
fn joint_angles_of_real_walks_have_the_textbook_shape() {
    let mut checked = 0;
    for t in trials() {
        // The files have no gaps: only the joints of absent markers are NaN.
        let no_medial = t.motion.point_index("L_FME").is_err();
        for (ch, v) in t.curves.channels.iter().zip(&t.curves.values) {
            let lower_limb = ["hip_", "knee_", "ankle_"].iter().any(|j| ch.starts_with(j));
            assert_eq!(
                v.iter().all(|x| x.is_finite()),
                !(no_medial && lower_limb),
                "{} {ch}",
                t.file
            );
        }
        if no_medial {
            continue;
        }
        checked += 1;
        for e in &t.events {
            let s = if e.side == "Left" { "l" } else { "r" };
            let other = t.events.iter().find(|c| c.side != e.side).unwrap();
            let n = e.end - e.start;
            let knee: Vec<f64> =
                (e.start..=e.end).map(|f| at(&t.curves, &format!("knee_{s}.flexion"), f)).collect();
            let (peak_at, peak) = knee
                .iter()
                .enumerate()
                .fold((0, f64::MIN), |b, (i, v)| if *v > b.1 { (i, *v) } else { b });
            // Knee: peak flexion 45–80° in swing (60–85 % of the cycle), nearly straight at strike.
            assert!((45.0..80.0).contains(&peak), "{} knee_{s} peak {peak}", t.file);
            let phase = peak_at as f64 / n as f64;
            assert!((0.6..0.85).contains(&phase), "{} knee_{s} peak at {phase}", t.file);
            assert!((-10.0..20.0).contains(&knee[0]), "{} knee_{s} at strike {}", t.file, knee[0]);
            // Hip: flexed at this foot's strike, extended half a cycle later (the other foot's strike).
            let hip = |f: usize| at(&t.curves, &format!("hip_{s}.flexion"), f);
            let opposite = if other.start > e.start { other.start } else { other.end };
            assert!(
                hip(e.start) - hip(opposite) > 20.0,
                "{} hip_{s}: {} at strike vs {} at the other's",
                t.file,
                hip(e.start),
                hip(opposite)
            );
            // Ankle: dorsiflexes through mid-stance (10–50 %), then plantarflexes at push-off (50–75 %).
            let ankle = |from: f64, to: f64| -> Vec<f64> {
                let (a, b) =
                    (e.start + (from * n as f64) as usize, e.start + (to * n as f64) as usize);
                (a..=b).map(|f| at(&t.curves, &format!("ankle_{s}.flexion"), f)).collect()
            };
            let stance_max = ankle(0.1, 0.5).into_iter().fold(f64::MIN, f64::max);
            let push_off_min = ankle(0.5, 0.75).into_iter().fold(f64::MAX, f64::min);
            assert!(
                stance_max - push_off_min > 10.0,
                "{} ankle_{s}: {stance_max} then {push_off_min}",
                t.file
            );
        }
    }
    assert_eq!(checked, 32);
}

fn analysed(t: &Trial) -> SubjectWalk {
    let analyzer = WaveformParametersParams::default().check().unwrap();
    let parameters = analyzer.parameters(&t.curves, &t.events).unwrap();
    SubjectWalk {
        subject: t.subject.clone(),
        condition: t.condition.clone(),
        analysed: AnalysedWalk {
            walk: Walk { curves: t.curves.clone(), cycles: t.events.clone() },
            parameters,
        },
    }
}

#[test]
fn frequency_change_rates_equal_those_of_the_listed_cadences() {
    // Independent: K_j from SOURCE.txt's cadence (120 / mean stride, 1 decimal) vs ours.
    let walks: Vec<SubjectWalk> = trials().iter().map(analysed).collect();
    let study = study_of("C4", &walks);
    let analysis = ChangeRatesParams::default().check().unwrap().analyse(&study).unwrap();
    let fast = analysis.condition("C5").unwrap();
    assert_eq!(fast.subjects.len(), 18);
    let strides = source_strides();
    let cadence = |subject: &str, cond: &str| {
        strides.iter().find(|s| s.0.starts_with(&format!("{subject}_{cond}_"))).unwrap().3
    };
    for f in &fast.frequency {
        let k_source = (cadence(&f.subject, "C5") - cadence(&f.subject, "C4"))
            / cadence(&f.subject, "C4")
            * 100.0;
        assert!(f.k_pct > 0.0, "{}: fast walking is not faster", f.subject);
        assert!(
            (f.k_pct - k_source).abs() < 0.3,
            "{}: K_f {} vs {k_source} from the cadences",
            f.subject,
            f.k_pct
        );
    }
    // Biomechanics: faster walking swings the hips and elbows more, on average.
    let mean = |ch: &str, c: Component| {
        fast.summary.iter().find(|s| s.channel == ch && s.component == c).unwrap().mean_pct
    };
    for ch in ["hip_l.flexion", "hip_r.flexion", "elbow_l.flexion", "elbow_r.flexion"] {
        assert!(mean(ch, Component::Amplitude) > 0.0, "{ch}: {}", mean(ch, Component::Amplitude));
    }
    println!(
        "fast vs normal: frequency μ {:.1} %, σ {:.1} %",
        fast.frequency_mean_pct, fast.frequency_sd_pct
    );
    for s in fast.summary.iter().filter(|s| s.feature) {
        println!(
            "  feature {:24} {:9} μ {:7.1} σ {:7.1} CV {:7.1}  n {:2} excl {}",
            s.channel,
            s.component.name(),
            s.mean_pct,
            s.sd_pct,
            s.cv_pct,
            s.n_subjects,
            s.n_excluded
        );
    }
}

#[test]
fn leave_one_subject_out_on_real_walks() {
    let walks: Vec<SubjectWalk> = trials().iter().map(analysed).collect();
    let rates = ChangeRatesParams::default().check().unwrap();
    let r =
        leave_one_subject_out(&walks, "C4", "C5", &rates, &FeatureChannelControl::default(), 101)
            .unwrap();
    assert_eq!(r.subjects.len(), 18);
    println!(
        "subject   n_ctrl  rms_synth rms_normal | ctrl: synth normal | dtw_synth dtw_normal | f_norm f_synth f_rec"
    );
    for s in r.subjects.iter().chain([&r.mean]) {
        println!(
            "{:8} {:6} {:9.2} {:10.2} | {:11.2} {:6.2} | {:9.2} {:10.2} | {:6.3} {:7.3} {:5.3}",
            s.subject,
            s.n_controlled,
            s.rms_synth_deg,
            s.rms_normal_deg,
            s.rms_synth_controlled_deg,
            s.rms_normal_controlled_deg,
            s.dtw_synth_deg,
            s.dtw_normal_deg,
            s.frequency_normal_hz,
            s.frequency_synth_hz,
            s.frequency_recorded_hz
        );
        assert!(
            s.rms_synth_deg.is_finite()
                && s.rms_normal_deg.is_finite()
                && s.dtw_synth_deg.is_finite()
        );
    }
    // The frequency control uses the others' mean speed-up: it must bring the tempo closer to
    // the recorded fast walk than leaving it unchanged, on average.
    let err = |f: fn(&motionlab_gait::loso::LosoSubjectRecord) -> f64| {
        r.subjects.iter().map(|s| (f(s) - s.frequency_recorded_hz).abs()).sum::<f64>()
            / r.subjects.len() as f64
    };
    assert!(err(|s| s.frequency_synth_hz) < err(|s| s.frequency_normal_hz));
}
