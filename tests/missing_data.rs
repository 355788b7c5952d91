//! Missing data in every stage: each feature, segmenter, fuser, point detector,
//! matcher, preprocessor and gait stage on the real gaps of `mct/walk1` (27 missing samples:
//! Head_FR over 11 frames, Shoulder_R over 16) and on gap-injected copies of real sequences
//! (`mct/dance1` with Hip_FL removed over 0.5 s and over 3 s; Schreiber & Moissenet 2014001
//! with L_FLE removed over 0.5 s and over the whole trial), asserting what each stage's doc
//! promises: refusal names the marker and frame, skipping gives finite output where defined
//! and leaves frames far from the gap unchanged, `fill_gaps` then the refusing stage works.
//!
//! Stages are built through the plugin registry with TOML parameters, as an experiment does.

use motionlab_core::registry;
use motionlab_core::{
    ErrorKind, EvalInput, FeatureCache, FeatureSet, MethodCandidates, Motion, Result,
    SegmenterOutput,
};
use motionlab_features::{AngleCurves, GaitCycle};
use motionlab_gait::{GaitStudy, GaitTrial, WalkChanges};

use motionlab_eval as _;
use motionlab_features as _;
use motionlab_gait as _;
use motionlab_io as _;
use motionlab_match as _;
use motionlab_segment as _;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn params(text: &str) -> toml::Value {
    toml::Value::Table(toml::from_str(text).unwrap_or_else(|e| panic!("test params {text:?}: {e}")))
}

fn load(loader: &str, relative: &str) -> Motion {
    registry::build_loader(loader, &params(""))
        .unwrap()
        .load(&motionlab_testkit::data_path(relative))
        .unwrap()
}

fn walk1() -> Motion {
    load("qualisys_tsv", "mct/walk1.tsv.gz")
}

fn dance1() -> Motion {
    load("qualisys_tsv", "mct/dance1.tsv.gz")
}

fn schreiber() -> Motion {
    load("c3d", "schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz")
}

/// A copy of `m` with `marker` missing over frames `start..start + len`.
fn with_gap(m: &Motion, marker: &str, start: usize, len: usize) -> Motion {
    let k = m.point_index(marker).unwrap();
    let n = m.n_points();
    let mut out = m.clone();
    for f in start..(start + len).min(m.n_frames()) {
        out.positions_mut()[f * n + k] = [f64::NAN; 3];
    }
    out.refresh_missing();
    assert_eq!(out.missing_count(), m.missing_count() + len.min(m.n_frames() - start));
    out
}

/// dance1 (60 Hz) with Hip_FL missing for 0.5 s (frames 600–629) and for 3 s (600–779).
const GAP_START: usize = 600;
fn dance1_gaps() -> [(Motion, usize); 2] {
    let d = dance1();
    assert_eq!(d.missing_count(), 0, "dance1 is complete");
    [(with_gap(&d, "Hip_FL", GAP_START, 30), 30), (with_gap(&d, "Hip_FL", GAP_START, 180), 180)]
}

fn preprocess(name: &str, p: &str, m: Motion) -> Result<Motion> {
    registry::build_preprocessor(name, &params(p)).unwrap().apply(m)
}

/// dance1 variants get a `root` marker: the centroid of the four hip markers, missing wherever
/// any of them is (`add_centroid`'s default), so root-based stages see the Hip_FL gap.
fn with_root(m: Motion) -> Motion {
    preprocess(
        "add_centroid",
        r#"name = "root"
markers = ["Hip_FL", "Hip_FR", "Hip_BL", "Hip_BR"]"#,
        m,
    )
    .unwrap()
}

fn features(name: &str, p: &str, m: &Motion) -> Result<FeatureSet> {
    registry::build_feature_extractor(name, &params(p)).unwrap().extract(m, &FeatureCache::new())
}

fn segment(name: &str, p: &str, m: &Motion) -> Result<SegmenterOutput> {
    registry::build_segmenter(name, &params(p)).unwrap().segment(m, &FeatureCache::new())
}

fn trace<'a>(traces: &'a [motionlab_core::Trace], name: &str) -> &'a [f64] {
    &traces.iter().find(|t| t.name == name).unwrap_or_else(|| panic!("no trace {name}")).values
}

/// Frames at which point `k` is missing.
fn missing_frames(m: &Motion, k: usize) -> Vec<usize> {
    (0..m.n_frames()).filter(|&f| m.is_missing(f, k)).collect()
}

