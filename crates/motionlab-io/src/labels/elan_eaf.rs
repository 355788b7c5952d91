//! ELAN annotation files (`.eaf`, EAF XML 2.x/3.x): the time-aligned tiers, each a list of
//! annotations with start and end in milliseconds (the ground-truth plugin is `elan_eaf` in
//! `motionlab-eval`).
//!
//! What is read: `TIME_ORDER/TIME_SLOT` (`TIME_SLOT_ID`, `TIME_VALUE` in ms; the header's
//! `TIME_UNITS`, when given, must be `milliseconds`), and every `TIER` with its
//! `ALIGNABLE_ANNOTATION`s (`TIME_SLOT_REF1` = start, `TIME_SLOT_REF2` = end,
//! `ANNOTATION_VALUE` = label). Tiers of reference annotations only (`REF_ANNOTATION`, ELAN's
//! symbolic subdivisions) carry no times of their own and are listed as not time-aligned.
//!
//! Errors name the file, the line and the attribute: XML that does not parse, a slot referenced
//! but not declared, a slot without `TIME_VALUE` (unaligned; align it in ELAN), a slot declared
//! twice, a negative or non-numeric time, an annotation that ends before it starts.
//!
//! Parsed with `roxmltree` (a read-only XML tree with line/column positions; no dependencies).
//! [`write_eaf`] writes a [`SequenceTiers`] as an EAF 3.0 document (by hand: a few fixed
//! elements, no XML crate needed to write them).

use std::collections::HashMap;
use std::path::Path;

use motionlab_core::{Error, ErrorKind, Result};

use super::annotations::{AnnotatedItem, AnnotatorTrack, parse_instant, start_after_end};
use super::tiers::SequenceTiers;

/// One tier: its id, where it starts, and its time-aligned annotations in ms (as items whose
/// `start`/`end` are milliseconds on ELAN's time line).
#[derive(Clone, Debug, PartialEq)]
pub struct EafTier {
    pub id: String,
    pub line: usize,
    /// False for a tier of reference annotations only.
    pub time_aligned: bool,
    pub track: AnnotatorTrack,
}

/// Reads every tier of an EAF document.
pub fn parse_eaf(text: &str, origin: &Path) -> Result<Vec<EafTier>> {
    let text = crate::text::strip_bom(text);
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        // roxmltree places "ended too early" at 1:1; the file's end is where it is.
        let (row, col) = match e {
            roxmltree::Error::UnclosedRootNode | roxmltree::Error::UnexpectedEndOfStream => {
                let last = text.trim_end().lines().last().unwrap_or("");
                (text.trim_end().lines().count().max(1), last.chars().count() + 1)
            }
            _ => (e.pos().row as usize, e.pos().col as usize),
        };
        Error::at_line(
            ErrorKind::Syntax,
            origin,
            row,
            format!("not well-formed XML (column {col}): {e}"),
        )
    })?;
    let line_of = |n: roxmltree::Node| doc.text_pos_at(n.range().start).row as usize;
    let root = doc.root_element();
    if root.tag_name().name() != "ANNOTATION_DOCUMENT" {
        return Err(Error::at_line(
            ErrorKind::Syntax,
            origin,
            line_of(root),
            format!(
                "root element <{}>; expected <ANNOTATION_DOCUMENT> (an ELAN .eaf file)",
                root.tag_name().name()
            ),
        ));
    }
    for header in children(root, "HEADER") {
        if let Some(units) = header.attribute("TIME_UNITS")
            && units != "milliseconds"
        {
            return Err(Error::at_line(
                ErrorKind::InvalidParameter,
                origin,
                line_of(header),
                format!("TIME_UNITS is {units:?}; expected \"milliseconds\""),
            )
            .with_field("TIME_UNITS"));
        }
    }
    // Slot id → (time in ms or None when unaligned, line).
    let mut slots: HashMap<&str, (Option<f64>, usize)> = HashMap::new();
    for order in children(root, "TIME_ORDER") {
        for slot in children(order, "TIME_SLOT") {
            let line = line_of(slot);
            let Some(id) = slot.attribute("TIME_SLOT_ID") else {
                return Err(Error::at_line(
                    ErrorKind::MissingKey,
                    origin,
                    line,
                    "TIME_SLOT without TIME_SLOT_ID",
                )
                .with_field("TIME_SLOT_ID"));
            };
            let value = slot
                .attribute("TIME_VALUE")
                .map(|v| parse_instant(v, origin, line, "TIME_VALUE"))
                .transpose()?;
            if let Some((_, first)) = slots.insert(id, (value, line)) {
                return Err(Error::at_line(
                    ErrorKind::DuplicateName,
                    origin,
                    line,
                    format!("time slot {id:?} is declared twice (first at line {first})"),
                )
                .with_field("TIME_SLOT_ID"));
            }
        }
    }
    let slot_ms = |node: roxmltree::Node, attr: &str| -> Result<f64> {
        let line = line_of(node);
        let Some(id) = node.attribute(attr) else {
            return Err(Error::at_line(
                ErrorKind::MissingKey,
                origin,
                line,
                format!("annotation without {attr}"),
            )
            .with_field(attr));
        };
        match slots.get(id) {
            None => Err(Error::at_line(ErrorKind::UnknownName, origin, line, format!("time slot {id:?} is not declared in TIME_ORDER")).with_field(attr)),
            Some((None, slot_line)) => Err(Error::at_line(
                ErrorKind::MissingData,
                origin,
                line,
                format!("time slot {id:?} (line {slot_line}) has no TIME_VALUE (unaligned); align the annotation in ELAN"),
            )
            .with_field(attr)),
            Some((Some(ms), _)) => Ok(*ms),
        }
    };
    let mut tiers = Vec::new();
    for tier in children(root, "TIER") {
        let line = line_of(tier);
        let id = tier.attribute("TIER_ID").unwrap_or("").to_string();
        let mut items = Vec::new();
        let mut n_ref = 0;
        for ann in children(tier, "ANNOTATION") {
            n_ref += children(ann, "REF_ANNOTATION").len();
            for a in children(ann, "ALIGNABLE_ANNOTATION") {
                let (start, end) = (slot_ms(a, "TIME_SLOT_REF1")?, slot_ms(a, "TIME_SLOT_REF2")?);
                let aline = line_of(a);
                if start > end {
                    return Err(start_after_end(origin, aline, "TIME_SLOT_REF2", start, end));
                }
                let label = children(a, "ANNOTATION_VALUE")
                    .first()
                    .and_then(|v| v.text())
                    .unwrap_or("")
                    .trim()
                    .to_string();
                items.push(AnnotatedItem {
                    line: aline,
                    start_field: "TIME_SLOT_REF1".into(),
                    start,
                    end: Some(("TIME_SLOT_REF2".into(), end)),
                    label,
                });
            }
        }
        items.sort_by(|a, b| a.start.total_cmp(&b.start));
        let time_aligned = !items.is_empty() || n_ref == 0;
        tiers.push(EafTier {
            track: AnnotatorTrack { annotator: id.clone(), items },
            id,
            line,
            time_aligned,
        });
    }
    Ok(tiers)
}

