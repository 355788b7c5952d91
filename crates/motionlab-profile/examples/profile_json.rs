//! Runs the profile segmenters on series given as JSON on stdin and prints JSON, for the
//! side-by-side scripts in `bench/` (`bench/profile_vs_peers.py`).
//!
//! Input: `{"tasks": [{"op": ..., "values": [...], "n_channels": 1, ...}, ...]}` with ops
//! - `clasp_segment` (`params`: a `clasp` parameter table) → `candidates`, `window`, `trace`;
//! - `clasp_profile` (`window`) → `profile` (null where −∞);
//! - `floss_segment` (`params`: a `floss` parameter table) → `candidates`, `window`, `trace`;
//! - `matrix_profile` (`window`) → `index`, `distance`.
//!
//! Every result carries `seconds`, the wall time of the computation alone.

use std::io::Read;
use std::time::Instant;

use motionlab_core::ParamGuard;
use motionlab_profile::{ClaspParams, FlossParams};
use serde_json::{Value, json};

fn finite_or_null(v: &[f64]) -> Value {
    Value::Array(v.iter().map(|&x| if x.is_finite() { json!(x) } else { Value::Null }).collect())
}

fn run(task: &Value) -> Result<Value, String> {
    let op = task["op"].as_str().ok_or("task without op")?;
    let values: Vec<f64> =
        serde_json::from_value(task["values"].clone()).map_err(|e| e.to_string())?;
    let n_channels = task["n_channels"].as_u64().unwrap_or(1) as usize;
    let params = task.get("params").cloned().unwrap_or(json!({}));
    let window = task["window"].as_u64().map(|w| w as usize);
    let err = |e: motionlab_core::Error| e.to_string();
    let start = Instant::now();
    let mut out = match op {
        "clasp_segment" => {
            let stage = serde_json::from_value::<ClaspParams>(params)
                .map_err(|e| e.to_string())?
                .check()
                .map_err(err)?;
            let w = stage.window_width(&values, n_channels).map_err(err)?;
            let seg = stage.segment_values(&values, n_channels).map_err(err)?;
            json!({"candidates": seg.candidates, "window": w, "trace": finite_or_null(&seg.traces[0].values)})
        }
        "clasp_profile" => {
            let stage = serde_json::from_value::<ClaspParams>(params)
                .map_err(|e| e.to_string())?
                .check()
                .map_err(err)?;
            let p = stage
                .profile(&values, n_channels, window.ok_or("clasp_profile needs window")?)
                .map_err(err)?;
            json!({"profile": finite_or_null(&p)})
        }
        "floss_segment" => {
            let stage = serde_json::from_value::<FlossParams>(params)
                .map_err(|e| e.to_string())?
                .check()
                .map_err(err)?;
            let seg = stage.segment_values(&values, n_channels).map_err(err)?;
            json!({"candidates": seg.candidates, "trace": finite_or_null(&seg.traces[0].values)})
        }
        "matrix_profile" => {
            let mp = motionlab_profile::floss::matrix_profile(
                &values,
                window.ok_or("matrix_profile needs window")?,
            )
            .map_err(err)?;
            json!({"index": mp.index, "distance": finite_or_null(&mp.distance)})
        }
        other => return Err(format!("unknown op {other}")),
    };
    out["seconds"] = json!(start.elapsed().as_secs_f64());
    Ok(out)
}

fn main() {
    let mut text = String::new();
    std::io::stdin().read_to_string(&mut text).expect("stdin");
    let input: Value = serde_json::from_str(&text).expect("JSON on stdin");
    let tasks = input["tasks"].as_array().cloned().unwrap_or_default();
    let results: Vec<Value> =
        tasks.iter().map(|t| run(t).unwrap_or_else(|e| json!({"error": e}))).collect();
    println!("{}", json!({"results": results}));
}
