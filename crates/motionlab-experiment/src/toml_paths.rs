//! Key paths into an experiment document: overrides (`a.b=c`), sweep keys, and mapping an
//! error's key path back to its line in the file.
//!
//! Path syntax: dot-separated keys; an array element is `[index]` or `[name]` (the element
//! whose `name` key — or, failing that, whose `type` — equals `name`):
//! `segmentation.segmenter[speed].v_low.fraction_of_p90`, `dataset[0].loader.up_axis`.

use std::fmt;

use motionlab_core::{Error, ErrorKind, Result};

/// One step of a key path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Seg {
    Key(String),
    Index(usize),
    Named(String),
}

/// A key path.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct KeyPath(pub Vec<Seg>);

impl KeyPath {
    pub fn parse(text: &str) -> Result<Self> {
        let bad =
            |why: &str| Error::new(ErrorKind::Syntax, format!("bad key path {text:?}: {why}"));
        let mut segs = Vec::new();
        for part in text.split('.') {
            let (key, mut rest) = match part.find('[') {
                Some(i) => (&part[..i], &part[i..]),
                None => (part, ""),
            };
            if key.is_empty() {
                return Err(bad("empty key"));
            }
            segs.push(Seg::Key(key.to_string()));
            while !rest.is_empty() {
                let close = rest.find(']').ok_or_else(|| bad("unclosed ["))?;
                let inner = &rest[1..close];
                if inner.is_empty() {
                    return Err(bad("empty []"));
                }
                segs.push(match inner.parse::<usize>() {
                    Ok(i) => Seg::Index(i),
                    Err(_) => Seg::Named(inner.to_string()),
                });
                rest = &rest[close + 1..];
                if !rest.is_empty() && !rest.starts_with('[') {
                    return Err(bad("expected . or [ after ]"));
                }
            }
        }
        Ok(KeyPath(segs))
    }
    pub fn child(&self, seg: Seg) -> KeyPath {
        let mut v = self.0.clone();
        v.push(seg);
        KeyPath(v)
    }
    pub fn key(&self, key: &str) -> KeyPath {
        self.child(Seg::Key(key.to_string()))
    }
    pub fn index(&self, i: usize) -> KeyPath {
        self.child(Seg::Index(i))
    }
    /// Appends a plugin's dotted field path (`v_low.mm_per_s`, `points[2]`).
    pub fn join_field(&self, field: &str) -> KeyPath {
        match KeyPath::parse(field) {
            Ok(p) => KeyPath(self.0.iter().cloned().chain(p.0).collect()),
            Err(_) => self.key(field),
        }
    }
    /// Converts `Named` segments to indices against a document, so the path can be located.
    pub fn resolve(&self, doc: &toml::Table) -> Result<KeyPath> {
        let mut out = Vec::new();
        let mut cur = Some(toml::Value::Table(doc.clone()));
        for seg in &self.0 {
            let next = match (seg, cur.as_ref()) {
                (Seg::Key(k), Some(toml::Value::Table(t))) => t.get(k).cloned(),
                (Seg::Index(i), Some(toml::Value::Array(a))) => a.get(*i).cloned(),
                (Seg::Named(n), Some(toml::Value::Array(a))) => {
                    let i = find_named(a, n).ok_or_else(|| {
                        Error::new(
                            ErrorKind::UnknownName,
                            format!(
                                "no array element named {n:?} (by `name` or `type`) at {}",
                                KeyPath(out.clone())
                            ),
                        )
                    })?;
                    out.push(Seg::Index(i));
                    cur = a.get(i).cloned();
                    continue;
                }
                _ => None,
            };
            out.push(seg.clone());
            cur = next;
        }
        Ok(KeyPath(out))
    }
}

