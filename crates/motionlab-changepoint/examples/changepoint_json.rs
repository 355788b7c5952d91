//! Runs this crate's segmenters on series given as JSON on stdin and prints JSON on stdout —
//! the bridge `bench/changepoint_vs_peers.py` uses to compare them with ruptures and a NumPy
//! BOCPD, and to time them.
//!
//! Input: `{"jobs": [{"segmenter": "kernel_cpd" | "window" | "bocpd", "params": {…},
//! "values_hex": "…" (sample-major float64, little-endian bytes in hex: exact, NaN included,
//! where JSON numbers would go through a decimal parse), "n_channels": d, "posterior": false,
//! "repeats": 1}]}`; `values` (a JSON array, null for NaN) or `values_file` (one float per
//! line, a TSSB series; one channel) may replace `values_hex`. A job describes the peer's call:
//! `kernel_cpd` without `pen`, `n_bkps` or `penalty` runs at ruptures' BIC-style penalty
//! (`pen = "bic"`), `bocpd` without `lambda` or `expected_segment` at λ = 100 samples.
//! `{"segmenter": "verify_exp", "stride": 1}` compares the rbf kernel's inlined `exp` with the
//! system's on every single-precision argument (`{"differ", "compared"}`).
//! Output: one object per job, `{"breakpoints": [..] (ruptures' convention: ends, the last
//! n), "candidates": [..], "pen", "gamma", "path": [{"pen_min", "pen_max", "breakpoints",
//! "cost"}, ..] and "chosen", "bic_pen" (kernel_cpd with `penalty = {path = [..]}`),
//! "posterior" (bocpd, when asked), "seconds": [..]
//! (wall time of each repeat, parsing excluded), "cpu_seconds": [..] (the thread's CPU time)}` or `{"error": "…"}`; then
//! `{"peak_rss_kib": …}` (the process's peak resident set, from /proc/self/status).
//!
//! `cargo run --release -p motionlab-changepoint --example changepoint_json < jobs.json`

use std::io::Read;
use std::time::Instant;

use motionlab_changepoint::{BocpdParams, KernelCpdParams, WindowParams};
use motionlab_core::registry::ParamGuard;
use serde_json::{Value, json};

