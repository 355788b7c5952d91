//! Parse throughput of the C3D and Qualisys TSV loaders on the shipped MoCap Toolbox dance1
//! recording (the same 1500 × 28 markers in both formats), with c3dio parsing the same C3D
//! bytes in the same run as the peer. Files are decompressed once, outside the timed loop.
//! Results: `README-binary-formats.md` beside this file.

use std::path::Path;

use divan::counter::BytesCount;
use divan::{Bencher, black_box};
use motionlab_core::Axis;
use motionlab_io::c3d::{C3dOptions, parse_c3d};
use motionlab_io::qualisys_tsv::parse_qualisys_tsv;
use motionlab_io::read::{read_bytes, read_text};

fn main() {
    divan::main();
}

fn data(rel: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data").join(rel)
}

#[divan::bench(sample_count = 30)]
fn c3d_motionlab(bencher: Bencher) {
    let path = data("mct/dance1.c3d.gz");
    let bytes = read_bytes(&path).unwrap();
    bencher
        .counter(BytesCount::new(bytes.len()))
        .bench(|| parse_c3d(black_box(&bytes), &path, &C3dOptions::default()).unwrap());
}

#[divan::bench(sample_count = 30)]
fn c3d_c3dio_peer(bencher: Bencher) {
    let bytes = read_bytes(&data("mct/dance1.c3d.gz")).unwrap();
    bencher
        .counter(BytesCount::new(bytes.len()))
        .bench(|| c3dio::C3d::from_bytes(black_box(&bytes)).unwrap());
}

#[divan::bench(sample_count = 30)]
fn c3d_motionlab_gait_trial_with_analog(bencher: Bencher) {
    // A Vicon trial: 52 markers plus 300 analog words per frame that the loader skips.
    let path = data("schreiber2019/2014001/dynamic/2014001_C4_05.c3d.gz");
    let bytes = read_bytes(&path).unwrap();
    bencher
        .counter(BytesCount::new(bytes.len()))
        .bench(|| parse_c3d(black_box(&bytes), &path, &C3dOptions::default()).unwrap());
}

#[divan::bench(sample_count = 30)]
fn tsv_motionlab(bencher: Bencher) {
    let path = data("mct/dance1.tsv.gz");
    let text = read_text(&path).unwrap();
    bencher
        .counter(BytesCount::new(text.len()))
        .bench(|| parse_qualisys_tsv(black_box(&text), &path, Axis::Z).unwrap());
}

/// The TSV's data tokens (all values of dance1, incl. none missing), for the two number
/// parsers below: the loader uses fast-float2; `str::parse` is the std alternative.
fn tsv_tokens() -> (Vec<String>, usize) {
    let text = read_text(&data("mct/dance1.tsv.gz")).unwrap();
    let body: Vec<String> = text
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit() || c == '-'))
        .flat_map(|l| l.split('\t').map(str::to_string).collect::<Vec<_>>())
        .collect();
    let bytes = body.iter().map(|t| t.len() + 1).sum();
    (body, bytes)
}

#[divan::bench(sample_count = 30)]
fn tsv_numbers_fast_float2(bencher: Bencher) {
    let (tokens, bytes) = tsv_tokens();
    bencher.counter(BytesCount::new(bytes)).bench(|| {
        tokens
            .iter()
            .map(|t| fast_float2::parse::<f64, _>(black_box(t.as_str())).unwrap())
            .sum::<f64>()
    });
}

#[divan::bench(sample_count = 30)]
fn tsv_numbers_std_parse(bencher: Bencher) {
    let (tokens, bytes) = tsv_tokens();
    bencher.counter(BytesCount::new(bytes)).bench(|| {
        tokens.iter().map(|t| black_box(t.as_str()).parse::<f64>().unwrap()).sum::<f64>()
    });
}
