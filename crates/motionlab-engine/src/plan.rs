//! Parsing and validating an experiment before any work (nextest-style: every file, plugin and
//! parameter is checked first, so a typo fails in milliseconds, not after an hour).
//!
//! Steps: read the TOML (syntax errors with line) → apply `a.b=c` overrides → deserialise the
//! schema (unknown keys and wrong types named by key path and line) → expand the sweep into
//! combinations → for each combination build every plugin (parameter errors named by key path
//! and line) and resolve every input file.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use motionlab_core::registry;
use motionlab_core::{Error, ErrorKind, Location, Result};
use motionlab_experiment::RunCache;
use motionlab_experiment::spec::{ExperimentFile, SweepGrid};
use motionlab_experiment::toml_paths::{KeyPath, parse_override, set_path, syntax_error_line};
use motionlab_experiment::workflow::{self, Workflow, WorkflowEntry};

// What workflows are given, defined beside the Workflow trait (polars-free).
pub use motionlab_experiment::context::{
    BuiltDataset, Combo, Datasets, LoadedItem, Source, build_stage, deserialize_section,
};

/// A validated experiment: every combination with its workflow built.
pub struct Plan {
    pub source: Source,
    pub overrides: Vec<String>,
    /// The document after overrides (before sweeping).
    pub doc: toml::Table,
    pub file: ExperimentFile,
    /// The registered workflow whose section the experiment has.
    pub workflow: &'static WorkflowEntry,
    pub combos: Vec<Combo>,
    pub built: Vec<BuiltCombo>,
    /// Shared by every combination's datasets: each input is loaded once per run.
    pub cache: Arc<RunCache>,
}

/// One combination's built stages.
pub struct BuiltCombo {
    pub data: Datasets,
    pub workflow: Box<dyn Workflow>,
}

impl Plan {
    /// Every input file of every combination, deduplicated (for provenance hashes).
    pub fn input_files(&self) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = self
            .built
            .iter()
            .flat_map(|b| {
                b.data.datasets.iter().flat_map(|d| {
                    d.files
                        .iter()
                        .cloned()
                        .chain((0..d.files.len()).filter_map(|k| d.ground_truth_path(k)))
                })
            })
            .collect();
        v.sort();
        v.dedup();
        v
    }
}

/// Reads, overrides, deserialises and validates an experiment.
pub fn plan(path: &Path, overrides: &[String]) -> Result<Plan> {
    let source = Source::read(path)?;
    let ParsedExperiment { doc, file, workflow, combos } = parse_experiment(&source, overrides)?;
    let mut built = Vec::with_capacity(combos.len());
    let cache = Arc::new(RunCache::default());
    for combo in &combos {
        let data = build_datasets(&source, combo, Inputs::Resolve, &cache)?;
        let built_workflow = workflow::build(workflow, &source, combo, &data)?;
        built.push(BuiltCombo { data, workflow: built_workflow });
    }
    Ok(Plan { source, overrides: overrides.to_vec(), doc, file, workflow, combos, built, cache })
}

/// An experiment parsed, overridden, deserialised and expanded over its sweep, with no plugin
/// built and no input file touched.
pub struct ParsedExperiment {
    /// The document after overrides (before sweeping).
    pub doc: toml::Table,
    pub file: ExperimentFile,
    pub workflow: &'static WorkflowEntry,
    pub combos: Vec<Combo>,
}

/// The in-memory first half of [`plan`]: TOML syntax → overrides → schema → experiment name →
/// sweep expansion, on text already read. Separate so it can be fuzzed
/// (`fuzz/fuzz_targets/experiment_toml.rs`) without a file system.
pub fn parse_experiment(source: &Source, overrides: &[String]) -> Result<ParsedExperiment> {
    let mut doc: toml::Table = toml::from_str(&source.text).map_err(|e| {
        let mut loc = Location::file(&source.path);
        if let Some(l) = syntax_error_line(&source.text, &e) {
            loc = loc.line(l);
        }
        Error::new(ErrorKind::Syntax, e.message().trim().to_string()).with_location(loc)
    })?;
    for o in overrides {
        // An override is not written in the file, so its errors name the file but no line.
        let (p, v) =
            parse_override(o).map_err(|e| e.with_location(Location::file(&source.path)))?;
        set_path(&mut doc, &p, v).map_err(|e| {
            Error::new(e.kind(), format!("override {o:?}: {}", e.message()))
                .with_location(Location::file(&source.path).field(p.to_string()))
        })?;
    }
    let file = deserialize_file(source, &doc)?;
    let workflow = workflow::find_workflow(&file.workflow).ok_or_else(|| {
        Error::new(ErrorKind::UnknownKey, format!("no workflow {:?}", file.workflow))
    })?;
    check_name(source, &file)?;
    let combos = expand_sweep(source, &doc, &file)?;
    Ok(ParsedExperiment { doc, file, workflow, combos })
}

