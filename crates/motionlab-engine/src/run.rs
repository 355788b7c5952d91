//! Running a plan: items in parallel (rayon), item results persisted under `items/`, then
//! `finish` per sweep combination, `summarize` across them, every output handed to
//! `motionlab-report` to write ([`motionlab_report::output::write`]), and the run's provenance.
//!
//! A sharded run (`--shard i/n --run-dir DIR`) computes only the items `k ≡ i (mod n)` of the
//! deterministic item list and writes `shards/shard-i-of-n.json`; `merge` then finishes from
//! the persisted items exactly as a single-machine run does.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Instant, SystemTime};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use motionlab_core::{ColumnValues, Error, ErrorKind, Location, Result, Table};
use motionlab_report::output::{FileLists, Written};
use motionlab_report::pages::write_run_html;

use crate::consent::{self, Consent, ExternalCommand, ExternalPolicy};
use crate::plan::{Plan, plan};
use crate::rundir::{RunDir, sha256_bytes, utc_iso, write_atomic};
use motionlab_experiment::workflow::{ComboOutput, ItemData, Output, WorkItem};

/// Progress reporting, implemented by the CLI (indicatif) or silent.
pub trait Progress: Send + Sync {
    fn begin(&self, _label: &str, _total: u64) {}
    fn advance(&self, _message: &str) {}
    fn end(&self) {}
}

/// No progress output.
pub struct Silent;
impl Progress for Silent {}

/// How to run.
#[derive(Clone)]
pub struct RunOptions {
    /// Folder holding `<experiment>/<run-id>/` (default `reports`).
    pub reports_dir: PathBuf,
    /// Worker threads for items (default: rayon's default, all cores).
    pub threads: Option<usize>,
    /// `(i, n)`: compute only shard i of n into `run_dir`.
    pub shard: Option<(usize, usize)>,
    /// Shared run directory for sharded runs.
    pub run_dir: Option<PathBuf>,
    pub progress: Arc<dyn Progress>,
    /// The command line, for provenance.
    pub command: Vec<String>,
    /// The on-disk cache of loaded inputs and stage outputs (`None`: compute everything; each
    /// input is still loaded once per run).
    pub cache: Option<motionlab_cache::Cache>,
    /// Whether the programs an experiment names may start (`--allow-external`, trust records).
    pub external: ExternalPolicy,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            reports_dir: PathBuf::from("reports"),
            threads: None,
            shard: None,
            run_dir: None,
            progress: Arc::new(Silent),
            command: std::env::args().collect(),
            cache: None,
            external: ExternalPolicy::default(),
        }
    }
}

/// What a run produced.
#[derive(Clone, Debug)]
pub struct RunSummary {
    pub run_dir: PathBuf,
    /// Everything its items and combinations wrote (paths relative to `run_dir`).
    pub written: Written,
    pub items: usize,
    /// False for a shard that still awaits `merge`.
    pub complete: bool,
}

#[derive(Serialize, Deserialize)]
struct RunManifest {
    experiment_file: PathBuf,
    overrides: Vec<String>,
    config_sha256: String,
    total_items: usize,
}

#[derive(Serialize, Deserialize)]
struct ShardManifest {
    shard: usize,
    shards: usize,
    config_sha256: String,
    items: Vec<(usize, String)>,
    finished_utc: String,
    /// What the loader repaired in the inputs this shard loaded, for the merged provenance.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    load_repairs: std::collections::BTreeMap<PathBuf, Vec<String>>,
}

#[derive(Serialize)]
struct InputFile {
    path: String,
    bytes: u64,
    sha256: String,
    /// What the loader repaired to read it (`LoadNotes::repairs`), when anything.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    load_repairs: Vec<String>,
}

