//! Odd names (docs/security.md): sequence, dataset, method and annotator names that become file
//! names or HTML — spaces, Unicode, `..`, `/`, markup, 300 characters, NUL and control
//! characters — never write outside the run directory and are shown escaped on every page.
//!
//! The corpus: a real take (MoCap Toolbox dance1) copied under odd file names, a dataset whose
//! `name` climbs out of the folder, methods and annotators named with markup and escapes.
//! Markup that would run sets `window.__motionlab_injected`; the browser test
//! (tests/browser/check_odd_names.py, run by .ci/run on the run this test keeps when
//! `MOTIONLAB_KEEP_ODD_NAMES` names a folder) checks it stays unset in Chromium.
//!
//! Experiment names name the run's folder and are refused unless plain (letters, digits, `_`,
//! `-`; at most 100).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use motionlab_testkit::repo_root;

/// Payloads that, unescaped, would run in a page (each sets the marker the browser test reads).
const SCRIPT: &str = "<script>window.__motionlab_injected=1</script>";
const IMG: &str = "<img src=x onerror=window.__motionlab_injected=2>";
const ATTR: &str = "\"><svg onload=window.__motionlab_injected=5>";

/// File names (stems) the take is copied under.
fn odd_stems() -> Vec<String> {
    vec![
        "my take".into(),
        format!("{IMG} take"),
        "日本語のテイク".into(),
        "..".into(),
        "x".repeat(240),
        "ctl\u{7}bell\u{1b}[31mred".into(),
    ]
}

/// Every file under `dir` (relative paths).
fn files_under(dir: &Path) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out
}

