//! The plugin registry.
//!
//! Every stage implementation registers itself with one line,
//!
//! ```ignore
//! motionlab_core::register_plugin!(Segmenter, SpeedMinimaParams, "speed_minima");
//! ```
//!
//! which submits a [`PluginEntry`] to `inventory`: its TOML name, its kind, the JSON schema of
//! its parameters (from the params struct's doc comments and serde attributes, via
//! `schemars`: this is what `motionlab describe` prints) and a builder that deserialises the
//! TOML table (`deny_unknown_fields`), then validates it into the checked stage
//! ([`ParamGuard`], as linfa does) — so a bad parameter is reported when the experiment is
//! validated, before any work runs.
//!
//! A stage kind defined outside this table — a trait in a researcher's own crate — registers
//! its plugins with [`register_custom_plugin!`](crate::register_custom_plugin) under the kind's
//! name and builds them with [`build_custom::<dyn Trait>`](build_custom), which downcasts and
//! names the closest kinds or plugins when a name is unknown.
//!
//! Caveat: a crate that the final binary never names is not linked, and its plugins vanish
//! silently. The CLI names every plugin crate, and a registry test lists every expected name.
//!
//! **Defaults have one source.** A parameter's default is its `#[serde(default = ...)]`, which
//! schemars copies into the schema and `motionlab describe` prints; doc comments do not repeat
//! it (the registry test rejects a description that states a default in prose). An optional key
//! whose absence means something decided at run time — "the motion's frame rate", "every other
//! method" — says so with the [`DEFAULT_NOTE_KEY`] schema extension on the field,
//! `#[schemars(extend("x-default" = "the motion's frame rate"))]`, which `describe` prints in the
//! default's place ([`ParamDoc::default_note`]).

use schemars::JsonSchema;
use serde::de::DeserializeOwned;

use crate::stage::*;
use crate::{Error, ErrorKind, Result};

/// The stage kinds: one row each — variant, stage trait, human label, typed builder. Adding a
/// stage kind is one row here (and its trait in [`crate::stage`]); the [`StageKind`] enum, its
/// list and labels, the [`Build`] enum, the generic builders behind
/// [`register_plugin!`](crate::register_plugin) and the typed `build_*` functions all come from
/// this table.
macro_rules! stage_kinds {
    ($($kind:ident => $trait:ident, $label:literal, $build_fn:ident;)*) => {
        /// The kinds of pluggable stage. `type = "..."` names are unique across all kinds.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
        #[serde(rename_all = "snake_case")]
        pub enum StageKind {
            $($kind,)*
        }

        impl StageKind {
            /// Every kind, in declaration order.
            pub const ALL: [StageKind; [$(stringify!($kind)),*].len()] = [$(StageKind::$kind),*];
            /// Human label (`ground-truth reader`, `walk synthesizer`).
            pub fn label(self) -> &'static str {
                match self {
                    $(StageKind::$kind => $label,)*
                }
            }
        }

        /// The builder of a plugin, by kind.
        #[derive(Clone, Copy)]
        pub enum Build {
            $($kind(BuildFn<dyn $trait>),)*
        }

        /// Per-kind generic builders used by [`register_plugin!`](crate::register_plugin).
        #[allow(non_snake_case)]
        pub mod builders {
            use super::*;
            $(
                pub fn $kind<P>(value: &toml::Value) -> Result<Box<dyn $trait>>
                where
                    P: ParamGuard,
                    P::Checked: $trait + 'static,
                {
                    let params: P = parse_params(value)?;
                    Ok(Box::new(params.check()?))
                }
            )*
        }

        $(
            /// Builds a stage of this kind from its TOML table (without the `type` key).
            pub fn $build_fn(name: &str, params: &toml::Value) -> Result<Box<dyn $trait>> {
                let entry = find_kind(name, StageKind::$kind)?;
                match entry.build {
                    Build::$kind(f) => f(params),
                    #[allow(unreachable_patterns)]
                    _ => Err(Error::new(ErrorKind::UnknownPlugin, format!("{name:?} is registered with a mismatched builder"))),
                }
            }
        )*
    };
}

stage_kinds! {
    Loader => Loader, "loader", build_loader;
    GroundTruth => GroundTruthReader, "ground-truth reader", build_ground_truth;
    Preprocessor => Preprocessor, "preprocessor", build_preprocessor;
    FeatureExtractor => FeatureExtractor, "feature extractor", build_feature_extractor;
    Segmenter => Segmenter, "segmenter", build_segmenter;
    Fuser => Fuser, "fuser", build_fuser;
    Evaluator => Evaluator, "evaluator", build_evaluator;
    Labeller => Labeller, "state labeller", build_labeller;
}

