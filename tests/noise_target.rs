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
    // pixel lands near the target. The allocation aims each pixel at the
    // target from its neighbourhood's mean need, so the median falls on
    // either side of it: over seeds 1-8 of this job the noisiest row (450
    // nm, albedo 0) read 0.0280-0.0323 (mean 0.0299, standard deviation
    // 0.0015) on 2026-11-29 before the by-day view connections and
    // 0.0280-0.0323 (mean 0.0300) with them; the check until then, at most
    // the target, held for seeds 1-3 and 6 only. So the check is at most
    // 1.1 times the target, and the noisiest row at least 0.8 times (each
    // pixel is allocated by its noisiest value), as the next test's.
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
        assert!(r[3] <= 1.1 * 0.03, "median {r:?}");
    }
    let noisiest = rows.iter().map(|r| r[3]).fold(0.0, f64::max);
    assert!(noisiest >= 0.8 * 0.03, "noisiest median {noisiest}: {rows:?}");
    let meta = String::from_utf8(sums[0].iter().find(|(n, _)| n == "task.toml").unwrap().1.clone()).unwrap();
    assert!(
        meta.contains("noise_target = 0.03") && meta.contains("max_samples = 3000"),
        "{meta}"
    );
}

#[test]
fn bad_noise_target_keys_are_refused_by_name() {
    let base = "[sensor]\ntype = \"fisheye\"\nresolution = 4\n[render]\n";
    // A directions sensor has no image to hold to a target as a whole.
    assert_refused(
        "render",
        "[sensor]\ntype = \"directions\"\n[render]\nnoise_target = 0.01\nnoise_target_per = \"image\"\n",
        &["render.noise_target_per", "image sensor"],
    );
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
        (
            "noise_target_albedos = \"above_zero\"\n",
            vec!["render.noise_target_albedos", "render.noise_target"],
        ),
        // The job's only albedo is the default, 0.
        (
            "noise_target = 0.01\nnoise_target_albedos = \"above_zero\"\n",
            vec!["render.noise_target_albedos", "no albedo above 0"],
        ),
        (
            "noise_target = 0.01\nnoise_target_albedos = \"nonzero\"\n",
            vec!["noise_target_albedos", "above_zero"],
        ),
        (
            "noise_target_per = \"image\"\n",
            vec!["render.noise_target_per", "render.noise_target"],
        ),
        (
            "noise_target = 0.01\nnoise_target_per = \"solid_angle\"\n",
            vec!["noise_target_per", "image"],
        ),
    ] {
        assert_refused("render", &format!("{base}{render}"), &words);
    }
}

