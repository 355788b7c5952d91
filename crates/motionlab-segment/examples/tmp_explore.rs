use motionlab_core::registry::{build_preprocessor, build_segmenter, build_fuser, ParamGuard};
use motionlab_core::{Axis, FeatureCache, FrameRate, MethodCandidates, Motion};
fn load(rel: &str) -> Motion {
    let path = std::path::PathBuf::from("data").join(rel);
    if rel.contains(".amc") {
        let asf = motionlab_io::asf_amc::asf_candidates(&path).into_iter().find(|p| p.exists()).unwrap();
        motionlab_io::asf_amc::load_asf_amc(&path, &asf, FrameRate::new(120.0).unwrap()).unwrap()
    } else {
        let text = motionlab_io::read::read_text(&path).unwrap();
        let m = motionlab_io::qualisys_tsv::parse_qualisys_tsv(&text, &path, Axis::Z).unwrap();
        let p: toml::Value = toml::from_str("name = \"root\"\nmarkers = [\"Hip_FL\", \"Hip_FR\", \"Hip_BL\", \"Hip_BR\"]").unwrap();
        build_preprocessor("add_centroid", &p).unwrap().apply(m).unwrap()
    }
}
fn main() {
    let _ = motionlab_features::hull::HullVolumeParams {}.check();
    let _ = motionlab_segment::union_merge::cumulative_path_mm(std::iter::empty());
    for rel in ["cmu86/86_01.amc.gz", "mct/dance1.tsv.gz", "mct/walk1.tsv.gz", "mocap6/amc/13_29.amc.gz"] {
        let m = load(rel);
        let cache = FeatureCache::new();
        let mut all = vec![];
        println!("== {rel}: {} frames {} pts missing {}", m.n_frames(), m.n_points(), m.missing_count());
        if m.missing_count() > 0 { let mm: Vec<(usize,&str)> = (0..m.n_frames()*m.n_points()).filter(|&i| m.missing_mask()[i]).map(|i| (i / m.n_points(), m.point_names()[i % m.n_points()].as_str())).collect(); println!("missing {:?}", mm); }
        {
            let c = motionlab_features::curvature::CurvatureSpec::new("root".into(), motionlab_core::TimeSpan::Seconds(0.125), 100.0, None).unwrap().compute(&m, &cache).unwrap();
            let fin: Vec<f64> = c.iter().copied().filter(|v| v.is_finite()).collect();
            let mx = fin.iter().copied().fold(-2.0, f64::max);
            let lm: Vec<(usize, f64)> = (1..c.len()-1).filter(|&i| motionlab_features::signal::is_local_max(&c, i) && c[i] > -0.7).map(|i| (i, (c[i]*100.0).round()/100.0)).collect();
            let r = m.point_index("root").unwrap();
            let up = m.up_axis(); let [a, b] = up.others();
            let tr: Vec<[f64;3]> = m.trajectory(r).collect();
            let mut sp: Vec<f64> = tr.windows(16).map(|w| ((w[15][a]-w[0][a]).powi(2) + (w[15][b]-w[0][b]).powi(2)).sqrt()).filter(|v| v.is_finite()).collect();
            sp.sort_by(f64::total_cmp);
            println!("root horizontal displacement over 15 frames: median {:.0} p90 {:.0} max {:.0} mm; up {:?}; first {:?} last {:?}", sp[sp.len()/2], sp[sp.len()*9/10], sp[sp.len()-1], up, tr[0], tr[tr.len()-1]);
            println!("C defined {} of {}, max {mx:.3}, local max > -0.7: {:?}", fin.len(), c.len(), &lm[..lm.len().min(20)]);
            let h = motionlab_features::hull::cached_hull_volumes(&m, &cache).unwrap();
            let d = &h.change_mm3_per_frame;
            for fr in [0.5, 1.0, 1.5, 2.0] {
                let t = fr * motionlab_features::signal::percentile(d, 90.0).unwrap();
                println!("  D frac {fr}: {} cands", motionlab_segment::hull_volume_change::volume_change_candidates(d, t).len());
            }
        }
        for name in ["speed_minima", "fastest_marker_speed", "direction_change", "hull_volume_change", "pca_error_rise"] {
            let t = std::time::Instant::now();
            let out = build_segmenter(name, &toml::Value::Table(Default::default())).unwrap().segment(&m, &cache).unwrap();
            println!("{name}: {} cands in {:?}: {:?} thr {:?}", out.candidates.len(), t.elapsed(), &out.candidates[..out.candidates.len().min(30)], out.thresholds.iter().map(|t| t.value).collect::<Vec<_>>());
            if name != "speed_minima" && name != "pca_error_rise" { all.push((name, out.candidates)); }
        }
        let inputs: Vec<MethodCandidates> = all.iter().map(|(n, c)| MethodCandidates { method: n, frames: c }).collect();
        let fused = build_fuser("union_merge", &toml::Value::Table(Default::default())).unwrap().fuse(&m, &inputs).unwrap();
        println!("fused: {} {:?}", fused.len(), fused);
    }
}
