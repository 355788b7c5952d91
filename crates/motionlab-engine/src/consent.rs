//! Consent before an experiment's external programs run.
//!
//! An experiment file can name programs (the `external` segmenter's `command`), and experiment
//! files are shared, so a file that names one is code from whoever wrote it. Before a run
//! starts anything, [`require`] finds every command line the experiment would run — in every
//! sweep combination, after overrides, wherever a stage table sits in the document — and
//! refuses the run with one error listing them unless the user allowed them:
//!
//! - `--allow-external` on the command line ([`ExternalPolicy::allow_external`]): this run only;
//! - a trust record ([`TrustStore`]), written by `motionlab trust EXPERIMENT.toml`: the SHA-256
//!   of the experiment's command lines, kept in the user's configuration folder
//!   (`$MOTIONLAB_CONFIG_DIR`, else `$XDG_CONFIG_HOME/motionlab`, else `~/.config/motionlab`)
//!   under the experiment's canonical path. It holds while the command lines are exactly the
//!   ones trusted: change one (in the file, by an override, by a sweep grid) and the record no
//!   longer matches.
//!
//! Once allowed, the command lines are handed to [`motionlab_core::programs::allow`], which the
//! plugins ask before they start a process. A stage declares that it runs a program with the
//! `x-runs-program` schema extension naming its command key
//! ([`motionlab_core::programs::RUNS_PROGRAM_KEY`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use motionlab_core::{Error, ErrorKind, Location, Result, programs, registry};

use crate::plan::{Combo, Plan};
use crate::rundir::{sha256_bytes, utc_iso, write_atomic};

/// The environment variable naming the configuration folder (trust records), for tests and for
/// users who keep configuration elsewhere.
pub const CONFIG_DIR_ENV: &str = "MOTIONLAB_CONFIG_DIR";

/// One program an experiment would start.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExternalCommand {
    /// Where the stage is in the (overridden, swept) document: `segmentation.segmenter[1]`.
    pub at: String,
    /// The plugin that runs it (`external`).
    pub plugin: String,
    /// The program and its arguments, as given.
    pub command: Vec<String>,
}

impl ExternalCommand {
    /// The command as a user reads it, control characters escaped.
    pub fn command_line(&self) -> String {
        programs::command_line(&self.command)
    }
}

/// Every program the plan's combinations would start, in document order, each (place,
/// command line) once.
pub fn external_commands(plan: &Plan) -> Vec<ExternalCommand> {
    commands_of(&plan.combos)
}

/// [`external_commands`] of sweep combinations (the documents after overrides and sweeping).
pub fn commands_of(combos: &[Combo]) -> Vec<ExternalCommand> {
    let mut out: Vec<ExternalCommand> = Vec::new();
    // Plugin name → its command key, looked up once (a schema is generated per lookup).
    let mut keys: HashMap<String, Option<String>> = HashMap::new();
    for combo in combos {
        for (key, value) in &combo.doc {
            walk(value, key.clone(), &mut keys, &mut out);
        }
    }
    out
}

/// Collects the command of every stage table (a table with a `type` naming a plugin that
/// declares a program key) under `value`, at any depth.
fn walk(
    value: &toml::Value,
    at: String,
    keys: &mut HashMap<String, Option<String>>,
    out: &mut Vec<ExternalCommand>,
) {
    match value {
        toml::Value::Table(t) => {
            if let Some(toml::Value::String(plugin)) = t.get("type")
                && let Some(key) =
                    keys.entry(plugin.clone()).or_insert_with(|| program_key(plugin)).clone()
                && let Some(toml::Value::Array(args)) = t.get(&key)
            {
                let command: Vec<String> = args
                    .iter()
                    .map(|a| a.as_str().map(str::to_string).unwrap_or_else(|| a.to_string()))
                    .collect();
                let found = ExternalCommand { at: at.clone(), plugin: plugin.clone(), command };
                if !out.contains(&found) {
                    out.push(found);
                }
            }
            for (k, v) in t {
                walk(v, format!("{at}.{k}"), keys, out);
            }
        }
        toml::Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                walk(v, format!("{at}[{i}]"), keys, out);
            }
        }
        _ => {}
    }
}

/// The command key of a registered plugin (of a built-in or a custom kind) that runs a program.
fn program_key(plugin: &str) -> Option<String> {
    if let Ok(entry) = registry::find(plugin) {
        return programs::program_key(&(entry.schema)());
    }
    registry::find_custom(plugin).and_then(|entry| programs::program_key(&(entry.schema)()))
}

/// The SHA-256 (hex) of a set of command lines: the distinct command lines, sorted, as JSON
/// (so `["a b"]` and `["a", "b"]` differ).
pub fn commands_sha256(commands: &[ExternalCommand]) -> String {
    let mut lines: Vec<&Vec<String>> = commands.iter().map(|c| &c.command).collect();
    lines.sort();
    lines.dedup();
    sha256_bytes(serde_json::to_string(&lines).unwrap_or_default().as_bytes())
}

