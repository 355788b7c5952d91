//! # motionlab-external
//!
//! Plugins that run **another program** — a Python, R or MATLAB prototype — as a motionlab
//! stage, so a researcher can try a segmenter without writing Rust:
//!
//! | `type =` | kind | the program returns |
//! |---|---|---|
//! | `external` | segmenter | candidate frames, optional traces and thresholds |
//! | `external_features` | feature extractor | traces (and optional per-frame labels) |
//!
//! ```toml
//! [[segmentation.segmenter]]
//! type = "external"
//! name = "speed_minima_py"
//! command = ["python3", "examples/external-segmenter/speed_minima.py"]
//! timeout_s = 120                                  # seconds per motion
//! params = { v_low = { fraction_of_p90 = 0.15 } }  # passed through unchanged
//! ```
//!
//! ## The protocol (version 1)
//!
//! Like mdBook's preprocessors: files in, JSON out, one process per motion.
//!
//! 1. motionlab makes a fresh folder (removed afterwards) holding
//!    - `positions.npy` — every point's position, NumPy `.npy` format 1.0, dtype `<f8`
//!      (little-endian float64), C order, shape `(n_frames, n_points, 3)`, in **millimetres**
//!      in the motion's own axes; a **missing sample is NaN** in all three coordinates (and
//!      only a missing sample is NaN), so the NaN pattern *is* the missing mask;
//!    - `meta.json` — `{"protocol": 1, "plugin", "expects", "command", "motion": {"name",
//!      "source", "format", "rate_hz", "n_frames", "n_points", "point_names", "point_kind",
//!      "up_axis", "n_missing_samples"}, "positions": {"file", "dtype", "shape", "unit",
//!      "missing"}, "params"}` where `params` is the stage's `params` table as given in the
//!      experiment (TOML → JSON).
//! 2. It runs `command…` with that folder's path appended as the **last argument**, in the
//!    current directory, with stdin empty; stderr is kept for error messages.
//! 3. The program prints **one JSON object on stdout** and exits 0. A segmenter's:
//!    `{"candidates": [12, 240, …], "traces": [{"name": "V_mm_per_s", "unit": "mm/s",
//!    "values": [… n_frames numbers, null for NaN …]}], "thresholds": [{"name": "v_low",
//!    "trace": "V_mm_per_s", "value": 81.2}], "flagged_frames": []}` — only `candidates` is
//!    required. A feature extractor's: `{"traces": […], "labels": [{"name": "phase",
//!    "values": [… n_frames strings …]}]}`. Unknown keys are refused (a typo is not ignored).
//!
//! Every output is checked before motionlab uses it, and each failure is one error naming the
//! plugin and the command: the program cannot be started (not found, not executable), runs
//! longer than `timeout_s` (its whole process group is killed), exits non-zero (the last
//! lines of its stderr are quoted), prints something that is not the expected JSON (serde's
//! line and column, with a hint when Python wrote `NaN`), or returns candidates that are out
//! of range, not sorted or repeated, traces or labels whose length is not `n_frames`,
//! threshold values that are not finite, or a threshold naming no returned trace.
//!
//! ## Consent and bounds
//!
//! An experiment that names a program is code, and experiment files are shared. The program
//! is started only when its exact command line was allowed ([`motionlab_core::programs`]: the
//! engine allows a run's command lines after `--allow-external` or a trust record from
//! `motionlab trust`); otherwise the stage fails without starting anything. Its stdout is read
//! up to `max_output_mb` (beyond it, the program is killed and the stage fails), of its stderr
//! only the last 64 KiB are kept, and it runs with RLIMIT_FSIZE at `max_output_mb`, so a file
//! it writes beyond that (a runaway `.npy`) stops it with SIGXFSZ, reported as such.
//! `docs/security.md` is the threat model.
//!
//! ## Why `.npy` is written by hand
//!
//! A `.npy` file is a 10-byte preamble, one line of Python-literal header padded to 64 bytes,
//! and the raw little-endian values ([`npy`], 30 lines). The crates that write it (`npyz`,
//! `ndarray-npy`) mainly add header *parsing* (with a parser-generator dependency) that
//! motionlab never needs; the tests read our files back with NumPy itself.
//!
//! ## Paths
//!
//! Stage parameters do not know the experiment file's folder, so relative paths in `command`
//! resolve against the **current directory** (where `motionlab` was started; the repository
//! root for `reproduce`); a program name without `/` is looked up on `PATH`.

/// How many plugins this crate registers (checked by `tests/registry.rs`).
pub const PLUGIN_COUNT: usize = 2;

mod features;
pub mod npy;
pub mod protocol;
mod runner;
mod segmenter;

pub use features::{ExternalFeatures, ExternalFeaturesParams};
pub use segmenter::{ExternalSegmenter, ExternalSegmenterParams};
