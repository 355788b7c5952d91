//! Ground-truth readers: human segment labels into one [`motionlab_core::Segmentation`]
//! (boundaries and labelled segments in frames at the motion's own rate).
//!
//! - [`cmu86`] — `cmu86_labels`: the CMU subject-86 label file of Zhou, De la Torre & Hodgins
//!   (`mocap.txt`), boundaries with annotated transition windows.
//! - [`mocap6`] — `mocap6_labels`: the mocap6 block labels of Fox, Hughes, Sudderth & Jordan
//!   (one action number per 12-frame block).
//!
//! - [`boundaries_csv`] and [`elan_eaf`] — the formats users keep their own annotations in (a
//!   CSV of boundaries or segments; ELAN `.eaf` tiers), parsed into per-annotator
//!   [`annotations::AnnotatorTrack`]s and turned into boundaries by one rule
//!   ([`annotations`]). Their ground-truth plugins live in `motionlab-eval`, beside the
//!   annotator consensus they can apply.
//!
//! - [`tiers`] — labelled boundary tiers (per annotator or per method) and the file a
//!   segmentation run keeps them in; `boundaries_csv` and `elan_eaf` write them back out.
//!
//! The two dataset formats are a few lines of whitespace-separated words, parsed by hand (no
//! crate reads them); CSV is read with the `csv` crate and EAF XML with `roxmltree`. Errors
//! name the file and line (and the column or attribute).

pub mod annotations;
pub mod boundaries_csv;
pub mod cmu86;
pub mod elan_eaf;
pub mod mocap6;
pub mod tiers;
pub mod tssb_desc;