#[derive(Serialize)]
struct Provenance {
    motionlab_version: &'static str,
    git_revision: String,
    git_dirty: Option<bool>,
    experiment: String,
    experiment_file: String,
    overrides: Vec<String>,
    config_sha256: String,
    command: Vec<String>,
    started_utc: String,
    finished_utc: String,
    duration_s: f64,
    threads: usize,
    shards: Option<usize>,
    combinations: Vec<String>,
    items: usize,
    inputs: Vec<InputFile>,
    /// What the run wrote, as `motionlab-report` lists it.
    #[serde(flatten)]
    outputs: FileLists,
    /// Where each input and cached stage output of each combination came from (`computed`,
    /// `memory`: shared within this run, `disk`: the on-disk cache).
    #[serde(skip_serializing_if = "Option::is_none")]
    cache: Option<serde_json::Value>,
    /// The programs the experiment names, and who allowed them (absent when it names none).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    external_commands: Vec<ExternalCommand>,
    #[serde(skip_serializing_if = "Option::is_none")]
    external_consent: Option<String>,
}

/// Per combination and input, where each logged stage came from (a stage logged twice — the
/// evaluation reloads each input — keeps its first origin unless the second computed it),
/// and the totals.
fn cache_provenance(plan: &Plan, opts: &RunOptions) -> Option<serde_json::Value> {
    use motionlab_experiment::Origin;
    use serde_json::{Map, Value, json};
    let mut rows = Vec::new();
    let mut totals: std::collections::BTreeMap<String, usize> = Default::default();
    for (c, b) in plan.built.iter().enumerate() {
        let mut by_input: Vec<((usize, usize), Map<String, Value>)> = Vec::new();
        for (d, f, stage, origin) in b.data.take_log() {
            let slot = match by_input.iter_mut().position(|(k, _)| *k == (d, f)) {
                Some(i) => &mut by_input[i].1,
                None => {
                    let mut m = Map::new();
                    m.insert("combination".into(), json!(c));
                    m.insert("input".into(), json!(b.data.datasets[d].sequence_name(f)));
                    by_input.push(((d, f), m));
                    &mut by_input.last_mut()?.1
                }
            };
            if slot.contains_key(&stage) && origin != Origin::Computed {
                continue;
            }
            slot.insert(stage, json!(origin));
        }
        by_input.sort_by_key(|(k, _)| *k);
        for (_, m) in &by_input {
            for (_, v) in m.iter().filter(|(k, _)| *k != "combination" && *k != "input") {
                *totals.entry(v.as_str().unwrap_or_default().to_string()).or_default() += 1;
            }
        }
        rows.extend(by_input.into_iter().map(|(_, m)| Value::Object(m)));
    }
    Some(json!({
        "dir": opts.cache.as_ref().map(|c| c.dir().to_string_lossy().into_owned()),
        "loads_from_files": plan.cache.loads(),
        "totals": totals,
        "stages": rows,
    }))
}

/// When a run started, and why it may start the programs its experiment names.
struct Started {
    at: (SystemTime, Instant),
    external_commands: Vec<ExternalCommand>,
    consent: Consent,
}

/// The canonical text of the resolved configuration (hashed to check shards belong together).
pub fn config_text(plan: &Plan) -> String {
    toml::to_string(&plan.doc).unwrap_or_default()
}

/// Plans and runs an experiment file.
pub fn run_file(path: &Path, overrides: &[String], opts: &RunOptions) -> Result<RunSummary> {
    let p = plan(path, overrides)?;
    run(&p, opts)
}

/// Every (combination, item) of a plan, in a deterministic order.
fn all_items(plan: &Plan) -> Vec<(usize, WorkItem)> {
    plan.built
        .iter()
        .enumerate()
        .flat_map(|(c, b)| b.workflow.items(&b.data).into_iter().map(move |i| (c, i)))
        .collect()
}

fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        b = b.num_threads(n.max(1));
    }
    b.build()
        .map_err(|e| Error::new(ErrorKind::Report, format!("cannot start worker threads: {e}")))
}

/// One finished item: its index in the full item list, its combination, the item, its result
/// and what its output wrote.
type DoneItem = (usize, usize, WorkItem, ItemData, Written);

/// Where an item's result and the record of its written output are persisted.
fn item_files(items_dir: &Path, c: usize, item: &WorkItem) -> (PathBuf, PathBuf) {
    let id = motionlab_core::paths::safe_file_name(&item.id);
    (items_dir.join(format!("c{c}-{id}.msgpack")), items_dir.join(format!("c{c}-{id}.output.json")))
}

