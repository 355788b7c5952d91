//! `type = "external_features"`: a feature extractor that is another program (protocol in the
//! crate docs; the same files and rules as the `external` segmenter).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{FeatureCache, FeatureExtractor, FeatureSet, Motion, Result};

use crate::protocol::{self, FeaturesReply};
use crate::runner::Invocation;
use crate::segmenter::{default_max_output_mb, default_timeout_s};

/// Per-frame features from another program (Python, R, …), over the same file protocol as the `external` segmenter.
///
/// For each motion motionlab writes `positions.npy` (float64, frames × points × 3, mm, NaN =
/// missing) and `meta.json` (rate, point names, `params`, …; `"expects": "feature_extractor"`)
/// to a fresh folder and runs `command` with the folder as last argument (see `motionlab
/// describe external` for every field). The program prints one JSON object on stdout and exits
/// 0: `{"traces": [{"name": "height_mm", "unit": "mm", "values": [one per frame, null for
/// NaN]}], "labels": [{"name": "phase", "values": [one string per frame]}]}` — at least one
/// trace or label; names are letters, digits and `_` (they become table columns), unique.
///
/// Errors name the plugin and the command: not found, timeout (killed), non-zero exit (last
/// lines of stderr), malformed JSON (line and column), a trace or label whose length is not
/// n_frames. Missing samples: passed as NaN; the program decides.
///
/// Safety, as for `external`: the program starts only when the user allowed it
/// (`--allow-external`, or `motionlab trust EXPERIMENT.toml`), and its output is bounded by
/// `max_output_mb`.
#[derive(Clone, Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("x-runs-program" = "command"))]
pub struct ExternalFeaturesParams {
    /// The program and its arguments, e.g. `["python3", "my_features.py"]`. Required. A
    /// program name without `/` is looked up on PATH; relative paths resolve against the
    /// current directory (where motionlab runs), not the experiment's folder.
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

/// The validated stage.
#[derive(Clone, Debug)]
pub struct ExternalFeatures {
    invocation: Invocation,
}

impl ParamGuard for ExternalFeaturesParams {
    type Checked = ExternalFeatures;
    fn check(self) -> Result<ExternalFeatures> {
        Ok(ExternalFeatures {
            invocation: Invocation::check(
                "external_features",
                self.command,
                self.timeout_s,
                self.max_output_mb,
                self.params,
            )?,
        })
    }
}

impl FeatureExtractor for ExternalFeatures {
    fn extract(&self, motion: &Motion, _cache: &FeatureCache) -> Result<FeatureSet> {
        self.invocation.call::<FeaturesReply, _>(motion, "feature_extractor", protocol::feature_set)
    }
}

motionlab_core::register_plugin!(FeatureExtractor, ExternalFeaturesParams, "external_features");
