//! `motionlab`: declare motion-capture experiments in TOML, run them on real data, get tables
//! and figures in a fresh run directory.
//!
//! A library so that a researcher's own plugin crates can be linked into a `motionlab`
//! command of their own (examples/plugin-template/):
//!
//! ```ignore
//! use your_plugins as _; // names the plugin crate so the linker keeps its registrations
//!
//! fn main() -> std::process::ExitCode {
//!     motionlab_cli::main()
//! }
//! ```

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

// Every plugin and workflow crate, named once in the bundle (crates/motionlab-plugins): naming
// it keeps the linker from dropping their `inventory` registrations.
use motionlab_plugins as _;

use motionlab_core::{Error, ErrorKind, Result};
use motionlab_engine::RunSummary;
use motionlab_engine::consent::{ExternalCommand, TrustStore};
use motionlab_engine::front::{RunChoices, external_policy};

mod convert;
mod export;
pub mod inspect;
mod live;
mod new;
mod plugin;
// Their old paths: they live in the engine now, shared with the Python package.
pub use motionlab_engine::{describe, progress};
mod slurm;

#[derive(Parser)]
#[command(
    name = "motionlab",
    version,
    about = "Motion-capture experiments from TOML: segmentation, multistream matching, walk analysis"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run an experiment into a fresh run directory.
    Run {
        /// The experiment file.
        experiment: PathBuf,
        /// Dotted overrides: `segmentation.fuser.merge_mm=200`.
        overrides: Vec<String>,
        #[command(flatten)]
        opts: RunArgs,
        /// Compute only shard `i/n` of the work items (needs --run-dir shared by all shards).
        #[arg(long, value_parser = parse_shard)]
        shard: Option<(usize, usize)>,
        /// Run directory (shared by shards; default: a fresh one under --reports).
        #[arg(long)]
        run_dir: Option<PathBuf>,
    },
    /// Check every file, plugin and parameter of an experiment without running it, and list
    /// the external programs it names (an error unless they are allowed).
    Validate {
        experiment: PathBuf,
        overrides: Vec<String>,
        /// Allow the external programs the experiment names (as `run --allow-external` would).
        #[arg(long)]
        allow_external: bool,
    },
    /// Allow the external programs an experiment names, until any of their command lines
    /// changes: stores the SHA-256 of the command lines in the configuration folder
    /// (`$MOTIONLAB_CONFIG_DIR`, else `$XDG_CONFIG_HOME/motionlab`, else `~/.config/motionlab`).
    Trust {
        experiment: PathBuf,
        /// Overrides that change a command line, to trust the run that uses them.
        overrides: Vec<String>,
        /// Remove the experiment's trust record instead.
        #[arg(long)]
        revoke: bool,
    },
    /// List every registered workflow and plugin by kind.
    List,
    /// Print a workflow's or a plugin's documentation and parameters.
    Describe {
        /// The workflow's section (`segmentation`) or the plugin's registered name (`bvh`, `fastest_marker_speed`, …).
        name: String,
    },
    /// Run every experiment in a folder (default `experiments/`) into `reports/`.
    Reproduce {
        /// Folder of experiment files.
        #[arg(long, default_value = "experiments")]
        experiments: PathBuf,
        #[command(flatten)]
        opts: RunArgs,
        /// Also copy each run to `reports/<experiment>/record/` (the runs of record, committed).
        #[arg(long)]
        record: bool,
        /// Run only experiments whose name contains this text.
        #[arg(long)]
        only: Option<String>,
    },
    /// Write a commented segmentation experiment for a folder or glob of motion files (and
    /// their annotations) that runs as is.
    New {
        /// A folder of motion files, or a glob (`captures/*.c3d`).
        input: String,
        /// Annotations: a `.csv` (boundaries_csv) or an ELAN `.eaf` (elan_eaf).
        #[arg(long)]
        truth: Option<PathBuf>,
        /// The experiment file to write (default `<folder>_segmentation.toml`).
        #[arg(short = 'o', long = "output")]
        output: Option<PathBuf>,
        /// Overwrite the output file if it exists.
        #[arg(long)]
        force: bool,
        /// Write a segmentation benchmark (every segmenter that reads channels, covering and F1
        /// against chance, mean ranks, the critical-difference diagram); implied by channel
        /// files (.txt/.csv/.npy series). Needs --truth.
        #[arg(long)]
        benchmark: bool,
    },
    /// Describe motion files: format, frames, rate, duration, points, missing samples, length
    /// unit and standing height, what the loader repaired, events, channels (a C3D's analog
    /// channels with their rate and units).
    Inspect {
        files: Vec<PathBuf>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Also write each file's positions (mm, NaN = missing) to DIR/<n>.npy, numbering the
        /// files from 0 in the order given (float64, frames × points × 3); its channels to
        /// DIR/<n>.channels.npy and a marker C3D's analog channels to DIR/<n>.analog.npy
        /// (samples × channels).
        #[arg(long, value_name = "DIR")]
        npy: Option<PathBuf>,
    },
    /// Convert a motion file by the output's extension: marker motions (TRC, C3D, TSV) and
    /// skeleton motions (BVH, ASF/AMC: their joint positions) to OpenSim `.trc` or `.csv`
    /// (`frame,time_s,<point>_x_mm,…`); channel motions (MOT/STO, channel files) to `.csv`
    /// (`time_s,<channel>,…`). Missing samples are `NaN` in TRC, empty cells in CSV.
    Convert {
        input: PathBuf,
        output: PathBuf,
        /// The TRC's length unit (`mm`, `cm`, `m`, `in`); OpenSim models are in metres.
        #[arg(long, default_value = "mm")]
        units: String,
    },
    /// Combine the shards of a sharded run into the tables and figures of a plain run.
    Merge {
        run_dir: PathBuf,
        #[command(flatten)]
        opts: RunArgs,
    },
    /// Write a Slurm job array (one task per shard) and a merge job that waits for it.
    Slurm {
        experiment: PathBuf,
        overrides: Vec<String>,
        /// Number of shards (array tasks).
        #[arg(long)]
        shards: usize,
        /// Shared run directory (default: a new one under --reports).
        #[arg(long)]
        run_dir: Option<PathBuf>,
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
        #[arg(long)]
        partition: Option<String>,
        /// Wall-time limit per task (`HH:MM:SS`).
        #[arg(long)]
        time: Option<String>,
        /// Memory per task (`4G`).
        #[arg(long)]
        mem: Option<String>,
        /// Threads per task.
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Submit with sbatch and print the job ids.
        #[arg(long)]
        submit: bool,
        /// Allow the external programs the experiment names, here and in the job scripts.
        #[arg(long)]
        allow_external: bool,
    },
    /// Parameter and metric differences between two runs of one experiment (text and HTML).
    Compare { run_a: PathBuf, run_b: PathBuf },
    /// The on-disk cache of loaded motions and stage outputs (`$MOTIONLAB_CACHE_DIR`, else
    /// `$XDG_CACHE_HOME/motionlab`, else `~/.cache/motionlab`).
    Cache {
        #[command(subcommand)]
        action: CacheAction,
    },
    /// Rebuild reports/index.html from experiments/ and the runs under reports/.
    Index {
        #[arg(long, default_value = "experiments")]
        experiments: PathBuf,
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
        /// Link the committed runs of record rather than the latest runs.
        #[arg(long)]
        records: bool,
    },
    /// Write a segmentation run's ground truth and each method's candidates as annotation
    /// files, one per sequence (one tier or annotator per method plus `truth`), to correct in
    /// ELAN and read back as ground truth.
    Export {
        run_dir: PathBuf,
        #[arg(long, value_enum)]
        format: export::ExportFormat,
        /// Folder to write into (default `<run_dir>/export/`).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Segment samples as they arrive with a streaming segmenter (`bocpd_online`,
    /// `fastest_marker_speed_online`, …): from standard input or a local TCP socket (JSON lines:
    /// a header, then one sample per line, then `{"end": true}`), or a motion file replayed at
    /// its capture rate; each boundary is printed as a JSON line the moment it is decided.
    Live(live::LiveArgs),
    /// Start a new plugin: `motionlab plugin new NAME --kind segmenter|extractor|evaluator`.
    Plugin {
        #[command(subcommand)]
        command: plugin::PluginCommand,
    },
}

