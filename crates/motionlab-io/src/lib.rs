//! # motionlab-io
//!
//! One file per format family; each loader is a registered plugin. Text formats are read
//! through [`read::read_text`], so a `.gz` file works wherever the plain file does.
//!
//! No sound crate exists for BVH or ASF/AMC (bvh_anim is abandoned with unsound
//! dependencies), so both are written here. Video pose estimation (OpenPose, COCO keypoints,
//! MediaPipe) loads as 2-D motions (`pose` holds what those loaders share); Xsens MVNX as segment
//! positions with orientation and joint-angle channels.

/// How many plugins this crate registers: the registry test (`tests/registry.rs`) checks the
/// binary holds exactly this many from this crate, so a plugin that silently vanishes (a
/// missing `mod` line, a crate left unlinked) fails it. Adding a plugin means counting it here.
pub const PLUGIN_COUNT: usize = 14;

pub mod read;

pub mod asf_amc;
pub mod bvh;
pub mod c3d;
pub mod channel_file;
pub mod coco_keypoints;
pub mod labels;
pub mod mediapipe;
pub mod mot;
pub mod mvnx;
pub mod openpose;
pub mod pose;
pub mod qualisys_tsv;
pub mod scores_csv;
mod text;
pub mod trc;
