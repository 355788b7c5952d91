//! The `[matching]` workflow (Yabe & Tanaka) — being built.

use motionlab_core::{Error, ErrorKind, Result};

use super::Workflow;
use crate::plan::{Combo, Datasets, Source};

pub fn build(source: &Source, _combo: &Combo, _data: &Datasets) -> Result<Box<dyn Workflow>> {
    Err(Error::new(ErrorKind::UnknownPlugin, "the [matching] workflow is not available in this build")
        .with_location(motionlab_core::Location::file(&source.path).field("matching")))
}