/// Builds every stage of one combination — loaders, ground-truth readers, preprocessors and
/// the workflow's own stages — through the registry, as [`plan`] does, but resolves no input
/// file (datasets get no files). For the experiment fuzz target.
pub fn build_stages_in_memory(
    source: &Source,
    workflow: &WorkflowEntry,
    combo: &Combo,
) -> Result<()> {
    let data = build_datasets(source, combo, Inputs::Skip, &Arc::new(RunCache::default()))?;
    workflow::build(workflow, source, combo, &data).map(|_| ())
}

/// The fixed part of the schema, and the one workflow section checked against the registered
/// workflows (which parse their sections themselves when they are built).
fn deserialize_file(source: &Source, doc: &toml::Table) -> Result<ExperimentFile> {
    let workflow = workflow::workflow_section(source, doc)?;
    let fixed = ExperimentFile::fixed_part(doc);
    let mut file: ExperimentFile =
        deserialize_section(source, doc, toml::Value::Table(fixed), &KeyPath::default())?;
    file.workflow = workflow.name.to_string();
    Ok(file)
}

/// The longest experiment name, in characters.
pub const MAX_EXPERIMENT_NAME: usize = 100;

fn check_name(source: &Source, file: &ExperimentFile) -> Result<()> {
    let n = &file.experiment.name;
    // It names the run's folder (`reports/<name>/`): nothing there may climb out or hide.
    if n.is_empty()
        || n.len() > MAX_EXPERIMENT_NAME
        || !n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        let doc = toml::Table::new();
        return Err(source.locate(
            Error::new(ErrorKind::OutOfRange, format!("experiment name {n:?} must be 1 to {MAX_EXPERIMENT_NAME} letters, digits, _ or -")),
            &KeyPath::parse("experiment.name")?,
            &doc,
        ));
    }
    Ok(())
}

/// The most combinations a sweep may have (each one is a full run of the experiment).
pub const MAX_SWEEP_COMBINATIONS: usize = 10_000;

fn expand_sweep(source: &Source, doc: &toml::Table, file: &ExperimentFile) -> Result<Vec<Combo>> {
    let Some(sweep) = &file.sweep else {
        return Ok(vec![Combo {
            index: 0,
            sweep: None,
            focus: None,
            params: vec![],
            doc: doc.clone(),
            file: file.clone(),
        }]);
    };
    let grids = sweep.grids();
    // Counted before expanding: 20 keys of 3 values are 3.5e9 combinations, which would
    // exhaust memory in `cartesian` long before any work started.
    let count = grids
        .iter()
        .map(|g| g.grid.values().try_fold(1usize, |n, v| n.checked_mul(v.len())))
        .try_fold(0usize, |total, n| total.checked_add(n?));
    if count.is_none_or(|n| n > MAX_SWEEP_COMBINATIONS) {
        let n = count.map_or_else(|| "more than 2^64".to_string(), |n| n.to_string());
        return Err(source.locate(
            Error::new(
                ErrorKind::OutOfRange,
                format!("the sweep has {n} combinations; expected at most {MAX_SWEEP_COMBINATIONS} (split it into several experiments)"),
            ),
            &KeyPath::parse("sweep")?,
            doc,
        ));
    }
    let mut base = doc.clone();
    base.remove("sweep");
    let mut combos = Vec::new();
    for (g, grid) in grids.iter().enumerate() {
        let name = grid.name.clone().unwrap_or_else(|| format!("sweep{g}"));
        for assignment in cartesian(grid) {
            let mut d = base.clone();
            for (k, v) in &assignment {
                // A malformed grid key (`"dataset[0.files"`) is located at the sweep: the key
                // path itself has no place in the file to point at.
                let p = KeyPath::parse(k).map_err(|e| {
                    let sweep_path = KeyPath::parse("sweep").unwrap_or_default();
                    source.locate(e, &sweep_path, doc)
                })?;
                set_path(&mut d, &p, v.clone()).map_err(|e| {
                    let sweep_path = KeyPath::parse("sweep").unwrap_or_default();
                    source.locate(e, &sweep_path, doc)
                })?;
            }
            let f = deserialize_file(source, &d)?;
            combos.push(Combo {
                index: combos.len(),
                sweep: Some(name.clone()),
                focus: grid.focus.clone(),
                params: assignment,
                doc: d,
                file: f,
            });
        }
    }
    if combos.is_empty() {
        return Err(Error::new(
            ErrorKind::EmptySequence,
            "the sweep has no combinations (an empty value list?)",
        )
        .with_location(Location::file(&source.path).field("sweep")));
    }
    Ok(combos)
}

