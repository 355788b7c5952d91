//! `type = "external"`: a segmenter that is another program (protocol in the crate docs).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{FeatureCache, Motion, Result, Segmenter, SegmenterOutput};

use crate::protocol::{self, SegmenterReply};
use crate::runner::Invocation;

/// Candidates from another program (Python, R, …): motionlab hands it the motion as files and reads candidate frames back as JSON.
///
/// Protocol 1, for each motion: motionlab writes a fresh folder with `positions.npy` (float64,
/// little-endian, shape frames × points × 3, mm, NaN exactly where a sample is missing) and
/// `meta.json` (`protocol`, `plugin`, `expects`, `command`, `motion` with `name`, `source`,
/// `format`, `rate_hz`, `n_frames`, `n_points`, `point_names`, `point_kind`, `up_axis`,
/// `n_missing_samples`; `positions` describing the array; and `params`, this stage's `params`
/// table unchanged), then runs `command` with the folder's path appended as the last argument,
/// in the current directory, stdin empty. The program prints one JSON object on stdout and
/// exits 0:
///
/// `{"candidates": [frame, …], "traces": [{"name": "V_mm_per_s", "unit": "mm/s", "values":
/// [one per frame, null for NaN]}], "thresholds": [{"name": "v_low", "trace": "V_mm_per_s",
/// "value": 81.2}], "flagged_frames": [frame, …]}` — only `candidates` is required; frames are
/// 0-based, ascending, unique, < n_frames. The result is used exactly like a built-in
/// segmenter's (fusion, evaluation, figures).
///
/// Errors (one line each, naming the plugin and the command): program not found (at
/// `validate`), cannot start, timeout (the program's process group is killed), non-zero exit
/// (with the last lines of its stderr), stdout not the expected JSON (serde's line and column;
/// JSON has no NaN: write null), candidates out of range, not integers, unsorted or repeated,
/// a trace whose length is not n_frames, a non-finite threshold. A worked example that
/// re-implements `speed_minima` in Python: `examples/external-segmenter/`.
/// Missing samples: passed to the program as NaN; what it does with them is its own rule.
///
/// Safety: an experiment file that names a program is code. motionlab starts `command` only
/// when the user allowed it — `--allow-external` on the command line, or a trust record
/// written by `motionlab trust EXPERIMENT.toml`, revoked when any command line changes — and
/// `validate` and the run page list it. What the program prints on stdout and any file it
/// writes are bounded by `max_output_mb` (docs/security.md).
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("x-runs-program" = "command"))]
pub struct ExternalSegmenterParams {
    /// The program and its arguments, e.g. `["python3", "examples/external-segmenter/speed_minima.py"]`.
    /// Required. A program name without `/` is looked up on PATH; relative paths resolve
    /// against the current directory (where motionlab runs), not the experiment's folder.
    pub command: Vec<String>,
    /// Seconds the program may run for one motion before it is killed.
    #[serde(default = "default_timeout_s")]
    pub timeout_s: f64,
    /// MiB the program may print on stdout, and the largest file it may write (its
    /// RLIMIT_FSIZE); beyond either it is stopped and the stage fails with an error saying so.
    #[serde(default = "default_max_output_mb")]
    pub max_output_mb: u64,
    /// Any table, passed unchanged to the program as `params` in `meta.json`.
    #[serde(default)]
    pub params: Map<String, Value>,
}

pub(crate) fn default_timeout_s() -> f64 {
    60.0
}

/// A segmenter's reply for a 36,000-frame take with five traces is about 4 MB of JSON.
pub(crate) fn default_max_output_mb() -> u64 {
    256
}

/// The validated stage.
#[derive(Clone, Debug)]
pub struct ExternalSegmenter {
    invocation: Invocation,
}

impl ParamGuard for ExternalSegmenterParams {
    type Checked = ExternalSegmenter;
    fn check(self) -> Result<ExternalSegmenter> {
        Ok(ExternalSegmenter {
            invocation: Invocation::check(
                "external",
                self.command,
                self.timeout_s,
                self.max_output_mb,
                self.params,
            )?,
        })
    }
}

impl Segmenter for ExternalSegmenter {
    fn segment(&self, motion: &Motion, _cache: &FeatureCache) -> Result<SegmenterOutput> {
        self.invocation.call::<SegmenterReply, _>(motion, "segmenter", protocol::segmenter_output)
    }
}

motionlab_core::register_plugin!(Segmenter, ExternalSegmenterParams, "external");
