//! A content-addressed on-disk cache of loaded motions and stage outputs, shared by runs,
//! shards and concurrent processes.
//!
//! ## Keys
//! A key is the SHA-256 of everything the cached value depends on, written by the caller with
//! [`KeyBuilder`]: the stage's name and resolved parameters, the SHA-256 of its input files'
//! bytes, the keys of the stages upstream of it and the [`build_fingerprint`] of the running
//! binary (its version, size and modification time: a rebuilt or upgraded motionlab never
//! reads entries an older build wrote, so a change of code can never be served stale numbers).
//!
//! ## Entries
//! `<dir>/<kind>/<first two hex digits>/<key hex>.bin`, each a header and a payload:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `MLCACHE\0` |
//! | 4 | format version ([`FORMAT_VERSION`], little-endian) |
//! | 32 | the key |
//! | 8 | payload length in bytes (little-endian) |
//! | 32 | SHA-256 of the payload |
//! | n | payload |
//!
//! [`Cache::get`] returns a payload only when the magic, the version, the key, the length and
//! the checksum all match: a truncated, corrupted, foreign (older format) or misplaced entry
//! (another key's file copied here) is a miss — recomputed and overwritten, never trusted.
//!
//! ## Writes
//! An entry is written whole to a temporary file in its own folder (`.tmp-<pid>-<n>`), then
//! renamed onto its name — atomic on POSIX file systems, so a reader sees the old entry, the
//! new one or none, never a partial one, and a process killed mid-write leaves only a temporary
//! file, which no lookup reads ([`Cache::clear`] removes them). Two processes writing the same
//! key write the same bytes (the key fixes the value), so the last rename wins harmlessly.
//!
//! ## Location
//! `$MOTIONLAB_CACHE_DIR` when set, else `$XDG_CACHE_HOME/motionlab`, else
//! `$HOME/.cache/motionlab` ([`default_dir`]); never inside a checkout unless pointed there.
//!
//! Hand-written rather than a crate (cacache, for instance): the format is 40 lines, and the
//! properties that matter here — checksum and key verified on every read, no index file that
//! concurrent writers would contend for — are simplest to state and test on our own format.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use sha2::{Digest, Sha256};

pub mod motion;
pub mod table;

/// The entry magic.
pub const MAGIC: &[u8; 8] = b"MLCACHE\0";
/// The entry format version; a different version is a miss.
pub const FORMAT_VERSION: u32 = 2;
/// Header length in bytes (magic, version, key, length, checksum).
pub const HEADER_LEN: usize = 8 + 4 + 32 + 8 + 32;

/// A cache key: SHA-256 of what the value depends on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Key(pub [u8; 32]);

impl Key {
    pub fn hex(&self) -> String {
        hex(&self.0)
    }
}

/// Lower-case hex of bytes.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Builds a [`Key`] from labelled parts (each part is length-prefixed, so `("ab","c")` and
/// `("a","bc")` differ).
pub struct KeyBuilder(Sha256);

impl KeyBuilder {
    /// Starts a key for values of `kind` (`motion`, `segmenter`), under this binary's
    /// [`build_fingerprint`].
    pub fn new(kind: &str) -> Self {
        let mut b = KeyBuilder(Sha256::new());
        b = b.part("kind", kind.as_bytes()).part("build", build_fingerprint().as_bytes());
        b
    }
    /// Adds a labelled part.
    pub fn part(mut self, label: &str, bytes: &[u8]) -> Self {
        for p in [label.as_bytes(), bytes] {
            self.0.update((p.len() as u64).to_le_bytes());
            self.0.update(p);
        }
        self
    }
    /// Adds an upstream key.
    pub fn upstream(self, label: &str, key: &Key) -> Self {
        self.part(label, &key.0)
    }
    pub fn finish(self) -> Key {
        Key(self.0.finalize().into())
    }
}

/// SHA-256 of bytes.
pub fn sha256(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// The running binary's identity: motionlab's version plus the executable's size and
/// modification time. Any rebuild changes it, so entries written by other code are never read.
pub fn build_fingerprint() -> &'static str {
    static FP: OnceLock<String> = OnceLock::new();
    FP.get_or_init(|| {
        let exe = std::env::current_exe().ok().and_then(|p| std::fs::metadata(p).ok());
        let (len, mtime) = match exe {
            Some(m) => (
                m.len(),
                m.modified()
                    .ok()
                    .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                    .map_or(0, |d| d.as_nanos()),
            ),
            None => (0, 0),
        };
        format!("motionlab {} exe {len} {mtime}", env!("CARGO_PKG_VERSION"))
    })
}

/// The default cache folder: `$MOTIONLAB_CACHE_DIR`, else `$XDG_CACHE_HOME/motionlab`, else
/// `$HOME/.cache/motionlab`; `None` when none of them is set.
pub fn default_dir() -> Option<PathBuf> {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("MOTIONLAB_CACHE_DIR")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("motionlab")))
        .or_else(|| var("HOME").map(|h| h.join(".cache").join("motionlab")))
}

