//! Bounded input (docs/security.md): a gzip bomb — 2 GB of zeros in a few MB of `.tsv.gz` —
//! is refused naming the file, by the `motionlab` process, with its peak resident memory
//! measured (its VmHWM) under 300 MB; annotation and experiment files are bounded too,
//! and `MOTIONLAB_MAX_INPUT_MB` sets the limit.

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

use motionlab_testkit::repo_root;

/// Runs `cmd` to its end; (exit code, stderr, peak resident set in bytes, samples taken).
///
/// The peak is the child's own `VmHWM` (/proc/PID/status), read every 2 ms while it runs: the
/// kernel's high-water mark of the process's memory since its `exec`, so it is neither this
/// test process's memory (which `wait4`'s ru_maxrss would include, since Linux carries the
/// parent's resident set into a child over fork and exec) nor a sample that missed a peak —
/// only growth in the last 2 ms before exit could go unseen.
fn run_measured(mut cmd: Command) -> (Option<i32>, String, u64, usize) {
    let mut child = cmd.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        stderr.read_to_string(&mut s).unwrap();
        s
    });
    let status_file = format!("/proc/{}/status", child.id());
    let (mut peak_kb, mut samples) = (0u64, 0usize);
    let status = loop {
        // Before try_wait reaps it: a zombie's status has no VmHWM line any more.
        let hwm = std::fs::read_to_string(&status_file).ok().and_then(|s| {
            s.lines().find_map(|l| {
                l.strip_prefix("VmHWM:")
                    .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            })
        });
        if let Some(kb) = hwm {
            peak_kb = peak_kb.max(kb);
            samples += 1;
        }
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    };
    (status.code(), reader.join().unwrap(), peak_kb * 1024, samples)
}

/// 2·10⁹ zero bytes, gzip-compressed as they stream (never held in memory here either).
fn write_bomb(path: &Path) -> u64 {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut gz = flate2::write::GzEncoder::new(file, flate2::Compression::default());
    let zeros = vec![0u8; 1 << 20];
    let mut left: u64 = 2_000_000_000;
    while left > 0 {
        let n = left.min(zeros.len() as u64) as usize;
        gz.write_all(&zeros[..n]).unwrap();
        left -= n as u64;
    }
    gz.finish().unwrap().flush().unwrap();
    std::fs::metadata(path).unwrap().len()
}

#[test]
fn a_2_gb_gzip_bomb_is_refused_within_300_mb_of_memory() {
    let dir = tempfile::tempdir().unwrap();
    let bomb = dir.path().join("bomb.tsv.gz");
    let gz_bytes = write_bomb(&bomb);
    assert!(gz_bytes < 10_000_000, "the bomb is {gz_bytes} bytes of gzip");
    let exp = dir.path().join("bomb.toml");
    std::fs::write(&exp, "[experiment]\nname = \"bomb\"\n\n[[dataset]]\nfiles = [\"bomb.tsv.gz\"]\nloader = { type = \"qualisys_tsv\" }\n\n[features]\nextractors = [{ type = \"marker_speed\" }]\n").unwrap();
    for args in [
        vec!["run", exp.to_str().unwrap(), "--quiet", "--no-cache", "--reports"],
        vec!["inspect", bomb.to_str().unwrap()],
    ] {
        let mut cmd = crate::motionlab_command();
        cmd.args(&args).current_dir(dir.path()).env_remove("MOTIONLAB_MAX_INPUT_MB");
        if args[0] == "run" {
            cmd.arg(dir.path().join("reports"));
        }
        let started = Instant::now();
        let (code, err, peak, samples) = run_measured(cmd);
        println!(
            "{}: {gz_bytes} bytes of gzip → 2e9 bytes: refused in {:.1} s, peak resident {:.1} MB ({samples} samples)",
            args[0],
            started.elapsed().as_secs_f64(),
            peak as f64 / 1e6
        );
        assert!(samples >= 3, "{}: too few memory samples ({samples}) to mean anything", args[0]);
        assert_eq!(code, Some(1), "{}: {err}", args[0]);
        assert!(
            err.contains("bomb.tsv.gz")
                && err
                    .contains("more than the input limit of 1024 MiB (set MOTIONLAB_MAX_INPUT_MB"),
            "{}: {err}",
            args[0]
        );
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(peak < 300_000_000, "{}: peak resident memory {peak} bytes", args[0]);
    }
}

#[test]
fn annotation_and_experiment_files_are_bounded_and_the_limit_is_configurable() {
    let dir = tempfile::tempdir().unwrap();
    // A real take of 1.03 MB (MoCap Toolbox dance1) with 2.2 MB of annotations: refused at a
    // limit of 2 MiB, read at 3 MiB.
    let mut csv = String::from("frame\n100\n700\n");
    while csv.len() < 2_200_000 {
        csv.push_str("# a comment line that pads the file beyond the limit\n");
    }
    std::fs::write(dir.path().join("dance1.csv"), &csv).unwrap();
    std::fs::copy(repo_root().join("data/mct/dance1.tsv.gz"), dir.path().join("dance1.tsv.gz"))
        .unwrap();
    let exp = dir.path().join("truth.toml");
    std::fs::write(
        &exp,
        "[experiment]\nname = \"big_truth\"\n\n[[dataset]]\nfiles = [\"dance1.tsv.gz\"]\nloader = { type = \"qualisys_tsv\" }\n\
         ground_truth = { type = \"boundaries_csv\", file = \"dance1.csv\" }\n\n[segmentation]\nroot = \"Spine\"\nfigures = []\n\n\
         [[segmentation.segmenter]]\ntype = \"speed_minima\"\n\n[[evaluate]]\ntype = \"boundary_pr\"\n",
    )
    .unwrap();
    let run = |limit_mb: &str| {
        let out = crate::motionlab_command()
            .args(["run", exp.to_str().unwrap(), "--quiet", "--no-cache", "--reports"])
            .arg(dir.path().join("reports"))
            .env("MOTIONLAB_MAX_INPUT_MB", limit_mb)
            .output()
            .unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = run("2");
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("dance1.csv: ")
            && err.contains(": holds 2200044 bytes, more than the input limit of 2 MiB"),
        "{err}"
    );
    let (code, err) = run("3");
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = run("lots");
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("MOTIONLAB_MAX_INPUT_MB=\"lots\": expected a positive whole number of MiB"),
        "{err}"
    );
    // An experiment file of 17 MB is refused before it is parsed.
    let huge = dir.path().join("huge.toml");
    let mut text = String::from("[experiment]\nname = \"huge\"\ndescription = \"");
    text.push_str(&"x".repeat(17 << 20));
    text.push_str("\"\n");
    std::fs::write(&huge, text).unwrap();
    let out =
        crate::motionlab_command().args(["validate", huge.to_str().unwrap()]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("huge.toml: holds 17825")
            && err.contains("more than the 16 MiB an experiment file may hold"),
        "{err}"
    );
}