impl StageKind {
    /// Where `motionlab list` shows this kind: ten apart, so a kind declared by a family crate
    /// ([`declare_stage_kind!`](crate::declare_stage_kind)) can sit between two of core's.
    pub fn list_order(self) -> u32 {
        StageKind::ALL.iter().position(|k| *k == self).map_or(u32::MAX, |i| i as u32 * 10)
    }
}

/// A stage kind declared by the crate that defines its trait — the matching family's
/// `matcher` in `motionlab-match`, a researcher's own kind — rather than in core's table: core
/// knows neither its trait nor its records. Its plugins register with
/// [`register_custom_plugin!`](crate::register_custom_plugin) under `name` and are built with
/// [`build_custom`]; `motionlab list` and `describe` show it like core's kinds. A custom kind
/// nobody declares is listed as a custom kind.
pub struct KindEntry {
    /// The kind's name (`matcher`, `gait_cycle_detector`), as `register_custom_plugin!` uses it.
    pub name: &'static str,
    /// Human label (`gait-cycle detector`).
    pub label: &'static str,
    /// Where `motionlab list` shows it among core's kinds ([`StageKind::list_order`]).
    pub list_order: u32,
    /// The crate that declared it.
    pub crate_name: &'static str,
}

inventory::collect!(KindEntry);

/// Every declared kind, in list order.
pub fn declared_kinds() -> Vec<&'static KindEntry> {
    let mut v: Vec<&'static KindEntry> = inventory::iter::<KindEntry>.into_iter().collect();
    v.sort_by_key(|k| (k.list_order, k.name));
    v
}

/// The declared kind named `name`, if any.
pub fn declared_kind(name: &str) -> Option<&'static KindEntry> {
    inventory::iter::<KindEntry>.into_iter().find(|k| k.name == name)
}

/// Declares a stage kind whose trait lives in this crate:
/// `declare_stage_kind!("matcher", label = "matcher", list_order = 52);`
#[macro_export]
macro_rules! declare_stage_kind {
    ($name:literal, label = $label:literal, list_order = $order:literal) => {
        $crate::inventory::submit! {
            $crate::registry::KindEntry { name: $name, label: $label, list_order: $order, crate_name: env!("CARGO_PKG_NAME") }
        }
    };
}

/// Validation of deserialised parameters into the type a stage runs with (linfa's ParamGuard).
pub trait ParamGuard: DeserializeOwned + JsonSchema {
    /// The validated stage.
    type Checked;
    /// Checks ranges and consistency; errors name the offending field
    /// (`Error::with_field("v_low")`).
    fn check(self) -> Result<Self::Checked>;
}

/// A builder from a TOML parameter table (the stage's table without its `type` key).
pub type BuildFn<T> = fn(&toml::Value) -> Result<Box<T>>;

/// One registered plugin.
pub struct PluginEntry {
    /// The name used in TOML (`type = "fastest_marker_speed"`).
    pub name: &'static str,
    pub kind: StageKind,
    /// The Rust params type (for docs and error messages).
    pub params_type: &'static str,
    /// The crate that registered it.
    pub crate_name: &'static str,
    /// JSON schema of the parameters, with doc comments as descriptions and defaults.
    pub schema: fn() -> schemars::Schema,
    pub build: Build,
}

inventory::collect!(PluginEntry);

/// `doc`, `summary` and `params` of a registry entry type with `schema` and `params_type`.
macro_rules! documented_entry {
    ($($entry:ty),*) => {$(
        impl $entry {
            /// The plugin's documentation: the params struct's doc comment (title + description).
            pub fn doc(&self) -> String {
                schema_doc(&(self.schema)(), self.params_type)
            }
            /// First line of the plugin's documentation.
            pub fn summary(&self) -> String {
                self.doc().lines().next().unwrap_or("").to_string()
            }
            /// The parameters: name, type, default and description, in declaration order.
            pub fn params(&self) -> Vec<ParamDoc> {
                schema_params(&(self.schema)())
            }
        }
    )*};
}

documented_entry!(PluginEntry, CustomPluginEntry);

