//! Consent before an experiment's external programs run (docs/security.md): a program an
//! experiment names is never started without `--allow-external` or a trust record — not by
//! `validate`, `run`, `reproduce`, `slurm` or `merge` — the refusal lists every command line,
//! `--allow-external` and `motionlab trust` each let it run, and a changed command line (in the
//! file, by an override, by a sweep grid) is not covered by a trust record.
//!
//! The program is `sh -c "touch MARKER && echo '{\"candidates\": []}'"`: the marker file shows
//! whether it ran (runs use `--no-cache`: a cached stage output would not run it again). Trust
//! records go to a folder of the test's own (`MOTIONLAB_CONFIG_DIR`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use motionlab_testkit::repo_root;

struct Probe {
    tmp: tempfile::TempDir,
}

impl Probe {
    fn new() -> Self {
        Probe { tmp: tempfile::tempdir().unwrap() }
    }
    fn path(&self, name: &str) -> PathBuf {
        self.tmp.path().join(name)
    }
    fn config(&self) -> PathBuf {
        self.path("config")
    }
    fn reports(&self) -> PathBuf {
        self.path("reports")
    }
    /// The command that touches `marker` and returns no candidates.
    fn command(&self, marker: &str) -> Vec<String> {
        let touch =
            format!("touch {} && echo '{{\"candidates\": []}}'", self.path(marker).display());
        vec!["sh".into(), "-c".into(), touch]
    }
    /// Writes `name` (an experiment running the probe that touches `marker`; `extra` appended).
    fn experiment(&self, name: &str, marker: &str, extra: &str) -> PathBuf {
        let command =
            toml::Value::Array(self.command(marker).into_iter().map(toml::Value::String).collect());
        let text = format!(
            "[experiment]\nname = \"consent_probe\"\n\n[[dataset]]\nfiles = [{data:?}]\nloader = {{ type = \"asf_amc\" }}\n\n\
             [segmentation]\nfigures = []\n\n[[segmentation.segmenter]]\ntype = \"external\"\nname = \"probe\"\ncommand = {command}\n{extra}",
            data = repo_root().join("data/cmu86/86_01.amc.gz").to_string_lossy(),
        );
        let path = self.path(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, text).unwrap();
        path
    }
    fn motionlab(&self, args: &[&str]) -> Output {
        let mut c: Command = crate::motionlab_command();
        c.current_dir(self.tmp.path()).env("MOTIONLAB_CONFIG_DIR", self.config()).args(args);
        c.output().unwrap()
    }
    fn ran(&self, marker: &str) -> bool {
        self.path(marker).exists()
    }
    fn forget(&self, marker: &str) {
        let _ = std::fs::remove_file(self.path(marker));
    }
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The refusal: exit 1, one line naming the file, every command line and both ways to allow.
fn assert_refused(out: &Output, experiment: &Path, commands: &[&[String]], what: &str) {
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{what}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{what}: one line expected: {err}");
    assert!(err.starts_with(&format!("error: {}: names ", experiment.display())), "{what}: {err}");
    for c in commands {
        assert!(
            err.contains(&format!("`{}`", motionlab_core::programs::command_line(c))),
            "{what}: {err}"
        );
    }
    assert!(
        err.contains("Nothing was started")
            && err.contains("--allow-external")
            && err.contains("motionlab trust"),
        "{what}: {err}"
    );
}

#[test]
fn an_external_command_is_never_started_without_consent() {
    let p = Probe::new();
    let exp = p.experiment("exp.toml", "marker", "");
    let cmd = p.command("marker");
    let reports = p.reports();
    let r = reports.to_str().unwrap();
    let e = exp.to_str().unwrap();
    for args in [
        vec!["validate", e],
        vec!["run", e, "--quiet", "--no-cache", "--reports", r],
        vec!["slurm", e, "--shards", "2", "--reports", r],
    ] {
        assert_refused(&p.motionlab(&args), &exp, &[&cmd], args[0]);
        assert!(!p.ran("marker"), "{}: the program ran", args[0]);
        assert!(!reports.exists(), "{}: wrote {}", args[0], reports.display());
    }
    // reproduce: refused before the first experiment runs.
    let folder = p.path("experiments");
    std::fs::create_dir_all(&folder).unwrap();
    let in_folder = p.experiment("experiments/probe.toml", "marker", "");
    assert_refused(
        &p.motionlab(&[
            "reproduce",
            "--experiments",
            folder.to_str().unwrap(),
            "--reports",
            r,
            "--quiet",
        ]),
        &in_folder,
        &[&cmd],
        "reproduce",
    );
    assert!(!p.ran("marker") && !reports.exists(), "reproduce started something");
    // merge: the shards ran with consent; the merge without it is refused.
    let run_dir = p.path("sharded");
    let shard = p.motionlab(&[
        "run",
        e,
        "--quiet",
        "--no-cache",
        "--allow-external",
        "--shard",
        "0/1",
        "--run-dir",
        run_dir.to_str().unwrap(),
    ]);
    assert!(shard.status.success(), "{}", text(&shard.stderr));
    assert!(p.ran("marker"));
    p.forget("marker");
    let canonical = std::fs::canonicalize(&exp).unwrap();
    assert_refused(
        &p.motionlab(&["merge", run_dir.to_str().unwrap(), "--quiet"]),
        &canonical,
        &[&cmd],
        "merge",
    );
    assert!(!run_dir.join("index.html").exists(), "merge without consent finished the run");
    let merged = p.motionlab(&["merge", run_dir.to_str().unwrap(), "--quiet", "--allow-external"]);
    assert!(merged.status.success(), "{}", text(&merged.stderr));
    assert!(run_dir.join("index.html").is_file());
}

#[test]
fn allow_external_and_trust_each_let_it_run_and_a_changed_command_is_not_trusted() {
    let p = Probe::new();
    let exp = p.experiment("exp.toml", "marker", "");
    let (e, reports) = (exp.to_str().unwrap(), p.reports());
    let r = reports.to_str().unwrap();
    let cmd_line = motionlab_core::programs::command_line(&p.command("marker"));

    // --allow-external: it runs, and the run page and provenance say so.
    let out = p.motionlab(&["run", e, "--quiet", "--no-cache", "--reports", r, "--allow-external"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(p.ran("marker"), "--allow-external did not run the program");
    let run = latest_run(&reports);
    let provenance: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("provenance.json")).unwrap()).unwrap();
    assert_eq!(provenance["external_consent"], "allowed by --allow-external");
    assert_eq!(provenance["external_commands"][0]["at"], "segmentation.segmenter[0]");
    let page = std::fs::read_to_string(run.join("index.html")).unwrap();
    assert!(page.contains("External programs"), "the run page does not list the program");
    assert!(page.contains(&escape_html(&cmd_line)), "the run page does not show {cmd_line}");
    p.forget("marker");

    // trust: validate lists it, run needs no flag.
    let out = p.motionlab(&["trust", e]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains(&cmd_line), "{}", text(&out.stdout));
    let records: Vec<_> = std::fs::read_dir(p.config().join("trust")).unwrap().collect();
    assert_eq!(records.len(), 1);
    let out = p.motionlab(&["validate", e]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let listed = text(&out.stdout);
    assert!(
        listed.contains("external programs (allowed by the trust record")
            && listed.contains(&format!("segmentation.segmenter[0] (external): {cmd_line}")),
        "{listed}"
    );
    assert!(!p.ran("marker"), "validate ran the program");
    let out = p.motionlab(&["run", e, "--quiet", "--no-cache", "--reports", r]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(p.ran("marker"), "a trusted experiment did not run its program");
    p.forget("marker");

    // An override that changes the command line is not covered by the record.
    let other = p.command("other_marker");
    let over = format!(
        "segmentation.segmenter[0].command={}",
        toml::Value::Array(other.iter().cloned().map(toml::Value::String).collect())
    );
    assert_refused(
        &p.motionlab(&["run", e, &over, "--quiet", "--no-cache", "--reports", r]),
        &exp,
        &[&other],
        "override",
    );
    assert!(!p.ran("other_marker"));

    // A sweep grid over the command: both command lines are listed, and a trust record made
    // without the grid covers neither the new one nor the set.
    let swept = p.experiment(
        "exp.toml",
        "marker",
        &format!(
            "\n[[sweep]]\ngrid = {{ \"segmentation.segmenter[probe].command\" = [{}, {}] }}\n",
            toml_array(&p.command("marker")),
            toml_array(&other)
        ),
    );
    let out =
        p.motionlab(&["run", swept.to_str().unwrap(), "--quiet", "--no-cache", "--reports", r]);
    assert_refused(&out, &exp, &[&p.command("marker"), &other], "sweep");
    assert!(text(&out.stderr).contains("have changed since"), "{}", text(&out.stderr));
    assert!(!p.ran("marker") && !p.ran("other_marker"));
    let out = p.motionlab(&["trust", e]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = p.motionlab(&["run", e, "--quiet", "--no-cache", "--reports", r]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        p.ran("marker") && p.ran("other_marker"),
        "the trusted sweep did not run both programs"
    );
    p.forget("marker");
    p.forget("other_marker");

    // Editing the file's command revokes the trust; revoking removes the record.
    p.experiment("exp.toml", "edited_marker", "");
    assert_refused(
        &p.motionlab(&["run", e, "--quiet", "--no-cache", "--reports", r]),
        &exp,
        &[&p.command("edited_marker")],
        "edited",
    );
    assert!(!p.ran("edited_marker"));
    let out = p.motionlab(&["trust", "--revoke", e]);
    assert!(
        out.status.success() && text(&out.stdout).contains("trust record removed"),
        "{}",
        text(&out.stdout)
    );
    assert_eq!(std::fs::read_dir(p.config().join("trust")).unwrap().count(), 0);
}

fn toml_array(args: &[String]) -> String {
    toml::Value::Array(args.iter().cloned().map(toml::Value::String).collect()).to_string()
}

/// As minijinja writes text into HTML.
fn escape_html(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&#x27;")
        .replace('/', "&#x2f;")
}

fn latest_run(reports: &Path) -> PathBuf {
    let exp = reports.join("consent_probe");
    exp.join(std::fs::read_to_string(exp.join("latest")).unwrap().trim())
}
