//! File-name helpers shared by loaders and the engine.

use std::path::Path;

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
}
