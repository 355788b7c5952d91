//! # motionlab-engine
//!
//! Experiments as data: a TOML file is parsed and validated in full before any work ([`plan`]:
//! every file, plugin and parameter, with errors naming the file, line and key path), expanded
//! over its `[sweep]` grid, and run as a map–reduce of work items ([`run`]), sharded or not,
//! into a fresh run directory ([`rundir`]) with its provenance; [`compare`] diffs two runs.
//! No program an experiment names starts without the user's consent ([`consent`]). What every
//! front end does alike (run options, validation, loader choice, `list`/`describe`, progress
//! bars) is here too ([`front`], [`describe`], [`progress`]), so the CLI and the Python package
//! only translate their arguments.
//!
//! It knows no workflow: the experiment's workflow section names a registered
//! [`Workflow`](motionlab_experiment::Workflow) plugin (`motionlab-experiment` holds the trait
//! and the schema; the built-in workflows are in `motionlab-workflows`). What a workflow returns
//! is handed whole to `motionlab-report` ([`motionlab_report::output::write`]), which also
//! writes the run's page, runs of record and the reproduction index
//! ([`motionlab_report::pages`]); the engine depends on no polars or plotters directly.

pub mod compare;
pub mod consent;
pub mod describe;
pub mod front;
pub mod plan;
pub mod progress;
pub mod run;
pub mod rundir;

// The schema and key paths live beside the Workflow trait; re-exported under their old paths.
pub use motionlab_experiment::{spec, toml_paths, workflow as workflows};

pub use plan::{Plan, plan};
pub use run::{Progress, RunOptions, RunSummary, Silent, merge, run, run_file};
