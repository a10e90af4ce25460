//! Rendering to a noise target (`render.noise_target`) from the command
//! line: the same bytes for any thread count, the per-pixel samples and
//! the reached noise written with the image, and bad keys refused.
//! (Merged shards and a stopped and resumed render: `scale_out.rs`;
//! unbiasedness: `image_polarization.rs`, many seeds against the exact
//! single-scattering sky.)

mod common;

use std::path::Path;

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