fn run_job(job: &Value) -> Result<Value, String> {
    let segmenter = job["segmenter"].as_str().ok_or("job without \"segmenter\"")?;
    if segmenter == "verify_exp" {
        let (bad, total) = motionlab_changepoint::kernel_cpd::verify_inlined_exp(
            job["stride"].as_u64().unwrap_or(1) as u32,
        );
        return Ok(json!({"differ": bad, "compared": total}));
    }
    let mut params = job.get("params").cloned().unwrap_or(json!({}));
    // A job describes a call of the peer (ruptures, the NumPy BOCPD of Adams & MacKay), whose
    // unset stopping rule is ruptures' suggested BIC-style penalty and whose hazard is
    // TCPDBench's λ = 100 samples; the plugins' own defaults were chosen at mocap rates
    // instead, so the bridge spells the peer's out.
    if let Some(p) = params.as_object_mut() {
        let unset = |p: &serde_json::Map<String, Value>, keys: &[&str]| {
            keys.iter().all(|k| !p.contains_key(*k))
        };
        if segmenter == "kernel_cpd" && unset(p, &["pen", "n_bkps", "penalty"]) {
            p.insert("pen".into(), json!("bic"));
        }
        if segmenter == "bocpd" && unset(p, &["lambda", "expected_segment"]) {
            p.insert("lambda".into(), json!(100.0));
        }
    }
    let (values, n_channels): (Vec<f64>, usize) = if let Some(path) = job["values_file"].as_str() {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
        let v = text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.trim().parse::<f64>().map_err(|e| format!("{path}: {e}")))
            .collect::<Result<_, _>>()?;
        (v, 1)
    } else if let Some(hex) = job["values_hex"].as_str() {
        let bytes: Vec<u8> = (0..hex.len() / 2)
            .map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16))
            .collect::<Result<_, _>>()
            .map_err(|e| format!("values_hex: {e}"))?;
        let v = bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
            .collect();
        (v, job["n_channels"].as_u64().unwrap_or(1) as usize)
    } else {
        let v = job["values"]
            .as_array()
            .ok_or("job without \"values\"")?
            .iter()
            .map(|v| v.as_f64().unwrap_or(f64::NAN))
            .collect();
        (v, job["n_channels"].as_u64().unwrap_or(1) as usize)
    };
    let repeats = job["repeats"].as_u64().unwrap_or(1).max(1);
    let mut seconds = Vec::new();
    let mut cpu_seconds = Vec::new();
    let mut out = json!({});
    for _ in 0..repeats {
        let start = Instant::now();
        let cpu_start = thread_cpu_ns();
        out = match segmenter {
            "kernel_cpd" => {
                let stage = serde_json::from_value::<KernelCpdParams>(params.clone())
                    .map_err(|e| e.to_string())?
                    .check()
                    .map_err(|e| e.to_string())?;
                let run = stage.run(&values, n_channels).map_err(|e| e.to_string())?;
                let n = values.len() / n_channels;
                let mut o = json!({"breakpoints": run.breakpoints, "candidates": run.breakpoints.iter().filter(|&&b| b < n).collect::<Vec<_>>(), "pen": run.pen, "gamma": run.gamma});
                if let Some(path) = &run.path {
                    // Penalties as exact bits too: the comparison is to 1e-9, the bits show more.
                    o["path"] = json!(
                        path.iter()
                            .map(|p| json!({"pen_min": p.pen_min, "pen_max": p.pen_max, "breakpoints": p.breakpoints, "cost": p.cost}))
                            .collect::<Vec<_>>()
                    );
                    o["chosen"] = json!(run.chosen);
                    o["bic_pen"] = json!(run.bic_pen);
                }
                o
            }
            "window" => {
                let stage = serde_json::from_value::<WindowParams>(params.clone())
                    .map_err(|e| e.to_string())?
                    .check()
                    .map_err(|e| e.to_string())?;
                let run = stage.run(&values, n_channels).map_err(|e| e.to_string())?;
                let n = values.len() / n_channels;
                json!({"breakpoints": run.breakpoints, "candidates": run.breakpoints.iter().filter(|&&b| b < n).collect::<Vec<_>>(), "pen": run.pen, "gamma": run.gamma})
            }
            "bocpd" => {
                let stage = serde_json::from_value::<BocpdParams>(params.clone())
                    .map_err(|e| e.to_string())?
                    .check()
                    .map_err(|e| e.to_string())?;
                let run = stage.run(&values, n_channels).map_err(|e| e.to_string())?;
                let mut o =
                    json!({"candidates": run.candidates, "map_run_length": run.map_run_length});
                if job["posterior"].as_bool().unwrap_or(false) {
                    o["posterior"] = json!(
                        stage
                            .run_length_posterior(&values, n_channels)
                            .map_err(|e| e.to_string())?
                    );
                }
                o
            }
            other => return Err(format!("unknown segmenter {other:?}")),
        };
        seconds.push(start.elapsed().as_secs_f64());
        cpu_seconds.push(thread_cpu_ns().zip(cpu_start).map(|(b, a)| (b - a) as f64 * 1e-9));
    }
    out["seconds"] = json!(seconds);
    out["cpu_seconds"] = json!(cpu_seconds);
    Ok(out)
}

/// CPU time of this thread so far (ns), from /proc/thread-self/schedstat: on a loaded machine
/// wall time counts the waits for a core, CPU time does not.
fn thread_cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status.lines().find(|l| l.starts_with("VmHWM:"))?.split_whitespace().nth(1)?.parse().ok()
}

fn main() {
    let mut input = String::new();
    if let Err(e) = std::io::stdin().read_to_string(&mut input) {
        eprintln!("stdin: {e}");
        std::process::exit(2);
    }
    let request: Value = match serde_json::from_str(&input) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("stdin is not JSON: {e}");
            std::process::exit(2);
        }
    };
    let jobs = request["jobs"].as_array().cloned().unwrap_or_default();
    let results: Vec<Value> =
        jobs.iter().map(|job| run_job(job).unwrap_or_else(|e| json!({"error": e}))).collect();
    println!("{}", json!({"results": results, "peak_rss_kib": peak_rss_kib()}));
}
