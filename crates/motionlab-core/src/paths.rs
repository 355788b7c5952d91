//! File-name helpers shared by loaders and the engine.

use std::borrow::Cow;
use std::path::Path;

/// The longest name [`safe_file_name`] keeps whole, in bytes: with a hash suffix and an
/// extension it stays well inside the 255-byte limit of common file systems.
pub const MAX_SAFE_NAME_BYTES: usize = 150;

/// A name from the data or an experiment (a sequence, a method, an annotator — and the table,
/// figure and viewer names built from them) as one file name inside its folder: unchanged
/// when it is already one — ASCII letters, digits, `_`, `-` and `.`, not starting with `.`,
/// at most [`MAX_SAFE_NAME_BYTES`] — and otherwise every other character replaced by `_`,
/// cut to that length and followed by `~` and a hash of the whole name, so that two different
/// names never share a file. A name can thus never climb out of its folder (`..`, `/`), hide
/// (a leading `.`), carry NUL or control characters, or exceed the file system's limit.
pub fn safe_file_name(name: &str) -> Cow<'_, str> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if !name.is_empty()
        && !name.starts_with('.')
        && name.len() <= MAX_SAFE_NAME_BYTES
        && name.chars().all(allowed)
    {
        return Cow::Borrowed(name);
    }
    let mut out: String =
        name.chars().map(|c| if allowed(c) { c } else { '_' }).take(MAX_SAFE_NAME_BYTES).collect();
    if out.starts_with('.') {
        out.replace_range(..1, "_");
    }
    Cow::Owned(format!("{out}~{:016x}", fnv1a(name.as_bytes())))
}

/// 64-bit FNV-1a: a stable hash (std's `DefaultHasher` may change between Rust releases, and
/// file names must not), needing no dependency; not a defence against chosen collisions, which
/// a name's author gains nothing from.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

/// The file name without `.gz` and without its format extension (`86_01` for `86_01.amc.gz`).
pub fn stem(path: &Path) -> String {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    match name.rfind('.') {
        Some(i) if i > 0 => name[..i].to_string(),
        _ => name.to_string(),
    }
}

/// The format extension, lower case, ignoring a trailing `.gz` (`amc` for `86_01.AMC.gz`).
pub fn format_extension(path: &Path) -> Option<String> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let i = name.rfind('.')?;
    Some(name[i + 1..].to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stem_and_extension_ignore_gz() {
        assert_eq!(stem(Path::new("data/86_01.amc.gz")), "86_01");
        assert_eq!(format_extension(Path::new("x/86_01.AMC.gz")).as_deref(), Some("amc"));
        assert_eq!(format_extension(Path::new("x/noext")), None);
    }

    #[test]
    fn safe_file_names_stay_in_their_folder_and_stay_distinct() {
        for plain in ["86_01", "86_01_speed_zoom", "walk-1.bvh", "a..b"] {
            assert!(matches!(safe_file_name(plain), Cow::Borrowed(_)), "{plain}");
        }
        let odd = [
            "..",
            "../../etc/passwd",
            "/abs",
            "a/b",
            "a b",
            "a_b\u{0}",
            "<script>alert(1)</script>",
            "日本語",
            ".hidden",
            "",
            "tab\there",
            "\u{1b}[2J",
        ];
        let mut seen = std::collections::HashSet::new();
        for name in odd {
            let safe = safe_file_name(name);
            assert!(
                !safe.is_empty()
                    && !safe.starts_with('.')
                    && safe.len() <= MAX_SAFE_NAME_BYTES + 17,
                "{name:?} → {safe}"
            );
            assert!(
                safe.chars().all(|c| c.is_ascii_alphanumeric() || "_-.~".contains(c)),
                "{name:?} → {safe}"
            );
            assert_eq!(Path::new(safe.as_ref()).components().count(), 1, "{name:?} → {safe}");
            assert!(seen.insert(safe.into_owned()), "{name:?} collides");
        }
        // "a b" and "a_b" are different names, so different files.
        assert_ne!(safe_file_name("a b"), safe_file_name("a_b"));
        let long = "x".repeat(300);
        assert_eq!(safe_file_name(&long).len(), MAX_SAFE_NAME_BYTES + 17);
    }
}
