//! `motionlab new <folder-or-glob> [--truth <csv|eaf>] [-o out.toml]`: writes a commented
//! segmentation experiment for one's own motion files that runs as is.
//!
//! What it decides, and says in the file's comments: the loader (from the files' extension;
//! when a folder holds several formats, the most common, C3D first on a tie), the root (the
//! skeleton's root joint; else a pelvis/sacrum marker; else the centroid of the hip markers —
//! names with "hip", ASIS/PSIS, Vicon's LFWT/RFWT/LBWT/RBWT — added by `add_centroid`; else the
//! centroid of every marker), the three Sonoda segmenters at the plugins' defaults (chosen by
//! leave-one-sequence-out on the seven shipped labelled takes) fused by union, and
//! `boundary_pr` (tolerance 0.5 s, annotated span only)
//! when a truth file is given (`.csv` → `boundaries_csv`, `.eaf` → `elan_eaf`). With a CSV
//! that names sequences, only the motion files it annotates are listed. The written file is
//! validated before the command returns.
//!
//! With `--benchmark`, or for a folder of channel files (`.txt`/`.csv`/`.npy` series; TSSB's
//! `desc.txt` as the truth), it writes a `[benchmark]` instead: every segmenter that reads
//! channels at its peers' defaults (on mocap: on the fastest marker's speed, beside the Sonoda
//! speed and hull methods and the PCA baseline), covering and F1 against chance, mean ranks.

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

use motionlab_core::{Error, ErrorKind, Location, Motion, Result};

use crate::inspect::loader_for;

/// The arguments of `motionlab new`.
pub struct NewArgs {
    pub input: String,
    pub truth: Option<PathBuf>,
    pub output: Option<PathBuf>,
    pub force: bool,
    /// Write a `[benchmark]` (every strong segmenter, covering and F1 against chance, ranks)
    /// instead of a Sonoda segmentation; implied by channel files.
    pub benchmark: bool,
}

/// The root the experiment uses, and how it was found.
#[derive(Debug, PartialEq)]
enum Root {
    /// A point of the motion (skeleton root joint or a pelvis marker).
    Point { name: String, why: String },
    /// A centroid added by `add_centroid`.
    Centroid { markers: Vec<String>, why: String },
}

/// Marker names that sit on the pelvis, one marker alone being a root.
fn is_pelvis(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    ["pelvis", "sacr", "root"].iter().any(|k| n.contains(k))
}

/// Marker names on the hips (left/right, front/back): their centroid is the pelvis.
fn is_hip(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    let plain = n.trim_start_matches(['l', 'r', '_']);
    n.contains("hip")
        || ["asi", "psi", "ias", "ips", "fwt", "bwt"].iter().any(|k| plain == *k || n.ends_with(k))
}

fn choose_root(m: &Motion) -> Root {
    if let Some(sk) = &m.skeleton
        && let Some(j) = sk.skeleton.joints.iter().find(|j| j.parent.is_none())
    {
        return Root::Point { name: j.name.clone(), why: "the skeleton's root joint".into() };
    }
    let names = m.point_names();
    if let Some(p) = names.iter().find(|n| is_pelvis(n)) {
        return Root::Point {
            name: p.clone(),
            why: format!("marker {p:?} (its name says pelvis/sacrum)"),
        };
    }
    let hips: Vec<String> = names.iter().filter(|n| is_hip(n)).cloned().collect();
    if !hips.is_empty() {
        return Root::Centroid {
            why: format!("no marker is a root: the centroid of the {} hip markers", hips.len()),
            markers: hips,
        };
    }
    Root::Centroid {
        markers: names.to_vec(),
        why: "no pelvis or hip marker by name: the centroid of every marker".into(),
    }
}

