//! What a workflow is given: the experiment file as read ([`Source`], which locates errors at
//! a file, line and key path), one sweep combination ([`Combo`]), the datasets with their
//! plugins built ([`Datasets`], which loads, cuts and preprocesses an input), and the helpers
//! that build a stage or parse a section with located errors.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use motionlab_cache::{Key, KeyBuilder};

use motionlab_core::registry;
use motionlab_core::{
    Error, ErrorKind, GroundTruthReader, Loader, Location, Motion, Preprocessor, Result,
    Segmentation,
};

use crate::run_cache::{Origin, RunCache, StageUse};
use crate::spec::{Cut, DatasetSpec, ExperimentFile, StageSpec};
use crate::toml_paths::{KeyPath, line_of};

/// The experiment file as read.
#[derive(Clone, Debug)]
pub struct Source {
    pub path: PathBuf,
    pub text: String,
}

impl Source {
    /// Reads an experiment file of at most [`motionlab_core::limits::MAX_EXPERIMENT_BYTES`].
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = motionlab_core::limits::read_experiment_file(path)?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let line = e.as_bytes()[..at].iter().filter(|b| **b == b'\n').count() + 1;
            Error::at_line(
                ErrorKind::Syntax,
                path,
                line,
                format!("invalid UTF-8 at byte {at}; expected a TOML text file"),
            )
        })?;
        Ok(Source { path: path.to_path_buf(), text })
    }
    /// Folder that relative paths in the experiment are resolved against.
    pub fn base_dir(&self) -> PathBuf {
        self.path.parent().map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."))
    }
    /// The one way to attach a place in the experiment to an error: this file, the key path
    /// `at` (a [`KeyPath`] or its text, `"gait.control.dataset"`) with the error's own field —
    /// a plugin's or a params struct's, relative to `at` — appended, and the line where that
    /// path (or its nearest written parent) is written in the file. Overrides and sweeps are
    /// resolved against `doc`, the combination's document.
    pub fn locate(&self, err: Error, at: impl Into<At>, doc: &toml::Table) -> Error {
        let kind = err.kind();
        let msg = err.message().to_string();
        let own = err.location().field.clone().filter(|f| !f.is_empty());
        let path = match at.into() {
            At::Path(p) => match own {
                Some(f) => p.join_field(&f),
                None => p,
            },
            At::Text(text) => match KeyPath::parse(&text) {
                Ok(p) => match own {
                    Some(f) => p.join_field(&f),
                    None => p,
                },
                // Not a key path (cannot happen for paths written in code): name it as text.
                Err(_) => {
                    return Error::new(kind, msg)
                        .with_location(Location::file(&self.path).field(text));
                }
            },
        };
        let resolved = path.resolve(doc).unwrap_or_else(|_| path.clone());
        let mut loc = Location::file(&self.path).field(resolved.to_string());
        if let Some(line) = line_of(&self.text, &resolved) {
            loc = loc.line(line);
        }
        Error::new(kind, msg).with_location(loc)
    }
}

/// Where in the experiment an error is: a key path, or its text.
pub enum At {
    Path(KeyPath),
    Text(String),
}

impl From<KeyPath> for At {
    fn from(p: KeyPath) -> Self {
        At::Path(p)
    }
}
impl From<&KeyPath> for At {
    fn from(p: &KeyPath) -> Self {
        At::Path(p.clone())
    }
}
impl From<&str> for At {
    fn from(t: &str) -> Self {
        At::Text(t.to_string())
    }
}
impl From<String> for At {
    fn from(t: String) -> Self {
        At::Text(t)
    }
}

/// One combination of swept parameter values (the only one when there is no sweep).
#[derive(Clone, Debug)]
pub struct Combo {
    pub index: usize,
    /// The sweep grid's name (`None` without a sweep).
    pub sweep: Option<String>,
    pub focus: Option<String>,
    /// The swept key paths and their values in this combination.
    pub params: Vec<(String, toml::Value)>,
    /// The resolved document of this combination.
    pub doc: toml::Table,
    pub file: ExperimentFile,
}

