//! The plugin registry: every plugin and workflow crate is linked into the binary's crates
//! with exactly the plugins it says it registers, and every one is documented (a crate the CLI
//! forgets to name, or a plugin file whose `mod` line is missing, would vanish silently).
//!
//! Each crate states its count (`PLUGIN_COUNT`, `WORKFLOW_COUNT` in its lib.rs); this test
//! derives everything else from the registry.

use motionlab_core::registry;
use motionlab_experiment::workflow::workflows;
use motionlab_plugins::LINKED;

/// The plugin crates the CLI and the Python package link (the one list, `motionlab-plugins`),
/// with the number of plugins each says it registers.
fn plugin_crates() -> Vec<(&'static str, usize)> {
    LINKED.iter().filter(|c| c.plugins > 0).map(|c| (c.package, c.plugins)).collect()
}

/// The workflow crates of that list, with the number of workflows each registers.
fn workflow_crates() -> Vec<(&'static str, usize)> {
    LINKED.iter().filter(|c| c.workflows > 0).map(|c| (c.package, c.workflows)).collect()
}

#[test]
fn every_plugin_crate_registers_the_plugins_it_counts() {
    // Plugins of core's kinds and of the kinds family crates declare (matcher, gait-cycle
    // detector, …), by name and crate.
    let all: Vec<(&str, &str)> = registry::plugins()
        .iter()
        .map(|p| (p.name, p.crate_name))
        .chain(registry::custom_plugins().iter().map(|p| (p.name, p.crate_name)))
        .collect();
    let plugin_crates = plugin_crates();
    for (krate, count) in &plugin_crates {
        let names: Vec<&str> = all.iter().filter(|p| p.1 == *krate).map(|p| p.0).collect();
        assert_eq!(
            names.len(),
            *count,
            "{krate} says it registers {count} plugins; the binary holds {}: {names:?} (crate not linked, or a plugin's `mod` line missing?)",
            names.len()
        );
    }
    for (name, krate) in &all {
        assert!(
            plugin_crates.iter().any(|(k, _)| k == krate),
            "plugin {name:?} comes from {krate}, which motionlab-plugins does not list"
        );
    }
}

/// The kinds family crates declare are listed among core's, each with its plugins, and a
/// plugin of one is built by its family's builder and refused by another kind's.
#[test]
fn declared_kinds_are_listed_and_built_like_cores() {
    let declared: Vec<&str> = registry::declared_kinds().iter().map(|k| k.name).collect();
    assert_eq!(
        declared,
        [
            "point_detector",
            "matcher",
            "synchroniser",
            "gait_cycle_detector",
            "waveform_analyzer",
            "walk_synthesizer"
        ]
    );
    let list = motionlab_engine::describe::list();
    let order: Vec<usize> = [
        "fusers:",
        "point detectors:",
        "matchers:",
        "synchronisers:",
        "gait-cycle detectors:",
        "waveform analyzers:",
        "walk synthesizers:",
        "evaluators:",
        "state labellers:",
    ]
    .iter()
    .map(|h| {
        list.lines()
            .position(|l| l == *h)
            .unwrap_or_else(|| panic!("{h} not in `motionlab list`:\n{list}"))
    })
    .collect();
    assert!(order.windows(2).all(|w| w[0] < w[1]), "kinds out of order: {order:?}");
    assert!(!list.contains("(custom kind)"), "no undeclared custom kind in the workspace");
    assert!(
        motionlab_match::build_matcher("multistream_two_stage", &registry::default_params())
            .is_ok()
    );
    let e = motionlab_match::build_matcher("velocity_peaks", &registry::default_params())
        .err()
        .unwrap();
    assert_eq!(
        e.to_string(),
        "\"velocity_peaks\" is a point detector, but a matcher is expected here"
    );
    let e = motionlab_match::build_matcher("multistream_two_stag", &registry::default_params())
        .err()
        .unwrap();
    assert!(e.to_string().starts_with("no matcher named \"multistream_two_stag\" is registered; did you mean \"multistream_two_stage\""), "{e}");
    let d = motionlab_engine::describe::describe("heel_height").unwrap();
    assert!(d.starts_with("heel_height (gait-cycle detector, from motionlab-features)"), "{d}");
}

#[test]
fn every_workflow_crate_registers_the_workflows_it_counts() {
    let all = workflows();
    let workflow_crates = workflow_crates();
    for (krate, count) in &workflow_crates {
        let names: Vec<&str> =
            all.iter().filter(|w| w.crate_name == *krate).map(|w| w.name).collect();
        assert_eq!(
            names.len(),
            *count,
            "{krate} says it registers {count} workflows; the binary holds {names:?}"
        );
    }
    for w in &all {
        assert!(
            workflow_crates.iter().any(|(k, _)| *k == w.crate_name),
            "workflow {:?} comes from {}, which motionlab-plugins does not list",
            w.name,
            w.crate_name
        );
    }
}

#[test]
fn every_registered_plugin_is_documented() {
    let problems = registry::check_registry();
    assert!(problems.is_empty(), "{problems:#?}");
}

#[test]
fn every_workflow_is_documented_and_its_section_names_are_unique() {
    let all = workflows();
    for w in &all {
        assert!(
            w.doc().len() >= 20,
            "workflow {:?} has no doc comment on {}",
            w.name,
            w.section_type
        );
        for p in w.params() {
            assert!(!p.description.is_empty(), "[{}] {}: no doc comment", w.name, p.name);
        }
        assert_eq!(
            all.iter().filter(|o| o.name == w.name).count(),
            1,
            "two workflows own [{}]",
            w.name
        );
        assert!(
            registry::plugins().iter().all(|p| p.name != w.name),
            "[{}] is also a plugin name",
            w.name
        );
    }
}