/// How a run may start external programs.
#[derive(Clone, Debug)]
pub struct ExternalPolicy {
    /// `--allow-external`: every command line of this run is allowed.
    pub allow_external: bool,
    /// Where trust records are kept (`None`: no configuration folder, so no record counts).
    pub trust: Option<TrustStore>,
}

impl Default for ExternalPolicy {
    fn default() -> Self {
        ExternalPolicy { allow_external: false, trust: TrustStore::open_default() }
    }
}

/// Why a run may start its external programs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Consent {
    /// It names none.
    NotNeeded,
    /// `--allow-external`.
    Flag,
    /// A trust record (its file).
    Trusted(PathBuf),
}

impl Consent {
    /// For provenance and the run page.
    pub fn describe(&self) -> String {
        match self {
            Consent::NotNeeded => "no external program".into(),
            Consent::Flag => "allowed by --allow-external".into(),
            Consent::Trusted(p) => format!("allowed by the trust record {}", p.display()),
        }
    }
}

/// Checks that every program `plan` would start is allowed, and allows them in this process
/// ([`programs::allow`]); otherwise one error listing every command line and how to allow
/// them, and nothing is started. Returns the command lines with the consent that allowed them
/// (a run's provenance records both).
pub fn require(plan: &Plan, policy: &ExternalPolicy) -> Result<(Vec<ExternalCommand>, Consent)> {
    let commands = external_commands(plan);
    let consent = check(&plan.source.path, &commands, policy)?;
    programs::allow(commands.iter().map(|c| c.command.as_slice()));
    Ok((commands, consent))
}

/// [`require`] without allowing anything: whether `commands`, the programs of the experiment
/// at `path`, may run.
pub fn check(
    path: &Path,
    commands: &[ExternalCommand],
    policy: &ExternalPolicy,
) -> Result<Consent> {
    if commands.is_empty() {
        return Ok(Consent::NotNeeded);
    }
    if policy.allow_external {
        return Ok(Consent::Flag);
    }
    let status = match &policy.trust {
        Some(store) => store.status(path, commands)?,
        None => TrustStatus::None,
    };
    if let TrustStatus::Trusted(record) = status {
        return Ok(Consent::Trusted(record));
    }
    let listed: Vec<String> = commands
        .iter()
        .map(|c| format!("`{}` ({}, {})", c.command_line(), c.at, c.plugin))
        .collect();
    let changed = match status {
        TrustStatus::Changed { trusted_utc } => format!(
            " (you trusted this file on {trusted_utc}, but its command lines have changed since)"
        ),
        _ => String::new(),
    };
    let shown = programs::shell_word(&path.display().to_string());
    let store_hint = if policy.trust.is_none() {
        format!(" (needs a configuration folder: set {CONFIG_DIR_ENV} or HOME)")
    } else {
        String::new()
    };
    Err(Error::new(
        ErrorKind::NotAllowed,
        format!(
            "names {} external program{} that motionlab starts only with your consent{changed}: {}. Nothing was started. Read {}; then allow {} for one run with --allow-external, or until a command line changes with `motionlab trust {shown}`{store_hint}",
            commands.len(),
            if commands.len() == 1 { "" } else { "s" },
            listed.join("; "),
            if commands.len() == 1 { "it" } else { "them" },
            if commands.len() == 1 { "it" } else { "them" },
        ),
    )
    .with_location(Location::file(path)))
}

/// Trust records in the user's configuration folder: `<dir>/trust/<sha256 of the experiment's
/// canonical path>.json`.
#[derive(Clone, Debug)]
pub struct TrustStore {
    dir: PathBuf,
}

/// What a trust record says about an experiment's current command lines.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TrustStatus {
    /// No record.
    None,
    /// A record for exactly these command lines.
    Trusted(PathBuf),
    /// A record for other command lines (one changed): it does not count.
    Changed { trusted_utc: String },
}

/// One trust record.
#[derive(Serialize, Deserialize)]
struct TrustRecord {
    experiment: PathBuf,
    commands_sha256: String,
    /// The command lines trusted, for the user who reads the folder.
    commands: Vec<ExternalCommand>,
    trusted_utc: String,
}