/// The error must be `MissingData`, name `marker` as its field and in the message, and name
/// the first missing frame.
fn assert_refused<T>(r: Result<T>, marker: &str, first_frame: usize, stage: &str) {
    let e = match r {
        Ok(_) => panic!("{stage} accepted missing samples of {marker}"),
        Err(e) => e,
    };
    let text = e.to_string();
    assert_eq!(e.kind(), ErrorKind::MissingData, "{stage}: {text}");
    assert_eq!(e.location().field.as_deref(), Some(marker), "{stage}: {text}");
    assert!(
        text.contains(&format!("{marker:?}")) && text.contains(&format!("frame {first_frame}")),
        "{stage}: {text}"
    );
}

// ---------------------------------------------------------------------------------------------
// Docs and data
// ---------------------------------------------------------------------------------------------

#[test]
fn every_plugin_says_how_it_treats_missing_samples() {
    let undocumented: Vec<&str> = registry::plugins()
        .iter()
        .filter(|p| {
            !(p.doc().contains("issing samples") || p.doc().contains("issing marker samples"))
        })
        .map(|p| p.name)
        .collect();
    assert!(
        undocumented.is_empty(),
        "plugins whose doc does not say how missing samples are treated: {undocumented:?}"
    );
    assert!(registry::plugins().len() >= 30, "{} plugins", registry::plugins().len());
}

#[test]
fn walk1_has_27_missing_samples_in_both_exports() {
    let tsv = walk1();
    let c3d = load("c3d", "mct/walk1.c3d.gz");
    assert_eq!((tsv.missing_count(), c3d.missing_count()), (27, 27));
    assert_eq!(tsv.missing_mask(), c3d.missing_mask());
    let head = tsv.point_index("Head_FR").unwrap();
    let shoulder = tsv.point_index("Shoulder_R").unwrap();
    assert_eq!(missing_frames(&tsv, head), (199..210).collect::<Vec<_>>());
    assert_eq!(missing_frames(&tsv, shoulder), (304..320).collect::<Vec<_>>());
}

// ---------------------------------------------------------------------------------------------
// Preprocessors
// ---------------------------------------------------------------------------------------------

#[test]
fn fill_gaps_fills_up_to_max_gap_on_the_straight_line_and_leaves_longer_gaps() {
    let w = walk1();
    // Linear, max 16 frames: both real gaps filled, each sample on the line between the
    // samples around its gap (independent computation).
    let filled = preprocess(
        "fill_gaps",
        r#"method = "linear"
max_gap = { frames = 16 }"#,
        w.clone(),
    )
    .unwrap();
    assert_eq!(filled.missing_count(), 0);
    for (marker, a, b) in [("Head_FR", 198, 210), ("Shoulder_R", 303, 320)] {
        let k = w.point_index(marker).unwrap();
        let (pa, pb) = (w.position(a, k), w.position(b, k));
        for f in a + 1..b {
            let t = (f - a) as f64 / (b - a) as f64;
            for c in 0..3 {
                let expected = pa[c] + t * (pb[c] - pa[c]);
                assert!((filled.position(f, k)[c] - expected).abs() < 1e-9, "{marker} frame {f}");
            }
        }
    }
    // Default max_gap 0.2 s = 12 frames at 60 Hz: the 11-frame gap is filled, the 16-frame one stays.
    let default = preprocess("fill_gaps", "", w.clone()).unwrap();
    assert_eq!(default.missing_count(), 16);
    assert_eq!(
        missing_frames(&default, w.point_index("Shoulder_R").unwrap()),
        (304..320).collect::<Vec<_>>()
    );
    // dance1: a 0.5 s gap is filled with max_gap 0.5 s (cubic, close to the removed truth);
    // a 3 s gap is left missing, every frame of it.
    let d = dance1();
    let k = d.point_index("Hip_FL").unwrap();
    for (gapped, len) in dance1_gaps() {
        let out = preprocess("fill_gaps", "max_gap = { seconds = 0.5 }", gapped).unwrap();
        if len == 30 {
            assert_eq!(out.missing_count(), 0);
            let rms = ((GAP_START..GAP_START + len)
                .map(|f| {
                    (0..3)
                        .map(|c| (out.position(f, k)[c] - d.position(f, k)[c]).powi(2))
                        .sum::<f64>()
                })
                .sum::<f64>()
                / len as f64)
                .sqrt();
            assert!(
                rms < 60.0,
                "cubic fill of a 0.5 s Hip_FL gap is {rms:.1} mm RMS from the removed data"
            );
        } else {
            assert_eq!(missing_frames(&out, k), (GAP_START..GAP_START + len).collect::<Vec<_>>());
        }
    }
}

