//! motionlab-cli's integration tests: one test binary, one module per file of this folder.
//!
//! One binary rather than one per file: each binary links the whole of motionlab with polars
//! and plotters: eleven of them were 2.3 % of a cold `cargo test --workspace --no-run`
//! (`--timings`, README's performance table). A test's full name starts with its file's name, so
//! one file's tests still run alone: `cargo test -p motionlab-cli --test integration gait::`.
//! A new file here is one `mod` line below (CONTRIBUTING.md, "Tests").

mod annotate;
mod benchmark;
mod cache;
mod cli;
mod consent;
mod data_manifest;
mod docs_truth;
mod gait;
mod input_limits;
mod live;
mod malformed;
mod matching;
mod missing_data;
mod odd_names;
mod opensim_formats;
mod own_annotations;
mod penalty_path;
mod pose_formats;
mod reader_repairs;
mod registry;
mod retrieval;
mod safe_outputs;
mod sharding;
mod viewer;

use std::path::PathBuf;
use std::process::Command;
use std::sync::OnceLock;

/// The `motionlab` binary, with its on-disk cache in this test run's own folder
/// (`$CARGO_TARGET_TMPDIR/motionlab-cache`, emptied once when the run starts): tests never touch
/// the user's `~/.cache/motionlab`, every run starts cold, and the tests that run at once share
/// one cache as concurrent runs do (tests/cache.rs gives its runs folders of their own).
pub fn motionlab_command() -> Command {
    static CACHE: OnceLock<PathBuf> = OnceLock::new();
    let dir = CACHE.get_or_init(|| {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("motionlab-cache");
        // A missing folder is the normal first run; any other failure shows in the tests.
        let _ = std::fs::remove_dir_all(&dir);
        dir
    });
    let mut c = Command::new(env!("CARGO_BIN_EXE_motionlab"));
    c.env("MOTIONLAB_CACHE_DIR", dir);
    c
}
