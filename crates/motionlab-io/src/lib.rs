//! # motionlab-io
//!
//! One file per format family; each loader is a registered plugin. Text formats are read
//! through [`read::read_text`], so a `.gz` file works wherever the plain file does.
//!
//! No sound crate exists for BVH or ASF/AMC (bvh_anim is abandoned with unsound
//! dependencies), so both are written here.

pub mod read;

pub mod asf_amc;
pub mod bvh;
pub mod labels;
mod text;
pub mod c3d;
pub mod qualisys_tsv;