/// Text safe in an XML attribute or element.
fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// The marks of every tier of `seq` as an ELAN document (EAF 3.0, times in whole ms from the
/// motion's first frame): one tier per [`super::tiers::MarkTier`] (`TIER_ID` and `ANNOTATOR`
/// its name), one annotation from each mark to the next (the last to the motion's last frame)
/// holding the mark's label. `date` is the document's `DATE` (ISO 8601).
///
/// Frame `f` is written as `round(f / rate × 1000)` ms, which reads back to `f` at any rate
/// up to 1000 Hz (the rounding moves it less than half a frame); a faster motion is an error,
/// since two frames could then share a millisecond.
pub fn write_eaf(seq: &SequenceTiers, date: &str) -> Result<String> {
    let rate = seq.frame_rate_hz;
    if !(rate.is_finite() && rate > 0.0 && rate <= 1000.0) {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!(
                "{}: ELAN keeps whole milliseconds, which tell frames apart only up to 1000 Hz; this motion is at {rate} Hz",
                seq.sequence
            ),
        ));
    }
    let ms = |frame: usize| (frame as f64 / rate * 1000.0).round() as u64;
    let last = seq.n_frames.saturating_sub(1);
    // Two slots per annotation in document order; their ids go in time order, ties in
    // document order, as ELAN lists its TIME_ORDER.
    let mut slots: Vec<u64> = Vec::new();
    let mut annotations: Vec<Vec<(usize, &str)>> = Vec::with_capacity(seq.tiers.len());
    for tier in &seq.tiers {
        let mut marks: Vec<_> = tier.marks.iter().filter(|m| m.frame < last).collect();
        marks.sort_by_key(|m| m.frame);
        marks.dedup_by_key(|m| m.frame);
        let mut list = Vec::with_capacity(marks.len());
        for (i, m) in marks.iter().enumerate() {
            list.push((slots.len(), m.label.as_str()));
            slots.push(ms(m.frame));
            slots.push(ms(marks.get(i + 1).map_or(last, |n| n.frame)));
        }
        annotations.push(list);
    }
    let mut order: Vec<usize> = (0..slots.len()).collect();
    order.sort_by_key(|&i| (slots[i], i));
    let mut id = vec![0; slots.len()];
    for (rank, &i) in order.iter().enumerate() {
        id[i] = rank + 1;
    }
    let mut tiers = String::new();
    let mut next_annotation = 1;
    for (tier, list) in seq.tiers.iter().zip(&annotations) {
        let name = xml_escape(&tier.name);
        tiers.push_str(&format!("    <TIER LINGUISTIC_TYPE_REF=\"default-lt\" TIER_ID=\"{name}\" ANNOTATOR=\"{name}\">\n"));
        for &(k, label) in list {
            tiers.push_str(&format!(
                "        <ANNOTATION>\n            <ALIGNABLE_ANNOTATION ANNOTATION_ID=\"a{next_annotation}\" TIME_SLOT_REF1=\"ts{}\" TIME_SLOT_REF2=\"ts{}\">\n                <ANNOTATION_VALUE>{}</ANNOTATION_VALUE>\n            </ALIGNABLE_ANNOTATION>\n        </ANNOTATION>\n",
                id[k],
                id[k + 1],
                xml_escape(label)
            ));
            next_annotation += 1;
        }
        tiers.push_str("    </TIER>\n");
    }
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    out.push_str(&format!(
        "<ANNOTATION_DOCUMENT AUTHOR=\"motionlab\" DATE=\"{}\" FORMAT=\"3.0\" VERSION=\"3.0\">\n",
        xml_escape(date)
    ));
    out.push_str("    <HEADER MEDIA_FILE=\"\" TIME_UNITS=\"milliseconds\">\n");
    out.push_str(&format!(
        "        <PROPERTY NAME=\"motionlab:sequence\">{}</PROPERTY>\n",
        xml_escape(&seq.sequence)
    ));
    if !seq.input_sha256.is_empty() {
        out.push_str(&format!(
            "        <PROPERTY NAME=\"motionlab:input_sha256\">{}</PROPERTY>\n",
            xml_escape(&seq.input_sha256)
        ));
    }
    out.push_str(&format!(
        "        <PROPERTY NAME=\"lastUsedAnnotationId\">{}</PROPERTY>\n",
        next_annotation - 1
    ));
    out.push_str("    </HEADER>\n    <TIME_ORDER>\n");
    for (rank, &i) in order.iter().enumerate() {
        out.push_str(&format!(
            "        <TIME_SLOT TIME_SLOT_ID=\"ts{}\" TIME_VALUE=\"{}\"/>\n",
            rank + 1,
            slots[i]
        ));
    }
    out.push_str("    </TIME_ORDER>\n");
    out.push_str(&tiers);
    out.push_str("    <LINGUISTIC_TYPE GRAPHIC_REFERENCES=\"false\" LINGUISTIC_TYPE_ID=\"default-lt\" TIME_ALIGNABLE=\"true\"/>\n");
    out.push_str("</ANNOTATION_DOCUMENT>\n");
    Ok(out)
}

