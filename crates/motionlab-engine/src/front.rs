//! What every front end does the same way — the `motionlab` command and the Python package:
//! the options of a run, an experiment's validation, the loader a file's extension picks.
//! Front ends only translate their own arguments into these and print or return the results.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use motionlab_core::registry::{self, Build, StageKind};
use motionlab_core::{Error, ErrorKind, Loader, Result};

use crate::consent::{self, ExternalCommand, ExternalPolicy, TrustStore};
use crate::{Progress, RunOptions, Silent};

/// A run's options as a user states them (`motionlab run`'s flags, `motionlab.run`'s keyword
/// arguments).
#[derive(Clone, Debug)]
pub struct RunChoices {
    /// Folder holding `<experiment>/<run-id>/`.
    pub reports: PathBuf,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// No progress bars (there are none anyway unless stderr is a terminal).
    pub quiet: bool,
    /// Neither read nor write the on-disk cache.
    pub no_cache: bool,
    /// Allow the programs the experiment names, for this run only.
    pub allow_external: bool,
}

impl Default for RunChoices {
    fn default() -> Self {
        RunChoices {
            reports: PathBuf::from("reports"),
            threads: None,
            quiet: false,
            no_cache: false,
            allow_external: false,
        }
    }
}

impl RunChoices {
    /// The engine's options: progress bars on stderr when it is a terminal and not `quiet`, the
    /// default cache unless `no_cache`, consent from `allow_external` or the user's trust
    /// records; `command` is recorded in the run's provenance.
    pub fn options(&self, command: Vec<String>) -> RunOptions {
        let progress: Arc<dyn Progress> = if !self.quiet && std::io::stderr().is_terminal() {
            Arc::new(crate::progress::Bars::default())
        } else {
            Arc::new(Silent)
        };
        RunOptions {
            reports_dir: self.reports.clone(),
            threads: self.threads,
            progress,
            command,
            cache: if self.no_cache { None } else { motionlab_cache::Cache::open_default() },
            external: external_policy(self.allow_external),
            ..Default::default()
        }
    }
}

/// Consent for the programs an experiment names: `allow_external`, else the user's trust
/// records (`motionlab trust`).
pub fn external_policy(allow_external: bool) -> ExternalPolicy {
    ExternalPolicy { allow_external, trust: TrustStore::open_default() }
}

/// What `validate` found: the experiment is valid, these are its sizes and the programs it
/// names, allowed as `consent` says.
#[derive(Clone, Debug)]
pub struct Validation {
    pub workflow: String,
    pub datasets: usize,
    pub input_files: usize,
    pub combinations: usize,
    pub items: usize,
    pub external: Vec<ExternalCommand>,
    /// How the external programs are allowed (`no external program`, `allowed by
    /// --allow-external`, …).
    pub consent: String,
}

/// Checks every file, plugin and parameter of an experiment without running it, and that the
/// programs it names are allowed (an error unless `allow_external` or a trust record).
pub fn validate(
    experiment: &Path,
    overrides: &[String],
    allow_external: bool,
) -> Result<Validation> {
    let plan = crate::plan(experiment, overrides)?;
    let external = consent::external_commands(&plan);
    let consent = consent::check(&plan.source.path, &external, &external_policy(allow_external))?;
    Ok(Validation {
        workflow: plan.workflow.name.to_string(),
        datasets: plan.file.datasets.len(),
        input_files: plan.input_files().len(),
        combinations: plan.combos.len(),
        items: plan.built.iter().map(|b| b.workflow.items(&b.data).len()).sum(),
        external,
        consent: consent.describe(),
    })
}

/// The loader registered for a file's extension, at its default parameters.
/// A folder is read by the loader that reads folders (OpenPose's per-frame JSON).
pub fn loader_for(path: &Path) -> Result<(&'static str, Box<dyn Loader>)> {
    let ext = motionlab_core::paths::format_extension(path).unwrap_or_default();
    let folder = path.is_dir();
    let mut known = Vec::new();
    for p in registry::plugins().into_iter().filter(|p| p.kind == StageKind::Loader) {
        if let Build::Loader(build) = p.build {
            let loader = build(&registry::default_params())?;
            if (folder && loader.reads_folders())
                || (!folder && loader.extensions().contains(&ext.as_str()))
            {
                return Ok((p.name, loader));
            }
            known.extend(loader.extensions().iter().map(|e| e.to_string()));
        }
    }
    Err(Error::new(
        ErrorKind::UnknownPlugin,
        format!("no loader reads .{ext} files (known: {})", known.join(", ")),
    )
    .with_location(motionlab_core::Location::file(path)))
}