#[test]
fn add_centroid_delay_and_initial_pose_keep_missing_samples_missing() {
    let w = walk1();
    let head = r#"name = "head"
markers = ["Head_FL", "Head_FR", "Head_BL", "Head_BR"]"#;
    // "any": missing exactly where Head_FR is.
    let any = preprocess("add_centroid", head, w.clone()).unwrap();
    let c = any.point_index("head").unwrap();
    assert_eq!(missing_frames(&any, c), (199..210).collect::<Vec<_>>());
    // "all": the mean of the three valid markers there (independent computation).
    let all =
        preprocess("add_centroid", &format!("{head}\nmissing_if = \"all\""), w.clone()).unwrap();
    assert!(missing_frames(&all, c).is_empty());
    let ks: Vec<usize> =
        ["Head_FL", "Head_BL", "Head_BR"].iter().map(|n| w.point_index(n).unwrap()).collect();
    for f in 199..210 {
        for axis in 0..3 {
            let mean = ks.iter().map(|&k| w.position(f, k)[axis]).sum::<f64>() / 3.0;
            assert!((all.position(f, c)[axis] - mean).abs() < 1e-9);
        }
    }
    // delay_points: Head_FR's gap moves 5 frames later with it.
    let delayed = preprocess(
        "delay_points",
        r#"points = ["Head_FR"]
delay = { frames = 5 }"#,
        w.clone(),
    )
    .unwrap();
    let k = w.point_index("Head_FR").unwrap();
    assert_eq!(missing_frames(&delayed, k), (204..215).collect::<Vec<_>>());
    assert_eq!(delayed.missing_count(), 27);
    // initial_pose_normalisation: the same 27 samples missing, the others p − p₀.
    let norm = preprocess("initial_pose_normalisation", "", w.clone()).unwrap();
    assert_eq!(norm.missing_mask(), w.missing_mask());
    assert_eq!(
        norm.position(250, k),
        [0, 1, 2].map(|c| w.position(250, k)[c] - w.position(0, k)[c])
    );
    for (gapped, _) in dance1_gaps() {
        let norm = preprocess("initial_pose_normalisation", "", gapped.clone()).unwrap();
        assert_eq!(norm.missing_mask(), gapped.missing_mask());
    }
}

#[test]
fn butterworth_and_distinct_points_keep_missing_samples_missing() {
    let w = walk1();
    // butterworth: the 27 real gaps stay missing, the runs around them are filtered separately
    // (the values against scipy: bench/butterworth_vs_scipy.py).
    let filtered = preprocess("butterworth", "cutoff_hz = 6.0", w.clone()).unwrap();
    assert_eq!(filtered.missing_mask(), w.missing_mask());
    let k = w.point_index("Head_FR").unwrap();
    assert_ne!(filtered.position(150, k), w.position(150, k), "present samples are filtered");
    for (gapped, _) in dance1_gaps() {
        assert_eq!(
            preprocess("butterworth", "", gapped.clone()).unwrap().missing_mask(),
            gapped.missing_mask()
        );
    }
    // distinct_points: no two markers of walk1 share a place, and a gap never merges points.
    let distinct = preprocess("distinct_points", "", w.clone()).unwrap();
    assert_eq!(distinct.point_names(), w.point_names());
    assert_eq!(distinct.missing_mask(), w.missing_mask());
}

// ---------------------------------------------------------------------------------------------
// Features
// ---------------------------------------------------------------------------------------------