/// Runs a validated plan.
pub fn run(plan: &Plan, opts: &RunOptions) -> Result<RunSummary> {
    // Consent before anything is written or started.
    let (external_commands, consent) = consent::require(plan, &opts.external)?;
    let started = Started { at: (SystemTime::now(), Instant::now()), external_commands, consent };
    let config = config_text(plan);
    let config_hash = sha256_bytes(config.as_bytes());
    let rundir = match (&opts.shard, &opts.run_dir) {
        (Some(_), Some(dir)) => RunDir::shared(dir)?,
        (Some(_), None) => {
            return Err(Error::new(
                ErrorKind::MissingKey,
                "--shard needs --run-dir (shared by all shards)",
            ));
        }
        (None, Some(dir)) => RunDir::shared(dir)?,
        (None, None) => RunDir::fresh(&opts.reports_dir, &plan.file.experiment.name)?,
    };
    let items = all_items(plan);
    let (shard, shards) = opts.shard.unwrap_or((0, 1));
    if shards == 0 || shard >= shards {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("shard {shard}/{shards}: expected 0 <= i < n"),
        ));
    }
    // The manifest is identical for every shard, so concurrent writers agree.
    let manifest = RunManifest {
        experiment_file: std::fs::canonicalize(&plan.source.path)
            .unwrap_or_else(|_| plan.source.path.clone()),
        overrides: plan.overrides.clone(),
        config_sha256: config_hash.clone(),
        total_items: items.len(),
    };
    write_atomic(&rundir.work.join("run.json"), &json_bytes(&manifest)?)?;
    write_atomic(&rundir.work.join("config.toml"), config.as_bytes())?;
    let mut mine: Vec<(usize, usize, WorkItem)> = items
        .iter()
        .enumerate()
        .filter(|(k, _)| k % shards == shard)
        .map(|(k, (c, i))| (k, *c, i.clone()))
        .collect();
    // By input file, then combination: each take is loaded once and is live for one stretch
    // of the run (threads take contiguous runs of this list), whatever the memory budget.
    mine.sort_by_key(|(k, c, i)| (i.dataset, i.file, *c, *k));
    plan.cache.set_disk(opts.cache.clone());
    let items_dir = rundir.subdir("items")?;
    opts.progress.begin(&format!("{} items", plan.file.experiment.name), mine.len() as u64);
    let pool = thread_pool(opts.threads)?;
    let results: Vec<Result<DoneItem>> = pool.install(|| {
        mine.par_iter()
            .map(|(k, c, item)| {
                let built = &plan.built[*c];
                // Per-item figures are drawn for the base combination only: a sweep would
                // otherwise multiply them by its size.
                let (result, output) = built
                    .workflow
                    .run_item(item, &built.data, *c == 0)
                    .map_err(|e| e.under_field(format!("item {}", item.id)))?
                    .into_parts();
                let (result_path, written_path) = item_files(&items_dir, *c, item);
                write_atomic(&result_path, &result.0)?;
                let written = motionlab_report::output::write(&rundir.work, &output)?;
                write_atomic(&written_path, &json_bytes(&written)?)?;
                opts.progress.advance(&item.id);
                Ok((*k, *c, item.clone(), result, written))
            })
            .collect()
    });
    opts.progress.end();
    let mut done = Vec::with_capacity(results.len());
    for r in results {
        done.push(r?);
    }
    done.sort_by_key(|d| d.0);
    if opts.shard.is_some() {
        let m = ShardManifest {
            shard,
            shards,
            config_sha256: config_hash,
            items: done.iter().map(|d| (d.1, d.2.id.clone())).collect(),
            finished_utc: utc_iso(SystemTime::now()),
            load_repairs: plan.cache.load_repairs(),
        };
        let dir = rundir.subdir("shards")?;
        write_atomic(&dir.join(format!("shard-{shard}-of-{shards}.json")), &json_bytes(&m)?)?;
        let written = Written::concat(done.iter().map(|d| &d.4));
        return Ok(RunSummary {
            run_dir: rundir.target.clone(),
            written,
            items: done.len(),
            complete: false,
        });
    }
    let item_outputs: Vec<(PathBuf, Written)> =
        done.iter().map(|d| (item_files(&items_dir, d.1, &d.2).1, d.4.clone())).collect();
    let by_combo = group_by_combo(plan, done.into_iter().map(|d| (d.1, d.2, d.3)).collect());
    let written = complete(plan, opts, &rundir, &started, None, by_combo, item_outputs)?;
    let target = rundir.finalize()?;
    Ok(RunSummary { run_dir: target, written, items: items.len(), complete: true })
}

