//! `atmosim fit-report` against the converged sky, on a case whose truth is
//! known: a smooth synthetic sky rendered four ways (twice with Gaussian
//! noise of 5 % per pixel from independent seeds, once as a reference
//! with 2 %, once exact), each noisy or exact set fitted like renders.
//!
//! - The reference's noise floor is reported (report.md and
//!   reference.csv) and is the noise it was given: −20·log10(0.02).
//! - The debiased SNR of the dataset against the noisy reference recovers
//!   its SNR against the exact sky, within four of its own standard
//!   deviations, where the SNR against the reference as it is falls short.
//! - The seed-to-seed SNR of two datasets fitted from independent noisy
//!   renders, plus 3.01 dB, recovers one dataset's SNR against its inherited
//!   noise (the dataset against the fit of the exact renders), within four
//!   standard errors of the mean over the images.

mod common;

use std::path::Path;

use atmosim::sensor::camera::Camera;
use atmosim::skymodel::angles::ViewAngles;
use common::run_ok;
use common::synthetic_sky::{SyntheticSky, write_render, write_transmittance_table};

const WAVELENGTHS: [f64; 3] = [450.0, 550.0, 650.0];
const ELEVATIONS: [f64; 2] = [10.0, 30.0];
const ALBEDO: f64 = 0.3;
const NOISE: f64 = 0.05;
const REFERENCE_NOISE: f64 = 0.02;

/// A smooth sky of rank 2 in (γ, θ): a glow about the sun and a
/// zenith-to-horizon gradient whose colour differs.
fn sky(a: &ViewAngles, c: usize) -> (f64, f64) {
    let glow = 1.0 + 2.0 * (-a.gamma * a.gamma / 0.1).exp();
    let gradient = 1.2 + a.theta.cos();
    let haze = (1.0 + 0.5 * c as f64) * (-(a.theta - 1.4).powi(2) / 0.3).exp();
    let value = 0.1 * (1.0 + c as f64) * glow * gradient + 0.05 * haze;
    let dolp = 0.6 * a.gamma.sin().powi(2) / (1.0 + a.gamma.cos().powi(2));
    (value, value * dolp)
}

/// Writes one render set (both elevations) and its fit settings, and fits
/// it: `<name>.dat`.
fn fit_set(root: &Path, name: &str, noise: Option<(f64, u64)>) {
    for (k, e) in ELEVATIONS.iter().enumerate() {
        let synthetic = SyntheticSky {
            wavelengths_nm: &WAVELENGTHS,
            band_width_nm: 100.0,
            albedo: ALBEDO,
            value: &sky,
            noise: noise.map(|(r, seed)| (r, seed * 10 + k as u64)),
        };
        let camera = Camera::Sphere {
            width: 256,
            height: 128,
        };
        write_render(&root.join(name).join(format!("elev{e}")), *e, camera, &synthetic);
    }
    std::fs::write(
        root.join(format!("fit_{name}.toml")),
        format!(
            "renders = \"{name}\"\ntransmittance = \"tables\"\nout = \"{name}.dat\"\nresolution = 181\n\
             transmittance_rank = 3\n"
        ),
    )
    .unwrap();
    run_ok(root, &["fit", &format!("fit_{name}.toml"), "-q"]);
}

/// A CSV file's rows as maps from column to text.
fn rows(path: &Path) -> Vec<std::collections::BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    lines
        .map(|l| header.iter().cloned().zip(l.split(',').map(str::to_string)).collect())
        .collect()
}

fn number(row: &std::collections::BTreeMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = {:?} is not a number", row[key]))
}

