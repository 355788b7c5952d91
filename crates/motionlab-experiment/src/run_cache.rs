//! Loading each input once per run, and stage outputs from the on-disk cache across runs.
//!
//! ## Within a run
//! Every sweep combination gets its own [`Datasets`](crate::Datasets), but they share one
//! [`RunCache`]: a loaded (cut, preprocessed) input is kept in memory under its *recipe* — file
//! path, loader, cut, ground truth, preprocessors, sequence name, as written in that
//! combination's document — so the 38 combinations of a sweep load each take once, not 38 × 2
//! times (item and evaluation). Concurrent requests for one recipe wait for the one load.
//!
//! Memory is bounded by a byte budget (`MOTIONLAB_MEMORY_BUDGET_MB`, default
//! [`DEFAULT_BUDGET_MB`]): past it the least recently used inputs are dropped from the table
//! (reloaded — from the disk cache when on — if asked for again). The engine orders a run's
//! items by input file, so each file is live for one stretch of the run; the peak is about the
//! budget plus one input per worker thread (the ones in use are held by their items). A budget
//! of 0 keeps nothing: every request loads (what a run costs without this cache, for measuring).
//!
//! ## Across runs
//! With a [`motionlab_cache::Cache`] set ([`RunCache::set_disk`]), a loaded input is also
//! stored on disk under a content key — SHA-256 of the motion file's and the ground-truth
//! file's bytes, the recipe without the folder path, and the binary's build fingerprint — and
//! stages that opt in through [`Datasets::stage_cached`](crate::Datasets::stage_cached) (one
//! input: the segmentation workflow's segmenters) or
//! [`Datasets::evaluation_cached`](crate::Datasets::evaluation_cached) (several inputs: its
//! evaluation) store their outputs under their resolved parameters and the inputs' keys. Every
//! use is logged with its [`Origin`] for the run's provenance.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock};

use motionlab_cache::{Cache, KeyBuilder};
pub use motionlab_cache::{Key, hex};
use motionlab_core::{Analysis, Error, Evaluation, Motion, Result};

use crate::context::LoadedItem;

/// Default in-memory budget for loaded inputs, MiB.
pub const DEFAULT_BUDGET_MB: usize = 1024;

/// Where a stage's output came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// Computed in this run.
    Computed,
    /// Shared from an earlier request in this run (another combination or item).
    Memory,
    /// Read from the on-disk cache.
    Disk,
}

/// One logged use: (dataset, file, stage, origin).
pub type StageUse = (usize, usize, String, Origin);

struct Slot {
    cell: Arc<Mutex<Option<LoadedItem>>>,
    last_use: u64,
    bytes: usize,
}

#[derive(Default)]
struct Table {
    slots: HashMap<Key, Slot>,
    tick: u64,
    bytes: usize,
}

/// Shared by every combination of a run: loaded inputs in memory, the disk cache, file hashes.
pub struct RunCache {
    budget_bytes: usize,
    table: Mutex<Table>,
    disk: RwLock<Option<Cache>>,
    file_hashes: Mutex<HashMap<PathBuf, [u8; 32]>>,
    loads: AtomicUsize,
    /// What the loader repaired in each input file ([`motionlab_core::LoadNotes`]), for the
    /// run's provenance; kept when the memory is cleared.
    load_repairs: Mutex<BTreeMap<PathBuf, Vec<String>>>,
}

impl Default for RunCache {
    fn default() -> Self {
        let mb = std::env::var("MOTIONLAB_MEMORY_BUDGET_MB")
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .unwrap_or(DEFAULT_BUDGET_MB);
        RunCache::with_budget(mb.saturating_mul(1 << 20))
    }
}