/// The end of a run, single-machine or merged from shards: `finish` and `summarize`, their
/// output written, the provenance (every item's files in item order, then the combinations'),
/// and the run page (listing the combinations' output first, then every item's in item-file
/// order).
/// `item_outputs` pairs each item's persisted record of its output with that record's path.
fn complete(
    plan: &Plan,
    opts: &RunOptions,
    rundir: &RunDir,
    started: &Started,
    shards: Option<usize>,
    by_combo: Vec<Vec<(WorkItem, ItemData)>>,
    mut item_outputs: Vec<(PathBuf, Written)>,
) -> Result<Written> {
    let total_items = item_outputs.len();
    let finished = finish_all(plan, rundir, by_combo, opts);
    plan.cache.clear_memory();
    let (tables, finished) = finished?;
    let in_item_order = Written::concat(item_outputs.iter().map(|(_, w)| w).chain([&finished]));
    write_provenance(
        plan,
        opts,
        rundir,
        started,
        total_items,
        shards,
        FileLists::of(&in_item_order),
    )?;
    item_outputs.sort_by(|a, b| a.0.cmp(&b.0));
    let page_order: Vec<&Written> =
        [&finished].into_iter().chain(item_outputs.iter().map(|(_, w)| w)).collect();
    let run_id =
        rundir.target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    write_run_html(&rundir.work, &plan.file, &config_text(plan), &tables, &page_order, &run_id)?;
    Ok(in_item_order)
}

fn group_by_combo(
    plan: &Plan,
    done: Vec<(usize, WorkItem, ItemData)>,
) -> Vec<Vec<(WorkItem, ItemData)>> {
    let mut by: Vec<Vec<(WorkItem, ItemData)>> =
        (0..plan.built.len()).map(|_| Vec::new()).collect();
    for (c, i, d) in done {
        by[c].push((i, d));
    }
    // Items in their deterministic order, whatever order threads or shards finished in.
    for (c, v) in by.iter_mut().enumerate() {
        let order: Vec<String> =
            plan.built[c].workflow.items(&plan.built[c].data).into_iter().map(|i| i.id).collect();
        v.sort_by_key(|(i, _)| order.iter().position(|o| *o == i.id).unwrap_or(usize::MAX));
    }
    by
}

/// `finish` per combination, sweep columns, concatenation, `summarize`; then the run's whole
/// output ([`Output::of_run`]) handed to `motionlab-report` to write. Returns the tables (for
/// the run page) and what was written.
fn finish_all(
    plan: &Plan,
    rundir: &RunDir,
    by_combo: Vec<Vec<(WorkItem, ItemData)>>,
    opts: &RunOptions,
) -> Result<(Vec<Table>, Written)> {
    opts.progress.begin("finishing", by_combo.len() as u64);
    let outputs: Vec<Output> = by_combo
        .iter()
        .enumerate()
        .map(|(c, items)| {
            let b = &plan.built[c];
            let o = b.workflow.finish(items, &b.data, c == 0);
            opts.progress.advance(&format!("combination {c}"));
            o
        })
        .collect::<Result<_>>()?;
    opts.progress.end();
    let swept = plan.file.sweep.is_some();
    let mut tables: Vec<Table> = Vec::new();
    for (c, out) in outputs.iter().enumerate() {
        for t in &out.tables {
            let t = if swept { with_sweep_columns(t.clone(), &plan.combos[c])? } else { t.clone() };
            match tables.iter_mut().find(|x| x.name == t.name) {
                Some(existing) => existing.append(t)?,
                None => tables.push(t),
            }
        }
    }
    let combos: Vec<ComboOutput<'_>> = outputs
        .iter()
        .enumerate()
        .map(|(c, o)| ComboOutput { combo: &plan.combos[c], output: o })
        .collect();
    let summary = plan.built[0].workflow.summarize(&combos)?;
    drop(combos);
    let all = Output::of_run(tables, outputs, summary);
    let written = motionlab_report::output::write(&rundir.work, &all)?;
    Ok((all.tables, written))
}

