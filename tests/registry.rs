//! The plugin registry: every plugin and workflow crate is linked into the binary's crates
//! with exactly the plugins it says it registers, and every one is documented (a crate the CLI
//! forgets to name, or a plugin file whose `mod` line is missing, would vanish silently).
//!
//! Each crate states its count (`PLUGIN_COUNT`, `WORKFLOW_COUNT` in its lib.rs); this test
//! derives everything else from the registry.

use motionlab_core::registry;
use motionlab_experiment::workflow::workflows;

/// The same plugin crates the CLI names, with the number of plugins each says it registers.
const PLUGIN_CRATES: &[(&str, usize)] = &[
    ("motionlab-eval", motionlab_eval::PLUGIN_COUNT),
    ("motionlab-external", motionlab_external::PLUGIN_COUNT),
    ("motionlab-features", motionlab_features::PLUGIN_COUNT),
    ("motionlab-gait", motionlab_gait::PLUGIN_COUNT),
    ("motionlab-io", motionlab_io::PLUGIN_COUNT),
    ("motionlab-match", motionlab_match::PLUGIN_COUNT),
    ("motionlab-segment", motionlab_segment::PLUGIN_COUNT),
];

/// The workflow crates the CLI names, with the number of workflows each registers.
const WORKFLOW_CRATES: &[(&str, usize)] = &[("motionlab-workflows", motionlab_workflows::WORKFLOW_COUNT)];

#[test]
fn every_plugin_crate_registers_the_plugins_it_counts() {
    let all = registry::plugins();
    for (krate, count) in PLUGIN_CRATES {
        let names: Vec<&str> = all.iter().filter(|p| p.crate_name == *krate).map(|p| p.name).collect();
        assert_eq!(names.len(), *count, "{krate} says it registers {count} plugins; the binary holds {}: {names:?} (crate not linked, or a plugin's `mod` line missing?)", names.len());
    }
    for p in &all {
        assert!(PLUGIN_CRATES.iter().any(|(k, _)| *k == p.crate_name), "plugin {:?} comes from {}, which the CLI does not name", p.name, p.crate_name);
    }
}

#[test]
fn every_workflow_crate_registers_the_workflows_it_counts() {
    let all = workflows();
    for (krate, count) in WORKFLOW_CRATES {
        let names: Vec<&str> = all.iter().filter(|w| w.crate_name == *krate).map(|w| w.name).collect();
        assert_eq!(names.len(), *count, "{krate} says it registers {count} workflows; the binary holds {names:?}");
    }
    for w in &all {
        assert!(WORKFLOW_CRATES.iter().any(|(k, _)| *k == w.crate_name), "workflow {:?} comes from {}, which the CLI does not name", w.name, w.crate_name);
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
        assert!(w.doc().len() >= 20, "workflow {:?} has no doc comment on {}", w.name, w.section_type);
        for p in w.params() {
            assert!(!p.description.is_empty(), "[{}] {}: no doc comment", w.name, p.name);
        }
        assert_eq!(all.iter().filter(|o| o.name == w.name).count(), 1, "two workflows own [{}]", w.name);
        assert!(registry::plugins().iter().all(|p| p.name != w.name), "[{}] is also a plugin name", w.name);
    }
}

#[test]
fn stage_kinds_have_distinct_labels() {
    let labels: Vec<&str> = registry::StageKind::ALL.iter().map(|k| k.label()).collect();
    for (i, l) in labels.iter().enumerate() {
        assert!(!labels[..i].contains(l), "two stage kinds are labelled {l:?}");
    }
}
