//! # motionlab-engine
//!
//! Experiments as data: a TOML file ([`spec`]) is parsed and validated in full before any work
//! ([`plan`]: every file, plugin and parameter, with errors naming the file, line and key
//! path), expanded over its `[sweep]` grid, and run as a map–reduce of work items
//! ([`workflows`], [`run`]) into a fresh run directory ([`rundir`]) with provenance.
//!
//! Depends on no polars or plotters directly: tables and figures go through
//! `motionlab-report`. Workflows call algorithm crates by name where a paper's analysis is more
//! than one plugin (the gait study, the BVH writer); stages come from the registry.

pub mod compare;
pub mod pages;
pub mod plan;
pub mod run;
pub mod rundir;
pub mod spec;
pub mod toml_paths;
pub mod workflows;

pub use plan::{plan, Plan};
pub use run::{merge, run, run_file, Progress, RunOptions, RunSummary, Silent};
