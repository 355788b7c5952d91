//! `motionlab list` and `motionlab describe` (and the Python package's `plugins()` and
//! `describe()`): plugin docs from the same source as the code (the params struct's doc
//! comments, via its JSON schema).

use std::fmt::Write;

use motionlab_core::Result;
use motionlab_core::registry::{self, ParamDoc, StageKind};
use motionlab_experiment::workflow::{find_workflow, workflows};

/// A kind's list position, its label and its plugins' (name, summary).
type KindLines<'a> = (u32, &'a str, Vec<(&'a str, String)>);

/// Every registered workflow and plugin by kind, one line each, in list order.
pub fn list() -> String {
    let all = registry::plugins();
    let mut out = String::new();
    let _ = writeln!(out, "workflows (an experiment's section):");
    for w in workflows() {
        let _ = writeln!(out, "  {:<28} {}", format!("[{}]", w.name), w.summary());
    }
    let custom = registry::custom_plugins();
    // Core's kinds and the kinds family crates declare, in list order; each kind's plugins.
    let mut kinds: Vec<KindLines> = StageKind::ALL
        .iter()
        .map(|&k| {
            (
                k.list_order(),
                k.label(),
                all.iter().filter(|p| p.kind == k).map(|p| (p.name, p.summary())).collect(),
            )
        })
        .collect();
    for k in registry::declared_kinds() {
        kinds.push((
            k.list_order,
            k.label,
            custom.iter().filter(|p| p.kind == k.name).map(|p| (p.name, p.summary())).collect(),
        ));
    }
    kinds.sort_by_key(|k| k.0);
    for (_, label, of_kind) in kinds {
        if of_kind.is_empty() {
            continue;
        }
        let _ = writeln!(out, "{label}s:");
        for (name, summary) in of_kind {
            let _ = writeln!(out, "  {name:<28} {summary}");
        }
    }
    // Kinds nobody declares (`register_custom_plugin!` alone), under their kind's name.
    for kind in
        registry::custom_kinds().into_iter().filter(|k| registry::declared_kind(k).is_none())
    {
        let _ = writeln!(out, "{kind} (custom kind):");
        for p in custom.iter().filter(|p| p.kind == kind) {
            let _ = writeln!(out, "  {:<28} {}", p.name, p.summary());
        }
    }
    out
}

/// A workflow's (`segmentation`, `[segmentation]`) or a plugin's documentation and parameters.
pub fn describe(name: &str) -> Result<String> {
    let section = name.trim_start_matches('[').trim_end_matches(']');
    if let Some(w) = find_workflow(section) {
        let mut out = String::new();
        let _ = writeln!(out, "[{}] (workflow, from {})\n", w.name, w.crate_name);
        let _ = writeln!(out, "{}\n", w.doc());
        write_params(&mut out, w.params());
        let _ = writeln!(out, "\nIn an experiment: a [{}] section with these keys.", w.name);
        return Ok(out);
    }
    if let Some(p) = registry::find_custom(name) {
        let mut out = String::new();
        match registry::declared_kind(p.kind) {
            Some(k) => writeln!(out, "{} ({}, from {})\n", p.name, k.label, p.crate_name),
            None => {
                writeln!(out, "{} ({}, a custom kind, from {})\n", p.name, p.kind, p.crate_name)
            }
        }
        .ok();
        let _ = writeln!(out, "{}\n", p.doc());
        if write_params(&mut out, p.params()) {
            let kind = registry::declared_kind(p.kind).map_or(p.kind, |k| k.label);
            let _ = writeln!(
                out,
                "\nIn an experiment: {{ type = \"{}\", <parameter> = <value>, … }} where a {kind} is expected",
                p.name
            );
        }
        return Ok(out);
    }
    let p = registry::find(name)?;
    let mut out = String::new();
    let _ = writeln!(out, "{} ({}, from {})\n", p.name, p.kind.label(), p.crate_name);
    let _ = writeln!(out, "{}\n", p.doc());
    if !write_params(&mut out, p.params()) {
        return Ok(out);
    }
    let tuned_on = registry::defaults_tuned_on(&(p.schema)());
    if !tuned_on.is_empty() {
        // Evaluation tables mark a sequence scored at these defaults whose input is one of
        // these as "tuned on this sequence (oracle)" (`parameters_chosen`).
        let _ = writeln!(out, "\nDefaults tuned on {} input file(s) (SHA-256):", tuned_on.len());
        for h in &tuned_on {
            let _ = writeln!(out, "  {h}");
        }
    }
    let _ =
        writeln!(out, "\nIn an experiment: {{ type = \"{}\", <parameter> = <value>, … }}", p.name);
    Ok(out)
}

/// The parameter list; false when there is none.
fn write_params(out: &mut String, params: Vec<ParamDoc>) -> bool {
    if params.is_empty() {
        let _ = writeln!(out, "Parameters: none");
        return false;
    }
    let _ = writeln!(out, "Parameters:");
    for d in params {
        let default = match (&d.default_note, &d.default, d.required) {
            (_, _, true) => "required".to_string(),
            (Some(note), _, _) => format!("default: {note}"),
            (None, Some(v), _) => format!("default {v}"),
            (None, None, _) => "optional".to_string(),
        };
        let _ = writeln!(out, "  {} : {}  ({default})", d.name, d.type_name);
        for line in d.description.lines() {
            let _ = writeln!(out, "      {line}");
        }
    }
    true
}
