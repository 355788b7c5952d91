//! The leave-one-take-out protocol for `multistream_dp`'s `threshold_mm` (its docs cite it):
//! on the five shipped labelled mocap6 takes, with the truth's own segments, each take held out
//! in turn; the threshold with the best mean AMI (per sample, against the exercise labels) on
//! the other four — from the candidates every merge distance of those takes offers, the
//! smallest among equal means — is scored on the held-out take. Prints each held-out row, their
//! mean beside the silhouette rule's AMI on the same takes, and the threshold the rule gives on
//! all five (what a default set by this protocol would be: an oracle on these takes).
//!
//! Run: `cargo run --release -p motionlab-workflows --example multistream_dp_threshold`

use std::path::PathBuf;

use motionlab_core::registry::ParamGuard;
use motionlab_core::{FrameRate, GroundTruthReader, Merge, Result, segments_of};
use motionlab_eval::label_metrics::{ami, truth_states};
use motionlab_features::clustering::{average_linkage, cut_at_distance, cut_to_k, k_by_silhouette};
use motionlab_match::state_labeller::MultistreamDpParams;

struct Take {
    name: String,
    n_segments: usize,
    merges: Vec<Merge>,
    /// Per segment, the samples it covers (for the per-sample labels).
    segments: Vec<std::ops::Range<usize>>,
    /// The truth on the samples it labels, and which samples those are.
    truth: Vec<String>,
    kept: Vec<usize>,
    silhouette_states: Vec<usize>,
}

impl Take {
    fn ami_of(&self, states: &[usize]) -> f64 {
        let mut per = vec![0; self.segments.last().map_or(0, |s| s.end)];
        for (s, &st) in self.segments.iter().zip(states) {
            per[s.clone()].fill(st);
        }
        let found: Vec<usize> = self.kept.iter().map(|&i| per[i]).collect();
        ami(&self.truth, &found).unwrap_or(f64::NAN)
    }
    fn ami_at(&self, t: f64) -> f64 {
        self.ami_of(&cut_at_distance(&self.merges, self.n_segments, t))
    }
}

fn main() -> Result<()> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..").join("data/mocap6");
    let labeller =
        MultistreamDpParams { points: None, rate_hz: 20.0, threshold_mm: None, max_states: 12 }
            .check()?;
    let reader = motionlab_io::labels::mocap6::Mocap6LabelsParams { block_frames: 12 }.check()?;
    let mut takes = Vec::new();
    for (name, subject) in
        [("13_29", "13"), ("13_30", "13"), ("13_31", "13"), ("14_14", "14"), ("14_20", "14")]
    {
        let amc = root.join(format!("amc/{name}.amc.gz"));
        let asf = root.join(format!("asf/{subject}.asf"));
        let motion = motionlab_io::asf_amc::load_asf_amc(&amc, &asf, FrameRate::new(120.0)?)?;
        let label_file = root.join(format!("truelabels/{name}.txt"));
        let truth = reader.read(&label_file, &motion)?;
        let n = motion.n_frames();
        let segments = segments_of(&truth.frames(), n);
        let states = truth_states(&truth.segments, n, &label_file.display().to_string())?;
        let kept: Vec<usize> = (0..n).filter(|&i| states[i].is_some()).collect();
        let truth_labels: Vec<String> = kept.iter().filter_map(|&i| states[i].clone()).collect();
        let d = labeller.distances(&motion, &segments)?;
        let k = segments.len();
        let merges = average_linkage(&d, k)?;
        let silhouette_states = cut_to_k(&merges, k, k_by_silhouette(&d, k, &merges, 12)?);
        takes.push(Take {
            name: name.to_string(),
            n_segments: k,
            merges,
            segments,
            truth: truth_labels,
            kept,
            silhouette_states,
        });
    }
    // The threshold with the best mean AMI over `on` (ties: the smallest).
    let choose = |on: &[&Take]| -> (f64, f64) {
        let mut grid: Vec<f64> =
            on.iter().flat_map(|t| t.merges.iter().map(|m| m.distance)).collect();
        grid.push(0.0);
        grid.sort_by(f64::total_cmp);
        grid.dedup();
        let mut best = (f64::NAN, f64::NEG_INFINITY);
        for &t in &grid {
            let mean = on.iter().map(|x| x.ami_at(t)).sum::<f64>() / on.len() as f64;
            if mean > best.1 {
                best = (t, mean);
            }
        }
        best
    };
    println!("held_out,segments,threshold_mm,train_mean_ami,heldout_ami,silhouette_ami");
    let (mut held, mut sil) = (Vec::new(), Vec::new());
    for (h, take) in takes.iter().enumerate() {
        let others: Vec<&Take> =
            takes.iter().enumerate().filter(|(i, _)| *i != h).map(|(_, t)| t).collect();
        let (t, train) = choose(&others);
        let a = take.ami_at(t);
        let s = take.ami_of(&take.silhouette_states);
        println!("{},{},{t:.3},{train:.4},{a:.4},{s:.4}", take.name, take.n_segments);
        held.push(a);
        sil.push(s);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    println!("mean,,,,{:.4},{:.4}", mean(&held), mean(&sil));
    let all: Vec<&Take> = takes.iter().collect();
    let (t, m) = choose(&all);
    println!(
        "# chosen on all five takes (an oracle there): threshold_mm = {t:.3}, mean AMI {m:.4}"
    );
    Ok(())
}
