//! The shipped data are the public files, unaltered: every file listed in data/MANIFEST.md is
//! present (gzip-compressed where large) and its decompressed bytes have the listed sha256.
//!
//! One documented exception: the manifest's entry for `schreiber2019/SOURCE.txt` (a description
//! written when the data were collected, not data) lists 4595 bytes, while the file handed to
//! the project in `../shared/data/` — and copied here unchanged — has 4550 bytes (sha256
//! 98a07e15…). Every motion and label file matches its entry exactly.

use motionlab_engine::rundir::sha256_bytes;

#[test]
fn every_manifest_file_is_shipped_with_its_original_sha256() {
    let data = motionlab_testkit::data_path("");
    let manifest = std::fs::read_to_string(data.join("MANIFEST.md")).unwrap();
    let mut checked = 0;
    for line in manifest.lines() {
        // | cmu131/131_01.bvh | 716137 | `525a…` |
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 5 || !cells[3].starts_with('`') {
            continue;
        }
        let (name, bytes, sha) = (cells[1], cells[2], cells[3].trim_matches('`'));
        if name == "schreiber2019/SOURCE.txt" {
            let content = std::fs::read(data.join(name)).unwrap();
            assert_eq!(
                sha256_bytes(&content),
                "98a07e1533d5e167dde88dd8274ad47f8dbd232649fefdd18e02e2d5cce9efe9"
            );
            checked += 1;
            continue;
        }
        let plain = data.join(name);
        let gz = data.join(format!("{name}.gz"));
        let path = if plain.is_file() { plain } else { gz };
        let content =
            motionlab_io::read::read_bytes(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(content.len().to_string(), bytes, "{name}: size");
        assert_eq!(sha256_bytes(&content), sha, "{name}: sha256 differs from MANIFEST.md");
        checked += 1;
    }
    assert_eq!(checked, 291, "every file of the manifest table");
}

/// The Sonoda stages' defaults say they were tuned on the seven labelled takes by the SHA-256 of
/// the files as shipped (what a run hashes to tell whether a sequence is one of them): the
/// digests are those files'.
#[test]
fn the_sonoda_defaults_name_their_tuning_takes_by_the_shipped_bytes() {
    let takes = [
        "cmu86/86_01",
        "cmu86/86_09",
        "mocap6/amc/13_29",
        "mocap6/amc/13_30",
        "mocap6/amc/13_31",
        "mocap6/amc/14_14",
        "mocap6/amc/14_20",
    ];
    let shipped: Vec<String> = takes
        .iter()
        .map(|t| {
            sha256_bytes(
                &std::fs::read(motionlab_testkit::data_path(&format!("{t}.amc.gz"))).unwrap(),
            )
        })
        .collect();
    assert_eq!(shipped, motionlab_segment::SONODA_DEFAULTS_TUNED_ON.map(str::to_string));
}
