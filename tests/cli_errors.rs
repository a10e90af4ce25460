//! Input and output errors as a user meets them: every one exits with code
//! 2 and one clear message (the operating system's text once), is found
//! before any rendering, and loses no finished work.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use common::atmosim;

/// A job that would render for hours: any error must come before the work.
const LONG_JOB: &str = "[sensor]\ntype = \"fisheye\"\nresolution = 64\n[render]\nsamples = 100000000\n";
const SMALL_JOB: &str = "[spectrum]\nwavelengths_nm = [550.0]\n[sensor]\ntype = \"fisheye\"\nresolution = 6\n\
                         [render]\nsamples = 4\n[output]\npreview = false\n";

/// Runs `atmosim ARGS` in `dir`: exit code and stderr.
fn run(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let out = atmosim().current_dir(dir).args(args).output().unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).to_string())
}

/// A temporary directory holding `job.toml` with `text`.
fn with_job(text: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.toml"), text).unwrap();
    dir
}

#[test]
fn a_job_file_that_is_not_utf8_exits_2_naming_where() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("job.toml"), b"[render]\nsamples = 10\xff\n").unwrap();
    for command in ["render", "plan", "atmosphere", "transmittance"] {
        let (code, err) = run(dir.path(), &[command, "job.toml"]);
        assert_eq!(code, Some(2), "{command}: {err}");
        assert!(
            err.contains("job.toml") && err.contains("not UTF-8") && err.contains("line 2"),
            "{err}"
        );
    }
    std::fs::write(dir.path().join("in.inp"), b"wavelength 500\xfe\n").unwrap();
    let (code, err) = run(dir.path(), &["uvspec", "in.inp"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("not UTF-8"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "files written");
}

#[test]
fn an_operating_system_message_is_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let (code, err) = run(dir.path(), &["render", "missing.toml"]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

#[test]
fn an_output_directory_that_cannot_be_written_is_refused_before_any_work() {
    let dir = with_job(LONG_JOB);
    std::fs::write(dir.path().join("a_file"), "").unwrap();
    for args in [
        vec!["render", "job.toml", "--out", "a_file/sky"],
        vec!["render", "job.toml", "--out", "a_file"],
        vec!["transmittance", "job.toml", "--out", "a_file/t"],
        vec!["validate", "--all", "--out", "a_file/report"],
    ] {
        let start = Instant::now();
        let (code, err) = run(dir.path(), &args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains("`--out`") && err.contains("a_file"), "{args:?}: {err}");
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "{args:?}: found after the work"
        );
    }
    // Named by the job file's key when it comes from there.
    let dir = with_job(&format!("{LONG_JOB}[output]\ndirectory = \"a_file/sky\"\n"));
    std::fs::write(dir.path().join("a_file"), "").unwrap();
    let (code, err) = run(dir.path(), &["render", "job.toml"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("job.toml") && err.contains("`output.directory`"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "files written");
}

#[test]
fn another_jobs_results_are_not_overwritten_unless_asked() {
    let dir = with_job(SMALL_JOB);
    let (code, err) = run(dir.path(), &["render", "job.toml", "--out", "sky", "--quiet"]);
    assert_eq!(code, Some(0), "{err}");
    let first = std::fs::read(dir.path().join("sky/image.exr")).unwrap();
    let hash = |text: &str| atmosim::job::Job::parse(text, "job.toml", Path::new(".")).unwrap().hash;
    let other = SMALL_JOB.replace("samples = 4", "samples = 5");
    std::fs::write(dir.path().join("other.toml"), &other).unwrap();
    let (code, err) = run(dir.path(), &["render", "other.toml", "--out", "sky", "--quiet"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(&hash(SMALL_JOB)) && err.contains(&hash(&other)) && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(
        std::fs::read(dir.path().join("sky/image.exr")).unwrap(),
        first,
        "overwritten"
    );
    let (code, err) = run(
        dir.path(),
        &["render", "other.toml", "--out", "sky", "--quiet", "--overwrite"],
    );
    assert_eq!(code, Some(0), "{err}");
    assert_ne!(std::fs::read(dir.path().join("sky/image.exr")).unwrap(), first);
}

#[test]
fn when_the_final_write_fails_the_sums_are_kept_and_resume_only_writes() {
    let dir = with_job(SMALL_JOB);
    // A directory where the image should go: writing it fails after the render.
    std::fs::create_dir_all(dir.path().join("sky/image.exr")).unwrap();
    let (code, err) = run(dir.path(), &["render", "job.toml", "--out", "sky"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("kept in") && err.contains("--resume"), "{err}");
    assert!(dir.path().join("sky/checkpoints/0001-of-0001.state").is_file());
    std::fs::remove_dir(dir.path().join("sky/image.exr")).unwrap();
    let (code, err) = run(dir.path(), &["render", "job.toml", "--out", "sky", "--resume"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("100.00 % done") && err.contains(": 0 paths"),
        "rendered again: {err}"
    );
    // The same bytes as a render that never failed.
    let (code, err) = run(dir.path(), &["render", "job.toml", "--out", "clean", "--quiet"]);
    assert_eq!(code, Some(0), "{err}");
    for file in ["image.exr", "task.toml"] {
        assert_eq!(
            std::fs::read(dir.path().join("sky").join(file)).unwrap(),
            std::fs::read(dir.path().join("clean").join(file)).unwrap(),
            "{file}"
        );
    }
    assert!(!dir.path().join("sky/checkpoints").exists());
}

#[test]
fn zero_threads_means_one_per_core_and_says_so() {
    let out = atmosim().args(["render", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("0 or absent: one per available core"), "{help}");
    let dir = with_job(SMALL_JOB);
    let (code, err) = run(dir.path(), &["render", "job.toml", "--out", "sky", "--threads", "0"]);
    assert_eq!(code, Some(0), "{err}");
    let cores = std::thread::available_parallelism().unwrap().get();
    assert!(err.contains(&format!("on {cores} threads")), "{err}");
}

#[test]
fn a_reader_that_has_gone_away_ends_the_output_quietly() {
    // `atmosim validate --list | true`: stdout's reader is gone before the
    // first line; the write fails with a broken pipe, which is not an error
    // of the user's (exit 0, nothing on stderr), never a panic (exit 101).
    let dir = tempfile::tempdir().unwrap();
    let uvspec = dir.path().join("in.inp");
    std::fs::write(
        &uvspec,
        "atmosphere_file afglus\nwavelength 500\nsza 30\numu -0.5\nphi 0\n",
    )
    .unwrap();
    let commands: [&[&str]; 2] = [&["validate", "--list"], &["uvspec", "in.inp", "--print-job"]];
    for args in commands {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = std::process::Command::new(assert_cmd::cargo::cargo_bin("atmosim"))
            .current_dir(dir.path())
            .args(args)
            .stdout(writer)
            .stderr(std::process::Stdio::piped())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {stderr}");
        assert!(stderr.is_empty(), "{args:?}: {stderr}");
    }
}
