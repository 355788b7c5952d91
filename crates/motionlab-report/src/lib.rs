//! # motionlab-report
//!
//! The only crate that knows polars and plotters: result [`Table`](motionlab_core::Table)s
//! become Polars DataFrames written as CSV, Parquet and Markdown ([`tables`]); figure specs
//! become PNG and SVG ([`figures`]); viewer specs become interactive pages ([`viewer`]).
//!
//! The engine hands a workflow's whole output to one entry point, [`output::write`], and
//! writes a finished run's page, a run of record and the reproduction index through
//! [`pages`]; it knows runs, items, shards and provenance, not what a run's output holds.

pub mod figures;
pub mod fonts;
pub mod html;
pub mod output;
pub mod pages;
pub mod tables;
pub mod viewer;

pub use figures::{
    BarRow, Chart, Figure, FigureKind, Pose, RefLine, Series, StickRow, StickStrip, TimelinePoses,
};
pub use tables::{WrittenTable, to_dataframe, write_table};
