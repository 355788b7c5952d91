//! `motionlab plugin new NAME --kind segmenter|extractor|evaluator|workflow [--crate DIR]`: a
//! new plugin (or workflow) in the shape of CONTRIBUTING's "A plugin is one file", wired into
//! its crate.
//!
//! The file is one of the skeletons beside this one (`plugin/segmenter.rs`, `extractor.rs`,
//! `evaluator.rs`, `workflow.rs`) with its placeholder names replaced: a params struct with its doc comment,
//! a `ParamGuard`, the stage impl, the `register_plugin!` line and a known-answer test. The
//! skeletons are compiled, and their tests run, as part of this crate's unit tests, so a
//! scaffold that no longer builds fails here first. Then the crate's `src/lib.rs` gets the
//! `pub mod` line and, when it counts its plugins (motionlab's own crates), its
//! `PLUGIN_COUNT` (`WORKFLOW_COUNT` for a workflow) goes up by one. Nothing else needs
//! regenerating: the docs name no plugin count, and the crate is already in the one list of
//! linked crates (`motionlab-plugins`). Without `--crate`, the crate is motionlab's for the kind in
//! the checkout around the current directory.

use std::path::{Path, PathBuf};

use clap::{Subcommand, ValueEnum};

use motionlab_core::registry;
use motionlab_core::{Error, ErrorKind, Location, Result};

#[derive(Subcommand)]
pub enum PluginCommand {
    /// Write a new plugin: its file (params struct, ParamGuard, doc comment, the stage, a
    /// known-answer test) and its wiring (the crate's `mod` line and `PLUGIN_COUNT`).
    New {
        /// The plugin's name, snake_case: its file name and its `type = "…"` in experiments.
        name: String,
        /// What it is.
        #[arg(long)]
        kind: PluginKind,
        /// The crate to add it to (a folder with Cargo.toml and src/lib.rs, such as a copy of the
        /// plugin template's segmenter crate, examples/plugin-template/README.md). Default: motionlab's crate for the kind
        /// (motionlab-segment, motionlab-features, motionlab-eval) in the checkout around the
        /// current directory.
        #[arg(long = "crate", value_name = "DIR")]
        crate_dir: Option<PathBuf>,
    },
}

/// The kinds of plugin the scaffold writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PluginKind {
    Segmenter,
    Extractor,
    Evaluator,
    /// A workflow: an experiment section of its own (`[name]`).
    Workflow,
}

impl PluginKind {
    /// The skeleton's text and its placeholder names (module, type stem).
    fn skeleton(self) -> (&'static str, &'static str, &'static str) {
        match self {
            PluginKind::Segmenter => {
                (include_str!("plugin/segmenter.rs"), "template_segmenter", "TemplateSegmenter")
            }
            PluginKind::Extractor => {
                (include_str!("plugin/extractor.rs"), "template_extractor", "TemplateExtractor")
            }
            PluginKind::Evaluator => {
                (include_str!("plugin/evaluator.rs"), "template_evaluator", "TemplateEvaluator")
            }
            PluginKind::Workflow => {
                (include_str!("plugin/workflow.rs"), "template_workflow", "TemplateWorkflow")
            }
        }
    }

    /// The constant of a motionlab crate's lib.rs that counts what it registers.
    fn count_const(self) -> &'static str {
        match self {
            PluginKind::Workflow => "WORKFLOW_COUNT",
            _ => "PLUGIN_COUNT",
        }
    }

    /// What the crate must depend on for the file to build.
    fn dependencies(self) -> &'static [&'static str] {
        match self {
            PluginKind::Workflow => {
                &["motionlab-core", "motionlab-experiment", "serde", "schemars"]
            }
            _ => &["motionlab-core", "serde", "schemars"],
        }
    }

    /// motionlab's crate for plugins of this kind.
    fn home_crate(self) -> &'static str {
        match self {
            PluginKind::Segmenter => "motionlab-segment",
            PluginKind::Extractor => "motionlab-features",
            PluginKind::Evaluator => "motionlab-eval",
            PluginKind::Workflow => "motionlab-workflows",
        }
    }

    /// What it is, with its article (`an evaluator`).
    fn label(self) -> &'static str {
        match self {
            PluginKind::Segmenter => "a segmenter",
            PluginKind::Extractor => "a feature extractor",
            PluginKind::Evaluator => "an evaluator",
            PluginKind::Workflow => "a workflow",
        }
    }
}