#[derive(Subcommand)]
enum CacheAction {
    /// Where the cache is, its entries and bytes per kind.
    Info,
    /// Remove every entry (and temporary files of interrupted writes).
    Clear,
}

#[derive(clap::Args, Clone)]
struct RunArgs {
    /// Folder holding `<experiment>/<run-id>/`.
    #[arg(long, default_value = "reports")]
    reports: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bars.
    #[arg(long, short)]
    quiet: bool,
    /// Neither read nor write the on-disk cache of loaded motions and stage outputs (each
    /// input is still loaded once per run).
    #[arg(long)]
    no_cache: bool,
    /// Allow the programs the experiment names (`type = "external"` stages) to run, for this
    /// run only; `motionlab trust EXPERIMENT` allows them until a command line changes.
    #[arg(long)]
    allow_external: bool,
}

fn parse_shard(s: &str) -> std::result::Result<(usize, usize), String> {
    let (i, n) = s.split_once('/').ok_or_else(|| format!("expected i/n, found {s:?}"))?;
    let i: usize = i.trim().parse().map_err(|_| format!("shard index {i:?} is not a number"))?;
    let n: usize = n.trim().parse().map_err(|_| format!("shard count {n:?} is not a number"))?;
    if n == 0 || i >= n {
        return Err(format!("expected 0 <= i < n, found {i}/{n}"));
    }
    Ok((i, n))
}