/// `to` relative to the folder `from` (both made absolute); absolute when they share only `/`.
fn relative(from: &Path, to: &Path) -> Result<PathBuf> {
    let abs = |p: &Path| std::path::absolute(p).map_err(|e| Error::io(p, e)).map(|p| normalise(&p));
    let (from, to) = (abs(from)?, abs(to)?);
    let (a, b): (Vec<Component>, Vec<Component>) =
        (from.components().collect(), to.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common <= 1 {
        return Ok(to);
    }
    let mut out = PathBuf::new();
    for _ in common..a.len() {
        out.push("..");
    }
    for c in &b[common..] {
        out.push(c.as_os_str());
    }
    Ok(out)
}

/// Removes `.` and resolves `..` lexically.
fn normalise(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// Paths in TOML strings use `/`.
fn toml_path(p: &Path) -> String {
    p.to_string_lossy().replace('\\', "/")
}

/// The motion files of a folder (the most common loadable format) or a glob.
fn motion_files(input: &str) -> Result<(Vec<PathBuf>, String)> {
    let dir = Path::new(input);
    let mut note = String::new();
    let files: Vec<PathBuf> = if dir.is_dir() {
        let mut by_ext: Vec<(String, Vec<PathBuf>)> = Vec::new();
        let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
        let mut paths: Vec<PathBuf> =
            entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file()).collect();
        paths.sort();
        for p in paths {
            if loader_for(&p).is_err() {
                continue;
            }
            let ext = motionlab_core::paths::format_extension(&p).unwrap_or_default();
            match by_ext.iter_mut().find(|(e, _)| *e == ext) {
                Some((_, v)) => v.push(p),
                None => by_ext.push((ext, vec![p])),
            }
        }
        // Folders of per-frame JSON (OpenPose) are one more group, one motion per folder.
        let folders = frame_folders(dir)?;
        if !folders.is_empty() {
            by_ext.push((FRAME_FOLDERS.into(), folders));
        }
        // Most files first; C3D first on a tie (it carries the capture's own rate and units).
        by_ext.sort_by_key(|(ext, v)| (std::cmp::Reverse(v.len()), ext != "c3d", ext.clone()));
        if by_ext.len() > 1 {
            let what = |e: &str| {
                if e == FRAME_FOLDERS {
                    "folders of JSON frames".to_string()
                } else {
                    format!(".{e} files")
                }
            };
            let others: Vec<String> =
                by_ext[1..].iter().map(|(e, v)| format!("{} {}", v.len(), what(e))).collect();
            note = format!(
                "the folder also holds {}; this uses the {}",
                others.join(", "),
                what(&by_ext[0].0)
            );
        }
        by_ext.into_iter().next().map(|(_, v)| v).unwrap_or_default()
    } else {
        let paths = glob::glob(input).map_err(|e| {
            Error::new(ErrorKind::Syntax, format!("{input:?} is no folder and no valid glob: {e}"))
        })?;
        let mut v: Vec<PathBuf> = paths.filter_map(|p| p.ok()).filter(|p| p.is_file()).collect();
        v.sort();
        v
    };
    if files.is_empty() {
        return Err(Error::new(ErrorKind::EmptySequence, "no motion file a loader reads (bvh, amc, c3d, tsv, …) and no folder of OpenPose frames; expected a folder or glob of them")
            .with_location(Location::file(input)));
    }
    Ok((files, note))
}

/// The group name of [`frame_folders`] among a folder's file extensions.
const FRAME_FOLDERS: &str = "json frame folders";

/// The subfolders of `dir` that hold per-frame JSON files (OpenPose writes one folder per
/// video): the motions of a folder without motion files of its own.
fn frame_folders(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut dirs: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir() && motionlab_io::openpose::frame_files(p).is_ok())
        .collect();
    dirs.sort();
    Ok(dirs)
}

/// The rate `new` writes for a loader whose files store none (OpenPose, COCO, MediaPipe), with
/// the comment that says so: common video's rate, to be set.
const ASSUMED_VIDEO_RATE_HZ: f64 = 30.0;

/// A name the experiment table accepts: lower-case letters, digits and `_`.
fn experiment_name(input: &str) -> String {
    let base = Path::new(input.trim_end_matches(['/', '*']))
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut name: String = base
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' })
        .collect();
    name = name.trim_matches('_').to_string();
    if name.is_empty() {
        name = "my_data".into();
    }
    format!("{name}_segmentation")
}

/// What the truth file gives the dataset: the TOML of its `ground_truth` and comment lines.
struct Truth {
    table: String,
    comments: Vec<String>,
    /// The stems with rows (CSV with a `sequence` column).
    sequences: Option<Vec<String>>,
    /// The truth labels its segments (states): a benchmark then labels states too.
    labelled: bool,
}