/// Every combination of a grid's values, keys in sorted order.
fn cartesian(grid: &SweepGrid) -> Vec<Vec<(String, toml::Value)>> {
    let mut out: Vec<Vec<(String, toml::Value)>> = vec![vec![]];
    for (k, values) in &grid.grid {
        out = out
            .into_iter()
            .flat_map(|prefix| {
                values.iter().map(move |v| {
                    let mut p = prefix.clone();
                    p.push((k.clone(), v.clone()));
                    p
                })
            })
            .collect();
    }
    out
}

/// Whether [`build_datasets`] resolves the input files (globs, existence) or leaves them out.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Inputs {
    Resolve,
    Skip,
}

fn build_datasets(
    source: &Source,
    combo: &Combo,
    inputs: Inputs,
    cache: &Arc<RunCache>,
) -> Result<Datasets> {
    let base = source.base_dir();
    let mut datasets = Vec::new();
    let root = KeyPath::parse("dataset")?;
    if combo.file.datasets.is_empty() {
        return Err(source.locate(
            Error::new(ErrorKind::MissingKey, "at least one [[dataset]] is required"),
            &root,
            &combo.doc,
        ));
    }
    for (i, spec) in combo.file.datasets.iter().enumerate() {
        let dp = root.index(i);
        let loader =
            build_stage(source, combo, &spec.loader, &dp.key("loader"), registry::build_loader)?;
        let ground_truth = match &spec.ground_truth {
            None => None,
            Some(gt) => {
                let gp = dp.key("ground_truth");
                let file = match gt.params.get("file") {
                    Some(toml::Value::String(f)) => base.join(f),
                    _ => {
                        return Err(source.locate(
                            Error::new(
                                ErrorKind::MissingKey,
                                "ground_truth needs `file = \"<path>\"`",
                            ),
                            &gp,
                            &combo.doc,
                        ));
                    }
                };
                let mut params = gt.clone();
                params.params.remove("file");
                let reader =
                    build_stage(source, combo, &params, &gp, registry::build_ground_truth)?;
                Some((reader, file))
            }
        };
        let preprocess = spec
            .preprocess
            .iter()
            .enumerate()
            .map(|(k, p)| {
                build_stage(
                    source,
                    combo,
                    p,
                    &dp.key("preprocess").index(k),
                    registry::build_preprocessor,
                )
            })
            .collect::<Result<Vec<_>>>()?;
        let files = match inputs {
            Inputs::Resolve => resolve_files(source, &base, &spec.files, loader.reads_folders())
                .map_err(|e| source.locate(e, dp.key("files"), &combo.doc))?,
            Inputs::Skip => Vec::new(),
        };
        let built =
            BuiltDataset { index: i, spec: spec.clone(), loader, ground_truth, preprocess, files };
        for k in 0..built.files.len() {
            if let Some(gt) = built.ground_truth_path(k)
                && !gt.is_file()
            {
                return Err(source.locate(
                    Error::new(
                        ErrorKind::Io,
                        format!("ground-truth file {} does not exist", gt.display()),
                    ),
                    dp.key("ground_truth").key("file"),
                    &combo.doc,
                ));
            }
        }
        datasets.push(built);
    }
    let preprocess = combo
        .file
        .preprocess
        .iter()
        .enumerate()
        .map(|(k, p)| {
            build_stage(
                source,
                combo,
                p,
                &KeyPath::parse("preprocess")?.index(k),
                registry::build_preprocessor,
            )
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Datasets::new(datasets, preprocess, combo.file.preprocess.clone(), Arc::clone(cache)))
}

/// The files the patterns name — or, for a loader that reads a folder per motion (OpenPose's
/// per-frame JSON), the folders.
fn resolve_files(
    _source: &Source,
    base: &Path,
    patterns: &[String],
    folders: bool,
) -> Result<Vec<PathBuf>> {
    let wanted = |f: &Path| if folders { f.is_dir() } else { f.is_file() };
    if patterns.is_empty() {
        return Err(Error::new(ErrorKind::MissingKey, "files = [] lists no file"));
    }
    let mut out = Vec::new();
    for p in patterns {
        let full = base.join(p);
        let text = full.to_string_lossy().into_owned();
        if p.contains(['*', '?', '[']) {
            let matches: Vec<PathBuf> = glob::glob(&text)
                .map_err(|e| Error::new(ErrorKind::Syntax, format!("bad glob {p:?}: {e}")))?
                .filter_map(|r| r.ok())
                .filter(|f| wanted(f))
                .collect();
            if matches.is_empty() {
                return Err(Error::new(
                    ErrorKind::Io,
                    format!(
                        "glob {p:?} matches no {} (relative to {})",
                        if folders { "folder" } else { "file" },
                        base.display()
                    ),
                ));
            }
            out.extend(matches);
        } else if wanted(&full) {
            out.push(full);
        } else {
            return Err(Error::new(
                ErrorKind::Io,
                format!(
                    "{} does not exist (paths are relative to the experiment file's folder)",
                    full.display()
                ),
            ));
        }
    }
    out.sort();
    out.dedup();
    Ok(out)
}