/// What the scaffold wrote.
#[derive(Debug)]
pub struct Scaffold {
    /// The plugin's file.
    pub file: PathBuf,
    /// The crate's `src/lib.rs`, which got the `mod` line.
    pub lib: PathBuf,
    /// `PLUGIN_COUNT` (`WORKFLOW_COUNT`) before and after, when the crate counts them.
    pub plugin_count: Option<(usize, usize)>,
}

/// Runs `motionlab plugin …` from the current directory.
pub fn run(command: PluginCommand) -> Result<()> {
    match command {
        PluginCommand::New { name, kind, crate_dir } => {
            let cwd = std::env::current_dir().map_err(|e| {
                Error::new(ErrorKind::Io, format!("cannot read the current directory: {e}"))
            })?;
            let crate_dir = match crate_dir {
                Some(d) => d,
                None => checkout_root(&cwd)?.join("crates").join(kind.home_crate()),
            };
            let s = new_plugin(&name, kind, &crate_dir)?;
            let what = match kind {
                PluginKind::Workflow => "the section, its build, the workflow, a known-answer test",
                _ => "params, ParamGuard, the stage, a known-answer test",
            };
            println!("wrote {} ({}: {what})", s.file.display(), kind.label());
            println!("added `pub mod {name};` to {}", s.lib.display());
            if let Some((before, after)) = s.plugin_count {
                println!("{} {before} → {after} in {}", kind.count_const(), s.lib.display());
            }
            // What a contributor would otherwise look for: nothing else to regenerate.
            println!(
                "nothing else to update: the crate is linked through motionlab-plugins, the docs quote no plugin count"
            );
            let (describe, section) = match kind {
                PluginKind::Workflow => {
                    (format!("[{name}]"), format!(" and an experiment with a [{name}] section"))
                }
                _ => (name.clone(), String::new()),
            };
            println!(
                "next: replace the placeholder with yours, then `cargo test` in the crate, `motionlab describe {describe}`{section}"
            );
            Ok(())
        }
    }
}

/// The motionlab checkout holding `dir`: the nearest ancestor with `Cargo.toml` and
/// `crates/motionlab-core/`.
fn checkout_root(dir: &Path) -> Result<PathBuf> {
    dir.ancestors().find(|d| d.join("Cargo.toml").is_file() && d.join("crates/motionlab-core").is_dir()).map(Path::to_path_buf).ok_or_else(|| {
        Error::new(
            ErrorKind::MissingKey,
            format!("{} is not inside a motionlab checkout; give the crate to add the plugin to with --crate DIR", dir.display()),
        )
    })
}

/// Writes plugin `name` of `kind` into the crate at `crate_dir` and wires it in.
pub fn new_plugin(name: &str, kind: PluginKind, crate_dir: &Path) -> Result<Scaffold> {
    let (skeleton, module, type_stem) = kind.skeleton();
    let type_name = check_name(name, skeleton)?;
    let lib = crate_dir.join("src/lib.rs");
    let manifest = crate_dir.join("Cargo.toml");
    if !manifest.is_file() || !lib.is_file() {
        return Err(Error::new(
            ErrorKind::MissingKey,
            format!(
                "{} is not a crate with a library: expected Cargo.toml and src/lib.rs in it",
                crate_dir.display()
            ),
        ));
    }
    check_dependencies(&manifest, kind)?;
    let file = crate_dir.join("src").join(format!("{name}.rs"));
    if file.exists() {
        return Err(Error::new(
            ErrorKind::DuplicateName,
            format!("{} exists already; choose another name", file.display()),
        ));
    }
    let lib_text = std::fs::read_to_string(&lib).map_err(|e| Error::io(&lib, e))?;
    if lib_text.lines().any(|l| l.trim_start_matches("pub ").trim() == format!("mod {name};")) {
        return Err(Error::new(
            ErrorKind::DuplicateName,
            format!("src/lib.rs declares `mod {name};` already"),
        )
        .with_location(Location::file(&lib)));
    }
    let (lib_text, plugin_count) = wire(&lib_text, name, kind.count_const());
    let text = skeleton.replace(module, name).replace(type_stem, &type_name);
    std::fs::write(&file, text).map_err(|e| Error::io(&file, e))?;
    std::fs::write(&lib, lib_text).map_err(|e| Error::io(&lib, e))?;
    Ok(Scaffold { file, lib, plugin_count })
}

