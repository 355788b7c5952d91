//! Run directories: `reports/<experiment>/<run-id>/`, never overwritten.
//!
//! A run writes into a hidden `.<run-id>.partial` folder and renames it to `<run-id>` only when
//! everything is written, so an interrupted run (even `kill -9`) never leaves a folder that
//! looks complete; `reports/<experiment>/latest` is replaced atomically afterwards. Run ids
//! carry the UTC time, the process id and a counter, so concurrent runs get distinct folders.
//! Every file is written to a temporary name and renamed into place.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use motionlab_core::{Error, ErrorKind, Location, Result};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

/// Where a run writes.
#[derive(Clone, Debug)]
pub struct RunDir {
    /// The folder being written.
    pub work: PathBuf,
    /// The final folder (equal to `work` for shared, sharded run directories).
    pub target: PathBuf,
    /// `reports/<experiment>` when the run updates `latest`.
    pub experiment_dir: Option<PathBuf>,
}

/// Seconds since the epoch as `YYYYMMDD-HHMMSS` (UTC).
pub fn utc_stamp(t: SystemTime) -> String {
    let (date, time) = utc_parts(t);
    format!("{:04}{:02}{:02}-{:02}{:02}{:02}", date.0, date.1, date.2, time.0, time.1, time.2)
}

/// ISO-8601 UTC (`2026-11-23T15:04:05Z`).
pub fn utc_iso(t: SystemTime) -> String {
    let (d, h) = utc_parts(t);
    format!("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", d.0, d.1, d.2, h.0, h.1, h.2)
}

fn utc_parts(t: SystemTime) -> ((i64, u32, u32), (u32, u32, u32)) {
    let secs = t.duration_since(UNIX_EPOCH).map(|d| d.as_secs() as i64).unwrap_or(0);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil-from-days (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    ((y, m, d), ((rem / 3600) as u32, ((rem % 3600) / 60) as u32, (rem % 60) as u32))
}

impl RunDir {
    /// Reserves a fresh run directory under `reports/<experiment>/`.
    pub fn fresh(reports: &Path, experiment: &str) -> Result<RunDir> {
        let exp_dir = reports.join(experiment);
        std::fs::create_dir_all(&exp_dir).map_err(|e| Error::io(&exp_dir, e))?;
        let stamp = utc_stamp(SystemTime::now());
        let pid = std::process::id();
        loop {
            let n = COUNTER.fetch_add(1, Ordering::SeqCst);
            let id = format!("{stamp}-p{pid}-{n}");
            let target = exp_dir.join(&id);
            let work = exp_dir.join(format!(".{id}.partial"));
            if target.exists() {
                continue;
            }
            // create_dir (not _all) fails if another process took the name: reservation.
            match std::fs::create_dir(&work) {
                Ok(()) => return Ok(RunDir { work, target, experiment_dir: Some(exp_dir) }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(Error::io(&work, e)),
            }
        }
    }

    /// A shared run directory given by the user (`--run-dir`), written in place by shards.
    pub fn shared(dir: &Path) -> Result<RunDir> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        Ok(RunDir { work: dir.to_path_buf(), target: dir.to_path_buf(), experiment_dir: None })
    }

    pub fn subdir(&self, name: &str) -> Result<PathBuf> {
        let d = self.work.join(name);
        std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
        Ok(d)
    }

    /// Renames the partial folder into place and points `latest` at it.
    pub fn finalize(&self) -> Result<PathBuf> {
        if self.work != self.target {
            if self.target.exists() {
                return Err(Error::new(ErrorKind::Report, "refusing to overwrite an existing run")
                    .with_location(Location::file(&self.target)));
            }
            std::fs::rename(&self.work, &self.target).map_err(|e| Error::io(&self.target, e))?;
        }
        if let Some(exp) = &self.experiment_dir {
            let id = self
                .target
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            write_atomic(&exp.join("latest"), format!("{id}\n").as_bytes())?;
        }
        Ok(self.target.clone())
    }
}

/// Writes a file through a temporary name in the same folder and a rename, so readers never see
/// a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    let tmp = dir.join(format!(
        ".{}.tmp-{}-{}",
        path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::SeqCst)
    ));
    std::fs::write(&tmp, bytes).map_err(|e| Error::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
}

/// sha256 of bytes, lower-case hex.
pub fn sha256_bytes(bytes: &[u8]) -> String {
    motionlab_cache::hex(&motionlab_cache::sha256(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_formatting_matches_known_instants() {
        let t = UNIX_EPOCH + std::time::Duration::from_secs(1_795_446_245); // 2026-11-23T15:04:05Z (checked with Python datetime)
        assert_eq!(utc_iso(t), "2026-11-23T15:04:05Z");
        assert_eq!(utc_stamp(UNIX_EPOCH), "19700101-000000");
        let leap = UNIX_EPOCH + std::time::Duration::from_secs(951_782_400); // 2000-02-29
        assert_eq!(&utc_iso(leap)[..10], "2000-02-29");
    }

    #[test]
    fn fresh_runs_never_collide_and_finalize_renames() {
        let reports = std::env::temp_dir().join(format!("mlab-rundir-{}", std::process::id()));
        let a = RunDir::fresh(&reports, "exp").unwrap();
        let b = RunDir::fresh(&reports, "exp").unwrap();
        assert_ne!(a.target, b.target);
        assert!(a.work.file_name().unwrap().to_string_lossy().starts_with('.'));
        let done = a.finalize().unwrap();
        assert!(done.is_dir() && !a.work.exists());
        let latest = std::fs::read_to_string(reports.join("exp/latest")).unwrap();
        assert_eq!(latest.trim(), done.file_name().unwrap().to_string_lossy());
        std::fs::remove_dir_all(&reports).ok();
    }

    #[test]
    fn sha256_of_known_bytes() {
        assert_eq!(
            sha256_bytes(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
