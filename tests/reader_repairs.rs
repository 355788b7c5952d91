//! What a loader repaired to read a file other software wrote is said: one `repaired` line of
//! `motionlab inspect` each, beside the file's length unit (as read or inferred) and the
//! figure's height; and in the run's `provenance.json` (`load_repairs` of the input), also
//! after a sharded run's merge. `strict = true` on the loader refuses such a file.
//! The per-file readings are checked in `crates/motionlab-io/tests/conformance.rs`.

use std::path::Path;
use std::process::Command;

fn motionlab() -> Command {
    let mut c = crate::motionlab_command();
    c.current_dir(motionlab_testkit::repo_root());
    c
}

fn run(c: &mut Command) -> (bool, String, String) {
    let out = c.output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const KYOWA: &str = "tests/fixtures/conformance/c3d/sample_27_kyowadengyo.c3d";
const WALK1: &str =
    "tests/fixtures/conformance/c3d/sample_00_Motion_Analysis_Corporation_Walk1.c3d";
const PYMO: &str = "tests/fixtures/conformance/bvh/pymo_AV_8Walk_Meredith_HVHA_Rep1.bvh";

#[test]
fn inspect_says_the_unit_the_height_and_every_repair() {
    let (ok, out, err) = run(motionlab().args([
        "inspect",
        KYOWA,
        PYMO,
        "data/mct/walk1.c3d.gz",
        "data/cmu86/86_01.amc.gz",
    ]));
    assert!(ok, "{err}");
    let of = |file: &str| -> Vec<&str> {
        let start = out.find(&format!("{file}\n")).unwrap();
        out[start..].lines().skip(1).take_while(|l| l.starts_with("  ")).collect()
    };
    let kyowa = of(KYOWA);
    assert!(kyowa.contains(&"  frames    152 at 60 Hz (2.533 s)"), "{kyowa:?}");
    assert!(kyowa.contains(&"  unit      mm — POINT:UNITS \"mm\""), "{kyowa:?}");
    assert!(
        kyowa.contains(&"  height    1296 mm along z in frame 1 (the figure's extent)"),
        "{kyowa:?}"
    );
    assert!(
        kyowa.contains(&"  repaired  POINT:USED is 12 but the header says 11 points per frame: the header's account fits the file (31232 bytes) and is used"),
        "{kyowa:?}"
    );
    let pymo = of(PYMO);
    assert!(
        pymo.contains(&"  unit      in — inferred from the rest pose: 60.5578 units tall along y"),
        "{pymo:?}"
    );
    assert!(
        pymo.contains(&"  height    1515 mm along y in frame 1 (the figure's extent)"),
        "{pymo:?}"
    );
    assert!(!pymo.iter().any(|l| l.starts_with("  repaired")), "{pymo:?}");
    let walk = of("data/mct/walk1.c3d.gz");
    assert!(!walk.iter().any(|l| l.starts_with("  repaired")), "{walk:?}");
    let amc = of("data/cmu86/86_01.amc.gz");
    assert!(
        amc.iter()
            .any(|l| l.starts_with("  unit      CMU unit, 1/0.45 in — the ASF's :units length")),
        "{amc:?}"
    );
    // JSON carries the same, and --npy the positions.
    let tmp = tempfile::tempdir().unwrap();
    let npy = tmp.path().join("npy");
    let (ok, out, err) =
        run(motionlab().args(["inspect", "--json", "--npy", npy.to_str().unwrap(), WALK1, KYOWA]));
    assert!(ok, "{err}");
    let reports: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(reports[1]["repairs"].as_array().unwrap().len(), 1);
    assert_eq!(reports[1]["length_unit"], "millimetre");
    assert!((reports[1]["height_mm"].as_f64().unwrap() - 1296.06).abs() < 0.01);
    assert!(
        reports[0]["repairs"][0]
            .as_str()
            .unwrap()
            .starts_with("duplicate point labels made unique")
    );
    let bytes = std::fs::read(npy.join("1.npy")).unwrap();
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    assert!(String::from_utf8_lossy(&bytes[10..10 + header_len]).contains("'shape': (152, 11, 3)"));
    assert_eq!(bytes.len(), 10 + header_len + 152 * 11 * 3 * 8);
    assert_eq!(reports[1]["positions_npy"], npy.join("1.npy").to_str().unwrap());
}

fn experiment(dir: &Path, files: &[&str], loader: &str) -> std::path::PathBuf {
    let root = motionlab_testkit::repo_root();
    let files: Vec<String> =
        files.iter().map(|f| format!("{:?}", root.join(f).display().to_string())).collect();
    let text = format!(
        "[experiment]\nname = \"repairs\"\n\n[[dataset]]\nfiles = [{}]\nloader = {loader}\n\n[features]\nextractors = [{{ type = \"marker_speed\" }}]\n",
        files.join(", ")
    );
    let path = dir.join(format!("repairs{}.toml", files.len()));
    std::fs::write(&path, text).unwrap();
    path
}

fn repairs_by_input(run_dir: &Path) -> Vec<(String, Vec<String>)> {
    let prov: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run_dir.join("provenance.json")).unwrap()).unwrap();
    prov["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| {
            let name = Path::new(i["path"].as_str().unwrap())
                .file_name()
                .unwrap()
                .to_string_lossy()
                .into_owned();
            let repairs = i.get("load_repairs").map_or_else(Vec::new, |r| {
                r.as_array().unwrap().iter().map(|s| s.as_str().unwrap().to_string()).collect()
            });
            (name, repairs)
        })
        .collect()
}