/// The documentation in a params type's schema: its doc comment (title + description).
/// `type_name` is the Rust type's name, which schemars uses as the title when there is none.
pub fn schema_doc(schema: &schemars::Schema, type_name: &str) -> String {
    let get = |k: &str| schema.get(k).and_then(|v| v.as_str()).unwrap_or("").trim().to_string();
    let (mut title, description) = (get("title"), get("description"));
    // schemars titles a root schema with the type name; that is not documentation.
    if title == type_name || !title.contains(' ') {
        title.clear();
    }
    match (title.is_empty(), description.is_empty()) {
        (true, _) => description,
        (false, true) => title,
        (false, false) => format!("{title}\n\n{description}"),
    }
}

/// The parameters documented in a params type's schema: name, type, default and description,
/// in declaration order.
pub fn schema_params(schema: &schemars::Schema) -> Vec<ParamDoc> {
    let root = schema.as_value();
    let defs = root.get("$defs");
    let Some(props) = root.get("properties").and_then(|p| p.as_object()) else { return Vec::new() };
    let required: Vec<&str> = root
        .get("required")
        .and_then(|r| r.as_array())
        .map(|a| a.iter().filter_map(|v| v.as_str()).collect())
        .unwrap_or_default();
    props
        .iter()
        .map(|(name, p)| ParamDoc {
            name: name.clone(),
            type_name: type_name(p, defs),
            default: p.get("default").map(toml_like),
            default_note: p
                .get(DEFAULT_NOTE_KEY)
                .and_then(|d| d.as_str())
                .map(|d| d.trim().to_string()),
            required: required.contains(&name.as_str()),
            description: p
                .get("description")
                .and_then(|d| d.as_str())
                .or_else(|| {
                    resolve(p, defs).and_then(|r| r.get("description")).and_then(|d| d.as_str())
                })
                .unwrap_or("")
                .trim()
                .to_string(),
        })
        .collect()
}

/// The schema key of a default that serde cannot hold: on an optional field (serde default
/// `None` or an empty collection), what leaving the key out means, in words.
pub const DEFAULT_NOTE_KEY: &str = "x-default";

/// The schema key (on a params struct) listing the inputs a plugin's defaults were tuned on:
/// lower-case hex SHA-256 of each input file. Evaluation tables then say, per sequence, whether
/// a method at its defaults was tuned on that very sequence (the segmentation workflow's
/// `parameters_chosen` column).
pub const DEFAULTS_TUNED_ON_KEY: &str = "x-defaults-tuned-on";

/// The [`DEFAULTS_TUNED_ON_KEY`] list of a params schema (empty when the plugin declares none).
pub fn defaults_tuned_on(schema: &schemars::Schema) -> Vec<String> {
    schema
        .as_value()
        .get(DEFAULTS_TUNED_ON_KEY)
        .and_then(|v| v.as_array())
        .map(|a| a.iter().filter_map(|h| h.as_str().map(str::to_string)).collect())
        .unwrap_or_default()
}

/// One documented parameter.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ParamDoc {
    pub name: String,
    pub type_name: String,
    /// The serde default, written as TOML (`(none)` for an unset optional key).
    pub default: Option<String>,
    /// What leaving the key out means when serde cannot say it (the [`DEFAULT_NOTE_KEY`]
    /// extension: decided at run time, like "the motion's frame rate").
    pub default_note: Option<String>,
    pub required: bool,
    pub description: String,
}

fn resolve<'a>(
    p: &'a serde_json::Value,
    defs: Option<&'a serde_json::Value>,
) -> Option<&'a serde_json::Value> {
    let r = p.get("$ref")?.as_str()?;
    let name = r.rsplit('/').next()?;
    defs?.get(name)
}