#[test]
fn marker_speed_skips_missing_markers() {
    let w = walk1();
    let f = features("marker_speed", "per_marker = true", &w).unwrap();
    let v = trace(&f.traces, "V_mm_per_s");
    let n = w.n_frames();
    // V is defined at every frame but the last (some marker is always valid) …
    assert!(v[..n - 1].iter().all(|x| x.is_finite()) && v[n - 1].is_nan());
    // … and equals the fastest valid marker's speed, computed here independently.
    for i in [150, 199, 205, 209, 310] {
        let fastest = (0..w.n_points())
            .filter(|&k| !w.is_missing(i, k) && !w.is_missing(i + 1, k))
            .map(|k| {
                (0..3)
                    .map(|c| (w.position(i + 1, k)[c] - w.position(i, k)[c]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    * 60.0
            })
            .fold(f64::NEG_INFINITY, f64::max);
        assert!((v[i] - fastest).abs() < 1e-9, "frame {i}: {} vs {fastest}", v[i]);
    }
    // Head_FR's own speed is NaN exactly where it or its successor is missing.
    let vh = trace(&f.traces, "v_Head_FR_mm_per_s");
    let nan: Vec<usize> = (0..n - 1).filter(|&i| vh[i].is_nan()).collect();
    assert_eq!(nan, (198..210).collect::<Vec<_>>());
    for (gapped, len) in dance1_gaps() {
        let f = features("marker_speed", "", &gapped).unwrap();
        let v = trace(&f.traces, "V_mm_per_s");
        assert!(v[..v.len() - 1].iter().all(|x| x.is_finite()), "{len}-frame gap");
    }
}

#[test]
fn hull_volume_uses_the_valid_markers_and_leaves_d_undefined_where_the_set_changes() {
    let w = walk1();
    let f = features("hull_volume", "", &w).unwrap();
    let vol = trace(&f.traces, "Vol_mm3");
    let d = trace(&f.traces, "D_mm3_per_frame");
    assert!(vol.iter().all(|v| v.is_finite() && *v > 0.0), "27 valid markers always span a volume");
    // The valid set changes entering and leaving each gap: D undefined there, defined elsewhere.
    let changes = [199, 210, 304, 320];
    for (i, di) in d.iter().enumerate().skip(1) {
        assert_eq!(di.is_nan(), changes.contains(&i), "frame {i}: D = {di}");
    }
    for (gapped, len) in dance1_gaps() {
        let f = features("hull_volume", "", &gapped).unwrap();
        let d = trace(&f.traces, "D_mm3_per_frame");
        assert!(d[GAP_START].is_nan() && d[GAP_START + len].is_nan());
        assert!(d[GAP_START + 1].is_finite() && d[GAP_START + len + 1].is_finite());
    }
}

#[test]
fn root_curvature_is_undefined_around_a_root_gap_and_unchanged_elsewhere() {
    let p = "root = \"root\"\nlag = { frames = 15 }";
    let complete = features("root_curvature", p, &with_root(dance1())).unwrap();
    let c0 = trace(&complete.traces, "C");
    for (gapped, len) in dance1_gaps() {
        let m = with_root(gapped);
        let f = features("root_curvature", p, &m).unwrap();
        let c = trace(&f.traces, "C");
        for i in 0..c.len() {
            let near = (GAP_START.saturating_sub(15)..GAP_START + len + 15).contains(&i);
            if near {
                assert!(c[i].is_nan(), "{len}: frame {i} uses the missing root");
            } else if c0[i].is_finite() {
                assert_eq!(c[i], c0[i], "{len}: frame {i} far from the gap changed");
            }
        }
    }
    // walk1 has no root marker: the stage names the one it needs.
    let e = features("root_curvature", p, &walk1()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::UnknownName, "{e}");
    assert!(e.to_string().contains("root"), "{e}");
}

/// The ISB channels that need L_FLE: the left thigh (hip, knee) and shank (knee, ankle).
fn uses_l_fle(channel: &str) -> bool {
    ["hip_l", "knee_l", "ankle_l"].iter().any(|j| channel.starts_with(j))
}

#[test]
fn isb_joint_angles_are_nan_only_where_their_markers_are_missing() {
    let s = schreiber();
    let p = r#"joints = ["hip", "knee", "ankle", "elbow"]"#;
    let complete = features("isb_joint_angles", p, &s).unwrap();
    // L_FLE (lateral femoral epicondyle) defines the left thigh and shank: left hip, knee and
    // ankle angles are undefined over its gap, every other channel and frame is unchanged.
    for (len, label) in [(50, "0.5 s"), (s.n_frames(), "whole trial")] {
        let g = with_gap(&s, "L_FLE", if len == 50 { 40 } else { 0 }, len);
        let f = features("isb_joint_angles", p, &g).unwrap();
        let gap: Vec<usize> = missing_frames(&g, g.point_index("L_FLE").unwrap());
        for (t, t0) in f.traces.iter().zip(&complete.traces) {
            let uses_fle = uses_l_fle(&t.name);
            for i in 0..t.values.len() {
                if uses_fle && gap.contains(&i) {
                    assert!(t.values[i].is_nan(), "{label}: {} frame {i}", t.name);
                } else {
                    assert_eq!(
                        t.values[i].to_bits(),
                        t0.values[i].to_bits(),
                        "{label}: {} frame {i}",
                        t.name
                    );
                }
            }
        }
    }
    // walk1 has none of the ISB markers: refused naming a marker and its joint.
    let e = features("isb_joint_angles", p, &walk1()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::UnknownName, "{e}");
}

#[test]
fn skeleton_joint_angles_need_a_skeleton_and_ignore_position_gaps() {
    let e = features("skeleton_joint_angles", "", &walk1()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::MissingData, "{e}");
    assert!(
        e.to_string().contains("has no skeleton") && e.to_string().contains("walk1.tsv.gz"),
        "{e}"
    );
    // A gap in the joint positions of an AMC motion does not touch its channels.
    let amc = load("asf_amc", "cmu86/86_01.amc.gz").slice_frames(0, 600).unwrap();
    let gapped = with_gap(&amc, "lfemur", 100, 60);
    assert_eq!(
        features("skeleton_joint_angles", "", &gapped).unwrap(),
        features("skeleton_joint_angles", "", &amc).unwrap()
    );
}

// ---------------------------------------------------------------------------------------------
// Segmenters and the fuser
// ---------------------------------------------------------------------------------------------

/// Candidates are inside the motion, sorted, unique, and never at a frame where `trace` is NaN.
fn assert_candidates_defined(out: &SegmenterOutput, trace_name: &str, n_frames: usize, what: &str) {
    assert!(
        out.candidates.windows(2).all(|w| w[0] < w[1])
            && out.candidates.iter().all(|&c| c < n_frames),
        "{what}"
    );
    let t = trace(&out.traces, trace_name);
    for &c in &out.candidates {
        assert!(t[c].is_finite(), "{what}: candidate {c} where {trace_name} is undefined");
    }
}

#[test]
fn speed_segmenters_skip_missing_markers() {
    for (name, p) in [("fastest_marker_speed", ""), ("speed_minima", "")] {
        let w = walk1();
        let out = segment(name, p, &w).unwrap();
        let v = trace(&out.traces, "V_mm_per_s");
        assert!(v[..v.len() - 1].iter().all(|x| x.is_finite()), "{name} on walk1");
        assert_candidates_defined(&out, "V_mm_per_s", w.n_frames(), name);
        for (gapped, len) in dance1_gaps() {
            let out = segment(name, p, &gapped).unwrap();
            let v = trace(&out.traces, "V_mm_per_s");
            assert!(
                v[..v.len() - 1].iter().all(|x| x.is_finite()),
                "{name} on dance1 with a {len}-frame gap"
            );
            assert_candidates_defined(&out, "V_mm_per_s", gapped.n_frames(), name);
        }
    }
}

#[test]
fn direction_change_finds_no_candidate_in_a_root_gap() {
    let p = "lag = { frames = 15 }";
    let complete = segment("direction_change", p, &with_root(dance1())).unwrap();
    for (gapped, len) in dance1_gaps() {
        let m = with_root(gapped);
        let out = segment("direction_change", p, &m).unwrap();
        assert_candidates_defined(&out, "C", m.n_frames(), "direction_change");
        let blind = GAP_START - 16..GAP_START + len + 16;
        assert!(out.candidates.iter().all(|c| !blind.contains(c)), "{len}: {:?}", out.candidates);
        // Far from the gap the candidates are those of the complete recording.
        let far = |v: &[usize]| {
            v.iter()
                .copied()
                .filter(|c| *c + 40 < GAP_START || *c > GAP_START + len + 40)
                .collect::<Vec<_>>()
        };
        assert_eq!(far(&out.candidates), far(&complete.candidates), "{len}-frame gap");
    }
}

#[test]
fn hull_and_pca_segmenters_run_on_gaps() {
    let w = walk1();
    let out = segment("hull_volume_change", "", &w).unwrap();
    assert_candidates_defined(&out, "D_mm3_per_frame", w.n_frames(), "hull_volume_change");
    for c in [199, 210, 304, 320] {
        assert!(!out.candidates.contains(&c), "hull candidate at the valid-set change {c}");
    }
    for (gapped, len) in dance1_gaps() {
        let out = segment("hull_volume_change", "", &gapped).unwrap();
        assert_candidates_defined(&out, "D_mm3_per_frame", gapped.n_frames(), "hull_volume_change");
        assert!(
            !out.candidates.contains(&GAP_START) && !out.candidates.contains(&(GAP_START + len))
        );
    }
    // PCA: frames with a missing sample are left out of the moments; the trace stays defined
    // (error scaled by frames spanned / frames used), so a rise is still found in the walk.
    let out = segment("pca_error_rise", "", &w).unwrap();
    let e = trace(&out.traces, "pca_error_mm2");
    assert_eq!(e.len(), w.n_frames());
    assert!(e.iter().any(|x| x.is_finite()));
    for (gapped, _) in dance1_gaps() {
        let out = segment("pca_error_rise", "", &gapped).unwrap();
        assert!(out.candidates.iter().all(|&c| c < gapped.n_frames()));
    }
}

#[test]
fn union_merge_bridges_a_root_gap_with_a_straight_line() {
    let fuser = registry::build_fuser("union_merge", &params("merge_mm = 100.0")).unwrap();
    let d = with_root(dance1());
    for (gapped, len) in dance1_gaps() {
        let m = with_root(gapped);
        // Two candidates just either side of the gap: merged exactly when the straight line
        // between the root's last and first valid samples around the gap plus the valid path
        // is under 100 mm — computed here from the positions.
        let (a, b) = (GAP_START - 2, GAP_START + len + 1);
        let r = m.point_index("root").unwrap();
        let dist =
            |p: [f64; 3], q: [f64; 3]| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
        let path = dist(m.position(a, r), m.position(a + 1, r))
            + dist(m.position(a + 1, r), m.position(b - 1, r))
            + dist(m.position(b - 1, r), m.position(b, r));
        let out = fuser.fuse(&m, &[MethodCandidates { method: "x", frames: &[a, b] }]).unwrap();
        assert_eq!(
            out.len(),
            if path < 100.0 { 1 } else { 2 },
            "{len}: path {path:.1} mm, fused {out:?}"
        );
        // Candidates far from the gap fuse as on the complete recording.
        let far = [100, 130, 1400];
        let c0 = fuser.fuse(&d, &[MethodCandidates { method: "x", frames: &far }]).unwrap();
        assert_eq!(fuser.fuse(&m, &[MethodCandidates { method: "x", frames: &far }]).unwrap(), c0);
    }
}

// ---------------------------------------------------------------------------------------------
// Refusing stages: point detector, matchers (and the synchroniser after them)
// ---------------------------------------------------------------------------------------------

fn fill(m: Motion, max_frames: usize) -> Motion {
    preprocess("fill_gaps", &format!("max_gap = {{ frames = {max_frames} }}\nedges = \"hold\""), m)
        .unwrap()
}

#[test]
fn velocity_peaks_refuses_a_gap_in_its_marker_and_works_after_fill_gaps() {
    let detector = |marker: &str| {
        motionlab_match::build_point_detector("velocity_peaks", &params(&format!("marker = \"{marker}\"\ncount = 3\nbefore = {{ seconds = 0.3 }}\nafter = {{ seconds = 0.3 }}"))).unwrap()
    };
    let w = walk1();
    assert_refused(detector("Head_FR").detect(&w), "Head_FR", 199, "velocity_peaks");
    // Other markers are not read: a complete marker of walk1 works.
    assert_eq!(detector("Head_FL").detect(&w).unwrap().peaks.len(), 3);
    assert_eq!(detector("Head_FR").detect(&fill(w, 16)).unwrap().peaks.len(), 3);
    for (gapped, len) in dance1_gaps() {
        assert_refused(detector("Hip_FL").detect(&gapped), "Hip_FL", GAP_START, "velocity_peaks");
        assert_eq!(detector("Hip_FL").detect(&fill(gapped, len)).unwrap().peaks.len(), 3, "{len}");
    }
}

#[test]
fn matchers_refuse_gaps_and_work_after_fill_gaps_then_synchronise() {
    let w = walk1();
    let model = w.slice_frames(20, 80).unwrap(); // complete
    let subsequence =
        motionlab_match::build_matcher("subsequence_dp", &params("marker = \"Head_FR\"")).unwrap();
    let multistream = motionlab_match::build_matcher("multistream_two_stage", &params("")).unwrap();
    assert_refused(subsequence.align(&model, &w), "Head_FR", 199, "subsequence_dp");
    assert_refused(multistream.align(&model, &w), "Head_FR", 199, "multistream_two_stage");
    // A gap in the model is refused too.
    let gappy_model = w.slice_frames(190, 260).unwrap();
    assert_refused(multistream.align(&gappy_model, &model), "Head_FR", 9, "multistream_two_stage");
    // After fill_gaps both align; the model cut from the target itself is found where it was.
    let filled = fill(w, 16);
    let a = subsequence.align(&model, &filled).unwrap();
    assert_eq!((a.start, a.end), (20, 79));
    let a = multistream.align(&model, &filled).unwrap();
    assert_eq!((a.start, a.end), (20, 79));
    assert!(a.total_distance.abs() < 1e-6, "H = {}", a.total_distance);
    let sync = motionlab_match::build_synchroniser("synchronisation", &params(""))
        .unwrap()
        .synchronise(&a, model.n_frames())
        .unwrap();
    assert!(sync.total.is_finite() && sync.total.abs() < 1e-9, "R = {}", sync.total);
    for (gapped, len) in dance1_gaps() {
        let m = gapped.slice_frames(100, 160).unwrap();
        assert_refused(
            multistream.align(&m, &gapped),
            "Hip_FL",
            GAP_START,
            "multistream_two_stage",
        );
        let a = multistream.align(&m, &fill(gapped, len)).unwrap();
        assert_eq!((a.start, a.end), (100, 159), "{len}");
    }
}

// ---------------------------------------------------------------------------------------------
// Gait stages
// ---------------------------------------------------------------------------------------------

fn cycles(name: &str, p: &str, m: &Motion) -> Result<Vec<GaitCycle>> {
    motionlab_features::build_gait_cycle_detector(name, &params(p)).unwrap().cycles(m)
}

fn angle_curves(m: &Motion) -> AngleCurves {
    let f = features("isb_joint_angles", r#"joints = ["hip", "knee", "ankle"]"#, m).unwrap();
    motionlab_features::joint_angles::angle_curves_from_features(&f, m.frame_rate()).unwrap()
}

#[test]
fn gait_cycles_from_events_ignore_marker_gaps_and_heel_height_skips_them() {
    let s = schreiber();
    let from_events = cycles("c3d_events", "", &s).unwrap();
    assert!(!from_events.is_empty());
    let heel = cycles("heel_height", "", &s).unwrap();
    for (len, start) in [(50, 40), (s.n_frames(), 0)] {
        let g = with_gap(&s, "L_FCC", start, len);
        assert_eq!(
            cycles("c3d_events", "", &g).unwrap(),
            from_events,
            "events are not marker samples"
        );
        // heel_height: the right foot is untouched; the left loses at most the cycles around
        // the gap and never gains one.
        match cycles("heel_height", "", &g) {
            Ok(found) => {
                let right = |c: &[GaitCycle]| {
                    c.iter().filter(|x| x.side == "Right").cloned().collect::<Vec<_>>()
                };
                assert_eq!(right(&found), right(&heel), "{len}");
                assert!(found.iter().all(|c| heel.contains(c)), "{len}: {found:?} vs {heel:?}");
            }
            Err(e) => panic!("{len}-frame heel gap: {e}"),
        }
    }
    // walk1 (no events) with its real gaps elsewhere: heel_height on the ankle markers works.
    let w = walk1();
    assert!(cycles("c3d_events", "", &w).is_err());
    let found =
        cycles("heel_height", "left_heel = \"Ankle_L\"\nright_heel = \"Ankle_R\"", &w).unwrap();
    assert!(found.len() >= 2, "{found:?}");
}

#[test]
fn waveform_parameters_leave_out_cycles_with_gaps_per_channel() {
    let s = schreiber();
    let cyc = cycles("c3d_events", "", &s).unwrap();
    let analyzer =
        motionlab_features::build_waveform_analyzer("waveform_parameters", &params("")).unwrap();
    let complete = analyzer.parameters(&angle_curves(&s), &cyc).unwrap();
    // L_FLE missing through the whole trial: left hip, knee, ankle have no complete cycle → NaN;
    // the other channels are exactly as without the gap.
    let g = with_gap(&s, "L_FLE", 0, s.n_frames());
    let p = analyzer.parameters(&angle_curves(&g), &cyc).unwrap();
    assert_eq!(p.channels, complete.channels);
    for (k, ch) in p.channels.iter().enumerate() {
        if uses_l_fle(ch) {
            assert!(p.dc[k].is_nan() && p.amplitude[k].is_nan(), "{ch}");
        } else {
            assert_eq!((p.dc[k], p.amplitude[k]), (complete.dc[k], complete.amplitude[k]), "{ch}");
        }
    }
    assert_eq!(p.frequency_hz, complete.frequency_hz);
    // A 0.5 s gap: only the cycles that overlap it are left out, for those channels only.
    let g = with_gap(&s, "L_FLE", 40, 50);
    let p = analyzer.parameters(&angle_curves(&g), &cyc).unwrap();
    let untouched: Vec<&GaitCycle> = cyc.iter().filter(|c| c.end < 40 || c.start >= 90).collect();
    for (k, ch) in p.channels.iter().enumerate() {
        if uses_l_fle(ch) && untouched.is_empty() {
            assert!(p.dc[k].is_nan(), "{ch}: every cycle overlaps the gap");
        } else if !uses_l_fle(ch) {
            assert_eq!(p.dc[k], complete.dc[k], "{ch}");
        }
    }
}

#[test]
fn walk_synthesis_keeps_nan_and_refuses_to_change_an_undefined_channel() {
    let s = schreiber();
    let cyc = cycles("c3d_events", "", &s).unwrap();
    let g = with_gap(&s, "L_FLE", 0, s.n_frames());
    let curves = angle_curves(&g);
    let synth =
        motionlab_gait::build_walk_synthesizer("feature_channel_control", &params("")).unwrap();
    // Changing a complete channel works; the NaN channels stay NaN throughout.
    let mut changes = WalkChanges::default();
    changes.dc_percent.insert("ankle_r.flexion".into(), 10.0);
    let out = synth.synthesize(&curves, &cyc, &changes).unwrap();
    let knee = out.channel_index("knee_l.flexion").unwrap();
    assert!(out.values[knee].iter().all(|v| v.is_nan()));
    let ankle = out.channel_index("ankle_r.flexion").unwrap();
    assert!(out.values[ankle].iter().all(|v| v.is_finite()));
    // Changing the channel without a defined DC is an error naming it.
    let mut bad = WalkChanges::default();
    bad.dc_percent.insert("knee_l.flexion".into(), 10.0);
    let e = synth.synthesize(&curves, &cyc, &bad).unwrap_err();
    assert!(e.to_string().contains("knee_l.flexion"), "{e}");
}

#[test]
fn change_rates_exclude_a_channel_with_no_complete_cycle_flagged_missing() {
    let analyzer =
        motionlab_features::build_waveform_analyzer("waveform_parameters", &params("")).unwrap();
    let trial = |file: &str, gap: bool| {
        let m = load("c3d", file);
        let m = if gap { with_gap(&m, "L_FLE", 0, m.n_frames()) } else { m };
        let cyc = cycles("c3d_events", "", &m).unwrap();
        analyzer.parameters(&angle_curves(&m), &cyc).unwrap()
    };
    let study = GaitStudy {
        normal_condition: "C4".into(),
        trials: vec![
            GaitTrial {
                subject: "2014001".into(),
                condition: "C4".into(),
                parameters: trial("schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz", false),
            },
            GaitTrial {
                subject: "2014001".into(),
                condition: "C5".into(),
                parameters: trial("schreiber2019/2014001/dynamic/2014001_C5_01.c3d.gz", true),
            },
        ],
    };
    let tables = registry::build_evaluator("change_rates", &params("min_subjects = 1"))
        .unwrap()
        .evaluate(EvalInput::new(&study))
        .unwrap();
    let rates = tables.iter().find(|t| t.name == "change_rates").unwrap();
    let col = |name: &str| rates.column(name).unwrap_or_else(|| panic!("no column {name}"));
    let (channel, reason) = (col("channel"), col("reason"));
    let mut missing = 0;
    for row in 0..rates.n_rows() {
        let ch = channel.cell(row);
        let needs_fle = uses_l_fle(&ch);
        assert_eq!(reason.cell(row) == "missing", needs_fle, "{ch}: reason {:?}", reason.cell(row));
        missing += usize::from(needs_fle);
    }
    assert_eq!(missing, 18, "hip_l, knee_l, ankle_l: 3 axes × 2 components each");
}