fn truth_spec(truth: &Path, out_dir: &Path, files: &[PathBuf]) -> Result<Truth> {
    let ext =
        truth.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let rel = toml_path(&relative(out_dir, truth)?);
    let text = motionlab_io::read::read_text(truth)?;
    match ext.as_str() {
        "csv" | "tsv" | "txt" => {
            let csv = motionlab_io::labels::boundaries_csv::parse_boundaries_csv(&text, truth)?;
            let mut annotators: Vec<&str> = csv.rows.iter().filter_map(|r| r.annotator.as_deref()).collect();
            annotators.sort_unstable();
            annotators.dedup();
            let mut comments = vec![format!(
                "{} rows, one per {}, in {}",
                csv.rows.len(),
                if csv.segments { "segment (boundaries: the starts plus the last end)" } else { "boundary" },
                match csv.unit {
                    motionlab_io::labels::boundaries_csv::CsvUnit::Frames => "frames",
                    motionlab_io::labels::boundaries_csv::CsvUnit::Seconds => "seconds",
                }
            )];
            let mut table = format!("{{ type = \"boundaries_csv\", file = \"{rel}\"");
            if annotators.len() > 1 {
                comments.push(format!(
                    "{} annotators ({}): combined by consensus (half of them within 0.25 s); `annotator = \"…\"` evaluates one",
                    annotators.len(),
                    annotators.join(", ")
                ));
                table.push_str(", consensus = { tolerance = { seconds = 0.25 } }");
            }
            table.push_str(" }");
            let sequences = csv.has_sequence.then(|| csv.sequences().into_iter().map(str::to_string).collect());
            let labelled = csv.segments && csv.rows.iter().any(|r| !r.item.label.trim().is_empty());
            Ok(Truth { table, comments, sequences, labelled })
        }
        "eaf" => {
            let tiers = motionlab_io::labels::elan_eaf::parse_eaf(&text, truth)?;
            let aligned: Vec<&str> = tiers.iter().filter(|t| t.time_aligned && !t.track.items.is_empty()).map(|t| t.id.as_str()).collect();
            // One .eaf per motion: when its stem is a motion's, the others are expected beside it.
            let stem = motionlab_core::paths::stem(truth);
            let file = if files.iter().any(|f| motionlab_core::paths::stem(f) == stem) && files.len() > 1 {
                rel.replacen(&stem, "{stem}", 1)
            } else {
                rel
            };
            let mut comments = vec!["ELAN times in ms; set offset_ms when the video starts before the capture".to_string()];
            let table = match aligned.as_slice() {
                [one] => format!("{{ type = \"elan_eaf\", file = \"{file}\", tier = \"{one}\" }}"),
                _ => {
                    comments.push(format!("tiers {}: one annotator each, combined by consensus; `tier = \"…\"` reads one", aligned.join(", ")));
                    format!("{{ type = \"elan_eaf\", file = \"{file}\", consensus = {{ tolerance = {{ seconds = 0.25 }} }} }}")
                }
            };
            Ok(Truth { table, comments, sequences: None, labelled: false })
        }
        _ => Err(Error::new(ErrorKind::UnknownPlugin, format!("no annotation reader for .{ext} files; expected .csv (boundaries_csv) or .eaf (elan_eaf)"))
            .with_location(Location::file(truth))),
    }
}