fn type_name(p: &serde_json::Value, defs: Option<&serde_json::Value>) -> String {
    if let Some(r) = p.get("$ref").and_then(|r| r.as_str()) {
        let name = r.rsplit('/').next().unwrap_or(r).to_string();
        // Enums of strings read best as their allowed values.
        if let Some(values) = resolve(p, defs).and_then(enum_values) {
            return values;
        }
        return name;
    }
    if let Some(values) = enum_values(p) {
        return values;
    }
    if let Some(all) = p.get("allOf").and_then(|a| a.as_array())
        && let Some(first) = all.first()
    {
        return type_name(first, defs);
    }
    if let Some(any) = p.get("anyOf").or_else(|| p.get("oneOf")).and_then(|a| a.as_array()) {
        let parts: Vec<String> = any
            .iter()
            .filter(|s| s.get("type").and_then(|t| t.as_str()) != Some("null"))
            .map(|s| type_name(s, defs))
            .collect();
        let nullable = any.iter().any(|s| s.get("type").and_then(|t| t.as_str()) == Some("null"));
        let joined = parts.join(" | ");
        return if nullable { format!("{joined} (optional)") } else { joined };
    }
    match p.get("type") {
        Some(serde_json::Value::String(t)) => match t.as_str() {
            "array" => {
                format!("[{}]", p.get("items").map(|i| type_name(i, defs)).unwrap_or_default())
            }
            "number" => "float".into(),
            other => other.to_string(),
        },
        Some(serde_json::Value::Array(ts)) => {
            let parts: Vec<&str> =
                ts.iter().filter_map(|t| t.as_str()).filter(|t| *t != "null").collect();
            let nullable = ts.iter().any(|t| t.as_str() == Some("null"));
            let joined = parts
                .iter()
                .map(|t| if *t == "number" { "float" } else { t })
                .collect::<Vec<_>>()
                .join(" | ");
            if nullable { format!("{joined} (optional)") } else { joined }
        }
        _ => "value".into(),
    }
}

fn enum_values(p: &serde_json::Value) -> Option<String> {
    let mut out = Vec::new();
    if let Some(e) = p.get("enum").and_then(|e| e.as_array()) {
        out.extend(e.iter().filter_map(|v| v.as_str()).map(|s| format!("\"{s}\"")));
    } else if let Some(one) = p.get("oneOf").and_then(|o| o.as_array()) {
        for v in one {
            if let Some(c) = v.get("const").and_then(|c| c.as_str()) {
                out.push(format!("\"{c}\""));
            } else if let Some(e) = v.get("enum").and_then(|e| e.as_array()) {
                out.extend(e.iter().filter_map(|v| v.as_str()).map(|s| format!("\"{s}\"")));
            } else if let Some(props) = v.get("properties").and_then(|p| p.as_object())
                && props.len() == 1
            {
                // Externally tagged variant with data, e.g. `{ seconds = float }`.
                let (k, inner) = props.iter().next()?;
                out.push(format!("{{ {k} = {} }}", type_name(inner, None)));
            } else {
                return None;
            }
        }
    } else {
        return None;
    }
    Some(out.join(" | "))
}

/// Renders a JSON default as TOML would write it.
fn toml_like(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Object(m) if m.is_empty() => "{}".into(),
        serde_json::Value::Object(m) => {
            let parts: Vec<String> =
                m.iter().map(|(k, v)| format!("{k} = {}", toml_like(v))).collect();
            format!("{{ {} }}", parts.join(", "))
        }
        serde_json::Value::Array(a) => {
            format!("[{}]", a.iter().map(toml_like).collect::<Vec<_>>().join(", "))
        }
        serde_json::Value::Null => "(none)".into(),
        other => other.to_string(),
    }
}

/// Every registered plugin, sorted by kind then name.
pub fn plugins() -> Vec<&'static PluginEntry> {
    let mut v: Vec<&'static PluginEntry> = inventory::iter::<PluginEntry>.into_iter().collect();
    v.sort_by_key(|p| (p.kind, p.name));
    v
}

/// Looks a plugin up by name; an unknown name lists the closest registered names.
pub fn find(name: &str) -> Result<&'static PluginEntry> {
    let all = plugins();
    if let Some(p) = all.iter().find(|p| p.name == name) {
        return Ok(p);
    }
    Err(unknown_plugin(name, None, &all))
}

/// Looks a plugin of one kind up by name; the error lists the closest names of that kind.
pub fn find_kind(name: &str, kind: StageKind) -> Result<&'static PluginEntry> {
    let all = plugins();
    match all.iter().find(|p| p.name == name) {
        Some(p) if p.kind == kind => Ok(p),
        Some(p) => Err(Error::new(
            ErrorKind::UnknownPlugin,
            format!("{name:?} is a {}, but a {} is expected here", p.kind.label(), kind.label()),
        )),
        None => Err(unknown_plugin(name, Some(kind), &all)),
    }
}

