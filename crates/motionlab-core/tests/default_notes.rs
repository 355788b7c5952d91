//! Defaults have one source: the serde default, or — for an optional key whose absence is
//! resolved at run time — an `x-default` note on the field, which `schema_params` reads and
//! `check_registry` keeps from shadowing a real default.

use motionlab_core::registry::{ParamDoc, default_note_problem, schema_of, schema_params};
use schemars::JsonSchema;
use serde::Deserialize;

#[allow(dead_code)]
#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct Params {
    /// Frames per second of the labels.
    #[serde(default)]
    #[schemars(extend("x-default" = "the motion's frame rate"))]
    rate_hz: Option<f64>,
    /// Markers to use.
    #[serde(default)]
    #[schemars(extend("x-default" = "every marker"))]
    markers: Vec<String>,
    /// Lag, frames.
    #[serde(default = "three")]
    lag: usize,
    /// Lag, frames, with a note that contradicts its serde default.
    #[serde(default = "three")]
    #[schemars(extend("x-default" = "five frames"))]
    shadowed: usize,
}

fn three() -> usize {
    3
}

fn param(name: &str) -> ParamDoc {
    schema_params(&schema_of::<Params>()).into_iter().find(|p| p.name == name).unwrap()
}

#[test]
fn a_note_is_read_beside_the_serde_default() {
    let rate = param("rate_hz");
    assert_eq!(
        (rate.default.as_deref(), rate.default_note.as_deref()),
        (Some("(none)"), Some("the motion's frame rate"))
    );
    assert_eq!(param("markers").default_note.as_deref(), Some("every marker"));
    let lag = param("lag");
    assert_eq!((lag.default.as_deref(), lag.default_note), (Some("3"), None));
}

#[test]
fn a_note_may_only_say_what_an_unset_key_means() {
    for name in ["rate_hz", "markers", "lag"] {
        assert_eq!(default_note_problem(&param(name)), None, "{name}");
    }
    let problem = default_note_problem(&param("shadowed"))
        .expect("a note beside a real default is a problem");
    assert!(problem.contains("serde default 3") && problem.contains("five frames"), "{problem}");
}