/// Writes the experiment; returns its path.
pub fn new_experiment(args: &NewArgs) -> Result<PathBuf> {
    let (mut files, folder_note) = motion_files(&args.input)?;
    if args.benchmark || loader_for(&files[0]).is_ok_and(|(name, _)| name == "channels") {
        return new_benchmark(args, files, &folder_note);
    }
    let name = experiment_name(&args.input);
    let (output, out_dir) = output_path(args, &name)?;
    let truth = args.truth.as_deref().map(|t| truth_spec(t, &out_dir, &files)).transpose()?;
    let mut skipped = Vec::new();
    if let Some(seqs) = truth.as_ref().and_then(|t| t.sequences.as_ref()) {
        let (keep, drop): (Vec<PathBuf>, Vec<PathBuf>) =
            files.into_iter().partition(|f| seqs.contains(&motionlab_core::paths::stem(f)));
        if keep.is_empty() {
            return Err(Error::new(
                ErrorKind::UnknownName,
                format!(
                    "the annotations name sequences {} but no motion file has those stems",
                    seqs.join(", ")
                ),
            )
            .with_location(
                Location::file(args.truth.as_deref().unwrap_or(Path::new(""))).field("sequence"),
            ));
        }
        files = keep;
        skipped = drop;
    }
    let (loader_name, loader) = loader_for(&files[0])?;
    // A format that stores no rate (video keypoints) is read, and written, at an assumed one.
    let (first, rate_line) = match loader.load(&files[0]) {
        Err(e)
            if e.kind() == ErrorKind::MissingKey
                && e.location().field.as_deref() == Some("rate_hz") =>
        {
            let mut params = toml::Table::new();
            params.insert("rate_hz".into(), toml::Value::Float(ASSUMED_VIDEO_RATE_HZ));
            let loader =
                motionlab_core::registry::build_loader(loader_name, &toml::Value::Table(params))?;
            (loader.load(&files[0]).map_err(|e| e.in_file(&files[0]))?, true)
        }
        other => (other.map_err(|e| e.in_file(&files[0]))?, false),
    };
    let two_d = first.dimensionality() == motionlab_core::Dimensionality::Two;
    let root = choose_root(&first);

    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(
        w,
        "# Written by `motionlab new {}{}`.",
        args.input,
        args.truth.as_ref().map(|p| format!(" --truth {}", p.display())).unwrap_or_default()
    );
    let _ = writeln!(w, "# Run it: motionlab run {}", output.display());
    let _ = writeln!(
        w,
        "# Segmentation of Sonoda et al. (fastest-marker speed, direction change, convex-hull volume,"
    );
    let _ = writeln!(
        w,
        "# fused by union) at the plugins' defaults, which were tuned on seven shipped CMU takes"
    );
    let _ = writeln!(
        w,
        "# (the evaluation's `parameters_chosen` column says, per file, whether it is one of them);"
    );
    let _ = writeln!(w, "# `motionlab describe <type>` documents every stage and parameter.\n");
    let _ = writeln!(w, "[experiment]\nname = \"{name}\"");
    let _ = writeln!(
        w,
        "description = \"Sonoda segmentation of {}{}\"\n",
        args.input.replace('"', "'"),
        if truth.is_some() { " against its annotations" } else { "" }
    );
    let _ = writeln!(w, "[[dataset]]");
    let _ = writeln!(
        w,
        "# {} file(s), loader `{loader_name}` (from the extension){}.",
        files.len(),
        if folder_note.is_empty() { String::new() } else { format!("; {folder_note}") }
    );
    if !skipped.is_empty() {
        let s: Vec<String> = skipped.iter().map(|p| motionlab_core::paths::stem(p)).collect();
        let _ = writeln!(w, "# Not annotated, so left out: {}.", s.join(", "));
    }
    let listed: Vec<String> = files
        .iter()
        .map(|f| relative(&out_dir, f).map(|p| format!("\"{}\"", toml_path(&p))))
        .collect::<Result<_>>()?;
    let _ = writeln!(w, "files = [{}]", listed.join(", "));
    if rate_line {
        let _ = writeln!(
            w,
            "# The {loader_name} files store no frame rate: {ASSUMED_VIDEO_RATE_HZ} is assumed; set your video's frames per second."
        );
        let _ = writeln!(
            w,
            "loader = {{ type = \"{loader_name}\", rate_hz = {ASSUMED_VIDEO_RATE_HZ:?} }}"
        );
    } else {
        let _ = writeln!(w, "loader = {{ type = \"{loader_name}\" }}");
    }
    let root_name = match &root {
        Root::Point { name, why } => {
            let _ = writeln!(w, "# Root: {name:?}, {why}.");
            name.clone()
        }
        Root::Centroid { markers, why } => {
            let _ = writeln!(w, "# Root: {why}, added as the virtual marker \"root\".");
            let quoted: Vec<String> = markers.iter().map(|m| format!("{m:?}")).collect();
            let _ = writeln!(
                w,
                "preprocess = [{{ type = \"add_centroid\", name = \"root\", markers = [{}] }}]",
                quoted.join(", ")
            );
            "root".into()
        }
    };
    if let Some(tr) = &truth {
        for c in &tr.comments {
            let _ = writeln!(w, "# Ground truth: {c}.");
        }
        let _ = writeln!(w, "ground_truth = {}", tr.table);
    }
    let fuse = if two_d { "[\"speed\"]" } else { "[\"speed\", \"direction\", \"hull\"]" };
    let _ = writeln!(w, "\n[segmentation]\nroot = {root_name:?}\nfuse = {fuse}\n");
    let _ = writeln!(
        w,
        "[[segmentation.segmenter]]\ntype = \"fastest_marker_speed\"                           # §2.1\nname = \"speed\"\n"
    );
    if two_d {
        let _ = writeln!(
            w,
            "# 2-D image keypoints (px): the speed method only (speeds in px/s); the direction (§2.2)\n# and hull (§2.3) methods need 3-D positions.\n"
        );
    } else {
        let _ = writeln!(
            w,
            "[[segmentation.segmenter]]\ntype = \"direction_change\"                               # §2.2\nname = \"direction\"\nlag = {{ seconds = 0.5 }}                                 # the paper's 15 frames at 30 fps\n"
        );
        let _ = writeln!(
            w,
            "[[segmentation.segmenter]]\ntype = \"hull_volume_change\"                             # §2.3\nname = \"hull\"\n"
        );
    }
    let _ = writeln!(
        w,
        "[segmentation.fuser]\ntype = \"union_merge\"                                    # §2.4\nname = \"fused\""
    );
    if truth.is_some() {
        let _ = writeln!(
            w,
            "\n# Precision/recall per file and pooled: a found frame matches an annotation within 0.5 s;"
        );
        let _ = writeln!(
            w,
            "# only found frames from the first to the last annotation (± 0.5 s) count (span = \"whole\""
        );
        let _ = writeln!(w, "# counts those in the unannotated start and end too).");
        let _ = writeln!(
            w,
            "[[evaluate]]\ntype = \"boundary_pr\"\ntolerance = {{ seconds = 0.5 }}\nspan = \"annotated\""
        );
    }
    write_validated(&output, &t)
}

