//! Times retrieval across a corpus ([`motionlab_match::retrieval`]) pruned and exhaustive, for
//! `bench/retrieval_vs_peers.py` (so our numbers and the peer's come from one run of that script).
//!
//! Loads the model (an AMC cut to `[first, last)` frames) and every take of the corpus (AMC
//! files), keeps each distinct point once (`distinct_points`), positions relative to `root`
//! every frame — as `experiments/yabe_retrieval.toml` does — and writes the exact matched data
//! to `--export DIR` (`model.f64`, `take_<k>.f64`: little-endian f64, frames × points × 3, and
//! `meta.json`) so the peer runs on the same numbers. stdout: JSON with the wall times of each
//! repetition of each mode, the lists found (identical in both modes, or the example fails) and
//! how many windows each mode matched.
//!
//! `cargo run --release -p motionlab-match --example retrieval_timing -- MODEL.amc.gz FIRST LAST
//! --export DIR --repeats R --window 250 --stride 31 --k 5 [--k-dissimilar K] TAKE.amc.gz…`
//! (`--k` sets both lists' length, `--k-dissimilar` the dissimilar list's alone.)

use std::path::PathBuf;
use std::time::Instant;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Loader, Motion, Preprocessor};
use motionlab_io::asf_amc::AsfAmcParams;
use motionlab_match::distinct_points::DistinctPointsParams;
use motionlab_match::dp::Trajectory3;
use motionlab_match::input::trajectories;
use motionlab_match::retrieval::{Retrieval, RetrievalSettings, relative_to_point, retrieve};
use serde::Serialize;

fn fail(msg: String) -> ! {
    eprintln!("retrieval_timing: {msg}");
    std::process::exit(1);
}

#[derive(Serialize)]
struct Listed {
    take: usize,
    start: usize,
    end: usize,
    h_mm: f64,
}

#[derive(Serialize)]
struct Output {
    pruned_times_s: Vec<f64>,
    exhaustive_times_s: Vec<f64>,
    candidates: usize,
    pruned_matched: usize,
    exhaustive_matched: usize,
    similar: Vec<Listed>,
    dissimilar: Vec<Listed>,
    takes: Vec<String>,
    frames: usize,
    points: usize,
    model_frames: usize,
    threads: usize,
}

fn load(path: &str) -> Motion {
    let loader = serde_json::from_str::<AsfAmcParams>("{}")
        .unwrap_or_else(|e| fail(e.to_string()))
        .check()
        .unwrap_or_else(|e| fail(e.to_string()));
    let motion = loader.load(&PathBuf::from(path)).unwrap_or_else(|e| fail(e.to_string()));
    let distinct = DistinctPointsParams { max_distance_mm: motionlab_core::Millimetres(1e-6) }
        .check()
        .unwrap_or_else(|e| fail(e.to_string()));
    distinct.apply(motion).unwrap_or_else(|e| fail(e.to_string()))
}

fn prepared(motion: &Motion, names: &[String]) -> Vec<Trajectory3> {
    let mut t = trajectories(motion, names, "take", "retrieval_timing")
        .unwrap_or_else(|e| fail(e.to_string()));
    let root = names
        .iter()
        .position(|n| n == "root")
        .unwrap_or_else(|| fail("no point named root".into()));
    relative_to_point(&mut t, root).unwrap_or_else(|e| fail(e.to_string()));
    t
}

