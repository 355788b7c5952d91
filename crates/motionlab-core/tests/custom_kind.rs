//! A stage kind defined outside core's `stage_kinds!` table (`register_custom_plugin!`): built
//! through `build_custom` as its trait object, with clear errors for an unknown kind or name and
//! for asking for the wrong trait.

use motionlab_core::registry::{
    ParamGuard, build_custom, check_registry, custom_kinds, find_custom,
};
use motionlab_core::{ErrorKind, Result};
use schemars::JsonSchema;
use serde::Deserialize;

trait Scaler: Send + Sync {
    fn scale(&self, x: f64) -> f64;
}

trait Other: Send + Sync {}

/// Multiplies by a factor: a test plugin of the custom `scaler` kind.
#[derive(Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
struct TimesParams {
    /// The factor, > 0.
    #[serde(default = "two")]
    factor: f64,
}

fn two() -> f64 {
    2.0
}

struct Times(f64);

impl ParamGuard for TimesParams {
    type Checked = Times;
    fn check(self) -> Result<Times> {
        if self.factor > 0.0 {
            Ok(Times(self.factor))
        } else {
            Err(motionlab_core::Error::new(ErrorKind::OutOfRange, "factor must be > 0")
                .with_field("factor"))
        }
    }
}

impl Scaler for Times {
    fn scale(&self, x: f64) -> f64 {
        x * self.0
    }
}

motionlab_core::register_custom_plugin!(Scaler, TimesParams, "times", kind = "scaler");

fn params(text: &str) -> toml::Value {
    toml::from_str(text).unwrap()
}

#[test]
fn builds_the_kinds_trait_object_with_its_parameters() {
    assert_eq!(build_custom::<dyn Scaler>("scaler", "times", &params("")).unwrap().scale(3.0), 6.0);
    assert_eq!(
        build_custom::<dyn Scaler>("scaler", "times", &params("factor = 0.5")).unwrap().scale(3.0),
        1.5
    );
    assert_eq!(custom_kinds(), vec!["scaler"]);
    assert_eq!(
        find_custom("times").map(|p| (p.kind, p.crate_name)),
        Some(("scaler", "motionlab-core"))
    );
    assert!(check_registry().is_empty(), "{:?}", check_registry());
}

#[test]
fn unknown_kind_name_wrong_trait_and_bad_parameter_are_clear_errors() {
    let err = |r: Result<Box<dyn Scaler>>| r.err().map(|e| (e.kind(), e.to_string())).unwrap();
    let (kind, msg) = err(build_custom::<dyn Scaler>("scalar", "times", &params("")));
    assert_eq!(kind, ErrorKind::UnknownPlugin);
    assert!(
        msg.contains("no custom stage kind \"scalar\"") && msg.contains("did you mean \"scaler\""),
        "{msg}"
    );
    let (_, msg) = err(build_custom::<dyn Scaler>("scaler", "tims", &params("")));
    assert!(
        msg.contains("no scaler named \"tims\"") && msg.contains("did you mean \"times\""),
        "{msg}"
    );
    let wrong =
        build_custom::<dyn Other>("scaler", "times", &params("")).err().unwrap().to_string();
    assert!(wrong.contains("builds a `dyn Scaler`") && wrong.contains("Other"), "{wrong}");
    let bad =
        build_custom::<dyn Scaler>("scaler", "times", &params("factor = -1.0")).err().unwrap();
    assert_eq!(bad.location().field.as_deref(), Some("factor"));
    let unknown_key =
        build_custom::<dyn Scaler>("scaler", "times", &params("factr = 1.0")).err().unwrap();
    assert_eq!(unknown_key.kind(), ErrorKind::UnknownKey);
}