#[test]
fn provenance_lists_each_inputs_repairs_and_strict_refuses_them() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(tmp.path(), &[KYOWA, WALK1], "{ type = \"c3d\" }");
    let reports = tmp.path().join("reports");
    let (ok, out, err) = run(motionlab().args([
        "run",
        exp.to_str().unwrap(),
        "--quiet",
        "--reports",
        reports.to_str().unwrap(),
    ]));
    assert!(ok, "{err}");
    let run_dir = Path::new(out.split(": ").next().unwrap().trim()).to_path_buf();
    let check = |by: Vec<(String, Vec<String>)>| {
        assert_eq!(by.len(), 2, "{by:?}");
        let (walk, kyowa) = (&by[0], &by[1]);
        assert_eq!(kyowa.0, "sample_27_kyowadengyo.c3d");
        assert_eq!(
            kyowa.1,
            [
                "POINT:USED is 12 but the header says 11 points per frame: the header's account fits the file (31232 bytes) and is used"
            ]
        );
        assert_eq!(walk.0, "sample_00_Motion_Analysis_Corporation_Walk1.c3d");
        assert!(
            walk.1.len() == 1
                && walk.1[0].starts_with("duplicate point labels made unique: \"RKNE\""),
            "{walk:?}"
        );
    };
    check(repairs_by_input(&run_dir));
    // Sharded: each shard loads one input; the merge lists both.
    let sharded = tmp.path().join("sharded");
    for i in ["0/2", "1/2"] {
        let (ok, _, err) = run(motionlab().args([
            "run",
            exp.to_str().unwrap(),
            "--quiet",
            "--shard",
            i,
            "--run-dir",
            sharded.to_str().unwrap(),
        ]));
        assert!(ok, "{err}");
    }
    let (ok, _, err) = run(motionlab().args(["merge", "--quiet", sharded.to_str().unwrap()]));
    assert!(ok, "{err}");
    check(repairs_by_input(&sharded));
    // Strict: the first repair is an error naming the file, the byte and the parameter.
    let strict = experiment(tmp.path(), &[KYOWA], "{ type = \"c3d\", strict = true }");
    let (ok, _, err) = run(motionlab().args([
        "run",
        strict.to_str().unwrap(),
        "--quiet",
        "--reports",
        reports.to_str().unwrap(),
    ]));
    assert!(!ok);
    assert!(err.contains("sample_27_kyowadengyo.c3d (byte 10240): item sample_27_kyowadengyo.POINT:USED: POINT:USED is 12 but the header says 11 points per frame; expected the header's and the parameters' accounts of the data section to agree (strict reading)"), "{err}");
}
