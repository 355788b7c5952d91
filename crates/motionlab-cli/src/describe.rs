//! `motionlab list` and `motionlab describe`: plugin docs from the same source as the code
//! (the params struct's doc comments, via its JSON schema).

use std::fmt::Write;

use motionlab_core::registry::{self, StageKind};
use motionlab_core::Result;

pub fn list() -> String {
    let all = registry::plugins();
    let mut out = String::new();
    for kind in StageKind::ALL {
        let of_kind: Vec<_> = all.iter().filter(|p| p.kind == kind).collect();
        if of_kind.is_empty() {
            continue;
        }
        let _ = writeln!(out, "{}s:", kind.label());
        for p in of_kind {
            let _ = writeln!(out, "  {:<28} {}", p.name, p.summary());
        }
    }
    out
}

pub fn describe(name: &str) -> Result<String> {
    let p = registry::find(name)?;
    let mut out = String::new();
    let _ = writeln!(out, "{} ({}, from {})\n", p.name, p.kind.label(), p.crate_name);
    let _ = writeln!(out, "{}\n", p.doc());
    let params = p.params();
    if params.is_empty() {
        let _ = writeln!(out, "Parameters: none");
        return Ok(out);
    }
    let _ = writeln!(out, "Parameters:");
    for d in params {
        let default = match (&d.default, d.required) {
            (_, true) => "required".to_string(),
            (Some(v), _) => format!("default {v}"),
            (None, _) => "optional".to_string(),
        };
        let _ = writeln!(out, "  {} : {}  ({default})", d.name, d.type_name);
        for line in d.description.lines() {
            let _ = writeln!(out, "      {line}");
        }
    }
    let _ = writeln!(out, "\nIn an experiment: {{ type = \"{}\", <parameter> = <value>, … }}", p.name);
    Ok(out)
}
