//! Docs that stay true: what README.md, CONTRIBUTING.md and docs/*.md state about the
//! repository is checked against the tree.
//!
//! - Every repository path they name (in inline code or as a link target, outside ```text
//!   blocks of example output) exists; `*` and `<name>` match any file name, `{a,b}` any of a
//!   list, and a `:line` suffix is ignored. A file the reader is to write is named as an
//!   example (`tests/foo.rs`, `experiments/my_dance.toml`) and not looked for.
//! - The counts they quote match: inputs in `tests/fixtures/malformed/`, plugins (the crates'
//!   `PLUGIN_COUNT`s), workflows (`WORKFLOW_COUNT`s) and test modules (`tests/*.rs`).
//! - `just bench` runs every benchmark, as README says: each crate with `benches/` and each
//!   side-by-side script in `bench/`.
//! - The crate graph of docs/ARCHITECTURE.md is the one the `crates/*/Cargo.toml` files give:
//!   generated here, from whatever crates exist. When a crate or a dependency changes, the test
//!   prints the new block; `MOTIONLAB_BLESS_DOCS=1 cargo test -p motionlab-cli --test
//!   integration docs_truth::` writes it into the page.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use regex::Regex;

fn root() -> PathBuf {
    motionlab_testkit::repo_root()
}