/// `name` checked — snake_case, no Rust keyword, no plugin of the binary, its CamelCase form
/// no name the skeleton imports — and that CamelCase form (`my_seg` → `MySeg`).
fn check_name(name: &str, skeleton: &str) -> Result<String> {
    let snake = name.chars().next().is_some_and(|c| c.is_ascii_lowercase())
        && name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        && !name.ends_with('_')
        && !name.contains("__");
    if !snake {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "plugin name {name:?}: expected snake_case (`my_segmenter`: lower-case letters, digits, single `_`)"
            ),
        ));
    }
    const KEYWORDS: [&str; 51] = [
        "as", "async", "await", "break", "const", "continue", "crate", "dyn", "else", "enum",
        "extern", "false", "fn", "for", "if", "impl", "in", "let", "loop", "match", "mod", "move",
        "mut", "pub", "ref", "return", "self", "static", "struct", "super", "trait", "true",
        "type", "unsafe", "use", "where", "while", "abstract", "become", "box", "do", "final",
        "gen", "macro", "override", "priv", "try", "typeof", "unsized", "virtual", "yield",
    ];
    if KEYWORDS.contains(&name) {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!("plugin name {name:?} is a Rust keyword; it cannot name a module"),
        ));
    }
    if let Some(p) = registry::plugins().into_iter().find(|p| p.name == name) {
        return Err(Error::new(
            ErrorKind::DuplicateName,
            format!(
                "a plugin named {name:?} exists already (a {} from {}); choose another name",
                p.kind.label(),
                p.crate_name
            ),
        ));
    }
    if let Some(p) = registry::custom_plugins().into_iter().find(|p| p.name == name) {
        return Err(Error::new(
            ErrorKind::DuplicateName,
            format!(
                "a plugin named {name:?} exists already (a {} from {}); choose another name",
                p.kind, p.crate_name
            ),
        ));
    }
    if let Some(w) = motionlab_experiment::workflow::find_workflow(name) {
        return Err(Error::new(
            ErrorKind::DuplicateName,
            format!(
                "a workflow named {name:?} exists already (from {}); choose another name",
                w.crate_name
            ),
        ));
    }
    let camel: String = name
        .split('_')
        .map(|part| {
            let mut c = part.chars();
            c.next().map(|f| f.to_ascii_uppercase().to_string() + c.as_str()).unwrap_or_default()
        })
        .collect();
    // Every name of the `use` items, which rustfmt may spread over several lines.
    let mut imported: Vec<&str> = Vec::new();
    let mut rest = skeleton;
    while let Some(at) = rest.find("\nuse ") {
        let item = &rest[at + 1..];
        let end = item.find(';').map_or(item.len(), |e| e + 1);
        imported.extend(item[..end].split(|c: char| !c.is_ascii_alphanumeric() && c != '_'));
        rest = &item[end..];
    }
    if imported.contains(&camel.as_str()) || imported.contains(&format!("{camel}Params").as_str()) {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "plugin name {name:?} would name its stage `{camel}`, which the file imports already; choose another name"
            ),
        ));
    }
    Ok(camel)
}

/// The crate must have what the plugin file uses: motionlab-core, serde and schemars
/// (motionlab-experiment too for a workflow), and toml for its test.
fn check_dependencies(manifest: &Path, kind: PluginKind) -> Result<()> {
    let text = std::fs::read_to_string(manifest).map_err(|e| Error::io(manifest, e))?;
    let doc: toml::Table = text.parse().map_err(|e| {
        Error::new(ErrorKind::Syntax, format!("cannot parse it: {e}"))
            .with_location(Location::file(manifest))
    })?;
    let has = |section: &str, dep: &str| {
        doc.get(section).and_then(|t| t.as_table()).is_some_and(|t| t.contains_key(dep))
    };
    let mut missing: Vec<String> = kind
        .dependencies()
        .iter()
        .filter(|d| !has("dependencies", d))
        .map(|d| format!("[dependencies] {d}"))
        .collect();
    if !has("dependencies", "toml") && !has("dev-dependencies", "toml") {
        missing.push("[dev-dependencies] toml".into());
    }
    if !missing.is_empty() {
        return Err(Error::new(
            ErrorKind::MissingKey,
            format!("the plugin needs {} (the plugin template's segmenter crate has them: examples/plugin-template/README.md)", missing.join(", ")),
        )
        .with_location(Location::file(manifest)));
    }
    Ok(())
}

