//! Rendering to a noise target (`render.noise_target`) from the command
//! line: the same bytes for any thread count, a stopped and resumed render
//! equal to an uninterrupted one, merged shards equal to one run, the
//! per-pixel samples and the reached noise written with the image, and bad
//! keys refused. (Unbiasedness: `image_polarization.rs`, many seeds against
//! the exact single-scattering sky.)

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use atmosim::io::exr::{ExrContents, read_exr};
use common::{assert_refused, files_under, run_ok};

const JOB: &str = "[spectrum]\nwavelengths_nm = [450.0, 600.0]\n[sun]\nelevation_deg = 25.0\n\
                   [ground]\nalbedo = [0.0, 0.5]\n[sensor]\ntype = \"fisheye\"\nresolution = 12\n\
                   [render]\nnoise_target = 0.03\npilot_samples = 16\nmax_samples = 3000\n";

fn write_job(d: &Path, text: &str) {
    std::fs::write(d.join("job.toml"), text).unwrap();
}

fn exr(path: &Path) -> ExrContents {
    read_exr(path).unwrap()
}

fn channel<'a>(e: &'a ExrContents, name: &str) -> &'a [f32] {
    &e.channels.iter().find(|c| c.name == name).unwrap().samples
}

#[test]
fn the_same_bytes_for_any_thread_count_with_samples_and_noise_written() {
    let sums: Vec<Vec<(String, Vec<u8>)>> = ["1", "2"]
        .iter()
        .map(|threads| {
            let dir = tempfile::tempdir().unwrap();
            write_job(dir.path(), JOB);
            run_ok(
                dir.path(),
                &["render", "job.toml", "--out", "out", "-q", "--threads", threads],
            );
            let out = dir.path().join("out");
            files_under(&out)
                .iter()
                .map(|p| {
                    (
                        p.strip_prefix(&out).unwrap().display().to_string(),
                        std::fs::read(p).unwrap(),
                    )
                })
                .collect()
        })
        .collect();
    assert_eq!(sums[0], sums[1]);
    let files: Vec<&str> = sums[0].iter().map(|(n, _)| n.as_str()).collect();
    assert!(
        files.contains(&"noise.csv") && files.contains(&"image.exr"),
        "{files:?}"
    );
    // The samples per pixel: between the pilot's count and the cap, 0
    // outside the circle, and not all alike.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("image.exr"),
        &sums[0].iter().find(|(n, _)| n == "image.exr").unwrap().1,
    )
    .unwrap();
    let e = exr(&dir.path().join("image.exr"));
    let samples = channel(&e, "samples");
    let traced: Vec<f32> = samples.iter().copied().filter(|&n| n > 0.0).collect();
    assert!(traced.len() > 80 && traced.len() < 144, "{}", traced.len());
    assert!(traced.iter().all(|&n| (16.0..=3000.0).contains(&n) && n.fract() == 0.0));
    assert!(traced.iter().any(|&n| n != traced[0]));
    // noise.csv: per (wavelength, albedo), the reached noise; the median
    // pixel meets the target.
    let noise = String::from_utf8(sums[0].iter().find(|(n, _)| n == "noise.csv").unwrap().1.clone()).unwrap();
    let mut lines = noise.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("wavelength_nm,albedo,counted,median_rel_se_I,p99_rel_se_I")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4);
    for r in &rows {
        assert!(r[2] > 80.0, "{r:?}");
        assert!(r[3] <= 0.03, "median {r:?}");
    }
    let meta = String::from_utf8(sums[0].iter().find(|(n, _)| n == "task.toml").unwrap().1.clone()).unwrap();
    assert!(
        meta.contains("noise_target = 0.03") && meta.contains("max_samples = 3000"),
        "{meta}"
    );
}

#[test]
fn a_stopped_noise_targeted_render_resumes_to_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Long enough on one thread for SIGTERM after 1 s to land mid-render
    // (past the pilot: its allocation must come back from the checkpoint).
    let job = JOB
        .replace("resolution = 12", "resolution = 24")
        .replace("0.03", "0.01")
        .replace("3000", "20000");
    write_job(d, &job);
    let mut child = Command::new(env!("CARGO_BIN_EXE_atmosim"))
        .current_dir(d)
        .args([
            "render",
            "job.toml",
            "--out",
            "sky",
            "--checkpoint-every",
            "0",
            "--threads",
            "1",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the render ended before SIGTERM: make it longer"
    );
    common::sigterm(&child);
    let out = child.wait_with_output().unwrap();
    let log = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(143), "{log}");
    assert!(d.join("sky/checkpoints/0001-of-0001.state").exists(), "{log}");
    run_ok(d, &["render", "job.toml", "--out", "sky", "--resume", "-q"]);
    run_ok(d, &["render", "job.toml", "--out", "whole", "-q"]);
    for f in ["image.exr", "noise.csv", "task.toml"] {
        let a = std::fs::read(d.join("whole").join(f)).unwrap();
        let b = std::fs::read(d.join("sky").join(f)).unwrap();
        assert!(a == b, "{f} differs after resume");
    }
}

#[test]
fn merged_shards_equal_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_job(d, JOB);
    run_ok(d, &["render", "job.toml", "--out", "whole", "-q"]);
    for shard in ["3/3", "1/3", "2/3"] {
        run_ok(d, &["render", "job.toml", "--out", "sharded", "--shard", shard, "-q"]);
    }
    run_ok(d, &["merge", "sharded", "-q"]);
    let (a, b) = (exr(&d.join("whole/image.exr")), exr(&d.join("sharded/image.exr")));
    assert_eq!(a.channels.len(), b.channels.len());
    for (x, y) in a.channels.iter().zip(&b.channels) {
        assert_eq!(x.name, y.name);
        for (p, q) in x.samples.iter().zip(&y.samples) {
            // Stored as f32: equal to its rounding (the counts exactly).
            assert!(
                (p - q).abs() <= 2.0 * f32::EPSILON * p.abs().max(q.abs()),
                "{}: {p} vs {q}",
                x.name
            );
        }
    }
    assert_eq!(channel(&a, "samples"), channel(&b, "samples"));
    let meta = std::fs::read_to_string(d.join("sharded/task.toml")).unwrap();
    assert!(meta.contains("shards = 3"), "{meta}");
}

#[test]
fn bad_noise_target_keys_are_refused_by_name() {
    let base = "[sensor]\ntype = \"fisheye\"\nresolution = 4\n[render]\n";
    for (render, words) in [
        (
            "noise_target = 0.01\nsamples = 100\n",
            vec!["render.samples", "render.noise_target"],
        ),
        ("noise_target = 0.0\n", vec!["render.noise_target", "above 0"]),
        ("noise_target = 2.0\n", vec!["render.noise_target", "at most 1"]),
        (
            "pilot_samples = 10\n",
            vec!["render.pilot_samples", "render.noise_target"],
        ),
        ("max_samples = 10\n", vec!["render.max_samples", "render.noise_target"]),
        (
            "noise_target = 0.01\npilot_samples = 1\n",
            vec!["render.pilot_samples", "at least 2"],
        ),
        (
            "noise_target = 0.01\npilot_samples = 64\nmax_samples = 10\n",
            vec!["render.max_samples", "at least 64"],
        ),
        (
            "noise_target = 0.01\nmax_samples = 100000000\n",
            vec!["render.max_samples", "16777216"],
        ),
    ] {
        assert_refused("render", &format!("{base}{render}"), &words);
    }
}