fn unknown_plugin(name: &str, kind: Option<StageKind>, all: &[&'static PluginEntry]) -> Error {
    let pool = all.iter().filter(|p| kind.is_none_or(|k| p.kind == k)).map(|p| p.name);
    let close = closest_names(name, pool);
    let what = kind.map(StageKind::label).unwrap_or("plugin");
    let hint = if close.is_empty() {
        " (run `motionlab list` to see them all)".to_string()
    } else {
        format!(
            "; did you mean {}?",
            close.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(" or ")
        )
    };
    Error::new(ErrorKind::UnknownPlugin, format!("no {what} named {name:?} is registered{hint}"))
}

/// Up to three names closest to `name` (normalised Damerau–Levenshtein ≥ 0.5, or a prefix match).
pub fn closest_names<'a>(name: &str, pool: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let mut scored: Vec<(f64, &str)> = pool
        .into_iter()
        .map(|c| {
            let mut s = strsim::normalized_damerau_levenshtein(name, c);
            if c.starts_with(name) || name.starts_with(c) || c.contains(name) {
                s = s.max(0.75);
            }
            (s, c)
        })
        .filter(|(s, _)| *s >= 0.5)
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(b.1)));
    scored.into_iter().take(3).map(|(_, c)| c.to_string()).collect()
}

/// Deserialises a params struct from a TOML table, naming the offending field on error.
pub fn parse_params<P: DeserializeOwned>(value: &toml::Value) -> Result<P> {
    let result: std::result::Result<P, serde_path_to_error::Error<toml::de::Error>> =
        serde_path_to_error::deserialize(value.clone());
    result.map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let msg = inner.message().to_string();
        let kind = if msg.starts_with("unknown field") || msg.starts_with("unknown variant") {
            if msg.starts_with("unknown field") {
                ErrorKind::UnknownKey
            } else {
                ErrorKind::WrongType
            }
        } else if msg.starts_with("invalid type") || msg.starts_with("invalid value") {
            ErrorKind::WrongType
        } else if msg.starts_with("missing field") {
            ErrorKind::MissingKey
        } else {
            ErrorKind::InvalidParameter
        };
        let field = if path == "." || path.is_empty() { String::new() } else { path };
        let mut err = Error::new(kind, msg);
        if !field.is_empty() {
            err = err.with_field(field);
        }
        err
    })
}

/// The JSON schema of a params type (stored as a fn pointer in [`PluginEntry::schema`]).
pub fn schema_of<P: JsonSchema>() -> schemars::Schema {
    schemars::SchemaGenerator::default().into_root_schema_for::<P>()
}

/// Registers a plugin: `register_plugin!(Segmenter, SpeedMinimaParams, "speed_minima");`
///
/// The first argument is the [`StageKind`] variant; the params type must implement
/// [`ParamGuard`] whose `Checked` type implements that kind's trait.
#[macro_export]
macro_rules! register_plugin {
    ($kind:ident, $params:ty, $name:literal) => {
        $crate::inventory::submit! {
            $crate::registry::PluginEntry {
                name: $name,
                kind: $crate::registry::StageKind::$kind,
                params_type: stringify!($params),
                crate_name: env!("CARGO_PKG_NAME"),
                schema: $crate::registry::schema_of::<$params>,
                build: $crate::registry::Build::$kind($crate::registry::builders::$kind::<$params>),
            }
        }
    };
}

/// A builder of a custom-kind plugin: the stage as `Box<dyn Trait>`, boxed again as `Any` so
/// that one registry holds every kind (the kind's trait is not known to core).
pub type CustomBuildFn = fn(&toml::Value) -> Result<Box<dyn std::any::Any + Send + Sync>>;

/// One registered plugin of a kind defined outside core (a trait in a researcher's crate),
/// registered with [`register_custom_plugin!`](crate::register_custom_plugin) and built with
/// [`build_custom`]. Core knows the kind only by its name (`"pose_labeller"`).
pub struct CustomPluginEntry {
    /// The name used in TOML (`type = "by_height"`); unique across built-in and custom plugins.
    pub name: &'static str,
    /// The kind's name (`pose_labeller`), as `motionlab list` and `describe` show it.
    pub kind: &'static str,
    /// The kind's trait, as written in the registration (for type-mismatch errors).
    pub trait_name: &'static str,
    /// The Rust params type (for docs and error messages).
    pub params_type: &'static str,
    /// The crate that registered it.
    pub crate_name: &'static str,
    /// JSON schema of the parameters, with doc comments as descriptions and defaults.
    pub schema: fn() -> schemars::Schema,
    /// Builds `Box<Box<dyn Trait>>` as `Box<dyn Any>`.
    pub build: CustomBuildFn,
}