/// The output path, refusing to overwrite without `--force`; its folder.
fn output_path(args: &NewArgs, name: &str) -> Result<(PathBuf, PathBuf)> {
    let output = args.output.clone().unwrap_or_else(|| PathBuf::from(format!("{name}.toml")));
    if output.exists() && !args.force {
        return Err(Error::new(
            ErrorKind::Report,
            "exists; choose another -o or pass --force to overwrite",
        )
        .with_location(Location::file(&output)));
    }
    let out_dir = output
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    Ok((output, out_dir))
}

/// Writes the file, then validates it ("runs as is": every file, plugin and parameter).
fn write_validated(output: &Path, text: &str) -> Result<PathBuf> {
    if let Some(dir) = output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    std::fs::write(output, text).map_err(|e| Error::io(output, e))?;
    motionlab_engine::plan(output, &[])?;
    Ok(output.to_path_buf())
}

/// A `[benchmark]` over channel files (TSSB's `desc.txt` or an annotation CSV as the truth) or
/// motion files (the segmenters that read channels on the fastest marker's speed, beside the
/// Sonoda ones and the PCA baseline).
fn new_benchmark(args: &NewArgs, mut files: Vec<PathBuf>, folder_note: &str) -> Result<PathBuf> {
    let Some(truth_path) = args.truth.as_deref() else {
        return Err(Error::new(
            ErrorKind::MissingKey,
            "a benchmark scores against ground truth: pass --truth (TSSB's desc.txt, a boundaries CSV or an ELAN .eaf)",
        ));
    };
    let base = experiment_name(&args.input);
    let name = format!("{}_benchmark", base.trim_end_matches("_segmentation"));
    let (output, out_dir) = output_path(args, &name)?;
    // TSSB's desc.txt (`name,width,cp,…` per line) names its series; anything else is read as
    // the segmentation scaffold reads annotations.
    let desc = motionlab_io::read::read_text(truth_path)
        .ok()
        .and_then(|t| motionlab_io::labels::tssb_desc::parse_tssb_desc(&t, truth_path).ok());
    let (truth_table, truth_comments, sequences, labelled) = match desc {
        Some(entries) => (
            format!(
                "{{ type = \"tssb_desc\", file = \"{}\" }}",
                toml_path(&relative(&out_dir, truth_path)?)
            ),
            vec![format!("TSSB's desc.txt: {} series with their change points", entries.len())],
            Some(entries.into_iter().map(|e| e.name).collect::<Vec<_>>()),
            // CLaP's folders label each segment's state in properties.txt beside desc.txt.
            truth_path.with_file_name("properties.txt").is_file(),
        ),
        None => {
            let t = truth_spec(truth_path, &out_dir, &files)?;
            (t.table, t.comments, t.sequences, t.labelled)
        }
    };
    let mut skipped = Vec::new();
    if let Some(seqs) = &sequences {
        let (keep, drop): (Vec<PathBuf>, Vec<PathBuf>) =
            files.into_iter().partition(|f| seqs.contains(&motionlab_core::paths::stem(f)));
        if keep.is_empty() {
            return Err(Error::new(
                ErrorKind::UnknownName,
                "the annotations name no file of the input (by its stem)",
            )
            .with_location(Location::file(truth_path)));
        }
        files = keep;
        skipped = drop;
    }
    let (loader_name, loader) = loader_for(&files[0])?;
    let channels = loader_name == "channels";
    // A channel file gives its rate in a time column; without one (a TSSB series) the rate is
    // declared as 1 (times in samples). Any other reason the file cannot be read is the error.
    let (loader_table, n_channels) = if channels {
        channel_loader_table(&files[0], &*loader)?
    } else {
        (format!("{{ type = \"{loader_name}\" }}"), 0)
    };
    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(
        w,
        "# Written by `motionlab new {} --truth {} --benchmark`.",
        args.input,
        truth_path.display()
    );
    let _ = writeln!(w, "# Run it: motionlab run {}", output.display());
    let _ = writeln!(
        w,
        "# Every segmenter at the defaults of its paper or peer library (never tuned on these data):"
    );
    let _ = writeln!(
        w,
        "# covering and TCPDBench F1 per sequence against chance, mean ranks and a critical-difference"
    );
    let _ = writeln!(
        w,
        "# diagram. A segmenter joins with one line in `segmenter = [...]`; `motionlab describe <type>`"
    );
    let _ = writeln!(w, "# documents each.\n");
    let _ = writeln!(w, "[experiment]\nname = \"{name}\"");
    let _ =
        writeln!(w, "description = \"Segmentation benchmark on {}\"", args.input.replace('"', "'"));
    let _ = writeln!(
        w,
        "record_tables = [\"benchmark_covering\", \"benchmark_f1\", \"benchmark_ranks\", \"benchmark_rank_test\"{}]   # runtimes vary run to run\n",
        if labelled { ", \"benchmark_states\"" } else { "" }
    );
    let _ = writeln!(w, "[[dataset]]");
    let _ = writeln!(
        w,
        "# {} file(s), loader `{loader_name}` (from the extension){}.",
        files.len(),
        if folder_note.is_empty() { String::new() } else { format!("; {folder_note}") }
    );
    if !skipped.is_empty() {
        let s: Vec<String> = skipped.iter().map(|p| motionlab_core::paths::stem(p)).collect();
        let _ = writeln!(w, "# Not annotated, so left out: {}.", s.join(", "));
    }
    let listed: Vec<String> = files
        .iter()
        .map(|f| relative(&out_dir, f).map(|p| format!("\"{}\"", toml_path(&p))))
        .collect::<Result<_>>()?;
    let _ = writeln!(w, "files = [{}]", listed.join(", "));
    let _ = writeln!(w, "loader = {loader_table}");
    for c in &truth_comments {
        let _ = writeln!(w, "# Ground truth: {c}.");
    }
    let _ = writeln!(w, "ground_truth = {truth_table}\n");
    let _ = writeln!(w, "[benchmark]");
    let margin = if channels {
        "{ frames = 5 }]                             # TCPDBench's margin, in samples"
    } else {
        "{ seconds = 0.5 }]"
    };
    let _ = writeln!(w, "margins = [{margin}");
    let _ = writeln!(w, "segmenter = [");
    if channels {
        let _ = writeln!(w, "    {{ type = \"clasp\" }},");
        let _ = writeln!(w, "    {{ type = \"kernel_cpd\", name = \"PELT\", search = \"pelt\" }},");
        let _ =
            writeln!(w, "    {{ type = \"kernel_cpd\", name = \"BinSeg\", search = \"binseg\" }},");
        // FLUSS is univariate: only for files of one channel.
        if n_channels == 1 {
            let _ = writeln!(
                w,
                "    {{ type = \"floss\", cac_threshold = 0.45 }},        # FLOSS needs a threshold or a regime count"
            );
        } else {
            let _ = writeln!(
                w,
                "    # floss left out: FLUSS is univariate and these files have {n_channels} channels"
            );
        }
        let _ = writeln!(w, "    {{ type = \"bocpd\" }},");
        let _ = writeln!(w, "    {{ type = \"window\" }},");
    } else {
        let input = "input = { features = [{ type = \"marker_speed\" }] }";
        let _ =
            writeln!(w, "    {{ type = \"clasp\", {input} }},     # on the fastest marker's speed");
        let _ = writeln!(w, "    {{ type = \"kernel_cpd\", {input} }},");
        let _ = writeln!(w, "    {{ type = \"fastest_marker_speed\", name = \"speed\" }},");
        let _ = writeln!(w, "    {{ type = \"hull_volume_change\", name = \"hull\" }},");
        let _ = writeln!(w, "    {{ type = \"pca_error_rise\", name = \"pca\" }},");
    }
    let _ = writeln!(w, "]");
    if labelled {
        let _ = writeln!(
            w,
            "# States: the truth labels its segments, so labellers say which segments are the same motion —"
        );
        let _ = writeln!(
            w,
            "# on the truth's own segments (an oracle segmentation) and on clasp's — scored per sample by"
        );
        let _ = writeln!(
            w,
            "# AMI, ARI and NMI, each beside chance (the same segments, labels permuted): `benchmark_states`."
        );
        let _ = writeln!(w, "label_segments = [\"truth\", \"clasp\"]");
        let _ = writeln!(w, "labeller = [");
        if channels {
            let _ = writeln!(w, "    {{ type = \"segment_clusters\" }},");
        } else {
            let _ = writeln!(
                w,
                "    {{ type = \"segment_clusters\", input = {{ features = [{{ type = \"marker_speed\", per_marker = true }}] }} }},"
            );
            let _ = writeln!(w, "    {{ type = \"multistream_dp\" }},");
        }
        let _ = writeln!(w, "]");
    }
    write_validated(&output, &t)
}

