//! `motionlab slurm`: a Slurm job array of shard tasks plus a merge job that waits for them
//! (`--dependency=afterok`). motionlab does not schedule anything itself: clusters already run
//! Slurm, and it is better at it.

use std::path::{Path, PathBuf};
use std::process::Command;

use motionlab_core::programs::shell_word;
use motionlab_core::{Error, ErrorKind, Location, Result};

/// What to put in the job scripts.
pub struct SlurmJob {
    pub experiment: PathBuf,
    pub overrides: Vec<String>,
    pub shards: usize,
    pub run_dir: PathBuf,
    pub partition: Option<String>,
    pub time: Option<String>,
    pub mem: Option<String>,
    pub threads: usize,
    /// Pass `--allow-external` to the shard and merge commands (the user gave it to `slurm`).
    pub allow_external: bool,
    pub binary: PathBuf,
}

/// `#SBATCH` lines must all come before the first command: sbatch stops reading them there.
fn header(job: &SlurmJob, name: &str, log: &str, extra: &[String]) -> String {
    let mut s = String::from("#!/usr/bin/env bash\n");
    s += &format!("#SBATCH --job-name={name}\n");
    s += &format!("#SBATCH --output={log}\n");
    s += &format!("#SBATCH --cpus-per-task={}\n", job.threads);
    if let Some(p) = &job.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &job.time {
        s += &format!("#SBATCH --time={t}\n");
    }
    if let Some(m) = &job.mem {
        s += &format!("#SBATCH --mem={m}\n");
    }
    for e in extra {
        s += &format!("#SBATCH {e}\n");
    }
    s += "set -euo pipefail\n";
    s
}

/// The array script (one task per shard) and the merge script.
pub fn scripts(job: &SlurmJob) -> (String, String) {
    let dir = job.run_dir.to_string_lossy();
    let bin = shell_word(&job.binary.to_string_lossy());
    let overrides: String = job.overrides.iter().map(|o| format!(" {}", shell_word(o))).collect();
    let allow = if job.allow_external { " --allow-external" } else { "" };
    let mut array = header(
        job,
        "motionlab-shard",
        &format!("{dir}/slurm/shard-%a.log"),
        &[format!("--array=0-{}", job.shards - 1)],
    );
    array += &format!(
        "exec {bin} run {}{overrides} --quiet{allow} --threads {} --shard \"$SLURM_ARRAY_TASK_ID/{}\" --run-dir {}\n",
        shell_word(&job.experiment.to_string_lossy()),
        job.threads,
        job.shards,
        shell_word(&dir)
    );
    let mut merge = header(job, "motionlab-merge", &format!("{dir}/slurm/merge.log"), &[]);
    merge += &format!(
        "exec {bin} merge --quiet{allow} --threads {} {}\n",
        job.threads,
        shell_word(&dir)
    );
    (array, merge)
}

/// Writes both scripts into `<run_dir>/slurm/` and returns their paths.
pub fn write_scripts(job: &SlurmJob) -> Result<(PathBuf, PathBuf)> {
    let dir = job.run_dir.join("slurm");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let (array, merge) = scripts(job);
    let a = dir.join("shards.sbatch");
    let m = dir.join("merge.sbatch");
    std::fs::write(&a, array).map_err(|e| Error::io(&a, e))?;
    std::fs::write(&m, merge).map_err(|e| Error::io(&m, e))?;
    Ok((a, m))
}

/// `sbatch --parsable` a script, returning the job id.
fn sbatch(args: &[&str], script: &Path) -> Result<String> {
    let out =
        Command::new("sbatch").arg("--parsable").args(args).arg(script).output().map_err(|e| {
            Error::new(ErrorKind::Io, format!("cannot run sbatch (is Slurm installed?): {e}"))
                .with_location(Location::file(script))
        })?;
    if !out.status.success() {
        return Err(Error::new(
            ErrorKind::Report,
            format!("sbatch failed: {}", String::from_utf8_lossy(&out.stderr).trim()),
        )
        .with_location(Location::file(script)));
    }
    // `--parsable` prints `jobid` or `jobid;cluster`.
    let text = String::from_utf8_lossy(&out.stdout);
    Ok(text.trim().split(';').next().unwrap_or("").to_string())
}

/// Submits the array, then the merge job with `afterok` on the whole array.
pub fn submit(array: &Path, merge: &Path) -> Result<(String, String)> {
    let a = sbatch(&[], array)?;
    let m = sbatch(&[&format!("--dependency=afterok:{a}")], merge)?;
    Ok((a, m))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_hold_the_array_the_shard_and_the_merge() {
        let job = SlurmJob {
            experiment: "/x/exp.toml".into(),
            overrides: vec!["a.b=1".into(), "c=two words".into()],
            shards: 4,
            run_dir: "/runs/r1".into(),
            partition: Some("short".into()),
            time: Some("00:10:00".into()),
            mem: None,
            threads: 2,
            allow_external: false,
            binary: "/bin/motionlab".into(),
        };
        let (a, m) = scripts(&job);
        assert!(a.contains("#SBATCH --array=0-3"));
        // Every directive precedes the first command, or sbatch ignores it.
        let first_command = a.lines().position(|l| !l.starts_with('#')).unwrap();
        let last_directive = a
            .lines()
            .enumerate()
            .filter(|(_, l)| l.starts_with("#SBATCH"))
            .map(|(i, _)| i)
            .max()
            .unwrap();
        assert!(last_directive < first_command, "{a}");
        assert!(a.contains("#SBATCH --partition=short") && a.contains("#SBATCH --time=00:10:00"));
        assert!(!a.contains("--mem"));
        assert!(a.contains("--shard \"$SLURM_ARRAY_TASK_ID/4\" --run-dir /runs/r1"), "{a}");
        assert!(a.contains(" a.b=1 'c=two words' "), "{a}");
        assert!(m.contains("merge --quiet --threads 2 /runs/r1"), "{m}");
        assert!(!a.contains("--allow-external") && !m.contains("--allow-external"));
        let (a, m) = scripts(&SlurmJob { allow_external: true, ..job });
        assert!(
            a.contains(" --quiet --allow-external --threads 2 --shard")
                && m.contains("merge --quiet --allow-external --threads 2 /runs/r1"),
            "{a}\n{m}"
        );
    }
}
