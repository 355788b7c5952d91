//! # motionlab-core
//!
//! The data model every other motionlab crate shares:
//!
//! - [`Motion`]: frame rate, point (marker/joint) positions in mm with an explicit up axis, a
//!   per-sample missing mask, events, and — for skeleton formats — the hierarchy with per-frame
//!   channel values and local rotations ([`skeleton`]).
//! - [`Segmentation`]: ground-truth boundaries and labelled segments, in frames.
//! - [`units`]: [`FrameRate`], [`TimeSpan`] (frames *or* seconds), [`Millimetres`], … so units
//!   are visible in types.
//! - [`Table`]: the column table results travel in (polars stays out of algorithm crates).
//! - [`Error`]: one error type whose message names the file and line/field and what was expected.
//! - [`stage`] and [`registry`]: the stage traits and the `inventory`-based plugin registry;
//!   [`streaming`]: segmenters that decide boundaries as samples arrive.
//! - [`limits`] and [`programs`]: how much of an input is read, and which external programs
//!   may be started (docs/security.md).
//!
//! It depends on no polars, plotters, clap or indicatif.

pub mod channels;
pub mod error;
pub mod limits;
pub mod motion;
pub mod paths;
pub mod programs;
pub mod registry;
pub mod segmentation;
pub mod skeleton;
pub mod stage;
pub mod streaming;
pub mod table;
pub mod units;
pub mod viewer;

pub use channels::Channels;
pub use error::{Error, ErrorKind, Location, Result};
pub use motion::{Dimensionality, Event, LoadNotes, Motion, Point3, PointKind};
pub use registry::{ParamGuard, StageKind};
pub use segmentation::{Boundary, Segment, Segmentation, Transition};
pub use skeleton::{ChannelKind, ForwardKinematics, Joint, Skeleton, SkeletonMotion};
pub use stage::*;
pub use streaming::{Decision, SegmenterSession, StreamLayout, Streamed, StreamingSegmenter};
pub use table::{Column, ColumnValues, Table};
pub use units::{
    Axis, CubicMillimetres, Degrees, FrameRate, LengthUnit, Millimetres, MillimetresPerSecond,
    Seconds, TimeSpan,
};

// Re-exported for `register_plugin!` and for plugin crates' params structs.
pub use inventory;
pub use schemars;
pub use serde;
pub use toml;