/// The `loader = …` line for a channel file and its number of channels: the rate read from its
/// time column (stated in the comment), else declared as 1 when the file has no time column.
/// A file that cannot be read for any other reason is the error, naming it.
fn channel_loader_table(
    file: &Path,
    loader: &dyn motionlab_core::Loader,
) -> Result<(String, usize)> {
    match loader.load(file) {
        Ok(m) => Ok((
            format!(
                "{{ type = \"channels\" }}                 # rate {} Hz, read from the time_s column of {}",
                crate::inspect::rate_text(m.frame_rate().hz()),
                file.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned())
            ),
            m.channels().n_channels(),
        )),
        Err(e)
            if e.kind() == ErrorKind::MissingKey
                && e.location().field.as_deref() == Some("rate_hz") =>
        {
            let mut params = toml::Table::new();
            params.insert("rate_hz".into(), toml::Value::Float(1.0));
            let params = toml::Value::Table(params);
            let loader = motionlab_core::registry::build_loader("channels", &params)?;
            let m = loader.load(file).map_err(|e| e.in_file(file))?;
            Ok((
                "{ type = \"channels\", rate_hz = 1.0 }                 # no time_s column: one sample per frame; set your rate".to_string(),
                m.channels().n_channels(),
            ))
        }
        Err(e) => Err(e.in_file(file)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hip_and_pelvis_names() {
        for hip in ["Hip_FL", "LASI", "R_IAS", "L_IPS", "RPSI", "LFWT", "rbwt", "hip_left"] {
            assert!(is_hip(hip), "{hip}");
        }
        for other in ["Head_FL", "LKNE", "Sternum", "L_FTC", "Finger_L"] {
            assert!(!is_hip(other), "{other}");
        }
        assert!(is_pelvis("Pelvis") && is_pelvis("SACR") && !is_pelvis("LASI"));
        assert_eq!(experiment_name("data/mct/"), "mct_segmentation");
        assert_eq!(experiment_name("captures/*.c3d"), "c3d_segmentation");
    }

    #[test]
    fn relative_paths() {
        assert_eq!(
            relative(Path::new("/a/b/exp"), Path::new("/a/b/data/x.c3d")).unwrap(),
            PathBuf::from("../data/x.c3d")
        );
        assert_eq!(
            relative(Path::new("/a/b"), Path::new("/a/b/x.c3d")).unwrap(),
            PathBuf::from("x.c3d")
        );
        assert_eq!(
            relative(Path::new("/tmp/q"), Path::new("/work/x.c3d")).unwrap(),
            PathBuf::from("/work/x.c3d")
        );
    }
}
