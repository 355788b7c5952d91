//! motionlab-cli's integration tests: one test binary, one module per file of this folder.
//!
//! One binary rather than one per file: each binary links the whole of motionlab with polars
//! and plotters: eleven of them were 2.3 % of a cold `cargo test --workspace --no-run`
//! (`--timings`, README's performance table). A test's full name starts with its file's name, so
//! one file's tests still run alone: `cargo test -p motionlab-cli --test integration gait::`.
//! A new file here is one `mod` line below (CONTRIBUTING.md, "Tests").

mod cache;
mod cli;
mod data_manifest;
mod gait;
mod malformed;
mod matching;
mod missing_data;
mod own_annotations;
mod registry;
mod retrieval;
mod safe_outputs;
mod sharding;
mod viewer;