/// The child elements of `n` named `tag`.
fn children<'a, 'input>(
    n: roxmltree::Node<'a, 'input>,
    tag: &str,
) -> Vec<roxmltree::Node<'a, 'input>> {
    n.children().filter(|c| c.is_element() && c.tag_name().name() == tag).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<ANNOTATION_DOCUMENT AUTHOR="" DATE="2024-01-01T00:00:00+00:00" FORMAT="3.0" VERSION="3.0">
    <HEADER MEDIA_FILE="" TIME_UNITS="milliseconds"/>
    <TIME_ORDER>
        <TIME_SLOT TIME_SLOT_ID="ts1" TIME_VALUE="1000"/>
        <TIME_SLOT TIME_SLOT_ID="ts2" TIME_VALUE="2500"/>
        <TIME_SLOT TIME_SLOT_ID="ts3" TIME_VALUE="4000"/>
        <TIME_SLOT TIME_SLOT_ID="ts4"/>
    </TIME_ORDER>
    <TIER LINGUISTIC_TYPE_REF="default" TIER_ID="steps">
        <ANNOTATION>
            <ALIGNABLE_ANNOTATION ANNOTATION_ID="a2" TIME_SLOT_REF1="ts2" TIME_SLOT_REF2="ts3">
                <ANNOTATION_VALUE>turn</ANNOTATION_VALUE>
            </ALIGNABLE_ANNOTATION>
        </ANNOTATION>
        <ANNOTATION>
            <ALIGNABLE_ANNOTATION ANNOTATION_ID="a1" TIME_SLOT_REF1="ts1" TIME_SLOT_REF2="ts2">
                <ANNOTATION_VALUE>step</ANNOTATION_VALUE>
            </ALIGNABLE_ANNOTATION>
        </ANNOTATION>
    </TIER>
    <TIER LINGUISTIC_TYPE_REF="sub" PARENT_REF="steps" TIER_ID="notes">
        <ANNOTATION>
            <REF_ANNOTATION ANNOTATION_ID="a3" ANNOTATION_REF="a1"><ANNOTATION_VALUE>x</ANNOTATION_VALUE></REF_ANNOTATION>
        </ANNOTATION>
    </TIER>
</ANNOTATION_DOCUMENT>
"#;

    #[test]
    fn tiers_slots_and_labels() {
        let tiers = parse_eaf(DOC, Path::new("a.eaf")).unwrap();
        assert_eq!(tiers.len(), 2);
        assert_eq!(
            (tiers[0].id.as_str(), tiers[0].line, tiers[0].time_aligned),
            ("steps", 10, true)
        );
        let spans: Vec<(f64, f64, &str, usize)> = tiers[0]
            .track
            .items
            .iter()
            .map(|i| (i.start, i.end.as_ref().unwrap().1, i.label.as_str(), i.line))
            .collect();
        assert_eq!(spans, vec![(1000.0, 2500.0, "step", 17), (2500.0, 4000.0, "turn", 12)]);
        assert!(!tiers[1].time_aligned);
    }

    #[test]
    fn written_documents_parse_back_to_one_tier_per_name_with_labels() {
        use crate::labels::tiers::{MarkTier, TierMark};
        let seq = SequenceTiers {
            name: "86_01".into(),
            sequence: "86_01".into(),
            input_sha256: "ab".repeat(32),
            frame_rate_hz: 120.0,
            n_frames: 4579,
            tiers: vec![
                MarkTier {
                    name: "ana & co".into(),
                    marks: vec![
                        TierMark { frame: 1149, label: "walk <fast>".into() },
                        TierMark { frame: 549, label: "jump".into() },
                    ],
                },
                MarkTier::unlabelled("empty", &[]),
            ],
        };
        let text = write_eaf(&seq, "2026-01-01T00:00:00Z").unwrap();
        let tiers = parse_eaf(&text, Path::new("w.eaf")).unwrap();
        assert_eq!(
            tiers.iter().map(|t| t.id.as_str()).collect::<Vec<_>>(),
            vec!["ana & co", "empty"]
        );
        // 549 / 120 s = 4575 ms; 1149 → 9575 ms; the last annotation ends at frame 4578 → 38150 ms.
        let spans: Vec<(f64, f64, &str)> = tiers[0]
            .track
            .items
            .iter()
            .map(|i| (i.start, i.end.as_ref().unwrap().1, i.label.as_str()))
            .collect();
        assert_eq!(spans, vec![(4575.0, 9575.0, "jump"), (9575.0, 38150.0, "walk <fast>")]);
        assert!(tiers[1].track.items.is_empty());
        let mut fast = seq.clone();
        fast.frame_rate_hz = 2000.0;
        assert_eq!(write_eaf(&fast, "").unwrap_err().kind(), ErrorKind::OutOfRange);
    }

    #[test]
    fn defects_name_line_and_attribute() {
        let at = |text: &str| {
            let e = parse_eaf(text, Path::new("a.eaf")).unwrap_err();
            (e.kind(), e.location().line, e.location().field.clone())
        };
        let unaligned = DOC.replace("TIME_SLOT_REF2=\"ts3\"", "TIME_SLOT_REF2=\"ts4\"");
        assert_eq!(
            at(&unaligned),
            (ErrorKind::MissingData, Some(12), Some("TIME_SLOT_REF2".into()))
        );
        let undeclared = DOC.replace("TIME_SLOT_REF1=\"ts1\"", "TIME_SLOT_REF1=\"ts9\"");
        assert_eq!(
            at(&undeclared),
            (ErrorKind::UnknownName, Some(17), Some("TIME_SLOT_REF1".into()))
        );
        let backwards = DOC.replace("TIME_VALUE=\"4000\"", "TIME_VALUE=\"2000\"");
        assert_eq!(
            at(&backwards),
            (ErrorKind::OutOfRange, Some(12), Some("TIME_SLOT_REF2".into()))
        );
        let text = DOC.replace("TIME_VALUE=\"1000\"", "TIME_VALUE=\"1s\"");
        assert_eq!(at(&text), (ErrorKind::Syntax, Some(5), Some("TIME_VALUE".into())));
        let cut = &DOC[..DOC.find("</TIER>").unwrap()];
        assert_eq!(at(cut).0, ErrorKind::Syntax);
        assert_eq!(at("<EAF/>"), (ErrorKind::Syntax, Some(1), None));
    }
}