/// `lib.rs` with `pub mod <name>;` after its last `pub mod` line (else at its end) and its
/// count (`count_const`: `PLUGIN_COUNT`, `WORKFLOW_COUNT`), if it has one, one higher; the
/// count before and after.
fn wire(lib: &str, name: &str, count_const: &str) -> (String, Option<(usize, usize)>) {
    let mut lines: Vec<String> = lib.lines().map(str::to_string).collect();
    let is_mod = |l: &str| l.starts_with("pub mod ") && l.ends_with(';');
    let at = lines.iter().rposition(|l| is_mod(l)).map_or(lines.len(), |k| k + 1);
    lines.insert(at, format!("pub mod {name};"));
    let mut count = None;
    let prefix = format!("pub const {count_const}: usize = ");
    for l in &mut lines {
        if let Some(n) = l
            .strip_prefix(prefix.as_str())
            .and_then(|rest| rest.strip_suffix(';'))
            .and_then(|n| n.trim().parse::<usize>().ok())
        {
            *l = format!("{prefix}{};", n + 1);
            count = Some((n, n + 1));
        }
    }
    let mut text = lines.join("\n");
    if lib.ends_with('\n') {
        text.push('\n');
    }
    (text, count)
}

// The skeletons, compiled and tested as they are written (placeholder names registered in this
// crate's unit-test binary only).
#[cfg(test)]
#[path = "plugin/segmenter.rs"]
mod segmenter_skeleton;

#[cfg(test)]
#[path = "plugin/extractor.rs"]
mod extractor_skeleton;

#[cfg(test)]
#[path = "plugin/evaluator.rs"]
mod evaluator_skeleton;

#[cfg(test)]
#[path = "plugin/workflow.rs"]
mod workflow_skeleton;

#[cfg(test)]
mod tests {
    use super::*;