#[test]
fn stage_kinds_have_distinct_labels() {
    let labels: Vec<&str> = registry::StageKind::ALL.iter().map(|k| k.label()).collect();
    for (i, l) in labels.iter().enumerate() {
        assert!(!labels[..i].contains(l), "two stage kinds are labelled {l:?}");
    }
}

/// A default stated in prose: the word `default(s)` …
/// 1. as a label: followed by `:` or `=` ("Default: none", "default = 3");
/// 2. followed by a value — after optional `(`, `,`, `is`, `of`, `to`, and an optional
///    backtick — a number, a quote, `[`, `{`, or `true`/`false`/`none`/`off`/`on`/`empty`/
///    `all`/`every` ("Default 0.5", "default `\"root\"`", "Default `{ seconds = 1.0 }`",
///    "defaults to 3"; a backticked name is not a value: "the default is `boundary_pr`'s");
/// 3. in parentheses after a value it marks ("`\"auto\"` (default)", "(default; the paper's)").
///
/// Prose about a default that names no value — "the default is the paper's value", "the default
/// reads the paper's 5 frames as one duration" — is allowed: it says why, and `describe` prints
/// the value from the serde default beside it.
const PROSE_DEFAULT: &str = r#"(?ix)
      \bdefaults?\s*[:=]
    | \bdefaults?\b [\s(,]* (?:is\s+|of\s+|to\s+)? `?
      (?: [-+.0-9"'\[{] | \b(?:true|false|none|off|on|empty|all|every)\b )
    | \(\s*defaults?\s*[);,]
"#;

/// Every string a schema documents: titles and descriptions of the type, its fields, nested
/// types (`$defs`) and enum variants, each with where it is.
fn documented_strings(value: &serde_json::Value, at: &str, out: &mut Vec<(String, String)>) {
    match value {
        serde_json::Value::Object(m) => {
            for (k, v) in m {
                match (k.as_str(), v) {
                    ("title" | "description", serde_json::Value::String(s)) => {
                        out.push((at.to_string(), s.clone()))
                    }
                    _ => documented_strings(v, &format!("{at}/{k}"), out),
                }
            }
        }
        serde_json::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                documented_strings(v, &format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
}

/// Defaults have one source, the serde default that `describe` prints: no doc comment of a
/// plugin or workflow (its own, its parameters', nested types' and enum variants') repeats one
/// in prose ([`PROSE_DEFAULT`] is the rule), and `x-default` notes only say what an unset
/// optional key means.
#[test]
fn no_doc_comment_states_a_default_in_prose() {
    let rule = regex::Regex::new(PROSE_DEFAULT).unwrap();
    let mut schemas = Vec::new();
    for p in registry::plugins() {
        schemas.push((format!("plugin {}", p.name), (p.schema)()));
    }
    for p in registry::custom_plugins() {
        schemas.push((format!("plugin {}", p.name), (p.schema)()));
    }
    for w in workflows() {
        schemas.push((format!("workflow [{}]", w.name), (w.schema)()));
    }
    assert!(schemas.len() > 40, "only {} schemas: the registry is not linked", schemas.len());
    let mut problems = Vec::new();
    for (who, schema) in &schemas {
        let mut texts = Vec::new();
        documented_strings(schema.as_value(), "", &mut texts);
        for (at, text) in texts {
            for m in rule.find_iter(&text) {
                let start = text[..m.start()].char_indices().rev().nth(40).map_or(0, |(i, _)| i);
                let end =
                    text[m.end()..].char_indices().nth(40).map_or(text.len(), |(i, _)| m.end() + i);
                problems.push(format!("{who} {at}: …{}…", text[start..end].replace('\n', " ")));
            }
        }
        for p in registry::schema_params(schema) {
            if let Some(problem) = registry::default_note_problem(&p) {
                problems.push(format!("{who}.{}: {problem}", p.name));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "defaults stated in prose (delete them: `describe` prints the serde default):\n{}",
        problems.join("\n")
    );
}

/// The rule catches the ways a default has been written in prose, and lets prose about a
/// default without a value through.
#[test]
fn the_prose_default_rule_has_known_answers() {
    let rule = regex::Regex::new(PROSE_DEFAULT).unwrap();
    for caught in [
        "Default 0.5.",
        "Default: none (off).",
        "Default: the motion's own.",
        "default `\"root\"`",
        "Default `{ seconds = 0.25 }`",
        "(`name = \"…\"`, default: the type)",
        "`\"auto\"` (default) or one of",
        "The group's first candidate (default; the paper's reading).",
        "defaults to 3 frames",
        "the default is 120 Hz",
        "Default true.",
        "Default: all.",
        "(default -1)",
        "Default `true`.",
        "default `[\"a\"]`",
    ] {
        assert!(rule.is_match(caught), "not caught: {caught:?}");
    }
    for allowed in [
        "the default tolerance is chosen by the paper's rule",
        "The default reads the paper's 5 frames (ballet) and 10 frames (street dance) as one duration.",
        "Sonoda's default is the paper's value (§2.2).",
        "every parameter at its default",
        "scipy's `CubicSpline` default)",
        "writes 0 into unfilled edges by default; here",
        "`filtfilt(b, a, x)` with its defaults — the run extended",
        "The default `max_distance_mm` accepts the rounding of forward kinematics",
        "the default is `boundary_pr`'s, which says why",
        "Why the defaults (`motionlab describe butterworth` lists them)",
    ] {
        assert!(!rule.is_match(allowed), "wrongly caught: {allowed:?}");
    }
}
