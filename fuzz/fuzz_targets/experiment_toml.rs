//! Experiment TOML: the in-memory half of `motionlab_engine::plan` — TOML syntax → an override
//! → schema deserialisation (serde_path_to_error, key path + line) → sweep expansion → every
//! stage built through the plugin registry (parameter validation) → the workflow built → the
//! consent scan (`consent::commands_of`: every program the combinations would start, each a
//! non-empty command line found at a key path of the document). No file is read or globbed:
//! inputs would otherwise make the fuzzer walk the file system.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use motionlab_engine::consent::commands_of;
use motionlab_engine::plan::{Source, build_stages_in_memory, parse_experiment};

// Name the plugin crates so their registrations are linked in.
use motionlab_eval as _;
use motionlab_external as _;
use motionlab_features as _;
use motionlab_gait as _;
use motionlab_match as _;
use motionlab_segment as _;
use motionlab_workflows as _;

fuzz_target!(|data: &[u8]| {
    let Some(text) = common::text(data) else { return };
    // The first line, when it is `#! key=value`, is used as a command-line override.
    let overrides: Vec<String> = match text.lines().next().and_then(|l| l.strip_prefix("#! ")) {
        Some(o) => vec![o.to_string()],
        None => vec![],
    };
    let source =
        Source { path: Path::new("/nonexistent/fuzz.toml").to_path_buf(), text: text.to_string() };
    match parse_experiment(&source, &overrides) {
        Ok(parsed) => {
            let mut built = true;
            for combo in &parsed.combos {
                if let Err(e) = build_stages_in_memory(&source, parsed.workflow, combo) {
                    common::assert_names_file(&e, "/nonexistent/fuzz.toml");
                    built = false;
                }
            }
            // A valid experiment's programs: each found where a stage table is, none empty.
            for c in commands_of(&parsed.combos) {
                assert!(!c.at.is_empty() && !c.plugin.is_empty());
                if built {
                    assert!(
                        !c.command.is_empty() && !c.command_line().is_empty(),
                        "an empty command line passed validation"
                    );
                }
            }
        }
        Err(e) => common::assert_names_file(&e, "/nonexistent/fuzz.toml"),
    }
});