#[test]
fn debiased_and_seed_to_seed_snr_recover_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    write_transmittance_table(&root.join("tables"), &WAVELENGTHS);
    fit_set(root, "a", Some((NOISE, 1)));
    fit_set(root, "b", Some((NOISE, 2)));
    fit_set(root, "truth", None);
    // The reference is rendered, not fitted: its renders alone.
    for (k, e) in ELEVATIONS.iter().enumerate() {
        let synthetic = SyntheticSky {
            wavelengths_nm: &WAVELENGTHS,
            band_width_nm: 100.0,
            albedo: ALBEDO,
            value: &sky,
            noise: Some((REFERENCE_NOISE, 30 + k as u64)),
        };
        let camera = Camera::Sphere {
            width: 256,
            height: 128,
        };
        write_render(&root.join("reference").join(format!("elev{e}")), *e, camera, &synthetic);
    }
    let report = |reference: &str, twin: &str, out: &str| {
        let output = run_ok(
            root,
            &[
                "fit-report",
                "fit_a.toml",
                "--reference",
                reference,
                "--twin",
                twin,
                "--out",
                out,
            ],
        );
        String::from_utf8_lossy(&output.stdout).to_string()
    };
    let noisy = report("reference", "b.dat", "noisy");
    let exact = report("truth", "truth.dat", "exact");

    // The reference's noise floor, reported where a reader looks.
    let md = std::fs::read_to_string(root.join("noisy").join("report.md")).unwrap();
    assert!(md.contains("the references' own noise floor"), "{md}");
    assert!(noisy.contains("their noise floor mean"), "{noisy}");
    let against_reference = rows(&root.join("noisy").join("reference.csv"));
    let against_truth = rows(&root.join("exact").join("reference.csv"));
    assert_eq!(against_reference.len(), ELEVATIONS.len() * WAVELENGTHS.len());
    assert_eq!(against_truth.len(), against_reference.len());
    let floor = -20.0 * REFERENCE_NOISE.log10();
    for (r, t) in against_reference.iter().zip(&against_truth) {
        // Σ w·L² holds the noise too: 1 + 0.02² of Σ w·T², 0.002 dB.
        let f = number(r, "noise_floor_db");
        assert!((f - floor).abs() < 0.02, "noise floor {f} dB, given {floor} dB");
        // The exact sky has no noise: an infinite floor, the debiased SNR
        // the SNR itself.
        assert!(number(t, "noise_floor_db").is_infinite());
        let truth = number(t, "snr_db");
        assert_eq!(number(t, "debiased_snr_db"), truth);
        // Debiased against the noisy reference: the truth within 4 sd.
        let debiased = number(r, "debiased_snr_db");
        let sd = number(r, "debiased_snr_sd_db");
        assert!(
            (debiased - truth).abs() < 4.0 * sd,
            "debiased {debiased:.3} ± {sd:.3} dB against the truth's {truth:.3} dB ({r:?})"
        );
        // As it is, the reference's noise takes it well below the truth.
        let raw = number(r, "snr_db");
        assert!(raw < truth - 1.0, "raw {raw} dB, truth {truth} dB");
    }

    // The noise one dataset inherits: seed to seed + 3.01 dB against the
    // dataset's own difference from the fit of the exact renders.
    let seed_to_seed = rows(&root.join("noisy").join("twin.csv"));
    let inherited = rows(&root.join("exact").join("twin.csv"));
    let d: Vec<f64> = seed_to_seed
        .iter()
        .zip(&inherited)
        .map(|(s, i)| number(s, "inherited_snr_db") - number(i, "seed_to_seed_snr_db"))
        .collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let se = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    assert!(
        mean.abs() < 4.0 * se,
        "seed to seed + 3.01 dB minus the inherited noise: mean {mean:.3} dB, standard error {se:.3} dB ({d:?})"
    );
    println!("{noisy}\n{exact}\ndifferences {d:?}");
}

#[test]
fn renders_to_an_image_target_are_fitted_and_compared_seed_to_seed() {
    // The grid as shipped renders to a target per image: the fit reads
    // such renders (their samples vary per pixel), and two of them from
    // other seeds give a finite seed-to-seed SNR that falls when the
    // target loosens (more noise carried into the dataset).
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let job = |seed: u64, target: f64| {
        format!(
            "[spectrum]\nwavelengths_nm = [450.0, 550.0]\nband_width_nm = 100.0\n[sun]\nelevation_deg = [10.0, 30.0]\n\
             [ground]\nalbedo = 0.3\n[sensor]\ntype = \"sphere\"\nresolution = [32, 16]\nstokes_frame = \"sun_view\"\n\
             [render]\nnoise_target = {target}\nnoise_target_per = \"image\"\npilot_samples = 8\nseed = {seed}\n\
             [output]\ndirectory = \"r{seed}_{target}\"\nunits = \"absolute\"\npreview = false\n"
        )
    };
    let mut snr = Vec::new();
    for target in [0.02, 0.08] {
        for seed in [1, 2] {
            std::fs::write(root.join(format!("j{seed}.toml")), job(seed, target)).unwrap();
            run_ok(root, &["render", &format!("j{seed}.toml"), "-q"]);
            std::fs::write(
                root.join(format!("fit{seed}.toml")),
                format!("renders = \"r{seed}_{target}\"\nout = \"sky{seed}.dat\"\nresolution = 91\n"),
            )
            .unwrap();
            run_ok(root, &["fit", &format!("fit{seed}.toml"), "-q"]);
        }
        let provenance = std::fs::read_to_string(root.join("sky1.dat.toml")).unwrap();
        assert!(provenance.contains("samples_per_pixel = { min = "), "{provenance}");
        run_ok(root, &["fit-report", "fit1.toml", "--twin", "sky2.dat", "--out", "rep"]);
        let twin = rows(&root.join("rep").join("twin.csv"));
        assert_eq!(twin.len(), 4);
        let mean = twin.iter().map(|t| number(t, "seed_to_seed_snr_db")).sum::<f64>() / 4.0;
        assert!(mean.is_finite(), "{twin:?}");
        snr.push(mean);
    }
    // A twin of another grid (one elevation of the two) is refused by name.
    let one = std::fs::read_dir(root.join("r1_0.08"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.join("image.exr").is_file())
        .unwrap();
    std::fs::write(
        root.join("fit_one.toml"),
        format!(
            "renders = {:?}\nout = \"one.dat\"\nresolution = 91\n",
            one.display().to_string()
        ),
    )
    .unwrap();
    run_ok(root, &["fit", "fit_one.toml", "-q"]);
    let out = common::atmosim()
        .current_dir(root)
        .args(["fit-report", "fit1.toml", "--twin", "one.dat", "--out", "rep2"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("one.dat") && err.contains("not a fit of the same grid"),
        "{err}"
    );
    // Four times the noise: about 12 dB less; at least 6.
    assert!(
        snr[0] > snr[1] + 6.0,
        "seed-to-seed SNR {snr:?} at targets 0.02 and 0.08"
    );
}
