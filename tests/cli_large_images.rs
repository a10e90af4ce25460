//! Large images stay under control: a stop request (SIGTERM) is honoured
//! within seconds however many pixels an image has (a wave may hold less
//! than one sample per pixel), with a checkpoint that resumes; `plan` of a
//! large image answers at once (no per-pixel work before its calibration).

mod common;

use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use atmosim::run::checkpoint::StateFile;
use common::{atmosim, sigterm};

/// 8.4 million pixels at one wavelength: a sample of every pixel takes
/// several seconds on two cores, their solid angles a while to compute.
const LARGE: &str = "[spectrum]\nwavelengths_nm = [550.0]\n[atmosphere]\naerosol = \"none\"\n\
                     [sensor]\ntype = \"sphere\"\nresolution = 2048\n[render]\nsamples = 64\n\
                     [output]\npreview = false\n";

#[test]
fn a_stop_request_is_honoured_within_seconds_on_a_large_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("job.toml"), LARGE).unwrap();
    let mut child = Process::cargo_bin("atmosim")
        .unwrap()
        .current_dir(d)
        .args(["render", "job.toml", "--out", "sky", "--checkpoint-every", "0"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Long enough for the tallies to be allocated and tracing to start.
    std::thread::sleep(Duration::from_secs(4));
    assert!(child.try_wait().unwrap().is_none(), "the render ended before SIGTERM");
    let sent = Instant::now();
    sigterm(&child);
    let out = child.wait_with_output().unwrap();
    let latency = sent.elapsed();
    let log = String::from_utf8_lossy(&out.stderr).to_string();
    eprintln!("stopped {:.2} s after SIGTERM\n{log}", latency.as_secs_f64());
    assert_eq!(out.status.code(), Some(143), "{log}");
    // The rest of the current wave (about a second), then the checkpoint
    // (670 MB of sums), whose writing the log times.
    let write: f64 = log
        .split(" MB in ")
        .nth(1)
        .and_then(|t| t.split(" s)").next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no checkpoint time in {log}"));
    let wave = latency.as_secs_f64() - write;
    assert!(
        wave < 3.0,
        "{wave:.2} s to the end of the wave (and {write:.2} s to write): {log}"
    );
    assert!(latency < Duration::from_secs(30), "{latency:?}: {log}");
    let cp = d.join("sky/checkpoints/0001-of-0001.state");
    let state = StateFile::read(&cp).unwrap().state;
    let pixels = 4096 * 2048;
    // Less than one sample per pixel was done: the stop came mid-pass.
    assert!(state.done[0] > 0 && state.done[0] < 64 * pixels, "{:?}", state.done);
}

#[test]
fn plan_of_a_large_image_answers_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let job = LARGE.replace(
        "type = \"sphere\"\nresolution = 2048",
        "type = \"fisheye\"\nresolution = 16384",
    );
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let start = Instant::now();
    let out = atmosim()
        .current_dir(dir.path())
        .args(["plan", "job.toml"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    // π/4 of 16384² pixels see the sky, the left half of them is traced
    // (the right half mirrors it), 64 samples each.
    let paths: f64 = text
        .lines()
        .find(|l| l.starts_with("0,"))
        .and_then(|l| l.split(',').nth(5))
        .unwrap()
        .parse()
        .unwrap();
    let expected = 64.0 * std::f64::consts::FRAC_PI_4 * 16384.0 * 16384.0 / 2.0;
    assert!((paths / expected - 1.0).abs() < 1e-3, "{text}");
    assert!(start.elapsed() < Duration::from_secs(20), "{:?}", start.elapsed());
}