    /// A crate folder like the plugin template's: its manifest with the dependencies a plugin
    /// needs, and a lib.rs with two plugin modules, a private one and a count.
    fn scratch_crate(count: bool) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("src")).unwrap();
        std::fs::write(
            dir.path().join("Cargo.toml"),
            "[package]\nname = \"mine\"\n\n[dependencies]\nmotionlab-core.workspace = true\nmotionlab-experiment.workspace = true\nserde.workspace = true\nschemars.workspace = true\n\n[dev-dependencies]\ntoml.workspace = true\n",
        )
        .unwrap();
        let count_line = if count { "pub const PLUGIN_COUNT: usize = 2;\n\n" } else { "" };
        std::fs::write(dir.path().join("src/lib.rs"), format!("//! Mine.\n\n{count_line}pub mod alpha;\npub mod beta;\n\n#[cfg(test)]\nmod support;\n")).unwrap();
        dir
    }

    #[test]
    fn a_segmenter_is_written_and_wired_in() {
        let dir = scratch_crate(true);
        let s = new_plugin("my_seg", PluginKind::Segmenter, dir.path()).unwrap();
        assert_eq!(s.plugin_count, Some((2, 3)));
        let lib = std::fs::read_to_string(dir.path().join("src/lib.rs")).unwrap();
        assert_eq!(
            lib,
            "//! Mine.\n\npub const PLUGIN_COUNT: usize = 3;\n\npub mod alpha;\npub mod beta;\npub mod my_seg;\n\n#[cfg(test)]\nmod support;\n"
        );
        let file = std::fs::read_to_string(dir.path().join("src/my_seg.rs")).unwrap();
        assert!(
            file.contains("motionlab_core::register_plugin!(Segmenter, MySegParams, \"my_seg\");"),
            "{file}"
        );
        assert!(
            file.contains("pub struct MySeg {")
                && file.contains("impl Segmenter for MySeg {")
                && file.contains("`motionlab describe my_seg`")
        );
        assert!(
            !file.contains("template") && !file.contains("Template"),
            "a placeholder is left:\n{file}"
        );
        // Written once: a second time is refused, and nothing changes.
        let e = new_plugin("my_seg", PluginKind::Segmenter, dir.path()).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::DuplicateName);
        assert_eq!(std::fs::read_to_string(dir.path().join("src/lib.rs")).unwrap(), lib);
    }

    #[test]
    fn every_kind_gets_its_skeleton_and_an_uncounted_crate_only_its_mod_line() {
        for (kind, name, line) in [
            (
                PluginKind::Extractor,
                "knee_height",
                "register_plugin!(FeatureExtractor, KneeHeightParams, \"knee_height\")",
            ),
            (PluginKind::Evaluator, "rate2", "register_plugin!(Evaluator, Rate2Params, \"rate2\")"),
            (PluginKind::Workflow, "cut_counts", "register_workflow!(CutCounts, \"cut_counts\")"),
        ] {
            let dir = scratch_crate(false);
            let s = new_plugin(name, kind, dir.path()).unwrap();
            assert_eq!(s.plugin_count, None);
            assert!(std::fs::read_to_string(&s.file).unwrap().contains(line));
            assert!(
                std::fs::read_to_string(&s.lib)
                    .unwrap()
                    .contains(&format!("pub mod beta;\npub mod {name};\n"))
            );
        }
    }

    #[test]
    fn bad_names_and_crates_are_refused_with_the_reason() {
        let dir = scratch_crate(true);
        let refused = |name: &str, kind: PluginKind| {
            new_plugin(name, kind, dir.path()).unwrap_err().to_string()
        };
        assert!(refused("MySeg", PluginKind::Segmenter).contains("expected snake_case"));
        assert!(refused("my__seg", PluginKind::Segmenter).contains("expected snake_case"));
        assert!(refused("type", PluginKind::Segmenter).contains("Rust keyword"));
        // The binary has the built-in plugins: their names are taken.
        assert!(
            refused("speed_minima", PluginKind::Segmenter)
                .contains("exists already (a segmenter from motionlab-segment)")
        );
        // `segmenter` would be a struct `Segmenter` beside the trait it implements.
        assert!(refused("segmenter", PluginKind::Segmenter).contains("imports already"));
        assert!(
            !dir.path().join("src/speed_minima.rs").exists()
                && !dir.path().join("src/segmenter.rs").exists()
        );
        // A crate without what the file uses.
        std::fs::write(
            dir.path().join("Cargo.toml"),
            "[package]\nname = \"mine\"\n\n[dependencies]\nmotionlab-core.workspace = true\n",
        )
        .unwrap();
        let e = refused("fine_name", PluginKind::Segmenter);
        assert!(
            e.contains("Cargo.toml")
                && e.contains(
                    "[dependencies] serde, [dependencies] schemars, [dev-dependencies] toml"
                ),
            "{e}"
        );
        let e = new_plugin("fine_name", PluginKind::Segmenter, &dir.path().join("src"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("expected Cargo.toml and src/lib.rs"), "{e}");
    }

    #[test]
    fn the_skeletons_register_documented_plugins() {
        // Compiled into this binary under their placeholder names: the registry's own rules
        // (documented parameters, defaults that build) hold for them.
        for name in ["template_segmenter", "template_extractor", "template_evaluator"] {
            assert!(registry::find(name).is_ok(), "{name} is not registered");
        }
        let problems: Vec<String> =
            registry::check_registry().into_iter().filter(|p| p.contains("template_")).collect();
        assert!(problems.is_empty(), "{problems:?}");
    }

    #[test]
    fn the_checkout_is_found_from_a_folder_inside_it() {
        let root = checkout_root(Path::new(env!("CARGO_MANIFEST_DIR"))).unwrap();
        assert!(root.join("crates/motionlab-segment/src/lib.rs").is_file());
        assert!(checkout_root(Path::new("/")).unwrap_err().to_string().contains("--crate DIR"));
    }
}