fn export(path: PathBuf, t: &[Trajectory3]) {
    let frames = t.first().map_or(0, |x| x.len());
    let mut bytes = Vec::with_capacity(frames * t.len() * 24);
    for i in 0..frames {
        for l in t {
            for v in [l.x[i], l.y[i], l.z[i]] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    std::fs::write(&path, bytes).unwrap_or_else(|e| fail(format!("{}: {e}", path.display())));
}

fn listed(r: &Retrieval) -> (Vec<Listed>, Vec<Listed>) {
    let l = |hits: &[motionlab_match::retrieval::Hit]| {
        hits.iter()
            .map(|h| Listed {
                take: h.take,
                start: h.window_start + h.alignment.start,
                end: h.window_start + h.alignment.end,
                h_mm: h.alignment.total_distance,
            })
            .collect()
    };
    (l(&r.similar), l(&r.dissimilar))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut positional = Vec::new();
    let (mut export_dir, mut repeats, mut window, mut stride, mut k, mut kd) =
        (None, 3usize, 250usize, 31usize, 5usize, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().cloned().unwrap_or_else(|| fail(format!("{a} needs a value")));
        let number =
            |v: String| v.parse::<usize>().unwrap_or_else(|e| fail(format!("{a} {v}: {e}")));
        match a.as_str() {
            "--export" => export_dir = Some(PathBuf::from(value())),
            "--repeats" => repeats = number(value()),
            "--window" => window = number(value()),
            "--stride" => stride = number(value()),
            "--k" => k = number(value()),
            "--k-dissimilar" => kd = Some(number(value())),
            _ => positional.push(a.clone()),
        }
    }
    let [model_path, first, last, takes @ ..] = positional.as_slice() else {
        fail("usage: MODEL FIRST LAST TAKE…".into())
    };
    let (first, last) = (
        first.parse::<usize>().unwrap_or_else(|e| fail(e.to_string())),
        last.parse::<usize>().unwrap_or_else(|e| fail(e.to_string())),
    );
    let model = load(model_path).slice_frames(first, last).unwrap_or_else(|e| fail(e.to_string()));
    let names: Vec<String> = model.point_names().to_vec();
    let model_t = prepared(&model, &names);
    let take_t: Vec<Vec<Trajectory3>> = takes.iter().map(|p| prepared(&load(p), &names)).collect();
    if let Some(dir) = &export_dir {
        std::fs::create_dir_all(dir).unwrap_or_else(|e| fail(e.to_string()));
        export(dir.join("model.f64"), &model_t);
        for (i, t) in take_t.iter().enumerate() {
            export(dir.join(format!("take_{i}.f64")), t);
        }
        let meta = serde_json::json!({
            "points": names,
            "model_frames": model.n_frames(),
            "take_frames": take_t.iter().map(|t| t[0].len()).collect::<Vec<_>>(),
            "takes": takes,
        });
        std::fs::write(dir.join("meta.json"), meta.to_string())
            .unwrap_or_else(|e| fail(e.to_string()));
    }
    let settings = |pruning| RetrievalSettings {
        k_similar: k,
        k_dissimilar: kd.unwrap_or(k),
        window_frames: window,
        stride_frames: stride,
        pruning,
    };
    let time = |pruning: bool| {
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..repeats.max(1) {
            let t0 = Instant::now();
            let r = retrieve(&model_t, &take_t, &settings(pruning))
                .unwrap_or_else(|e| fail(e.to_string()));
            times.push(t0.elapsed().as_secs_f64());
            last = Some(r);
        }
        (times, last.unwrap_or_else(|| fail("no run".into())))
    };
    let (pruned_times_s, pruned) = time(true);
    let (exhaustive_times_s, exhaustive) = time(false);
    if (&pruned.similar, &pruned.dissimilar) != (&exhaustive.similar, &exhaustive.dissimilar) {
        fail("the pruned and the exhaustive search found different lists".into());
    }
    let (similar, dissimilar) = listed(&pruned);
    let out = Output {
        pruned_times_s,
        exhaustive_times_s,
        candidates: pruned.candidates.len(),
        pruned_matched: pruned.matched_candidates,
        exhaustive_matched: exhaustive.matched_candidates,
        similar,
        dissimilar,
        takes: takes.to_vec(),
        frames: take_t.iter().map(|t| t[0].len()).sum(),
        points: names.len(),
        model_frames: model.n_frames(),
        threads: rayon_threads(),
    };
    println!("{}", serde_json::to_string(&out).unwrap_or_else(|e| fail(e.to_string())));
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
