//! # motionlab-experiment
//!
//! The contract between the engine and the workflows, free of polars and plotters:
//!
//! - [`spec`]: the experiment file's schema (datasets, preprocessors, evaluators, sweeps,
//!   published numbers); the workflow section is left to the workflow.
//! - [`toml_paths`]: key paths (`segmentation.segmenter[speed].v_low`), overrides, and the line
//!   a key is written on.
//! - [`context`]: what a workflow is given — the [`Source`] that locates errors at file, line
//!   and key path, the sweep [`Combo`], the [`Datasets`] that load an input.
//! - [`segmenters`]: segmenters as an experiment names them, checked against what the datasets
//!   give (positions or channels), with the features a channel segmenter reads on a take.
//! - [`workflow`]: the [`Workflow`] trait, its registry ([`register_workflow!`]) and what a
//!   workflow returns: tables ([`motionlab_core::Table`]), figure specs
//!   ([`motionlab_figure::Figure`]) and named files.
//!
//! The engine (`motionlab-engine`) plans, runs, shards and records; the built-in workflows live
//! in `motionlab-workflows`; a researcher's own workflow is one file in their own crate.

pub mod context;
pub mod labellers;
pub mod run_cache;
pub mod segmenters;
pub mod spec;
pub mod toml_paths;
pub mod workflow;

pub use context::{
    At, BuiltDataset, Combo, Datasets, LoadedItem, Source, build_stage, deserialize_section,
};
pub use run_cache::{Origin, RunCache};
pub use workflow::{
    BuildContext, ComboOutput, ItemData, ItemOutput, Locator, Output, WorkItem, Workflow,
    WorkflowEntry, WorkflowPlugin, build_named_stages,
};

// Re-exported for `register_workflow!`.
pub use inventory;
pub use motionlab_figure as figure;