fn find_named(a: &[toml::Value], name: &str) -> Option<usize> {
    let by = |key: &str| {
        a.iter().position(|v| {
            v.as_table().and_then(|t| t.get(key)).and_then(|n| n.as_str()) == Some(name)
        })
    };
    by("name").or_else(|| by("type"))
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) if i == 0 => write!(f, "{k}")?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(n) => write!(f, "[{n}]")?,
                Seg::Named(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

impl From<&serde_path_to_error::Path> for KeyPath {
    fn from(p: &serde_path_to_error::Path) -> Self {
        use serde_path_to_error::Segment;
        KeyPath(
            p.iter()
                .filter_map(|s| match s {
                    Segment::Seq { index } => Some(Seg::Index(*index)),
                    Segment::Map { key } => Some(Seg::Key(key.clone())),
                    Segment::Enum { variant } => Some(Seg::Key(variant.clone())),
                    Segment::Unknown => None,
                })
                .collect(),
        )
    }
}

/// Sets `value` at `path`, creating missing tables; array elements must exist.
pub fn set_path(doc: &mut toml::Table, path: &KeyPath, value: toml::Value) -> Result<()> {
    let path = path.resolve(doc)?;
    let mut root = toml::Value::Table(std::mem::take(doc));
    let result = set_in(&mut root, &path.0, value)
        .map_err(|why| Error::new(ErrorKind::UnknownKey, format!("cannot set {path}: {why}")));
    if let toml::Value::Table(t) = root {
        *doc = t;
    }
    result
}

fn set_in(
    cur: &mut toml::Value,
    segs: &[Seg],
    value: toml::Value,
) -> std::result::Result<(), String> {
    let Some((seg, rest)) = segs.split_first() else { return Err("empty path".into()) };
    let type_name = cur.type_str();
    let slot = match (seg, cur) {
        (Seg::Key(k), toml::Value::Table(t)) => {
            if rest.is_empty() {
                t.insert(k.clone(), value);
                return Ok(());
            }
            t.entry(k.clone()).or_insert_with(|| toml::Value::Table(toml::Table::new()))
        }
        (Seg::Index(i), toml::Value::Array(a)) => {
            let n = a.len();
            let slot =
                a.get_mut(*i).ok_or_else(|| format!("index {i} out of range (array has {n})"))?;
            if rest.is_empty() {
                *slot = value;
                return Ok(());
            }
            slot
        }
        (s, _) => return Err(format!("{s:?} does not apply to a {type_name}")),
    };
    set_in(slot, rest, value)
}

/// Parses a command-line override `a.b.c=value`: the value as a TOML value (`1`, `0.5`,
/// `true`, `"x"`, `[1, 2]`, `{ seconds = 0.1 }`), or as a bare string when it is not TOML.
pub fn parse_override(text: &str) -> Result<(KeyPath, toml::Value)> {
    let (k, v) = text.split_once('=').ok_or_else(|| {
        Error::new(
            ErrorKind::Syntax,
            format!("override {text:?} is not of the form key.path=value"),
        )
    })?;
    let path = KeyPath::parse(k.trim())?;
    let v = v.trim();
    let value = toml::from_str::<toml::Table>(&format!("v = {v}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(v.to_string()));
    Ok((path, value))
}

/// The 1-based line where `path` is written in `src` (the key's line when it is there, else the
/// nearest enclosing table's).
pub fn line_of(src: &str, path: &KeyPath) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let doc = DeTable::parse(src).ok()?;
    let line =
        |offset: usize| src[..offset.min(src.len())].bytes().filter(|b| *b == b'\n').count() + 1;
    let mut best: Option<usize> = None;
    let mut table: &DeTable<'_> = doc.get_ref();
    let mut value: Option<&toml::Spanned<DeValue<'_>>> = None;
    for seg in &path.0 {
        match (seg, value.map(|v| v.get_ref())) {
            (Seg::Key(k), None) | (Seg::Key(k), Some(DeValue::Table(_))) => {
                if let Some(DeValue::Table(t)) = value.map(|v| v.get_ref()) {
                    table = t;
                }
                let Some((key, v)) = table.iter().find(|(key, _)| key.get_ref() == k) else {
                    break;
                };
                best = Some(line(key.span().start));
                value = Some(v);
            }
            (Seg::Index(i), Some(DeValue::Array(a))) => {
                let Some(v) = a.get(*i) else { break };
                best = Some(line(v.span().start));
                value = Some(v);
            }
            _ => break,
        }
    }
    best
}

/// The line of a TOML syntax error, from its byte span.
pub fn syntax_error_line(src: &str, e: &toml::de::Error) -> Option<usize> {
    e.span().map(|s| src[..s.start.min(src.len())].bytes().filter(|b| *b == b'\n').count() + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = r#"[experiment]
name = "x"

[[segmentation.segmenter]]
type = "fastest_marker_speed"
name = "speed"
v_high = { mm_per_s = 500.0 }

[[segmentation.segmenter]]
type = "direction_change"
c_min = 0.2
"#;

    #[test]
    fn paths_parse_and_print() {
        let p = KeyPath::parse("segmentation.segmenter[speed].v_high.mm_per_s").unwrap();
        assert_eq!(p.to_string(), "segmentation.segmenter[speed].v_high.mm_per_s");
        assert!(KeyPath::parse("a..b").is_err());
        assert!(KeyPath::parse("a[0").is_err());
    }

    #[test]
    fn named_elements_resolve_by_name_then_type() {
        let doc: toml::Table = toml::from_str(DOC).unwrap();
        let p = KeyPath::parse("segmentation.segmenter[direction_change].c_min")
            .unwrap()
            .resolve(&doc)
            .unwrap();
        assert_eq!(p.to_string(), "segmentation.segmenter[1].c_min");
        assert!(KeyPath::parse("segmentation.segmenter[nope]").unwrap().resolve(&doc).is_err());
    }

    #[test]
    fn overrides_set_values_and_create_tables() {
        let mut doc: toml::Table = toml::from_str(DOC).unwrap();
        let (p, v) = parse_override("segmentation.segmenter[speed].v_high.mm_per_s=650").unwrap();
        set_path(&mut doc, &p, v).unwrap();
        let (p, v) = parse_override("segmentation.segmenter[1].smoothing={ frames = 3 }").unwrap();
        set_path(&mut doc, &p, v).unwrap();
        let (p, v) = parse_override("experiment.description=hello world").unwrap();
        set_path(&mut doc, &p, v).unwrap();
        let s = &doc["segmentation"]["segmenter"];
        assert_eq!(s[0]["v_high"]["mm_per_s"].as_integer(), Some(650));
        assert_eq!(s[1]["smoothing"]["frames"].as_integer(), Some(3));
        assert_eq!(doc["experiment"]["description"].as_str(), Some("hello world"));
        let (p, v) = parse_override("segmentation.segmenter[5].x=1").unwrap();
        assert!(set_path(&mut doc, &p, v).is_err());
    }

    #[test]
    fn lines_are_found_for_keys_and_array_elements() {
        let p = KeyPath::parse("segmentation.segmenter[1].c_min").unwrap();
        assert_eq!(line_of(DOC, &p), Some(11));
        let p = KeyPath::parse("segmentation.segmenter[0].v_high.mm_per_s").unwrap();
        assert_eq!(line_of(DOC, &p), Some(7));
        let p = KeyPath::parse("experiment.name").unwrap();
        assert_eq!(line_of(DOC, &p), Some(2));
        // A key that is not written falls back to the innermost written ancestor.
        let p = KeyPath::parse("segmentation.segmenter[1].smoothing").unwrap();
        assert_eq!(line_of(DOC, &p).map(|l| l >= 9), Some(true));
    }
}