#[test]
fn albedos_the_target_leaves_out_allocate_nothing_and_are_still_reported() {
    // Seen from 5 km, looking down and up: the path radiance over a black
    // ground (albedo 0) is a value of its own. With "above_zero" the same
    // pilot (the same job but for the key) allocates the most the albedos
    // above 0 need, so no pixel gets more than with every albedo counted.
    // The pilot is the default (32): with 16, since noise targets leave the
    // first scattering unsplit, the noisiest row's median pixel came out 2
    // and 4 % above the target (0.0510, 0.0520), a small pilot missing the
    // rare bright paths ("Noise targets", heavy tails). The allocation aims
    // each pixel's noisiest value at the target from its neighbourhood's
    // mean need, so the median pixel lands near the target, on either side:
    // over seeds 1-8 of this job (the mirrored image, 64 pixels traced) the
    // noisiest targeted row's median came out 0.0446-0.0505 (mean 0.0492,
    // standard deviation 0.0019) counting every albedo and 0.0453-0.0503
    // above 0 (every column traced: 0.0467-0.0511). So the check is 0.8 to
    // 1.1 times the target, about 2.5 of those deviations from its mean
    // either way.
    let job = |albedos: &str| {
        format!(
            "[spectrum]\nwavelengths_nm = [450.0, 600.0]\n[sun]\nelevation_deg = 25.0\n[observer]\naltitude_km = 5.0\n\
             [ground]\nalbedo = [0.0, 0.5]\n[sensor]\ntype = \"sphere\"\nresolution = 8\n\
             [render]\nnoise_target = 0.05\nmax_samples = 3000\nnoise_target_albedos = \"{albedos}\"\n"
        )
    };
    let render = |albedos: &str| {
        let dir = tempfile::tempdir().unwrap();
        write_job(dir.path(), &job(albedos));
        run_ok(
            dir.path(),
            &["render", "job.toml", "--out", "out", "-q", "--threads", "2"],
        );
        let task = files_under(&dir.path().join("out"))
            .into_iter()
            .find(|p| p.ends_with("image.exr"))
            .unwrap()
            .parent()
            .unwrap()
            .to_path_buf();
        let samples = channel(&exr(&task.join("image.exr")), "samples").to_vec();
        let noise = std::fs::read_to_string(task.join("noise.csv")).unwrap();
        let meta = std::fs::read_to_string(task.join("task.toml")).unwrap();
        (samples, noise, meta, dir)
    };
    let (all, noise_all, _, _d1) = render("all");
    let (above, noise_above, meta, _d2) = render("above_zero");
    assert_eq!(all.len(), above.len());
    assert!(all.iter().zip(&above).all(|(a, b)| b <= a), "{all:?}\n{above:?}");
    let (sum_all, sum_above) = (all.iter().sum::<f32>(), above.iter().sum::<f32>());
    assert!(sum_above < sum_all, "{sum_above} against {sum_all}");
    assert!(meta.contains("noise_target_albedos = \"above_zero\""), "{meta}");
    // noise.csv: every (wavelength, albedo) reported, `targeted` 0 for
    // albedo 0 alone; the targeted rows' median pixel meets the target.
    for (noise, left_out) in [(noise_all, false), (noise_above, true)] {
        let mut lines = noise.lines();
        assert!(lines.next().unwrap().ends_with(",targeted,image_rel_noise"));
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 4);
        for r in &rows {
            let targeted = !(left_out && r[1] == 0.0);
            assert_eq!(r[10], f64::from(u8::from(targeted)), "{r:?}");
            assert!(r[2] > 100.0, "{r:?}");
        }
        let noisiest = rows.iter().filter(|r| r[10] == 1.0).map(|r| r[3]).fold(0.0, f64::max);
        assert!(
            (0.04..=0.055).contains(&noisiest),
            "noisiest median {noisiest}: {rows:?}"
        );
    }
}

#[test]
fn an_image_held_to_a_target_as_a_whole_meets_it() {
    // noise.csv's image_rel_noise, √(Σ Ω·se² / Σ Ω·I²), of the worst
    // targeted channel and albedo comes to the target: the allocation meets
    // it exactly for the pilot's variances, which estimate the true ones
    // from 8 samples per pixel and its neighbours (measured 0.0207).
    let dir = tempfile::tempdir().unwrap();
    let job = "[sensor]\ntype = \"sphere\"\nresolution = [32, 16]\n[spectrum]\nwavelengths_nm = [450.0, 650.0]\n\
               [sun]\nelevation_deg = 20.0\n[ground]\nalbedo = [0.0, 0.5]\n\
               [render]\nnoise_target = 0.02\nnoise_target_per = \"image\"\npilot_samples = 8\n\
               noise_target_albedos = \"above_zero\"\n[output]\ndirectory = \"out\"\npreview = false\n";
    write_job(dir.path(), job);
    run_ok(dir.path(), &["render", "job.toml", "-q"]);
    let noise = std::fs::read_to_string(dir.path().join("out").join("noise.csv")).unwrap();
    let mut lines = noise.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |k: &str| header.iter().position(|&c| c == k).unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let worst = rows
        .iter()
        .filter(|r| r[at("targeted")] == 1.0)
        .map(|r| r[at("image_rel_noise")])
        .fold(0.0, f64::max);
    assert!((0.016..=0.024).contains(&worst), "worst image noise {worst}: {noise}");
    let meta = std::fs::read_to_string(dir.path().join("out").join("task.toml")).unwrap();
    assert!(meta.contains("noise_target_per = \"image\""), "{meta}");
}