impl RunCache {
    pub fn with_budget(budget_bytes: usize) -> Self {
        RunCache {
            budget_bytes,
            table: Mutex::default(),
            disk: RwLock::new(None),
            file_hashes: Mutex::default(),
            loads: AtomicUsize::new(0),
            load_repairs: Mutex::default(),
        }
    }
    /// Uses (or, with `None`, stops using) an on-disk cache.
    pub fn set_disk(&self, cache: Option<Cache>) {
        if let Ok(mut d) = self.disk.write() {
            *d = cache;
        }
    }
    pub fn disk(&self) -> Option<Cache> {
        self.disk.read().ok().and_then(|d| d.clone())
    }
    /// Drops every input kept in memory (a run calls it when it is done, so that plans
    /// kept for later runs — `reproduce` plans every experiment first — hold no motion).
    pub fn clear_memory(&self) {
        if let Ok(mut t) = self.table.lock() {
            *t = Table::default();
        }
    }
    /// How many inputs were loaded from their files (not from memory or disk) so far.
    pub fn loads(&self) -> usize {
        self.loads.load(Ordering::Relaxed)
    }
    /// Records what the loader repaired in `path` (nothing when `repairs` is empty; the first
    /// record of a file stands: every load of it repairs the same).
    pub fn note_repairs(&self, path: &Path, repairs: &[String]) {
        if repairs.is_empty() {
            return;
        }
        if let Ok(mut m) = self.load_repairs.lock() {
            m.entry(path.to_path_buf()).or_insert_with(|| repairs.to_vec());
        }
    }
    /// Every input's recorded repairs, by file.
    pub fn load_repairs(&self) -> BTreeMap<PathBuf, Vec<String>> {
        self.load_repairs.lock().map(|m| m.clone()).unwrap_or_default()
    }
    /// SHA-256 of a file's bytes, read once per run. A folder (a motion of per-frame files,
    /// OpenPose's) hashes the list of its files' names and SHA-256, in name order: any frame
    /// changed, added or removed changes it.
    pub fn file_sha256(&self, path: &Path) -> Result<[u8; 32]> {
        if let Some(h) = self.file_hashes.lock().ok().and_then(|m| m.get(path).copied()) {
            return Ok(h);
        }
        let bytes = if path.is_dir() {
            let entries = std::fs::read_dir(path).map_err(|e| Error::io(path, e))?;
            let mut files: Vec<std::path::PathBuf> =
                entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file()).collect();
            files.sort();
            let mut list = Vec::new();
            for f in files {
                let content = std::fs::read(&f).map_err(|e| Error::io(&f, e))?;
                let name =
                    f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                list.extend_from_slice(name.as_bytes());
                list.push(0);
                list.extend_from_slice(&motionlab_cache::sha256(&content));
            }
            list
        } else {
            std::fs::read(path).map_err(|e| Error::io(path, e))?
        };
        let h = motionlab_cache::sha256(&bytes);
        if let Ok(mut m) = self.file_hashes.lock() {
            m.insert(path.to_path_buf(), h);
        }
        Ok(h)
    }

    /// The input under `recipe`: from memory, else from disk (`content_key` computes its
    /// content key, only when a disk cache is set), else `load`ed — stored in both.
    pub(crate) fn get_or_load(
        &self,
        recipe: &Key,
        content_key: impl FnOnce() -> Result<Key>,
        load: impl FnOnce() -> Result<LoadedItem>,
    ) -> Result<(LoadedItem, Origin)> {
        let cell = {
            let mut t = self.table.lock().map_err(|_| poisoned())?;
            t.tick += 1;
            let tick = t.tick;
            let slot = t.slots.entry(*recipe).or_insert_with(|| Slot {
                cell: Arc::default(),
                last_use: tick,
                bytes: 0,
            });
            slot.last_use = tick;
            Arc::clone(&slot.cell)
        };
        // One load per recipe: later requests wait here for the first.
        let mut guard = cell.lock().map_err(|_| poisoned())?;
        if let Some(item) = guard.as_ref() {
            return Ok((item.clone(), Origin::Memory));
        }
        let disk = self.disk();
        let key = match &disk {
            Some(_) => Some(content_key()?),
            None => None,
        };
        let from_disk = match (&disk, &key) {
            (Some(c), Some(k)) => {
                c.get("motion", k).and_then(|bytes| motionlab_cache::motion::decode(&bytes).ok())
            }
            _ => None,
        };
        let (mut item, origin) = match from_disk {
            Some((motion, truth)) => (
                LoadedItem {
                    name: motion.name.clone(),
                    motion: Arc::new(motion),
                    truth,
                    key: None,
                },
                Origin::Disk,
            ),
            None => {
                self.loads.fetch_add(1, Ordering::Relaxed);
                let item = load()?;
                if let (Some(c), Some(k)) = (&disk, &key)
                    && let Ok(bytes) =
                        motionlab_cache::motion::encode(&item.motion, item.truth.as_ref())
                {
                    // A cache that cannot be written only costs time.
                    let _ = c.put("motion", k, &bytes);
                }
                (item, Origin::Computed)
            }
        };
        item.key = key;
        let bytes = motion_bytes(&item.motion);
        if self.budget_bytes > 0 {
            *guard = Some(item.clone());
        }
        drop(guard);
        self.account(recipe, bytes);
        Ok((item, origin))
    }

    /// Records a slot's size and drops the least recently used slots past the budget.
    fn account(&self, recipe: &Key, bytes: usize) {
        let Ok(mut t) = self.table.lock() else { return };
        if self.budget_bytes == 0 {
            t.slots.remove(recipe);
            return;
        }
        if let Some(s) = t.slots.get_mut(recipe) {
            let old = std::mem::replace(&mut s.bytes, bytes);
            t.bytes = t.bytes.saturating_sub(old) + bytes;
        }
        while t.bytes > self.budget_bytes {
            let Some(oldest) = t
                .slots
                .iter()
                .filter(|(k, s)| *k != recipe && s.bytes > 0)
                .min_by_key(|(_, s)| s.last_use)
                .map(|(k, _)| *k)
            else {
                break;
            };
            if let Some(s) = t.slots.remove(&oldest) {
                t.bytes = t.bytes.saturating_sub(s.bytes);
            }
        }
    }

    /// A stage output from disk under `key`, else computed (and stored).
    pub(crate) fn stage<T: serde::Serialize + serde::de::DeserializeOwned>(
        &self,
        kind: &str,
        key: Option<Key>,
        compute: impl FnOnce() -> Result<T>,
    ) -> Result<(T, Origin)> {
        let disk = self.disk();
        let (Some(c), Some(k)) = (disk, key) else { return Ok((compute()?, Origin::Computed)) };
        if let Some(v) = c.get(kind, &k).and_then(|b| rmp_serde::from_slice::<T>(&b).ok()) {
            return Ok((v, Origin::Disk));
        }
        let v = compute()?;
        if let Ok(bytes) = rmp_serde::to_vec(&v) {
            let _ = c.put(kind, &k, &bytes);
        }
        Ok((v, Origin::Computed))
    }
}

