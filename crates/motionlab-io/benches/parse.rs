//! Text-format parsing throughput on the shipped files, in bytes of *decompressed* text per
//! second (results and the command in `README.md` beside this file).
//!
//! - `bvh_parse` / `amc_parse`: text → channel values (the scanner; what the ≥ 200 MB/s target
//!   is about), from an in-memory `&str`.
//! - `bvh_parse_and_fk` / `amc_parse_and_fk`: text → `Motion` with joint positions (adds forward
//!   kinematics in `motionlab-core`), from an in-memory `&str`.
//! - `bvh_loader` / `amc_loader`: the registered loader on the `.gz` file (read, gunzip, parse,
//!   FK) — what a user waits for.
//! - `bvh_fk` / `amc_fk`: forward kinematics alone (`ForwardKinematics::positions` on channel
//!   values parsed beforehand), counted in frames.
//! - `floats_*`: every number of 131_01's MOTION section parsed by `str::parse::<f64>` after
//!   whitespace splitting vs `fast_float2::parse_partial` in one pass — why the scanner uses
//!   the crate.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::LazyLock;

use divan::Bencher;
use divan::counter::{BytesCount, ItemsCount};
use motionlab_core::registry::{build_loader, default_params};
use motionlab_core::{ForwardKinematics, FrameRate, SkeletonMotion};
use motionlab_io::asf_amc::{AsfSkeleton, amc_motion, parse_amc, parse_asf};
use motionlab_io::bvh::{BvhOptions, parse_bvh, parse_bvh_channels};
use motionlab_io::read::read_text;

fn main() {
    divan::main();
}

const BVH_FILES: &[&str] =
    &["cmu131/131_01.bvh.gz", "cmu131/131_02.bvh.gz", "cmu131/131_03.bvh.gz"];
const AMC_FILES: &[&str] = &["cmu86/86_01.amc.gz", "mocap6/amc/13_29.amc.gz"];

fn data(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data").join(relative)
}

static TEXTS: LazyLock<HashMap<&'static str, String>> = LazyLock::new(|| {
    BVH_FILES
        .iter()
        .chain(AMC_FILES)
        .map(|f| (*f, read_text(&data(f)).expect("shipped file reads")))
        .collect()
});

/// The ASF beside each AMC file.
fn asf_for(amc: &str) -> PathBuf {
    if amc.starts_with("cmu86") { data("cmu86/86.asf") } else { data("mocap6/asf/13.asf") }
}

static ASFS: LazyLock<HashMap<&'static str, AsfSkeleton>> = LazyLock::new(|| {
    AMC_FILES
        .iter()
        .map(|f| {
            let p = asf_for(f);
            (*f, parse_asf(&read_text(&p).expect("ASF reads"), &p).expect("ASF parses"))
        })
        .collect()
});

fn bytes(file: &str) -> BytesCount {
    BytesCount::new(TEXTS[file].len())
}

#[divan::bench(args = BVH_FILES)]
fn bvh_parse(bencher: Bencher, file: &str) {
    let text = &TEXTS[file];
    bencher.counter(bytes(file)).bench(|| {
        parse_bvh_channels(divan::black_box(text), Path::new(file), &BvhOptions::default()).unwrap()
    });
}

#[divan::bench(args = BVH_FILES)]
fn bvh_parse_and_fk(bencher: Bencher, file: &str) {
    let text = &TEXTS[file];
    bencher.counter(bytes(file)).bench(|| {
        parse_bvh(divan::black_box(text), Path::new(file), &BvhOptions::default()).unwrap()
    });
}

#[divan::bench(args = BVH_FILES)]
fn bvh_loader(bencher: Bencher, file: &str) {
    let loader = build_loader("bvh", &default_params()).unwrap();
    let path = data(file);
    bencher.counter(bytes(file)).bench(|| loader.load(&path).unwrap());
}

#[divan::bench(args = AMC_FILES)]
fn amc_parse(bencher: Bencher, file: &str) {
    let text = &TEXTS[file];
    let asf = &ASFS[file];
    bencher
        .counter(bytes(file))
        .bench(|| parse_amc(divan::black_box(text), Path::new(file), asf).unwrap());
}

#[divan::bench(args = AMC_FILES)]
fn amc_parse_and_fk(bencher: Bencher, file: &str) {
    let text = &TEXTS[file];
    let asf = &ASFS[file];
    let rate = FrameRate::new(120.0).unwrap();
    bencher.counter(bytes(file)).bench(|| {
        let channels = parse_amc(divan::black_box(text), Path::new(file), asf).unwrap();
        amc_motion(channels, Path::new(file), rate).unwrap()
    });
}

#[divan::bench(args = AMC_FILES)]
fn amc_loader(bencher: Bencher, file: &str) {
    let loader = build_loader("asf_amc", &default_params()).unwrap();
    let path = data(file);
    bencher.counter(bytes(file)).bench(|| loader.load(&path).unwrap());
}

/// Parsed channel values of every shipped take, for the FK-only benches.
static CHANNELS: LazyLock<HashMap<&'static str, SkeletonMotion>> = LazyLock::new(|| {
    let bvh = BVH_FILES.iter().map(|f| {
        (
            *f,
            parse_bvh_channels(&TEXTS[f], Path::new(f), &BvhOptions::default())
                .expect("BVH parses")
                .motion,
        )
    });
    let amc = AMC_FILES
        .iter()
        .map(|f| (*f, parse_amc(&TEXTS[f], Path::new(f), &ASFS[f]).expect("AMC parses")));
    bvh.chain(amc).collect()
});

fn fk(bencher: Bencher, file: &str) {
    let channels = &CHANNELS[file];
    let fk = ForwardKinematics::new(&channels.skeleton);
    bencher
        .counter(ItemsCount::new(channels.n_frames()))
        .bench(|| fk.positions(divan::black_box(channels.channel_values())));
}

#[divan::bench(args = BVH_FILES)]
fn bvh_fk(bencher: Bencher, file: &str) {
    fk(bencher, file);
}

#[divan::bench(args = AMC_FILES)]
fn amc_fk(bencher: Bencher, file: &str) {
    fk(bencher, file);
}

/// 131_01's MOTION section (every frame line).
static MOTION_SECTION: LazyLock<&'static str> = LazyLock::new(|| {
    let text: &'static str = &TEXTS["cmu131/131_01.bvh.gz"];
    let at = text.find("Frame Time").expect("BVH has Frame Time");
    let start = at + text[at..].find('\n').expect("line ends") + 1;
    &text[start..]
});

#[divan::bench]
fn floats_std_parse(bencher: Bencher) {
    let s = *MOTION_SECTION;
    bencher.counter(BytesCount::new(s.len())).bench(|| {
        let mut sum = 0.0;
        for w in divan::black_box(s).split_ascii_whitespace() {
            sum += w.parse::<f64>().unwrap();
        }
        sum
    });
}

#[divan::bench]
fn floats_fast_float2(bencher: Bencher) {
    let s = *MOTION_SECTION;
    bencher.counter(BytesCount::new(s.len())).bench(|| {
        let b = divan::black_box(s).as_bytes();
        let (mut sum, mut i) = (0.0, 0);
        while i < b.len() {
            if b[i].is_ascii_whitespace() {
                i += 1;
                continue;
            }
            let (v, n) = fast_float2::parse_partial::<f64, _>(&b[i..]).unwrap();
            sum += v;
            i += n;
        }
        sum
    });
}
