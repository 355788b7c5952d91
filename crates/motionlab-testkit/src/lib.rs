//! Synthetic motions with known answers — for unit tests only. Every experiment in
//! `experiments/` runs on real data.

pub mod degenerate;

use std::path::PathBuf;

use motionlab_core::{Axis, FrameRate, Motion, Point3, PointKind};

/// A motion of `n_points` markers named `m0, m1, …` whose position at (frame, point) is `f`.
/// Z is up.
pub fn motion_from_fn(
    n_frames: usize,
    rate_hz: f64,
    n_points: usize,
    f: impl Fn(usize, usize) -> Point3,
) -> Motion {
    let names = (0..n_points).map(|k| format!("m{k}")).collect();
    let positions = (0..n_frames)
        .flat_map(|i| (0..n_points).map(move |k| (i, k)))
        .map(|(i, k)| f(i, k))
        .collect();
    Motion::new(
        "synthetic",
        FrameRate::new(rate_hz).expect("test rate > 0"),
        Axis::Z,
        PointKind::Marker,
        names,
        positions,
    )
    .expect("synthetic motion is well formed")
}

/// Like [`motion_from_fn`] with explicit marker names.
pub fn named_motion(
    n_frames: usize,
    rate_hz: f64,
    names: &[&str],
    f: impl Fn(usize, usize) -> Point3,
) -> Motion {
    let m = names.len();
    let positions =
        (0..n_frames).flat_map(|i| (0..m).map(move |k| (i, k))).map(|(i, k)| f(i, k)).collect();
    Motion::new(
        "synthetic",
        FrameRate::new(rate_hz).expect("test rate > 0"),
        Axis::Z,
        PointKind::Marker,
        names.iter().map(|s| s.to_string()).collect(),
        positions,
    )
    .expect("synthetic motion is well formed")
}

/// The eight corners of an axis-aligned cube of side `side` mm with one corner at `origin`.
pub fn cube_corners(origin: Point3, side: f64) -> Vec<Point3> {
    let mut v = Vec::with_capacity(8);
    for dx in [0.0, side] {
        for dy in [0.0, side] {
            for dz in [0.0, side] {
                v.push([origin[0] + dx, origin[1] + dy, origin[2] + dz]);
            }
        }
    }
    v
}

/// Path of a file in the repository's `data/` folder (real mocap shipped with the project).
pub fn data_path(relative: &str) -> PathBuf {
    repo_root().join("data").join(relative)
}

/// The repository root: two levels above this crate, as compiled. When that path no longer
/// exists (a build artefact reused from a clone since deleted), the nearest ancestor of the
/// working directory holding both `Cargo.toml` and `experiments/` — tests run from a crate
/// folder, so the walk up finds the workspace. Panics when neither is found: a test must not
/// silently resolve data paths against the wrong folder.
pub fn repo_root() -> PathBuf {
    let compiled = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    if let Ok(root) = compiled.canonicalize()
        && root.join("experiments").is_dir()
    {
        return root;
    }
    let cwd = std::env::current_dir().expect("tests need a working directory");
    cwd.ancestors()
        .find(|dir| dir.join("Cargo.toml").is_file() && dir.join("experiments").is_dir())
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            panic!("no repository root above {} or {}", compiled.display(), cwd.display())
        })
}

/// A tiny deterministic PRNG (xorshift64*) so tests need no extra dependency and stay
/// reproducible.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.max(1))
    }
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Approximately standard normal (sum of 12 uniforms − 6).
    pub fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
    }
}

/// Every viewer page of a run directory (`viewers/*.html`, sorted by file name) with its
/// embedded metadata (the `viewer-meta` JSON: frame count, point names, lanes). Panics — these
/// are test helpers — when the folder or a page's metadata is missing, or when a lane's mark or
/// interval lies outside the motion's frames or an interval ends before it starts (what
/// `ViewerSpec::validate` refuses before a page is written: a page that breaks it was not
/// validated).
pub fn viewer_pages(run: &std::path::Path) -> Vec<(String, serde_json::Value)> {
    let dir = run.join("viewers");
    let mut pages: Vec<(String, serde_json::Value)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "html"))
        .map(|p| {
            let page = std::fs::read_to_string(&p).unwrap();
            let start = page
                .find(r#"id="viewer-meta">"#)
                .unwrap_or_else(|| panic!("{}: no viewer-meta", p.display()))
                + 17;
            let end = start + page[start..].find("</script>").unwrap();
            let meta: serde_json::Value =
                serde_json::from_str(&page[start..end].replace("<\\/", "</")).unwrap();
            (p.file_name().unwrap().to_string_lossy().into_owned(), meta)
        })
        .collect();
    pages.sort_by(|a, b| a.0.cmp(&b.0));
    for (name, meta) in &pages {
        let n = meta["n_frames"].as_u64().unwrap_or_else(|| panic!("{name}: no n_frames"));
        assert!(
            n > 0 && !meta["point_names"].as_array().unwrap().is_empty(),
            "{name}: empty motion"
        );
        for lane in meta["lanes"].as_array().unwrap() {
            for m in lane["marks"].as_array().into_iter().flatten() {
                assert!(
                    m["frame"].as_u64().unwrap() < n,
                    "{name}: lane {}: mark {m} outside 0..{n}",
                    lane["name"]
                );
            }
            for i in lane["intervals"].as_array().into_iter().flatten() {
                let (a, b) = (i[0].as_u64().unwrap(), i[1].as_u64().unwrap());
                assert!(
                    a <= b && b < n,
                    "{name}: lane {}: interval [{a}, {b}] outside 0..{n}",
                    lane["name"]
                );
            }
        }
    }
    pages
}

/// The lane named `name` of a viewer page's metadata (see [`viewer_pages`]).
pub fn viewer_lane<'a>(meta: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    meta["lanes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["name"] == name)
        .unwrap_or_else(|| panic!("no lane {name:?} in {}", meta["title"]))
}

/// A text parser's no-panic sweep: `parse` gets every prefix of `text` (cut at char
/// boundaries), then `flips` copies with one byte replaced by a byte of `alphabet` (position and
/// byte drawn from `Rng::new(seed)`; copies that are no longer UTF-8 are skipped). What `parse`
/// returns is the caller's to ignore: only a panic fails the calling test.
pub fn truncations_and_byte_flips(
    text: &str,
    seed: u64,
    alphabet: &[u8],
    flips: usize,
    mut parse: impl FnMut(&str),
) {
    for cut in 0..=text.len() {
        if text.is_char_boundary(cut) {
            parse(&text[..cut]);
        }
    }
    let mut rng = Rng::new(seed);
    for _ in 0..flips {
        let mut b = text.as_bytes().to_vec();
        let i = (rng.next_u64() % b.len() as u64) as usize;
        b[i] = alphabet[(rng.next_u64() % alphabet.len() as u64) as usize];
        if let Ok(s) = String::from_utf8(b) {
            parse(&s);
        }
    }
}