inventory::collect!(CustomPluginEntry);

/// Every registered custom-kind plugin, sorted by kind then name.
pub fn custom_plugins() -> Vec<&'static CustomPluginEntry> {
    let mut v: Vec<&'static CustomPluginEntry> =
        inventory::iter::<CustomPluginEntry>.into_iter().collect();
    v.sort_by_key(|p| (p.kind, p.name));
    v
}

/// The custom kinds' names, sorted, each once.
pub fn custom_kinds() -> Vec<&'static str> {
    let mut kinds: Vec<&'static str> = custom_plugins().iter().map(|p| p.kind).collect();
    kinds.dedup();
    kinds
}

/// The custom-kind plugin registered under `name`, if any.
pub fn find_custom(name: &str) -> Option<&'static CustomPluginEntry> {
    custom_plugins().into_iter().find(|p| p.name == name)
}

/// Builds a plugin of a custom kind from its TOML table (without the `type` key), as the
/// kind's trait object: `build_custom::<dyn PoseLabeller>("pose_labeller", "by_height", &params)`.
///
/// Errors ([`ErrorKind::UnknownPlugin`]): the kind is not registered (closest kinds named), no
/// plugin of that kind has this name (closest names of the kind), the name belongs to another
/// kind, or the plugin builds another trait object than `T`.
pub fn build_custom<T: ?Sized + 'static>(
    kind: &str,
    name: &str,
    params: &toml::Value,
) -> Result<Box<T>> {
    let all = custom_plugins();
    let hint = |close: Vec<String>| {
        if close.is_empty() {
            " (run `motionlab list` to see them all)".to_string()
        } else {
            format!(
                "; did you mean {}?",
                close.iter().map(|c| format!("{c:?}")).collect::<Vec<_>>().join(" or ")
            )
        }
    };
    if !all.iter().any(|p| p.kind == kind) {
        let close = closest_names(kind, custom_kinds());
        return Err(Error::new(
            ErrorKind::UnknownPlugin,
            format!("no custom stage kind {kind:?} is registered{}", hint(close)),
        ));
    }
    fn label(k: &str) -> &str {
        declared_kind(k).map_or(k, |d| d.label)
    }
    let entry = match all.iter().find(|p| p.name == name) {
        Some(p) if p.kind == kind => *p,
        Some(p) => {
            let msg =
                format!("{name:?} is a {}, but a {} is expected here", label(p.kind), label(kind));
            return Err(Error::new(ErrorKind::UnknownPlugin, msg));
        }
        None => {
            if let Some(p) = plugins().into_iter().find(|p| p.name == name) {
                let msg = format!(
                    "{name:?} is a {}, but a {} is expected here",
                    p.kind.label(),
                    label(kind)
                );
                return Err(Error::new(ErrorKind::UnknownPlugin, msg));
            }
            let close = closest_names(name, all.iter().filter(|p| p.kind == kind).map(|p| p.name));
            return Err(Error::new(
                ErrorKind::UnknownPlugin,
                format!("no {} named {name:?} is registered{}", label(kind), hint(close)),
            ));
        }
    };
    let built = (entry.build)(params)?;
    match built.downcast::<Box<T>>() {
        Ok(stage) => Ok(*stage),
        Err(_) => Err(Error::new(
            ErrorKind::UnknownPlugin,
            format!(
                "{name:?} ({kind}, from {}) builds a `dyn {}`, but `{}` was asked for",
                entry.crate_name,
                entry.trait_name,
                std::any::type_name::<T>()
            ),
        )),
    }
}

/// Registers a plugin of a stage kind defined outside core:
/// `register_custom_plugin!(PoseLabeller, ByHeightParams, "by_height", kind = "pose_labeller");`
///
/// The trait must be `Send + Sync` (make them supertraits) and the params type must implement
/// [`ParamGuard`] whose `Checked` type implements the trait. Build it with
/// [`build_custom::<dyn Trait>(kind, name, params)`](build_custom).
#[macro_export]
macro_rules! register_custom_plugin {
    ($trait:path, $params:ty, $name:literal, kind = $kind:literal) => {
        const _: () = {
            fn build(
                value: &$crate::toml::Value,
            ) -> $crate::Result<::std::boxed::Box<dyn ::std::any::Any + Send + Sync>> {
                let params: $params = $crate::registry::parse_params(value)?;
                let stage: ::std::boxed::Box<dyn $trait> =
                    ::std::boxed::Box::new($crate::registry::ParamGuard::check(params)?);
                Ok(::std::boxed::Box::new(stage))
            }
            $crate::inventory::submit! {
                $crate::registry::CustomPluginEntry {
                    name: $name,
                    kind: $kind,
                    trait_name: stringify!($trait),
                    params_type: stringify!($params),
                    crate_name: env!("CARGO_PKG_NAME"),
                    schema: $crate::registry::schema_of::<$params>,
                    build,
                }
            }
        };
    };
}

