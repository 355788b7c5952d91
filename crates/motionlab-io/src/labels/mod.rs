//! Ground-truth readers: human segment labels into one [`motionlab_core::Segmentation`]
//! (boundaries and labelled segments in frames at the motion's own rate).
//!
//! - [`cmu86`] — `cmu86_labels`: the CMU subject-86 label file of Zhou, De la Torre & Hodgins
//!   (`mocap.txt`), boundaries with annotated transition windows.
//! - [`mocap6`] — `mocap6_labels`: the mocap6 block labels of Fox, Hughes, Sudderth & Jordan
//!   (one action number per 12-frame block).
//!
//! Both formats are a few lines of whitespace-separated words, parsed by hand (no crate reads
//! them); errors name the file and line.

pub mod cmu86;
pub mod mocap6;