/// The documents whose statements are checked: README.md, CONTRIBUTING.md and docs/*.md.
fn documents(root: &Path) -> Vec<PathBuf> {
    let mut docs = vec![root.join("README.md"), root.join("CONTRIBUTING.md")];
    let mut pages: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .expect("docs/ reads")
        .map(|e| e.expect("docs/ entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    pages.sort();
    docs.extend(pages);
    docs
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The entries at the top of the repository (`crates`, `README.md`, `.ci`, …): a named path
/// is a repository path when it starts with one of them.
fn top_level(root: &Path) -> BTreeSet<String> {
    std::fs::read_dir(root)
        .expect("the repository root reads")
        .map(|e| e.expect("root entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n != ".git" && n != "target")
        .collect()
}

/// The repository paths a Markdown text names, with their 1-based lines: the words of its
/// inline code spans and its link targets that start with a top-level entry, outside fenced
/// ```text blocks (example output, which names files of a made-up experiment). Fenced code of
/// other languages counts: its commands name real files.
fn named_paths(text: &str, top: &BTreeSet<String>) -> Vec<(usize, String)> {
    let code = Regex::new(r"`([^`]+)`").unwrap();
    let link = Regex::new(r"\]\(([^)\s]+)\)").unwrap();
    let mut out = Vec::new();
    let mut in_fence: Option<String> = None;
    for (k, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if let Some(info) = trimmed.strip_prefix("```") {
            in_fence = match in_fence {
                Some(_) => None,
                None => Some(info.trim().to_string()),
            };
            continue;
        }
        let words: Vec<&str> = match in_fence.as_deref() {
            Some("text") => continue,
            Some(_) => line.split_whitespace().collect(),
            None => code
                .captures_iter(line)
                .flat_map(|c| c.get(1).map_or("", |m| m.as_str()).split_whitespace())
                .chain(link.captures_iter(line).filter_map(|c| c.get(1).map(|m| m.as_str())))
                .collect(),
        };
        for w in words {
            if let Some(p) = repository_path(w, top) {
                out.push((k + 1, p));
            }
        }
    }
    out
}

/// `word` as a repository path, if it is one: quotes, trailing punctuation and a `:line`
/// suffix removed, then its first component a top-level entry. A file named as an example of
/// one the reader writes — `foo.rs`, `my_dance.toml`: stem `foo` or starting with `my_` — is
/// none.
fn repository_path(word: &str, top: &BTreeSet<String>) -> Option<String> {
    let w =
        word.trim_matches(|c: char| matches!(c, '"' | '\'' | ',' | ';' | '(' | ')' | '[' | ']'));
    let w = w.trim_end_matches('.');
    let w = match w.rsplit_once(':') {
        Some((path, line)) if !line.is_empty() && line.bytes().all(|b| b.is_ascii_digit()) => path,
        _ => w,
    };
    let first = w.split('/').next()?;
    let stem = w.rsplit('/').next().unwrap_or(w).split('.').next().unwrap_or("");
    let example = stem == "foo" || stem.starts_with("my_");
    (top.contains(first) && (w.contains('/') || w == first) && !example)
        .then(|| w.trim_end_matches('/').to_string())
}

/// Whether `path` (relative to `root`, possibly with `*`, `<name>` or `{a,b}`) matches
/// something in the tree.
fn exists(root: &Path, path: &str) -> bool {
    let angle = Regex::new(r"<[^>]*>").unwrap();
    let pattern = angle.replace_all(path, "*").into_owned();
    alternatives(&pattern).iter().any(|p| {
        let full = root.join(p).to_string_lossy().into_owned();
        if p.contains(['*', '?', '[']) {
            glob::glob(&full).is_ok_and(|mut hits| hits.next().is_some())
        } else {
            Path::new(&full).exists()
        }
    })
}

/// `a.{x,y}` → `a.x`, `a.y` (one brace group; a path without one is its own alternative).
fn alternatives(pattern: &str) -> Vec<String> {
    match (pattern.find('{'), pattern.find('}')) {
        (Some(a), Some(b)) if a < b => pattern[a + 1..b]
            .split(',')
            .map(|alt| format!("{}{alt}{}", &pattern[..a], &pattern[b + 1..]))
            .collect(),
        _ => vec![pattern.to_string()],
    }
}

/// The paths `text` names that do not exist under `root`: `(line, path)`.
fn missing_paths(root: &Path, text: &str) -> Vec<(usize, String)> {
    named_paths(text, &top_level(root)).into_iter().filter(|(_, p)| !exists(root, p)).collect()
}

#[test]
fn every_path_the_docs_name_exists() {
    let root = root();
    let mut missing = Vec::new();
    let mut checked = 0;
    for doc in documents(&root) {
        let text = read(&doc);
        checked += named_paths(&text, &top_level(&root)).len();
        for (line, path) in missing_paths(&root, &text) {
            missing.push(format!(
                "{}:{line}: {path}",
                doc.strip_prefix(&root).unwrap_or(&doc).display()
            ));
        }
    }
    assert!(checked > 100, "only {checked} paths found in the docs: is the extraction broken?");
    assert!(missing.is_empty(), "the docs name paths that do not exist:\n{}", missing.join("\n"));
}

#[test]
fn the_checker_reports_a_named_path_that_is_gone() {
    let root = root();
    let doc = "The worked example is `crates/motionlab-segment/src/speed_minima.rs`; its tests are in\n\
               `crates/motionlab-segment/src/no_such_file.rs:12`, and [the map](docs/NO_SUCH_PAGE.md).\n\
               ```text\nerror: data/made_up.bvh:3: example output is not checked\n```\n\
               ```sh\nmotionlab run experiments/no_such_experiment.toml\n```\n";
    let missing = missing_paths(&root, doc);
    assert_eq!(
        missing,
        [
            (2, "crates/motionlab-segment/src/no_such_file.rs".to_string()),
            (2, "docs/NO_SUCH_PAGE.md".to_string()),
            (7, "experiments/no_such_experiment.toml".to_string())
        ]
    );
    // Globs and placeholders match existing files; a glob that matches nothing is missing.
    assert!(
        exists(&root, "crates/*/benches")
            && exists(&root, "reports/<experiment>/record")
            && exists(&root, "README.{md,txt}")
    );
    assert!(!exists(&root, "crates/*/no_such_folder"));
    // A file the reader is to write is an example, not a claim.
    assert!(
        missing_paths(
            &root,
            "Add `tests/foo.rs`, or `motionlab new … -o experiments/my_dance.toml`."
        )
        .is_empty()
    );
}

/// Files in `tests/fixtures/malformed/` other than the script that makes them.
fn malformed_inputs(root: &Path) -> usize {
    std::fs::read_dir(root.join("tests/fixtures/malformed"))
        .expect("the malformed corpus reads")
        .filter(|e| e.as_ref().is_ok_and(|e| e.file_name() != "make.py"))
        .count()
}

/// The sum of `pub const <NAME>: usize = N;` over the crates' `src/lib.rs`.
fn declared_count(root: &Path, name: &str) -> usize {
    let re = Regex::new(&format!(r"pub const {name}: usize = (\d+);")).unwrap();
    crate_dirs(root)
        .iter()
        .filter_map(|d| std::fs::read_to_string(d.join("src/lib.rs")).ok())
        .filter_map(|lib| re.captures(&lib).map(|c| c[1].parse::<usize>().unwrap()))
        .sum()
}

/// The test modules of the integration binary: `tests/*.rs` but `integration.rs`.
fn test_modules(root: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(root.join("tests"))
        .expect("tests/ reads")
        .filter_map(|e| {
            let p = e.ok()?.path();
            (p.extension()? == "rs" && p.file_stem()? != "integration")
                .then(|| p.file_stem().unwrap().to_string_lossy().into_owned())
        })
        .collect();
    v.sort();
    v
}

/// The counts a text quotes that differ from the tree: (line, what, quoted, actual).
fn wrong_counts(text: &str, counts: &[(&str, Regex, usize)]) -> Vec<(usize, String, usize, usize)> {
    let mut wrong = Vec::new();
    for (k, line) in text.lines().enumerate() {
        for (what, re, actual) in counts {
            for c in re.captures_iter(line) {
                let quoted: usize = c[1].replace(',', "").parse().unwrap();
                if quoted != *actual {
                    wrong.push((k + 1, what.to_string(), quoted, *actual));
                }
            }
        }
    }
    wrong
}

fn quoted_counts(root: &Path) -> Vec<(&'static str, Regex, usize)> {
    vec![
        (
            "inputs in tests/fixtures/malformed/",
            Regex::new(r"(\d[\d,]*) [^.`]*`tests/fixtures/malformed/`").unwrap(),
            malformed_inputs(root),
        ),
        (
            "plugins (PLUGIN_COUNT)",
            Regex::new(r"\b(\d[\d,]*) (?:built-in )?plugins\b").unwrap(),
            declared_count(root, "PLUGIN_COUNT"),
        ),
        (
            "workflows (WORKFLOW_COUNT)",
            Regex::new(r"\b(\d[\d,]*) (?:built-in )?workflows\b").unwrap(),
            declared_count(root, "WORKFLOW_COUNT"),
        ),
        (
            "test modules (tests/*.rs)",
            Regex::new(r"\b(\d[\d,]*) test modules\b").unwrap(),
            test_modules(root).len(),
        ),
    ]
}

#[test]
fn the_counts_the_docs_quote_match_the_tree() {
    let root = root();
    let counts = quoted_counts(&root);
    let mut wrong = Vec::new();
    for doc in documents(&root) {
        for (line, what, quoted, actual) in wrong_counts(&read(&doc), &counts) {
            wrong.push(format!(
                "{}:{line}: {quoted} {what}, the tree has {actual}",
                doc.strip_prefix(&root).unwrap_or(&doc).display()
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // The malformed count is quoted somewhere, so this test is not vacuous.
    let readme = read(&root.join("README.md"));
    assert!(
        counts[0].1.is_match(&readme),
        "README should quote how many inputs tests/fixtures/malformed/ holds"
    );
    // And a wrong quote is caught.
    let n = malformed_inputs(&root);
    let stale = format!(
        "This is tested: {} inputs in `tests/fixtures/malformed/`, and {} plugins.",
        n + 1,
        declared_count(&root, "PLUGIN_COUNT")
    );
    assert_eq!(wrong_counts(&stale, &counts), [(1, counts[0].0.to_string(), n + 1, n)]);
}

#[test]
fn every_test_module_is_in_the_integration_binary() {
    let root = root();
    let integration = read(&root.join("tests/integration.rs"));
    let missing: Vec<String> = test_modules(&root)
        .into_iter()
        .filter(|m| !integration.lines().any(|l| l.trim() == format!("mod {m};")))
        .collect();
    assert!(
        missing.is_empty(),
        "tests/*.rs files without a `mod` line in tests/integration.rs (they never compile): {missing:?}"
    );
}

#[test]
fn just_bench_runs_every_benchmark() {
    let root = root();
    let justfile = read(&root.join("justfile"));
    let recipe: String = justfile
        .split("\nbench:")
        .nth(1)
        .expect("justfile has a bench recipe")
        .lines()
        .skip(1)
        .take_while(|l| l.starts_with(' ') || l.starts_with('\t'))
        .collect::<Vec<_>>()
        .join("\n");
    let mut missing = Vec::new();
    for dir in crate_dirs(&root) {
        if dir.join("benches").is_dir() {
            let name = crate_name(&dir);
            if !recipe.contains(&format!("cargo bench -p {name}")) {
                missing.push(format!("cargo bench -p {name}"));
            }
        }
    }
    for e in std::fs::read_dir(root.join("bench")).expect("bench/ reads") {
        let p = e.expect("bench/ entry").path();
        let file = p.file_name().unwrap().to_string_lossy().into_owned();
        // bench_env.py is the scripts' shared helper, not a benchmark.
        if p.extension().is_some_and(|x| x == "py")
            && file != "bench_env.py"
            && !recipe.contains(&format!("bench/{file}"))
        {
            missing.push(format!("bench/{file}"));
        }
    }
    assert!(
        missing.is_empty(),
        "README says `just bench` runs every benchmark; the justfile's bench recipe lacks: {missing:?}"
    );
}

#[test]
fn the_templates_dev_and_test_profiles_are_the_workspaces() {
    // Its Cargo.toml says so: a shared target dir then reuses the workspace's debug builds.
    let root = root();
    let profiles = |path: &str| -> Vec<(String, toml::Value)> {
        let m: toml::Table = read(&root.join(path)).parse().unwrap();
        let p = m.get("profile").and_then(|p| p.as_table()).cloned().unwrap_or_default();
        ["dev", "test"]
            .iter()
            .map(|k| {
                (
                    k.to_string(),
                    p.get(*k).cloned().unwrap_or(toml::Value::Table(toml::Table::new())),
                )
            })
            .collect()
    };
    assert_eq!(profiles("examples/plugin-template/Cargo.toml"), profiles("Cargo.toml"));
}

// ---------------------------------------------------------------------------------------------
// The crate graph of docs/ARCHITECTURE.md
// ---------------------------------------------------------------------------------------------

const GRAPH_BEGIN: &str = "<!-- crate graph: generated by tests/docs_truth.rs from crates/*/Cargo.toml; do not edit by hand -->";
const GRAPH_END: &str = "<!-- end of the generated crate graph -->";

fn crate_dirs(root: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .expect("crates/ reads")
        .map(|e| e.expect("crates/ entry").path())
        .filter(|p| p.join("Cargo.toml").is_file())
        .collect();
    v.sort();
    v
}

fn manifest(dir: &Path) -> toml::Table {
    read(&dir.join("Cargo.toml")).parse().unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
}

fn crate_name(dir: &Path) -> String {
    manifest(dir)["package"]["name"].as_str().expect("package.name").to_string()
}

/// One crate as its Cargo.toml describes it.
struct CrateInfo {
    name: String,
    description: String,
    /// Its normal dependencies among the workspace's crates.
    internal: BTreeSet<String>,
    /// Its normal dependencies among polars, plotters and clap.
    front_end: BTreeSet<String>,
    /// What it registers, for a crate of the one list (`motionlab-plugins`): plugins or
    /// workflows. Not their number: that changes with every plugin (`motionlab plugin new`),
    /// and `tests/registry.rs` checks it.
    registers: Option<String>,
    /// Whether its lib.rs declares a `PLUGIN_COUNT` or a `WORKFLOW_COUNT`.
    declares_count: bool,
}

fn crates(root: &Path) -> Vec<CrateInfo> {
    let dirs = crate_dirs(root);
    let names: BTreeSet<String> = dirs.iter().map(|d| crate_name(d)).collect();
    let plugins = Regex::new(r"pub const PLUGIN_COUNT: usize = (\d+);").unwrap();
    let workflows = Regex::new(r"pub const WORKFLOW_COUNT: usize = (\d+);").unwrap();
    dirs.iter()
        .map(|d| {
            let m = manifest(d);
            let deps: Vec<String> = m
                .get("dependencies")
                .and_then(|t| t.as_table())
                .map(|t| t.keys().cloned().collect())
                .unwrap_or_default();
            let lib = std::fs::read_to_string(d.join("src/lib.rs")).unwrap_or_default();
            let name = m["package"]["name"].as_str().unwrap().to_string();
            let registers = motionlab_plugins::find(&name).map(|l| {
                match (l.plugins > 0, l.workflows > 0) {
                    (true, true) => "plugins, workflows",
                    (true, false) => "plugins",
                    (false, true) => "workflows",
                    (false, false) => "linked, no plugin",
                }
                .to_string()
            });
            let declares_count = plugins.is_match(&lib) || workflows.is_match(&lib);
            CrateInfo {
                name,
                description: m["package"]
                    .get("description")
                    .and_then(|v| v.as_str())
                    .unwrap_or("")
                    .to_string(),
                internal: deps.iter().filter(|d| names.contains(*d)).cloned().collect(),
                front_end: deps
                    .iter()
                    .filter(|d| ["polars", "plotters", "clap"].contains(&d.as_str()))
                    .cloned()
                    .collect(),
                registers,
                declares_count,
            }
        })
        .collect()
}

/// Every crate `name` depends on, directly or not.
fn closure(name: &str, by_name: &BTreeMap<&str, &CrateInfo>) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut stack = vec![name.to_string()];
    while let Some(n) = stack.pop() {
        for d in by_name.get(n.as_str()).map(|c| &c.internal).into_iter().flatten() {
            if seen.insert(d.clone()) {
                stack.push(d.clone());
            }
        }
    }
    seen
}

/// The generated part of docs/ARCHITECTURE.md: a Mermaid graph of the direct dependencies
/// (without the edges another path already implies) and a table of every crate.
fn crate_graph(root: &Path) -> String {
    let all = crates(root);
    let by_name: BTreeMap<&str, &CrateInfo> = all.iter().map(|c| (c.name.as_str(), c)).collect();
    let short = |n: &str| n.strip_prefix("motionlab-").unwrap_or(n).replace('-', "_");
    let mut out = String::new();
    out.push_str(GRAPH_BEGIN);
    out.push_str("\n\n```mermaid\ngraph TD\n");
    for c in &all {
        out.push_str(&format!("  {}[{}]\n", short(&c.name), c.name));
    }
    for c in &all {
        for d in &c.internal {
            // `c → d` is implied when another direct dependency of `c` reaches `d`.
            let implied = c.internal.iter().any(|o| o != d && closure(o, &by_name).contains(d));
            if !implied {
                out.push_str(&format!("  {} --> {}\n", short(&c.name), short(d)));
            }
        }
    }
    out.push_str("```\n\n");
    out.push_str("| crate | what it is (its `description`) | depends on (directly) | registers | polars / plotters / clap |\n|---|---|---|---|---|\n");
    let quoted = |names: &BTreeSet<String>| {
        names.iter().map(|d| format!("`{d}`")).collect::<Vec<_>>().join(", ")
    };
    for c in &all {
        let direct = if c.internal.is_empty() { "—".to_string() } else { quoted(&c.internal) };
        // The front-end crates it depends on itself, then those it gets through another crate.
        let own = c.front_end.iter().cloned().collect::<Vec<_>>().join(", ");
        let via: BTreeSet<String> = closure(&c.name, &by_name)
            .into_iter()
            .filter(|d| !by_name[d.as_str()].front_end.is_empty())
            .collect();
        let through: BTreeSet<String> = via
            .iter()
            .flat_map(|d| by_name[d.as_str()].front_end.iter().cloned())
            .filter(|f| !c.front_end.contains(f))
            .collect();
        let through = if through.is_empty() {
            String::new()
        } else {
            format!(
                "{} through {}",
                through.into_iter().collect::<Vec<_>>().join(", "),
                quoted(&via)
            )
        };
        let front = match (own.is_empty(), through.is_empty()) {
            (true, true) => "no".to_string(),
            (false, true) => own,
            (true, false) => through,
            (false, false) => format!("{own}; {through}"),
        };
        out.push_str(&format!(
            "| `{}` | {} | {} | {} | {} |\n",
            c.name,
            c.description.replace('|', "\\|"),
            direct,
            c.registers.as_deref().unwrap_or("—"),
            front
        ));
    }
    out.push('\n');
    out.push_str(GRAPH_END);
    out
}

#[test]
fn the_architecture_pages_crate_graph_is_the_cargo_manifests() {
    let root = root();
    let path = root.join("docs/ARCHITECTURE.md");
    let page = read(&path);
    let (Some(a), Some(b)) = (page.find(GRAPH_BEGIN), page.find(GRAPH_END)) else {
        panic!(
            "docs/ARCHITECTURE.md lacks the generated crate graph between {GRAPH_BEGIN:?} and {GRAPH_END:?}"
        );
    };
    let written = &page[a..b + GRAPH_END.len()];
    let generated = crate_graph(&root);
    if written == generated {
        return;
    }
    if std::env::var_os("MOTIONLAB_BLESS_DOCS").is_some() {
        let updated = format!("{}{generated}{}", &page[..a], &page[b + GRAPH_END.len()..]);
        std::fs::write(&path, updated).expect("docs/ARCHITECTURE.md writes");
        return;
    }
    panic!(
        "docs/ARCHITECTURE.md's crate graph is not the one crates/*/Cargo.toml give; rewrite it with\n  \
         MOTIONLAB_BLESS_DOCS=1 cargo test -p motionlab-cli --test integration docs_truth::\nor paste:\n{generated}"
    );
}

/// The one list of plugin crates (`motionlab-plugins`' `LINKED`) is its Cargo.toml's
/// dependencies, and holds every crate that counts plugins or workflows.
#[test]
fn the_plugin_bundle_lists_every_plugin_crate() {
    let root = root();
    let all = crates(&root);
    let linked: BTreeSet<String> =
        motionlab_plugins::LINKED.iter().map(|c| c.package.to_string()).collect();
    let bundle = all.iter().find(|c| c.name == "motionlab-plugins").expect("the bundle crate");
    assert_eq!(
        bundle.internal, linked,
        "crates/motionlab-plugins: its Cargo.toml's dependencies and its LINKED list differ"
    );
    let counting: BTreeSet<String> =
        all.iter().filter(|c| c.declares_count).map(|c| c.name.clone()).collect();
    let missing: Vec<&String> = counting.difference(&linked).collect();
    assert!(
        missing.is_empty(),
        "{missing:?} declare a PLUGIN_COUNT or WORKFLOW_COUNT but are not in motionlab-plugins' LINKED: their plugins would not be linked"
    );
}

#[test]
fn readme_lists_every_crate_once() {
    let root = root();
    let readme = read(&root.join("README.md"));
    let row = Regex::new(r"(?m)^\| `(motionlab-[a-z0-9-]+)` \|").unwrap();
    let listed: Vec<String> = row.captures_iter(&readme).map(|c| c[1].to_string()).collect();
    let tree: Vec<String> = crate_dirs(&root).iter().map(|d| crate_name(d)).collect();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(sorted, tree, "README's crate table should have one row per crate under crates/");
    // One table: CONTRIBUTING points to it instead of keeping a second.
    let contributing = read(&root.join("CONTRIBUTING.md"));
    assert!(
        !row.is_match(&contributing),
        "CONTRIBUTING.md has a crate table of its own; README's is the one"
    );
}