/// Why a parameter's [`DEFAULT_NOTE_KEY`] note is misplaced, if it is: a note may only say what
/// an *unset* key means (serde default `None`, `[]` or `{}`), never shadow a real default value,
/// and it must say something.
pub fn default_note_problem(param: &ParamDoc) -> Option<String> {
    let note = param.default_note.as_deref()?;
    if note.is_empty() {
        return Some(format!("its {DEFAULT_NOTE_KEY:?} note is empty"));
    }
    match param.default.as_deref() {
        Some("(none)" | "[]" | "{}") => None,
        Some(value) => Some(format!(
            "has the serde default {value} and also a {DEFAULT_NOTE_KEY:?} note ({note:?}); keep one"
        )),
        None if param.required => Some(format!("is required but has a {DEFAULT_NOTE_KEY:?} note")),
        None => None,
    }
}

/// An empty parameter table (every parameter at its default).
pub fn default_params() -> toml::Value {
    toml::Value::Table(toml::Table::new())
}

/// Checks the registry invariants the registry test enforces: names are unique snake_case,
/// every plugin is documented, every parameter has a description, and default parameters
/// either build or fail only for a missing required key.
pub fn check_registry() -> Vec<String> {
    let mut problems = Vec::new();
    let builtin = plugins()
        .into_iter()
        .map(|p| (p.name, p.kind.label().to_string(), p.params_type, p.doc(), p.params()));
    let custom = custom_plugins()
        .into_iter()
        .map(|p| (p.name, p.kind.to_string(), p.params_type, p.doc(), p.params()));
    let snake = |s: &str| {
        s.chars().next().is_some_and(|c| c.is_ascii_lowercase())
            && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
    };
    for kind in custom_kinds() {
        if !snake(kind) || StageKind::ALL.iter().any(|k| k.label() == kind) {
            problems.push(format!(
                "custom kind {kind:?} is not a snake_case name distinct from the built-in kinds"
            ));
        }
    }
    let mut declared = std::collections::HashSet::new();
    for k in declared_kinds() {
        if !declared.insert(k.name)
            || !snake(k.name)
            || StageKind::ALL.iter().any(|c| c.label() == k.label)
        {
            problems.push(format!("declared kind {:?} ({}) is not a unique snake_case name with a label distinct from core's kinds", k.name, k.crate_name));
        }
    }
    for p in plugins() {
        let schema = (p.schema)();
        let tuned_on = defaults_tuned_on(&schema);
        if schema.as_value().get(DEFAULTS_TUNED_ON_KEY).is_some() && tuned_on.is_empty()
            || tuned_on.iter().any(|h| {
                h.len() != 64 || !h.chars().all(|c| c.is_ascii_digit() || ('a'..='f').contains(&c))
            })
        {
            problems.push(format!(
                "{:?}: {DEFAULTS_TUNED_ON_KEY:?} must list lower-case hex SHA-256 digests",
                p.name
            ));
        }
    }
    let mut seen = std::collections::HashSet::new();
    for (name, kind, params_type, doc, params) in builtin.chain(custom) {
        if !seen.insert(name) {
            problems.push(format!("{name:?} is registered twice"));
        }
        if !snake(name) {
            problems.push(format!("{name:?} is not a snake_case name"));
        }
        if doc.len() < 20 {
            problems.push(format!("{name:?} ({kind}) has no doc comment on {params_type}"));
        }
        for param in params {
            if param.description.is_empty() {
                problems.push(format!("{name:?}: parameter {:?} has no doc comment", param.name));
            }
            if !param.required && param.default.is_none() && !param.type_name.contains("optional") {
                problems.push(format!(
                    "{name:?}: parameter {:?} is optional but documents no default",
                    param.name
                ));
            }
            if let Some(problem) = default_note_problem(&param) {
                problems.push(format!("{name:?}: parameter {:?}: {problem}", param.name));
            }
        }
    }
    problems
}