impl Combo {
    /// `v_low.fraction_of_p90=0.1, c_min=0.2` — the swept values, for table columns.
    pub fn label(&self) -> String {
        self.params.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(", ")
    }
}

/// A dataset with its plugins built and its files resolved.
pub struct BuiltDataset {
    pub index: usize,
    pub spec: DatasetSpec,
    pub loader: Box<dyn Loader>,
    /// The reader and the ground-truth path, which may hold `{stem}` (replaced by each motion
    /// file's stem, so one dataset can list several sequences with a label file each).
    pub ground_truth: Option<(Box<dyn GroundTruthReader>, PathBuf)>,
    pub preprocess: Vec<Box<dyn Preprocessor>>,
    /// Resolved files (globs expanded, sorted).
    pub files: Vec<PathBuf>,
}

impl BuiltDataset {
    /// The sequence name of file `k`: the dataset's name when it has one file, else the stem.
    pub fn sequence_name(&self, k: usize) -> String {
        let stem = motionlab_core::paths::stem(&self.files[k]);
        match (&self.spec.name, self.files.len()) {
            (Some(n), 1) => n.clone(),
            (Some(n), _) => format!("{n}/{stem}"),
            (None, _) => stem,
        }
    }
    pub fn tag(&self, key: &str) -> Option<&str> {
        self.spec.tags.get(key).map(String::as_str)
    }
    /// The ground-truth file of motion file `k` (`{stem}` substituted).
    pub fn ground_truth_path(&self, k: usize) -> Option<PathBuf> {
        let (_, template) = self.ground_truth.as_ref()?;
        let stem = motionlab_core::paths::stem(&self.files[k]);
        Some(PathBuf::from(template.to_string_lossy().replace("{stem}", &stem)))
    }
}

/// A loaded, cut and preprocessed input.
#[derive(Clone)]
pub struct LoadedItem {
    pub name: String,
    pub motion: Arc<Motion>,
    pub truth: Option<Segmentation>,
    /// Its content key in the on-disk cache, when one is in use (the upstream key of the
    /// stages cached under it, [`Datasets::stage_cached`]).
    pub key: Option<Key>,
}

/// Every dataset of a combination, plus the experiment-wide preprocessors.
pub struct Datasets {
    pub datasets: Vec<BuiltDataset>,
    pub preprocess: Vec<Box<dyn Preprocessor>>,
    /// The experiment-wide preprocessors as written (part of each input's recipe).
    preprocess_specs: Vec<StageSpec>,
    /// Shared by every combination of the run: see [`crate::run_cache`].
    pub cache: Arc<RunCache>,
    /// Where each stage output of this combination came from (see [`Datasets::take_log`]).
    log: Mutex<Vec<StageUse>>,
}

