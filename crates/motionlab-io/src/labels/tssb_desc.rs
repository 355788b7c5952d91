//! `tssb_desc`: the change points of the Time Series Segmentation Benchmark (`desc.txt`).

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use motionlab_core::registry::ParamGuard;
use motionlab_core::{Error, ErrorKind, GroundTruthReader, Motion, Result, Segment, Segmentation};

/// Reads the true change points of a TSSB series (Ermshaus, Schäfer & Leser, DMKD 2023) from
/// the benchmark's `desc.txt`: one line per series, `name,window,cp1,cp2,…` — the series name
/// (its file's stem), the suggested subsequence width, then its change points as 0-based sample
/// indices (none: one segment).
///
/// The line is found by the motion file's stem (`Adiac.txt` → `Adiac`). The change points
/// split the series into segments `0..cp1, cp1..cp2, …, cpk..n` (labelled `segment 1`, …);
/// each change point is a boundary without a transition window. The suggested width is not a
/// boundary; a segmenter that wants it reads `desc.txt` itself (the benchmark's published
/// methods choose their own).
///
/// Errors name `desc.txt` and the line: no line for the series (with the closest names), a
/// change point that is not a whole number, not increasing, or not inside `1..n` of the
/// series. Missing samples in the series do not matter: only its length is used.
#[derive(Clone, Debug, Default, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TssbDescParams {}

/// The validated reader.
#[derive(Clone, Copy, Debug)]
pub struct TssbDesc;

impl ParamGuard for TssbDescParams {
    type Checked = TssbDesc;
    fn check(self) -> Result<TssbDesc> {
        Ok(TssbDesc)
    }
}

/// One line of `desc.txt`.
#[derive(Clone, Debug, PartialEq)]
pub struct TssbEntry {
    pub name: String,
    /// The suggested subsequence width (samples).
    pub window: usize,
    /// 0-based sample indices, increasing.
    pub change_points: Vec<usize>,
    pub line: usize,
}

/// Parses `desc.txt`.
pub fn parse_tssb_desc(text: &str, origin: &Path) -> Result<Vec<TssbEntry>> {
    let text = crate::text::strip_bom(text);
    let mut out = Vec::new();
    for (i, raw) in text.split('\n').enumerate() {
        let line = raw.trim_end_matches('\r').trim();
        if line.is_empty() {
            continue;
        }
        let mut fields = line.split(',').map(str::trim);
        let name = fields.next().unwrap_or_default().to_string();
        let number = |f: &str, what: &str| {
            f.parse::<usize>().map_err(|_| {
                Error::at_line(
                    ErrorKind::Syntax,
                    origin,
                    i + 1,
                    format!("{what} {f:?} is not a whole number"),
                )
            })
        };
        let window = number(fields.next().unwrap_or_default(), "window")?;
        let change_points =
            fields.map(|f| number(f, "change point")).collect::<Result<Vec<_>>>()?;
        if let Some(w) = change_points.windows(2).find(|w| w[1] <= w[0]) {
            return Err(Error::at_line(
                ErrorKind::OutOfRange,
                origin,
                i + 1,
                format!("change point {} after {}; expected increasing", w[1], w[0]),
            ));
        }
        out.push(TssbEntry { name, window, change_points, line: i + 1 });
    }
    Ok(out)
}

impl GroundTruthReader for TssbDesc {
    fn read(&self, path: &Path, motion: &Motion) -> Result<Segmentation> {
        let entries = parse_tssb_desc(&crate::read::read_text(path)?, path)?;
        let stem = motion
            .source
            .as_deref()
            .map(motionlab_core::paths::stem)
            .unwrap_or_else(|| motion.name.clone());
        let Some(e) = entries.iter().find(|e| e.name == stem) else {
            let close = motionlab_core::registry::closest_names(
                &stem,
                entries.iter().map(|e| e.name.as_str()),
            );
            return Err(Error::new(
                ErrorKind::UnknownName,
                format!("no line for series {stem:?} (closest: {})", close.join(", ")),
            )
            .in_file(path));
        };
        let n = motion.n_frames();
        if let Some(&cp) = e.change_points.iter().find(|&&cp| cp == 0 || cp >= n) {
            return Err(Error::at_line(
                ErrorKind::OutOfRange,
                path,
                e.line,
                format!("change point {cp} is outside 1..{n} of {stem} ({n} samples)"),
            ));
        }
        let mut bounds = vec![0];
        bounds.extend(&e.change_points);
        bounds.push(n);
        let segments = bounds
            .windows(2)
            .enumerate()
            .map(|(k, w)| Segment { start: w[0], end: w[1], label: format!("segment {}", k + 1) })
            .collect();
        Segmentation::from_segments(motion.frame_rate(), segments).map_err(|err| err.in_file(path))
    }
}

motionlab_core::register_plugin!(GroundTruth, TssbDescParams, "tssb_desc");

#[cfg(test)]
mod tests {
    use super::*;
    use motionlab_core::{Channels, FrameRate};

    fn series(name: &str, n: usize) -> Motion {
        let c = Channels::new(vec!["value".into()], vec![String::new()], vec![0.0; n]).unwrap();
        Motion::from_channels(name, FrameRate::new(1.0).unwrap(), c)
            .unwrap()
            .with_source(format!("/x/{name}.txt"), "channels")
    }

    #[test]
    fn the_shipped_desc_gives_each_series_its_change_points() {
        let desc = motionlab_testkit::data_path("tssb/datasets/desc.txt");
        let all = parse_tssb_desc(&std::fs::read_to_string(&desc).unwrap(), &desc).unwrap();
        assert_eq!(all.len(), 75);
        assert_eq!(
            all[0],
            TssbEntry {
                name: "Adiac".into(),
                window: 10,
                change_points: vec![572, 1012, 1232],
                line: 1
            }
        );
        let t = TssbDesc.read(&desc, &series("Adiac", 1408)).unwrap();
        assert_eq!(t.frames(), vec![572, 1012, 1232]);
        assert_eq!((t.segments.len(), t.segments[3].end), (4, 1408));
    }

    #[test]
    fn unknown_series_and_bad_change_points_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let desc = dir.path().join("desc.txt");
        std::fs::write(&desc, "Adiac,10,5,9\nBeef,50\n").unwrap();
        let e = TssbDesc.read(&desc, &series("Adiak", 20)).unwrap_err();
        assert!(e.to_string().contains("\"Adiak\"") && e.to_string().contains("Adiac"), "{e}");
        let e = TssbDesc.read(&desc, &series("Adiac", 9)).unwrap_err();
        assert!(
            e.to_string().contains("desc.txt:1") && e.to_string().contains("change point 9"),
            "{e}"
        );
        assert_eq!(TssbDesc.read(&desc, &series("Beef", 9)).unwrap().boundaries.len(), 0);
        let e = parse_tssb_desc("A,10,7,3\n", &desc).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::OutOfRange);
        let e = parse_tssb_desc("A,10,x\n", &desc).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Syntax);
    }
}