/// What [`Cache::info`] counts.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Info {
    /// Entries per kind (`motion`, `segmenter`), sorted by kind.
    pub kinds: Vec<(String, u64, u64)>,
    pub entries: u64,
    pub bytes: u64,
    /// Temporary files left by interrupted writes (never read).
    pub temporary: u64,
}

/// Why a lookup missed (for tests and `--verbose` diagnostics).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Miss {
    Absent,
    /// Shorter than its header or its stated length.
    Truncated,
    BadMagic,
    OtherVersion,
    /// The file holds another key's entry.
    WrongKey,
    /// The payload's SHA-256 differs from the header's.
    BadChecksum,
}

static TMP_COUNTER: AtomicUsize = AtomicUsize::new(0);

/// A cache folder.
#[derive(Clone, Debug)]
pub struct Cache {
    dir: PathBuf,
}

impl Cache {
    /// The cache at `dir` (created on first write).
    pub fn at(dir: impl Into<PathBuf>) -> Self {
        Cache { dir: dir.into() }
    }
    /// The cache at [`default_dir`].
    pub fn open_default() -> Option<Self> {
        default_dir().map(Cache::at)
    }
    pub fn dir(&self) -> &Path {
        &self.dir
    }
    /// The file of an entry.
    pub fn entry_path(&self, kind: &str, key: &Key) -> PathBuf {
        let h = key.hex();
        self.dir.join(kind).join(&h[..2]).join(format!("{h}.bin"))
    }
    /// The payload stored under `key`, when a whole, checked entry is there.
    pub fn get(&self, kind: &str, key: &Key) -> Option<Vec<u8>> {
        self.lookup(kind, key).ok()
    }
    /// [`Cache::get`], saying why it missed.
    pub fn lookup(&self, kind: &str, key: &Key) -> Result<Vec<u8>, Miss> {
        let bytes = std::fs::read(self.entry_path(kind, key)).map_err(|_| Miss::Absent)?;
        decode_entry(&bytes, key)
    }
    /// Stores `payload` under `key`, atomically. Errors are returned, but a caller may ignore
    /// them: a cache that cannot be written only costs time.
    pub fn put(&self, kind: &str, key: &Key, payload: &[u8]) -> std::io::Result<()> {
        let path = self.entry_path(kind, key);
        let Some(dir) = path.parent() else { return Ok(()) };
        std::fs::create_dir_all(dir)?;
        let tmp = dir.join(format!(
            ".tmp-{}-{}",
            std::process::id(),
            TMP_COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let result = (|| {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(&encode_entry(key, payload))?;
            f.sync_data()?;
            drop(f);
            test_hook_pause();
            std::fs::rename(&tmp, &path)
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result
    }
    /// Entries, bytes and temporary files, per kind.
    pub fn info(&self) -> std::io::Result<Info> {
        let mut info = Info::default();
        let Ok(kinds) = std::fs::read_dir(&self.dir) else { return Ok(info) };
        let mut kinds: Vec<PathBuf> =
            kinds.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_dir()).collect();
        kinds.sort();
        for k in kinds {
            let (mut n, mut bytes) = (0, 0);
            for shard in std::fs::read_dir(&k)?.filter_map(|e| e.ok()) {
                let Ok(files) = std::fs::read_dir(shard.path()) else { continue };
                for f in files.filter_map(|e| e.ok()) {
                    let name = f.file_name().to_string_lossy().into_owned();
                    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
                    if name.starts_with(".tmp-") {
                        info.temporary += 1;
                    } else if name.ends_with(".bin") {
                        n += 1;
                        bytes += len;
                    }
                }
            }
            info.entries += n;
            info.bytes += bytes;
            info.kinds.push((
                k.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
                n,
                bytes,
            ));
        }
        Ok(info)
    }
    /// Removes every entry and temporary file (the folder itself stays).
    pub fn clear(&self) -> std::io::Result<Info> {
        let info = self.info()?;
        if let Ok(kinds) = std::fs::read_dir(&self.dir) {
            for k in kinds.filter_map(|e| e.ok()) {
                if k.path().is_dir() {
                    std::fs::remove_dir_all(k.path())?;
                }
            }
        }
        Ok(info)
    }
}

/// An entry's bytes: header then payload.
pub fn encode_entry(key: &Key, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&key.0);
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&sha256(payload));
    out.extend_from_slice(payload);
    out
}

/// The payload of an entry read for `key`, after every check.
pub fn decode_entry(bytes: &[u8], key: &Key) -> Result<Vec<u8>, Miss> {
    if bytes.len() < HEADER_LEN {
        return Err(Miss::Truncated);
    }
    let (header, payload) = bytes.split_at(HEADER_LEN);
    if &header[..8] != MAGIC {
        return Err(Miss::BadMagic);
    }
    let u32_at =
        |a: usize| header.get(a..a + 4).and_then(|s| s.try_into().ok()).map(u32::from_le_bytes);
    let u64_at =
        |a: usize| header.get(a..a + 8).and_then(|s| s.try_into().ok()).map(u64::from_le_bytes);
    if u32_at(8) != Some(FORMAT_VERSION) {
        return Err(Miss::OtherVersion);
    }
    if header[12..44] != key.0 {
        return Err(Miss::WrongKey);
    }
    if u64_at(44) != Some(payload.len() as u64) {
        return Err(Miss::Truncated);
    }
    if header[52..84] != sha256(payload) {
        return Err(Miss::BadChecksum);
    }
    Ok(payload.to_vec())
}

/// Test hook (debug builds only): `MOTIONLAB_CACHE_TEST_PAUSE_MS=<ms>` sleeps between writing
/// an entry's temporary file and renaming it, so a test can kill the process mid-write.
fn test_hook_pause() {
    #[cfg(debug_assertions)]
    if let Some(ms) =
        std::env::var("MOTIONLAB_CACHE_TEST_PAUSE_MS").ok().and_then(|v| v.parse::<u64>().ok())
    {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(s: &str) -> Key {
        KeyBuilder::new("test").part("s", s.as_bytes()).finish()
    }

    #[test]
    fn round_trip_and_every_damage_is_a_miss() {
        let d = tempfile::tempdir().unwrap();
        let c = Cache::at(d.path());
        let (a, b) = (key("a"), key("b"));
        assert_eq!(c.lookup("t", &a), Err(Miss::Absent));
        c.put("t", &a, b"payload a").unwrap();
        c.put("t", &b, b"payload b, longer").unwrap();
        assert_eq!(c.get("t", &a).as_deref(), Some(&b"payload a"[..]));
        let pa = c.entry_path("t", &a);
        let good = std::fs::read(&pa).unwrap();
        // A flipped payload byte.
        let mut bad = good.clone();
        *bad.last_mut().unwrap() ^= 1;
        std::fs::write(&pa, &bad).unwrap();
        assert_eq!(c.lookup("t", &a), Err(Miss::BadChecksum));
        // A flipped header byte of the length.
        let mut bad = good.clone();
        bad[44] ^= 1;
        std::fs::write(&pa, &bad).unwrap();
        assert_eq!(c.lookup("t", &a), Err(Miss::Truncated));
        // Truncated, in the payload and in the header.
        std::fs::write(&pa, &good[..good.len() - 1]).unwrap();
        assert_eq!(c.lookup("t", &a), Err(Miss::Truncated));
        std::fs::write(&pa, &good[..20]).unwrap();
        assert_eq!(c.lookup("t", &a), Err(Miss::Truncated));
        // Foreign: magic, version.
        let mut bad = good.clone();
        bad[0] = b'X';
        std::fs::write(&pa, &bad).unwrap();
        assert_eq!(c.lookup("t", &a), Err(Miss::BadMagic));
        let mut bad = good.clone();
        bad[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
        std::fs::write(&pa, &bad).unwrap();
        assert_eq!(c.lookup("t", &a), Err(Miss::OtherVersion));
        // Another key's entry under this name.
        std::fs::copy(c.entry_path("t", &b), &pa).unwrap();
        assert_eq!(c.lookup("t", &a), Err(Miss::WrongKey));
        // Rewritten: trusted again.
        c.put("t", &a, b"payload a").unwrap();
        assert_eq!(c.get("t", &a).as_deref(), Some(&b"payload a"[..]));
        let info = c.info().unwrap();
        assert_eq!((info.entries, info.temporary), (2, 0));
        assert_eq!(info.bytes, (2 * HEADER_LEN + 9 + 17) as u64);
        c.clear().unwrap();
        assert_eq!(c.info().unwrap().entries, 0);
        assert_eq!(c.lookup("t", &a), Err(Miss::Absent));
    }

    #[test]
    fn keys_separate_their_parts() {
        let k1 = KeyBuilder::new("k").part("x", b"ab").part("y", b"c").finish();
        let k2 = KeyBuilder::new("k").part("x", b"a").part("y", b"bc").finish();
        let k3 = KeyBuilder::new("other").part("x", b"ab").part("y", b"c").finish();
        assert_ne!(k1, k2);
        assert_ne!(k1, k3);
        assert_eq!(k1, KeyBuilder::new("k").part("x", b"ab").part("y", b"c").finish());
    }

    #[test]
    fn leftover_temporary_files_are_counted_never_read_and_cleared() {
        let d = tempfile::tempdir().unwrap();
        let c = Cache::at(d.path());
        let k = key("k");
        let p = c.entry_path("t", &k);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        // What a process killed between write and rename leaves.
        std::fs::write(p.parent().unwrap().join(".tmp-1-0"), encode_entry(&k, b"x")).unwrap();
        assert_eq!(c.lookup("t", &k), Err(Miss::Absent));
        assert_eq!(c.info().unwrap().temporary, 1);
        c.clear().unwrap();
        assert_eq!(c.info().unwrap().temporary, 0);
    }
}