fn options(args: &RunArgs) -> motionlab_engine::RunOptions {
    RunChoices {
        reports: args.reports.clone(),
        threads: args.threads,
        quiet: args.quiet,
        no_cache: args.no_cache,
        allow_external: args.allow_external,
    }
    .options(std::env::args().collect())
}

/// The external programs of a plan, one line each, for `validate` and `trust`.
fn print_external(commands: &[ExternalCommand], consent: &str) {
    if commands.is_empty() {
        println!("external programs: none");
        return;
    }
    println!("external programs ({consent}):");
    for c in commands {
        println!("  {} ({}): {}", c.at, c.plugin, c.command_line());
    }
}

/// The `motionlab` command on this process's arguments, with every plugin linked into the binary.
pub fn main() -> ExitCode {
    main_with(std::env::args_os())
}

/// The `motionlab` command on `args` (the first is the program name); `--help`, `--version`
/// and usage errors print and exit as clap does. A run's provenance records the process's own
/// command line (`std::env::args`).
pub fn main_with<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = Cli::parse_from(args);
    match dispatch(cli.command) {
        Ok(code) => code,
        Err(e) => {
            // One line, naming the file and line/field: the contract of every motionlab error.
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn dispatch(command: Command) -> Result<ExitCode> {
    match command {
        Command::Run { experiment, overrides, opts, shard, run_dir } => {
            let mut o = options(&opts);
            o.shard = shard;
            o.run_dir = run_dir;
            let summary = motionlab_engine::run_file(&experiment, &overrides, &o)?;
            print_summary(&summary);
            Ok(ExitCode::SUCCESS)
        }
        Command::Validate { experiment, overrides, allow_external } => {
            let v = motionlab_engine::front::validate(&experiment, &overrides, allow_external)?;
            println!(
                "{}: valid — {} workflow, {} dataset(s), {} input file(s), {} combination(s), {} work item(s)",
                experiment.display(),
                v.workflow,
                v.datasets,
                v.input_files,
                v.combinations,
                v.items
            );
            print_external(&v.external, &v.consent);
            Ok(ExitCode::SUCCESS)
        }
        Command::Trust { experiment, overrides, revoke } => trust(&experiment, &overrides, revoke),
        Command::List => {
            print!("{}", describe::list());
            Ok(ExitCode::SUCCESS)
        }
        Command::Describe { name } => {
            print!("{}", describe::describe(&name)?);
            Ok(ExitCode::SUCCESS)
        }
        Command::Reproduce { experiments, opts, record, only } => {
            reproduce(&experiments, &opts, record, only.as_deref())
        }
        Command::Inspect { files, json, npy } => inspect::inspect(&files, json, npy.as_deref()),
        Command::Convert { input, output, units } => {
            let unit = motionlab_core::LengthUnit::from_label(&units).ok_or_else(|| {
                Error::new(
                    ErrorKind::InvalidParameter,
                    format!("--units {units:?}; expected mm, cm, m or in"),
                )
            })?;
            let c = convert::convert(&input, &output, unit)?;
            println!("wrote {} ({} frames, {} {})", output.display(), c.frames, c.columns, c.what);
            Ok(ExitCode::SUCCESS)
        }
        Command::New { input, truth, output, force, benchmark } => {
            let path =
                new::new_experiment(&new::NewArgs { input, truth, output, force, benchmark })?;
            println!(
                "wrote {} (valid); run it with: motionlab run {}",
                path.display(),
                path.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Merge { run_dir, opts } => {
            let summary = motionlab_engine::merge(&run_dir, &options(&opts))?;
            print_summary(&summary);
            Ok(ExitCode::SUCCESS)
        }
        Command::Slurm {
            experiment,
            overrides,
            shards,
            run_dir,
            reports,
            partition,
            time,
            mem,
            threads,
            submit,
            allow_external,
        } => {
            if shards == 0 {
                return Err(Error::new(ErrorKind::OutOfRange, "--shards must be at least 1"));
            }
            // Validate now, on the login node, rather than in N failing array tasks — consent
            // too (the tasks check it again: a trust record must be readable there).
            let plan = motionlab_engine::plan(&experiment, &overrides)?;
            motionlab_engine::consent::check(
                &plan.source.path,
                &motionlab_engine::consent::external_commands(&plan),
                &external_policy(allow_external),
            )?;
            let run_dir = match run_dir {
                Some(d) => d,
                None => {
                    let stamp = motionlab_engine::rundir::utc_stamp(std::time::SystemTime::now());
                    reports
                        .join(&plan.file.experiment.name)
                        .join(format!("{stamp}-slurm-p{}", std::process::id()))
                }
            };
            let abs = |p: &Path| std::path::absolute(p).map_err(|e| Error::io(p, e));
            let job = slurm::SlurmJob {
                experiment: abs(&experiment)?,
                overrides,
                shards,
                run_dir: abs(&run_dir)?,
                partition,
                time,
                mem,
                threads,
                allow_external,
                binary: std::env::current_exe().map_err(|e| {
                    Error::new(ErrorKind::Io, format!("cannot locate the motionlab binary: {e}"))
                })?,
            };
            let (array, merge) = slurm::write_scripts(&job)?;
            println!("wrote {} and {}", array.display(), merge.display());
            if submit {
                let (a, m) = slurm::submit(&array, &merge)?;
                println!(
                    "submitted shard array job {a} ({shards} tasks) and merge job {m} (afterok:{a})"
                );
                println!("results: {}", job.run_dir.display());
            } else {
                println!(
                    "submit with: sbatch {}  then  sbatch --dependency=afterok:<array id> {}",
                    array.display(),
                    merge.display()
                );
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Compare { run_a, run_b } => {
            let page = motionlab_engine::compare::compare(&run_a, &run_b)?;
            print!("{}", motionlab_engine::compare::compare_text(&page));
            let path = motionlab_engine::compare::write_compare(&run_a, &run_b, &page)?;
            println!("wrote {}", path.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Cache { action } => {
            let Some(cache) = motionlab_cache::Cache::open_default() else {
                return Err(Error::new(
                    ErrorKind::MissingKey,
                    "no cache folder: set MOTIONLAB_CACHE_DIR (or HOME)",
                ));
            };
            let io = |e: std::io::Error| Error::io(cache.dir(), e);
            match action {
                CacheAction::Info => {
                    let info = cache.info().map_err(io)?;
                    println!("cache: {}", cache.dir().display());
                    for (kind, n, bytes) in &info.kinds {
                        println!("  {kind}: {n} entries, {bytes} bytes");
                    }
                    println!(
                        "total: {} entries, {} bytes ({:.1} MiB)",
                        info.entries,
                        info.bytes,
                        info.bytes as f64 / 1048576.0
                    );
                    if info.temporary > 0 {
                        println!(
                            "{} temporary file(s) of interrupted writes (never read; `motionlab cache clear` removes them)",
                            info.temporary
                        );
                    }
                }
                CacheAction::Clear => {
                    let info = cache.clear().map_err(io)?;
                    println!(
                        "removed {} entries ({} bytes) from {}",
                        info.entries,
                        info.bytes,
                        cache.dir().display()
                    );
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Index { experiments, reports, records } => {
            let p =
                motionlab_report::pages::write_reproduction_index(&experiments, &reports, records)?;
            println!("wrote {}", p.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Export { run_dir, format, out } => {
            for path in export::export(&run_dir, format, out.as_deref())? {
                println!("wrote {}", path.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Live(args) => live::run(&args),
        Command::Plugin { command } => {
            plugin::run(command)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn print_summary(s: &RunSummary) {
    if s.complete {
        println!(
            "{}: {} item(s), {} table file(s), {} figure file(s)",
            s.run_dir.display(),
            s.items,
            s.written.tables.len(),
            s.written.figures.len()
        );
    } else {
        println!(
            "{}: shard done ({} item(s)); run `motionlab merge {}` when every shard has finished",
            s.run_dir.display(),
            s.items,
            s.run_dir.display()
        );
    }
}

/// `motionlab trust`: validates the experiment, lists its programs and records (or removes)
/// the user's trust in exactly these command lines.
fn trust(experiment: &Path, overrides: &[String], revoke: bool) -> Result<ExitCode> {
    let store = TrustStore::open_default().ok_or_else(|| {
        Error::new(
            ErrorKind::MissingKey,
            format!(
                "no configuration folder: set {} (or HOME)",
                motionlab_engine::consent::CONFIG_DIR_ENV
            ),
        )
    })?;
    if revoke {
        let removed = store.revoke(experiment)?;
        println!(
            "{}: {}",
            experiment.display(),
            if removed { "trust record removed" } else { "had no trust record" }
        );
        return Ok(ExitCode::SUCCESS);
    }
    let plan = motionlab_engine::plan(experiment, overrides)?;
    let commands = motionlab_engine::consent::external_commands(&plan);
    if commands.is_empty() {
        println!("{}: names no external program; nothing to trust", experiment.display());
        return Ok(ExitCode::SUCCESS);
    }
    let record = store.trust(experiment, &commands)?;
    print_external(&commands, "trusted");
    println!(
        "wrote {}: these command lines may run until one of them changes (`motionlab trust --revoke {}` removes it)",
        record.display(),
        experiment.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Every `*.toml` in the folder, sorted.
fn experiment_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    Ok(files)
}

fn reproduce(dir: &Path, args: &RunArgs, record: bool, only: Option<&str>) -> Result<ExitCode> {
    let files = experiment_files(dir)?;
    let files: Vec<PathBuf> = files
        .into_iter()
        .filter(|f| only.is_none_or(|o| f.to_string_lossy().contains(o)))
        .collect();
    if files.is_empty() {
        return Err(Error::new(
            ErrorKind::Io,
            format!("no experiment files (*.toml) in {}", dir.display()),
        ));
    }
    // Validate everything first: a typo in the last experiment fails before an hour of work.
    let plans = files.iter().map(|f| motionlab_engine::plan(f, &[])).collect::<Result<Vec<_>>>()?;
    let opts = options(args);
    // Consent too, for every experiment, before the first one runs.
    for plan in &plans {
        motionlab_engine::consent::check(
            &plan.source.path,
            &motionlab_engine::consent::external_commands(plan),
            &opts.external,
        )?;
    }
    for (f, plan) in files.iter().zip(&plans) {
        let started = std::time::Instant::now();
        let summary = motionlab_engine::run(plan, &opts)?;
        println!("{} ({:.1} s)", f.display(), started.elapsed().as_secs_f64());
        print_summary(&summary);
        if record {
            let dest = args.reports.join(&plan.file.experiment.name).join("record");
            motionlab_report::pages::write_record(&summary.run_dir, &dest, &plan.file)?;
            println!("  recorded into {}", dest.display());
        }
    }
    let index = motionlab_report::pages::write_reproduction_index(dir, &args.reports, record)?;
    println!("wrote {}", index.display());
    Ok(ExitCode::SUCCESS)
}
