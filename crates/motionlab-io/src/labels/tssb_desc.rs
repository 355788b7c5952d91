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
/// **States**: when a `properties.txt` lies beside `desc.txt` (as in CLaP's TSSB, UTSA and
/// SKAB folders), each segment is labelled with its state from the series' line there: TSSB's
/// `name,flag,label_cut,resample_rate,c0,c1,…` gives segment i the state `c_i // (label_cut + 1)`
/// (CLaP's loader: UCR classes merged into states), the other benchmarks'
/// `name,l0,l1,…` the label `l_i` as written; the labels read `state S`. Without
/// `properties.txt` (or without a line for the series) every segment is its own state.
///
/// Errors name `desc.txt` (or `properties.txt`) and the line: no line for the series (with the
/// closest names), a change point that is not a whole number, not increasing, or not inside
/// `1..n` of the series; a properties line whose number of labels is not the number of
/// segments, or a class that is not a whole number. Missing samples in the series do not
/// matter: only its length is used.
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

/// The state of each of the `n_segments` segments of series `name` from a `properties.txt`
/// (see [`TssbDescParams`]); `None` when the file has no line for it.
pub fn states_of(
    text: &str,
    origin: &Path,
    name: &str,
    n_segments: usize,
) -> Result<Option<Vec<String>>> {
    let text = crate::text::strip_bom(text);
    for (i, raw) in text.split('\n').enumerate() {
        let line = raw.trim_end_matches('\r').trim();
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.first() != Some(&name) {
            continue;
        }
        let at = |msg: String| Error::at_line(ErrorKind::Syntax, origin, i + 1, msg);
        let states: Vec<String> = if matches!(fields.get(1), Some(&"true") | Some(&"false")) {
            // TSSB: name, flag, label_cut, resample_rate, then one UCR class per segment.
            let whole = |f: &str, what: &str| {
                f.parse::<usize>().map_err(|_| at(format!("{what} {f:?} is not a whole number")))
            };
            let cut = whole(fields.get(2).copied().unwrap_or_default(), "label_cut")?;
            fields
                .iter()
                .skip(4)
                .map(|c| whole(c, "class").map(|c| (c / (cut + 1)).to_string()))
                .collect::<Result<_>>()?
        } else {
            fields.iter().skip(1).map(|l| l.to_string()).collect()
        };
        if states.len() != n_segments || states.iter().any(String::is_empty) {
            return Err(Error::at_line(
                ErrorKind::WrongValueCount,
                origin,
                i + 1,
                format!(
                    "{} state label(s) for the {n_segments} segment(s) of {name} in desc.txt; expected one non-empty label per segment",
                    states.len()
                ),
            ));
        }
        return Ok(Some(states));
    }
    Ok(None)
}

impl GroundTruthReader for TssbDesc {
    fn companions(&self, path: &Path) -> Vec<std::path::PathBuf> {
        vec![path.with_file_name("properties.txt")]
    }
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
        let properties = path.with_file_name("properties.txt");
        let states = if properties.is_file() {
            states_of(&crate::read::read_text(&properties)?, &properties, &stem, bounds.len() - 1)?
        } else {
            None
        };
        let segments = bounds
            .windows(2)
            .enumerate()
            .map(|(k, w)| Segment {
                start: w[0],
                end: w[1],
                label: match &states {
                    Some(s) => format!("state {}", s[k]),
                    None => format!("segment {}", k + 1),
                },
            })
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
        // properties.txt beside it: `Adiac,true,0,4,0,1,2,4` → label_cut 0: states 0 1 2 4.
        let labels: Vec<&str> = t.segments.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(labels, ["state 0", "state 1", "state 2", "state 4"]);
    }

    /// CLaP's rule `c // (label_cut + 1)`: Crop-like classes 0,3,6,1 with label_cut 2 give
    /// 0,1,2,0; UTSA's plain labels are kept; a count mismatch names properties.txt's line.
    #[test]
    fn states_from_properties() {
        let p = Path::new("properties.txt");
        let text = "X,true,2,1,0,3,6,1\nU,0,1,0\n";
        assert_eq!(states_of(text, p, "X", 4).unwrap().unwrap(), ["0", "1", "2", "0"]);
        assert_eq!(states_of(text, p, "U", 3).unwrap().unwrap(), ["0", "1", "0"]);
        assert_eq!(states_of(text, p, "Z", 3).unwrap(), None);
        let e = states_of(text, p, "U", 4).unwrap_err();
        assert!(
            e.to_string().contains("properties.txt:2")
                && e.to_string().contains("3 state label(s) for the 4"),
            "{e}"
        );
        let e = states_of("X,true,a,1,0\n", p, "X", 1).unwrap_err();
        assert!(e.to_string().contains("label_cut"), "{e}");
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