impl Datasets {
    /// `preprocess` are built from `preprocess_specs`, in order.
    pub fn new(
        datasets: Vec<BuiltDataset>,
        preprocess: Vec<Box<dyn Preprocessor>>,
        preprocess_specs: Vec<StageSpec>,
        cache: Arc<RunCache>,
    ) -> Self {
        Datasets { datasets, preprocess, preprocess_specs, cache, log: Mutex::default() }
    }
    /// The uses logged so far (and clears the log).
    pub fn take_log(&self) -> Vec<StageUse> {
        self.log.lock().map(|mut l| std::mem::take(&mut *l)).unwrap_or_default()
    }
    /// Logs where a stage's output on file `file` of dataset `dataset` came from (for the
    /// run's provenance; [`Datasets::load`] and [`Datasets::stage_cached`] log their own).
    pub fn record(&self, dataset: usize, file: usize, stage: &str, origin: Origin) {
        if let Ok(mut l) = self.log.lock() {
            l.push((dataset, file, stage.to_string(), origin));
        }
    }
    /// How file `file` of dataset `dataset` is loaded, as text: everything [`Datasets::load`]
    /// reads besides the files' bytes (with the file's folder when `with_folder`).
    fn recipe(&self, dataset: usize, file: usize, with_folder: bool) -> String {
        let d = &self.datasets[dataset];
        let path = &d.files[file];
        let place = if with_folder {
            path.to_string_lossy().into_owned()
        } else {
            path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
        };
        let stage = |s: &StageSpec| format!("{} {}", s.kind, s.plugin_params());
        let gt = d.spec.ground_truth.as_ref().map(|g| {
            format!(
                "{} {:?}",
                stage(g),
                d.ground_truth_path(file).map(|p| if with_folder {
                    p
                } else {
                    p.file_name().map(PathBuf::from).unwrap_or_default()
                })
            )
        });
        let pre: Vec<String> =
            d.spec.preprocess.iter().chain(&self.preprocess_specs).map(stage).collect();
        format!(
            "file {place}\nname {}\nloader {}\ncut {:?}\ntruth {gt:?}\npreprocess {pre:?}",
            d.sequence_name(file),
            stage(&d.spec.loader),
            d.spec.cut
        )
    }
    /// Loads file `file` of dataset `dataset` (loader → cut → ground truth → dataset
    /// preprocessors → experiment preprocessors), once per run: later requests — from any
    /// combination with the same recipe — share it ([`crate::run_cache`]).
    pub fn load(&self, dataset: usize, file: usize) -> Result<LoadedItem> {
        let recipe = KeyBuilder::new("recipe")
            .part("recipe", self.recipe(dataset, file, true).as_bytes())
            .finish();
        let content_key = || {
            let d = &self.datasets[dataset];
            let mut k = KeyBuilder::new("motion")
                .part("recipe", self.recipe(dataset, file, false).as_bytes())
                .part("file", &self.cache.file_sha256(&d.files[file])?);
            if let Some(gt) = d.ground_truth_path(file) {
                k = k.part("truth", &self.cache.file_sha256(&gt)?);
                let companions = d.ground_truth.as_ref().map(|(r, _)| r.companions(&gt));
                for c in companions.unwrap_or_default().iter().filter(|c| c.is_file()) {
                    k = k.part("truth companion", &self.cache.file_sha256(c)?);
                }
            }
            Ok(k.finish())
        };
        let (mut item, origin) =
            self.cache.get_or_load(&recipe, content_key, || self.load_uncached(dataset, file))?;
        self.cache
            .note_repairs(&self.datasets[dataset].files[file], &item.motion.load_notes.repairs);
        if origin == Origin::Disk {
            // The entry is content-addressed: the same bytes may have been read from elsewhere.
            let mut m = (*item.motion).clone();
            m.source = Some(self.datasets[dataset].files[file].clone());
            item.motion = Arc::new(m);
        }
        self.record(dataset, file, "load", origin);
        Ok(item)
    }
    /// A stage's output on a loaded input: from the on-disk cache when it holds one under the
    /// input's key, `kind` and `params` (the stage's resolved parameters as text), else
    /// `compute`d and stored. Logged as `stage` for the provenance.
    pub fn stage_cached<T: serde::Serialize + serde::de::DeserializeOwned>(
        &self,
        loaded: &LoadedItem,
        (dataset, file): (usize, usize),
        stage: &str,
        kind: &str,
        params: &str,
        compute: impl FnOnce() -> Result<T>,
    ) -> Result<T> {
        let key = loaded.key.as_ref().map(|k| crate::run_cache::stage_key(kind, k, params));
        let (v, origin) = self.cache.stage(kind, key, compute)?;
        self.record(dataset, file, stage, origin);
        Ok(v)
    }
    /// An evaluation over several inputs — a combination's sequences — from the on-disk cache
    /// when it holds one under `params` (the stage's resolved parameters as text) and `inputs`
    /// (each input's [`LoadedItem::key`] and the bytes of what the stage reads besides, such
    /// as each method's candidates), else `compute`d and stored: its tables, and its typed
    /// analysis when that is [`Analysis::cacheable`](motionlab_core::Analysis::cacheable) (an
    /// evaluation whose analysis is not is never stored). Logged as `stage` on each
    /// `(dataset, file)` of `logged`.
    pub fn evaluation_cached(
        &self,
        stage: &str,
        params: &str,
        inputs: &[(Option<Key>, Vec<u8>)],
        logged: &[(usize, usize)],
        compute: impl FnOnce() -> Result<motionlab_core::Evaluation>,
    ) -> Result<motionlab_core::Evaluation> {
        let key = inputs.iter().try_fold(
            KeyBuilder::new("evaluation").part("params", params.as_bytes()),
            |k, (input, bytes)| input.as_ref().map(|i| k.upstream("input", i).part("reads", bytes)),
        );
        let (v, origin) = self.cache.evaluation(key.map(KeyBuilder::finish), compute)?;
        for &(d, f) in logged {
            self.record(d, f, stage, origin);
        }
        Ok(v)
    }
    fn load_uncached(&self, dataset: usize, file: usize) -> Result<LoadedItem> {
        let d = &self.datasets[dataset];
        let path = &d.files[file];
        let mut motion = d.loader.load(path).map_err(|e| e.in_file(path))?;
        motion.name = d.sequence_name(file);
        if let Some(cut) = d.spec.cut {
            let rate = motion.frame_rate();
            let (a, b) = match cut {
                Cut::Frames([a, b]) => (a, b),
                Cut::Seconds([a, b]) => (
                    rate.seconds_to_frames(motionlab_core::Seconds(a)).round() as usize,
                    rate.seconds_to_frames(motionlab_core::Seconds(b)).round() as usize,
                ),
            };
            motion = motion
                .slice_frames(a, b)
                .map_err(|e| e.in_file(path).with_field(format!("dataset[{dataset}].cut")))?;
        }
        // Ground truth is read against the motion as loaded (and cut), before preprocessors
        // that may add points but never change timing.
        let truth = match (&d.ground_truth, d.ground_truth_path(file)) {
            (Some((reader, _)), Some(gt_path)) => {
                Some(reader.read(&gt_path, &motion).map_err(|e| e.in_file(&gt_path))?)
            }
            _ => None,
        };
        // What the loader noted stays with the motion (a preprocessor may build a new one),
        // so a motion from the disk cache still says it for the provenance.
        let notes = motion.load_notes.clone();
        for p in d.preprocess.iter().chain(&self.preprocess) {
            motion = p.apply(motion).map_err(|e| e.in_file(path))?;
        }
        motion.load_notes = notes;
        Ok(LoadedItem { name: d.sequence_name(file), motion: Arc::new(motion), truth, key: None })
    }
    /// The dataset whose tag `key` equals `value`.
    pub fn find_tagged(&self, key: &str, value: &str) -> Vec<&BuiltDataset> {
        self.datasets.iter().filter(|d| d.tag(key) == Some(value)).collect()
    }
}

/// Builds a plugin, mapping its parameter errors to the stage's key path and line.
pub fn build_stage<T: ?Sized>(
    source: &Source,
    combo: &Combo,
    spec: &StageSpec,
    path: &KeyPath,
    builder: fn(&str, &toml::Value) -> Result<Box<T>>,
) -> Result<Box<T>> {
    builder(&spec.kind, &spec.plugin_params()).map_err(|e| {
        if e.kind() == ErrorKind::UnknownPlugin {
            // An unknown name is the `type` key's fault, whatever field the registry named.
            source.locate(
                Error::new(e.kind(), e.message().to_string()),
                path.key("type"),
                &combo.doc,
            )
        } else {
            source.locate(e, path, &combo.doc)
        }
    })
}

/// Deserialises a table of the document found at `root` (a workflow section, or the whole
/// document at the empty path), with errors located at `root.<field>` and its line.
pub fn deserialize_section<T: serde::de::DeserializeOwned>(
    source: &Source,
    doc: &toml::Table,
    value: toml::Value,
    root: &KeyPath,
) -> Result<T> {
    registry::parse_params::<T>(&value).map_err(|e| source.locate(e, root, doc))
}