/// Prepends `sweep`, `combination` and `parameters` columns.
fn with_sweep_columns(mut t: Table, combo: &crate::plan::Combo) -> Result<Table> {
    let n = t.n_rows();
    t.columns.insert(
        0,
        motionlab_core::Column {
            name: "parameters".into(),
            values: ColumnValues::Str(vec![Some(combo.label()); n]),
        },
    );
    t.columns.insert(
        0,
        motionlab_core::Column {
            name: "combination".into(),
            values: ColumnValues::I64(vec![combo.index as i64; n]),
        },
    );
    t.columns.insert(
        0,
        motionlab_core::Column {
            name: "sweep".into(),
            values: ColumnValues::Str(vec![combo.sweep.clone(); n]),
        },
    );
    Ok(t)
}

fn write_provenance(
    plan: &Plan,
    opts: &RunOptions,
    rundir: &RunDir,
    started: &Started,
    items: usize,
    shards: Option<usize>,
    outputs: FileLists,
) -> Result<()> {
    // A merged run's items ran in other processes: their cache log is in no one's memory here.
    let cache = if shards.is_none() { cache_provenance(plan, opts) } else { None };
    let repairs = plan.cache.load_repairs();
    let inputs = plan
        .input_files()
        .iter()
        .map(|p| {
            Ok(InputFile {
                path: p.to_string_lossy().into_owned(),
                bytes: std::fs::metadata(p).map(|m| m.len()).unwrap_or(0),
                // The run cache hashed every input already (its keys): read once per run.
                sha256: motionlab_cache::hex(&plan.cache.file_sha256(p)?),
                load_repairs: repairs.get(p).cloned().unwrap_or_default(),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let (git_revision, git_dirty) = git_state(&plan.source.base_dir());
    let prov = Provenance {
        motionlab_version: env!("CARGO_PKG_VERSION"),
        git_revision,
        git_dirty,
        experiment: plan.file.experiment.name.clone(),
        experiment_file: plan.source.path.to_string_lossy().into_owned(),
        overrides: plan.overrides.clone(),
        config_sha256: sha256_bytes(config_text(plan).as_bytes()),
        command: opts.command.clone(),
        started_utc: utc_iso(started.at.0),
        finished_utc: utc_iso(SystemTime::now()),
        duration_s: started.at.1.elapsed().as_secs_f64(),
        threads: opts.threads.unwrap_or_else(rayon::current_num_threads),
        shards,
        combinations: plan.combos.iter().map(|c| c.label()).collect(),
        items,
        inputs,
        outputs,
        cache,
        external_commands: started.external_commands.clone(),
        external_consent: (started.consent != Consent::NotNeeded)
            .then(|| started.consent.describe()),
    };
    write_atomic(&rundir.work.join("provenance.json"), &json_bytes(&prov)?)
}

fn json_bytes<T: Serialize>(v: &T) -> Result<Vec<u8>> {
    serde_json::to_vec_pretty(v)
        .map_err(|e| Error::new(ErrorKind::Report, format!("cannot write JSON: {e}")))
}

/// The git revision of the checkout holding `dir` and whether it has uncommitted changes —
/// outside `reports/`: a `reproduce --record` rewrites the committed runs of record as it goes,
/// which says nothing about the code and configuration that produced the numbers.
fn git_state(dir: &Path) -> (String, Option<bool>) {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(dir)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "HEAD"]) {
        Some(rev) => (
            rev,
            git(&[
                "status",
                "--porcelain",
                "--untracked-files=no",
                "--",
                ":/",
                ":(exclude,top)reports",
            ])
            .map(|s| !s.is_empty()),
        ),
        None => ("unknown (not a git checkout)".into(), None),
    }
}

/// Finishes a sharded run: checks every shard is present and was produced by the same
/// configuration, then finishes exactly as a single-machine run does.
pub fn merge(run_dir: &Path, opts: &RunOptions) -> Result<RunSummary> {
    let at = (SystemTime::now(), Instant::now());
    let loc = |p: &Path| Location::file(p);
    let manifest_path = run_dir.join("run.json");
    let manifest: RunManifest = read_json(&manifest_path)?;
    let plan = plan(&manifest.experiment_file, &manifest.overrides)?;
    // `finish` may run stages again (an evaluation reloads inputs): the same consent as a run.
    let (external_commands, consent) = consent::require(&plan, &opts.external)?;
    let started = Started { at, external_commands, consent };
    let config = config_text(&plan);
    let hash = sha256_bytes(config.as_bytes());
    if hash != manifest.config_sha256 {
        return Err(Error::new(
            ErrorKind::Mismatch,
            format!("the experiment changed since the shards ran (config sha256 {} now, {} then); re-run the shards", &hash[..12], &manifest.config_sha256[..12]),
        )
        .with_location(loc(&manifest.experiment_file)));
    }
    let shard_dir = run_dir.join("shards");
    let mut shard_files: Vec<PathBuf> = std::fs::read_dir(&shard_dir)
        .map_err(|e| Error::io(&shard_dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    shard_files.sort();
    let shards: Vec<ShardManifest> =
        shard_files.iter().map(|p| read_json(p)).collect::<Result<_>>()?;
    let n = shards.first().map(|s| s.shards).ok_or_else(|| {
        Error::new(ErrorKind::Report, "no shard has finished").with_location(loc(&shard_dir))
    })?;
    for (s, p) in shards.iter().zip(&shard_files) {
        if s.config_sha256 != manifest.config_sha256 {
            return Err(Error::new(
                ErrorKind::Mismatch,
                format!(
                    "shard {}/{} was produced by a different configuration (sha256 {} ≠ {})",
                    s.shard,
                    s.shards,
                    &s.config_sha256[..12],
                    &manifest.config_sha256[..12]
                ),
            )
            .with_location(loc(p)));
        }
        if s.shards != n {
            return Err(Error::new(
                ErrorKind::Mismatch,
                format!("shard counts differ: {} and {n}", s.shards),
            )
            .with_location(loc(p)));
        }
    }
    let missing: Vec<usize> = (0..n).filter(|i| !shards.iter().any(|s| s.shard == *i)).collect();
    if !missing.is_empty() {
        return Err(Error::new(
            ErrorKind::Report,
            format!("shard(s) {} of {n} have not finished; run them (`motionlab run … --shard i/{n} --run-dir {}`) before merging", missing.iter().map(|m| m.to_string()).collect::<Vec<_>>().join(", "), run_dir.display()),
        )
        .with_location(loc(&shard_dir)));
    }
    let items = all_items(&plan);
    let items_dir = run_dir.join("items");
    let mut done = Vec::with_capacity(items.len());
    let mut item_outputs = Vec::with_capacity(items.len());
    for (c, item) in items {
        let (result_path, written_path) = item_files(&items_dir, c, &item);
        let bytes = std::fs::read(&result_path).map_err(|e| Error::io(&result_path, e))?;
        item_outputs.push((written_path.clone(), read_json::<Written>(&written_path)?));
        done.push((c, item, ItemData(bytes)));
    }
    let total = done.len();
    for s in &shards {
        for (path, repairs) in &s.load_repairs {
            plan.cache.note_repairs(path, repairs);
        }
    }
    let rundir = RunDir::shared(run_dir)?;
    let by_combo = group_by_combo(&plan, done);
    // The evaluation reloads every input (once, shared by the combinations) and may find its
    // tables on disk, as in a plain run.
    plan.cache.set_disk(opts.cache.clone());
    let written = complete(&plan, opts, &rundir, &started, Some(n), by_combo, item_outputs)?;
    Ok(RunSummary { run_dir: run_dir.to_path_buf(), written, items: total, complete: true })
}

fn read_json<T: for<'de> Deserialize<'de>>(p: &Path) -> Result<T> {
    let bytes = std::fs::read(p).map_err(|e| Error::io(p, e))?;
    serde_json::from_slice(&bytes)
        .map_err(|e| Error::new(ErrorKind::Syntax, format!("{e}")).with_location(Location::file(p)))
}