impl RunCache {
    /// An evaluation from disk under `key`, else computed (and stored when its analysis, if
    /// any, can be encoded). The tables are one entry (`evaluation`), the analysis — its type
    /// name and bytes, or none — another under the same key (`analysis`).
    pub(crate) fn evaluation(
        &self,
        key: Option<Key>,
        compute: impl FnOnce() -> Result<Evaluation>,
    ) -> Result<(Evaluation, Origin)> {
        let disk = self.disk();
        let (Some(c), Some(k)) = (disk, key) else { return Ok((compute()?, Origin::Computed)) };
        if let Some(tables) =
            c.get("evaluation", &k).and_then(|b| motionlab_cache::table::decode(&b).ok())
            && let Some(analysis) =
                c.get("analysis", &k).and_then(|b| rmp_serde::from_slice::<StoredAnalysis>(&b).ok())
        {
            let analysis = analysis.map(|(type_name, bytes)| Analysis::restored(type_name, bytes));
            return Ok((Evaluation { tables, analysis }, Origin::Disk));
        }
        let v = compute()?;
        let analysis: Option<StoredAnalysis> = match &v.analysis {
            None => Some(None),
            Some(a) => a.encode().map(|bytes| Some((a.type_name().to_string(), bytes))),
        };
        // An analysis that cannot be encoded: nothing is stored, the next run computes again.
        if let (Some(analysis), Ok(tables)) = (analysis, motionlab_cache::table::encode(&v.tables))
            && let Ok(analysis) = rmp_serde::to_vec(&analysis)
            && c.put("analysis", &k, &analysis).is_ok()
        {
            // The tables last: a reader finds them only with their analysis beside.
            let _ = c.put("evaluation", &k, &tables);
        }
        Ok((v, Origin::Computed))
    }
}

/// An evaluation's analysis as stored: its type name and encoded bytes, or `None` for an
/// evaluator without one.
type StoredAnalysis = Option<(String, Vec<u8>)>;

/// Builds a stage key under an upstream key.
pub fn stage_key(kind: &str, upstream: &Key, params: &str) -> Key {
    KeyBuilder::new(kind).upstream("input", upstream).part("params", params.as_bytes()).finish()
}

fn poisoned() -> Error {
    Error::new(motionlab_core::ErrorKind::Report, "a worker thread panicked while loading an input")
}

/// Bytes a motion holds (positions, mask, channel values).
fn motion_bytes(m: &Motion) -> usize {
    m.positions().len() * 25
        + m.skeleton.as_ref().map_or(0, |s| s.channel_values().len() * 8)
        + m.channels().values().len() * 8
        + 4096
}