impl TrustStore {
    /// The store in `dir` (created when the first record is written).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        TrustStore { dir: dir.into() }
    }

    /// `$MOTIONLAB_CONFIG_DIR`, else `$XDG_CONFIG_HOME/motionlab`, else
    /// `$HOME/.config/motionlab`; `None` when none is set.
    pub fn open_default() -> Option<Self> {
        let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
        let dir = var(CONFIG_DIR_ENV)
            .or_else(|| var("XDG_CONFIG_HOME").map(|d| d.join("motionlab")))
            .or_else(|| var("HOME").map(|h| h.join(".config").join("motionlab")))?;
        Some(TrustStore::new(dir))
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn canonical(experiment: &Path) -> Result<PathBuf> {
        std::fs::canonicalize(experiment).map_err(|e| Error::io(experiment, e))
    }

    /// The record file of an experiment.
    pub fn record_path(&self, experiment: &Path) -> Result<PathBuf> {
        let canonical = Self::canonical(experiment)?;
        Ok(self
            .dir
            .join("trust")
            .join(format!("{}.json", sha256_bytes(canonical.as_os_str().as_encoded_bytes()))))
    }

    /// Whether the record of `experiment` covers exactly `commands`.
    pub fn status(&self, experiment: &Path, commands: &[ExternalCommand]) -> Result<TrustStatus> {
        let path = self.record_path(experiment)?;
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(TrustStatus::None),
            Err(e) => return Err(Error::io(&path, e)),
        };
        // A damaged record counts as none: trust is never granted on what cannot be read.
        let Ok(record) = serde_json::from_slice::<TrustRecord>(&bytes) else {
            return Ok(TrustStatus::None);
        };
        if record.experiment != Self::canonical(experiment)? {
            return Ok(TrustStatus::None);
        }
        Ok(if record.commands_sha256 == commands_sha256(commands) {
            TrustStatus::Trusted(path)
        } else {
            TrustStatus::Changed { trusted_utc: record.trusted_utc }
        })
    }

    /// Records that the user trusts `commands`, the programs of `experiment`; returns the record.
    pub fn trust(&self, experiment: &Path, commands: &[ExternalCommand]) -> Result<PathBuf> {
        let path = self.record_path(experiment)?;
        let record = TrustRecord {
            experiment: Self::canonical(experiment)?,
            commands_sha256: commands_sha256(commands),
            commands: commands.to_vec(),
            trusted_utc: utc_iso(std::time::SystemTime::now()),
        };
        let dir = self.dir.join("trust");
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let json = serde_json::to_vec_pretty(&record)
            .map_err(|e| Error::new(ErrorKind::Report, format!("cannot write JSON: {e}")))?;
        write_atomic(&path, &json)?;
        Ok(path)
    }

    /// Removes the record of `experiment`; whether there was one.
    pub fn revoke(&self, experiment: &Path) -> Result<bool> {
        let path = self.record_path(experiment)?;
        match std::fs::remove_file(&path) {
            Ok(()) => Ok(true),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
            Err(e) => Err(Error::io(&path, e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(at: &str, args: &[&str]) -> ExternalCommand {
        ExternalCommand {
            at: at.into(),
            plugin: "external".into(),
            command: args.iter().map(|s| s.to_string()).collect(),
        }
    }

    #[test]
    fn the_hash_covers_the_command_lines_not_their_places() {
        let a = [cmd("x[0]", &["sh", "-c", "a b"]), cmd("x[1]", &["sh", "-c", "a b"])];
        let b = [cmd("y[3]", &["sh", "-c", "a b"])];
        assert_eq!(commands_sha256(&a), commands_sha256(&b));
        assert_ne!(commands_sha256(&b), commands_sha256(&[cmd("y[3]", &["sh", "-c", "a", "b"])]));
    }

    #[test]
    fn a_record_holds_until_a_command_line_changes() {
        let dir = tempfile::tempdir().unwrap();
        let exp = dir.path().join("e.toml");
        std::fs::write(&exp, "").unwrap();
        let store = TrustStore::new(dir.path().join("config"));
        let policy = ExternalPolicy { allow_external: false, trust: Some(store.clone()) };
        let cmds = vec![cmd("s[0]", &["python3", "seg.py"])];
        let e = check(&exp, &cmds, &policy).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NotAllowed);
        assert!(
            e.to_string().contains("`python3 seg.py` (s[0], external)")
                && e.to_string().contains("motionlab trust"),
            "{e}"
        );
        assert_eq!(
            check(&exp, &cmds, &ExternalPolicy { allow_external: true, trust: None }).unwrap(),
            Consent::Flag
        );
        assert_eq!(check(&exp, &[], &policy).unwrap(), Consent::NotNeeded);
        let record = store.trust(&exp, &cmds).unwrap();
        assert_eq!(check(&exp, &cmds, &policy).unwrap(), Consent::Trusted(record));
        let changed = vec![cmd("s[0]", &["python3", "seg.py", "--fast"])];
        assert!(matches!(store.status(&exp, &changed).unwrap(), TrustStatus::Changed { .. }));
        assert!(
            check(&exp, &changed, &policy).unwrap_err().to_string().contains("have changed since")
        );
        // Another file with the same commands is not trusted by this one's record.
        let other = dir.path().join("f.toml");
        std::fs::write(&other, "").unwrap();
        assert_eq!(store.status(&other, &cmds).unwrap(), TrustStatus::None);
        assert!(store.revoke(&exp).unwrap());
        assert_eq!(store.status(&exp, &cmds).unwrap(), TrustStatus::None);
    }
}