fn toml_str(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// The corpus experiment in `root`, returning its path.
fn write_corpus(root: &Path) -> PathBuf {
    let take = repo_root().join("data/mct/dance1.tsv.gz");
    std::fs::create_dir_all(root.join("data")).unwrap();
    std::fs::create_dir_all(root.join("data2")).unwrap();
    for stem in odd_stems() {
        std::fs::copy(&take, root.join("data").join(format!("{stem}.tsv.gz"))).unwrap();
    }
    std::fs::copy(&take, root.join("data2/a.tsv.gz")).unwrap();
    std::fs::copy(&take, root.join("data2/b.tsv.gz")).unwrap();
    // Two annotators with odd names; the first one is evaluated. Frames at 60 Hz.
    let mut csv = String::from("sequence\tframe\tannotator\n");
    for stem in odd_stems() {
        for (frame, annotator) in
            [(300, IMG), (700, IMG), (300, "../../annotator 日本"), (1100, "../../annotator 日本")]
        {
            csv.push_str(&format!("{stem}\t{frame}\t{annotator}\n"));
        }
    }
    std::fs::write(root.join("data/truth.csv"), csv).unwrap();
    std::fs::write(
        root.join("data2/truth.csv"),
        format!("frame\tannotator\n300\t{SCRIPT}\n900\t{SCRIPT}\n"),
    )
    .unwrap();
    let methods = [
        SCRIPT.to_string(),
        "../../../../../../../../tmp/motionlab-escape-method".into(),
        "nul\u{0}and\u{7}bell\u{1b}[2J".into(),
        "m".repeat(300),
        "日本語 with spaces".into(),
        ATTR.into(),
    ];
    let segmenters: String = methods
        .iter()
        .map(|m| format!("[[segmentation.segmenter]]\ntype = \"speed_minima\"\nname = {}\nv_low = {{ fraction_of_p90 = 0.2 }}\n\n", toml_str(m)))
        .collect();
    let text = format!(
        "[experiment]\nname = \"odd_names\"\ndescription = {desc}\n\n\
         [[dataset]]\nfiles = [\"data/*.tsv.gz\"]\nloader = {{ type = \"qualisys_tsv\" }}\n\
         ground_truth = {{ type = \"boundaries_csv\", file = \"data/truth.csv\", annotator = {annotator} }}\n\n\
         [[dataset]]\nname = {dataset_name}\nfiles = [\"data2/*.tsv.gz\"]\nloader = {{ type = \"qualisys_tsv\" }}\n\
         ground_truth = {{ type = \"boundaries_csv\", file = \"data2/truth.csv\" }}\n\n\
         [segmentation]\nroot = \"Spine\"\nfigures = [\"traces\", \"timeline\"]\n\n{segmenters}\
         [[evaluate]]\ntype = \"boundary_pr\"\ntolerance = {{ seconds = 0.5 }}\n",
        annotator = toml_str(IMG),
        desc = toml_str(&format!("{SCRIPT} & {IMG}")),
        dataset_name =
            toml_str(&format!("../../../../../../../../tmp/motionlab-escape-dataset {SCRIPT}")),
    );
    let path = root.join("odd_names.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn odd_names_stay_inside_the_run_directory_and_are_escaped_on_every_page() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let exp = write_corpus(root);
    let before = files_under(root);
    let out = crate::motionlab_command()
        .current_dir(root)
        .args(["run", exp.to_str().unwrap(), "--quiet", "--reports", "reports"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let index = crate::motionlab_command()
        .current_dir(root)
        .args(["index", "--experiments", ".", "--reports", "reports"])
        .output()
        .unwrap();
    assert!(index.status.success(), "{}", String::from_utf8_lossy(&index.stderr));

    // Nothing outside the run directory (its `latest` pointer and the index beside it).
    let exp_dir = root.join("reports/odd_names");
    let run_id = std::fs::read_to_string(exp_dir.join("latest")).unwrap().trim().to_string();
    let run_prefix = Path::new("reports/odd_names").join(&run_id);
    let written: Vec<PathBuf> = files_under(root).difference(&before).cloned().collect();
    let outside: Vec<&PathBuf> = written
        .iter()
        .filter(|p| {
            !p.starts_with(&run_prefix)
                && *p != Path::new("reports/odd_names/latest")
                && *p != Path::new("reports/index.html")
        })
        .collect();
    assert!(outside.is_empty(), "written outside the run directory: {outside:?}");
    for escape in std::fs::read_dir("/tmp").unwrap() {
        let name = escape.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with("motionlab-escape"), "a name climbed out to /tmp/{name}");
    }
    // Every file name in the run is one plain component.
    for p in &written {
        for c in p.components() {
            let c = c.as_os_str().to_string_lossy();
            assert!(
                c.chars().all(|ch| ch.is_ascii_alphanumeric() || "_-.~".contains(ch)),
                "file name {c:?} in {}",
                p.display()
            );
        }
    }
    let run = root.join(&run_prefix);
    let viewers: Vec<PathBuf> = written
        .iter()
        .filter(|p| p.starts_with(run_prefix.join("viewers")))
        .map(|p| root.join(p))
        .collect();
    assert_eq!(viewers.len(), odd_stems().len() + 2, "one viewer per sequence: {viewers:?}");

    // Every page shows the payloads as text, never as markup.
    let pages: Vec<PathBuf> = [run.join("index.html"), root.join("reports/index.html")]
        .into_iter()
        .chain(viewers.iter().cloned())
        .collect();
    for page in &pages {
        let html = std::fs::read_to_string(page).unwrap();
        for raw in ["<script>window.__motionlab_injected", "<img src=x", "<svg onload", "\"><svg"] {
            assert!(!html.contains(raw), "{} holds {raw:?} unescaped", page.display());
        }
    }
    let run_page = std::fs::read_to_string(run.join("index.html")).unwrap();
    assert!(
        run_page.contains("&lt;script&gt;window.__motionlab_injected=1&lt;&#x2f;script&gt;"),
        "the method name is not on the run page, escaped"
    );
    for viewer in &viewers {
        let html = std::fs::read_to_string(viewer).unwrap();
        assert!(
            html.contains("\\u003cscript\\u003ewindow.__motionlab_injected=1\\u003c/script\\u003e"),
            "{}: the method's lane is missing",
            viewer.display()
        );
    }
    // SVG figures hold no character XML forbids and no payload unescaped, whatever the names hold.
    let svgs: Vec<_> =
        written.iter().filter(|p| p.extension().is_some_and(|e| e == "svg")).collect();
    assert!(!svgs.is_empty(), "the run wrote no SVG figure to check");
    for svg in svgs {
        let text = std::fs::read_to_string(root.join(svg)).unwrap();
        assert!(
            !text.chars().any(|c| c < ' ' && !"\t\n\r".contains(c)),
            "{}: a control character in XML",
            svg.display()
        );
        assert!(!text.contains("<script>window"), "{}", svg.display());
    }

    if let Some(keep) = std::env::var_os("MOTIONLAB_KEEP_ODD_NAMES") {
        let keep = PathBuf::from(keep);
        for p in files_under(&root.join("reports")) {
            let to = keep.join(&p);
            std::fs::create_dir_all(to.parent().unwrap()).unwrap();
            std::fs::copy(root.join("reports").join(&p), &to).unwrap();
        }
        println!("kept the odd-names reports in {}", keep.display());
    }
}

#[test]
fn odd_experiment_names_are_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let take = repo_root().join("data/mct/dance1.tsv.gz");
    for name in
        ["..", "a/b", "../../escape", "a b", SCRIPT, &"e".repeat(300), "nul\u{0}", "日本", ""]
    {
        let exp = tmp.path().join("odd.toml");
        std::fs::write(
            &exp,
            format!(
                "[experiment]\nname = {}\n\n[[dataset]]\nfiles = [{:?}]\nloader = {{ type = \"qualisys_tsv\" }}\n\n[features]\nextractors = [{{ type = \"marker_speed\" }}]\n",
                toml_str(name),
                take.to_string_lossy()
            ),
        )
        .unwrap();
        let out = crate::motionlab_command()
            .current_dir(tmp.path())
            .args(["run", "odd.toml", "--quiet", "--reports", "reports"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{name:?}: {err}");
        assert!(
            err.contains("odd.toml:2: experiment.name: experiment name")
                && err.contains("must be 1 to 100 letters, digits, _ or -"),
            "{name:?}: {err}"
        );
        assert!(!tmp.path().join("reports").exists(), "{name:?}: wrote reports/");
    }
}
