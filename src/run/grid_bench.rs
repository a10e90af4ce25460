//! `atmosim bench --grid`: what the sky model's grid costs. A representative
//! subset of `examples/sky_model_grid.toml` rendered at reduced resolution
//! (full-sphere 64×32 images, 11 bands of 40 nm from 320 nm, albedos 0,
//! 0.3, 0.6 and 1, polarised, OPAC continental_average with its Mie phase
//! matrices): sun elevation −4.2, −1, 2, 10, 45 and 90°, visibility 20 and
//! 131.8 km, observers at 0 and 15 km (`--quick`: −1, 10 and 90°, 20 km,
//! the ground).
//!
//! Every task renders to a noise target (`render.noise_target`) ten times
//! the real one, [`BENCH_TARGET`], in the albedos the target below counts,
//! those above 0 (`noise_target_albedos = "above_zero"`; its pilot
//! allocates the samples per pixel; until 2026-11-26 albedo 0 allocated
//! samples too), so that the subset fits in minutes, with the job's defaults
//! otherwise (spectral groups, the ground view). The target is set so that
//! pixels get thousands of paths: a path's contribution is heavy-tailed
//! (at twilight the paths that carry most of the variance are rarer than
//! one in a thousand), and an estimate of a pixel's variance from a few
//! dozen paths falls short of the variance itself, so a looser target
//! understated the cost (0.2 with a pilot of 16, this benchmark until
//! 2026-11-26: 157 / 889 core-hours per task where this one measures
//! 429 / 2534 with the same build; README, "Noise targets"). Per task it
//! reports the core-seconds (wall time × the pool's threads) of the pilot
//! and of the allocated samples, the mean paths per traced pixel (over
//! every spectral group), and per band the median and 99th percentile over the traced
//! pixels (not those that share the ground view) of the relative standard
//! error of I (the worst over the albedos above 0). Scaled to the noise target
//! (median ≤ 0.5 %, 99th percentile ≤ 2 % in every band and albedo above
//! 0) and to 1024×512:
//!
//! core-hours = (allocated core-seconds × max_b max(median_b/0.005, p99_b/0.02)²
//!               + pilot core-seconds) × P_1024×512 / P_64×32 / 3600,
//!
//! P the pixels an image of that size traces (`sensor.symmetry`, the
//! default "auto": the left half, the mirror, so the ratio is
//! (1024·512)/(64·32) = 256, but with the sun at the zenith one column,
//! 512/32 = 16; the rows below the horizon of an observer on the ground
//! share the ground view at both sizes), assuming that a pixel's relative
//! error falls as 1/√samples (a noise target scales every pixel's
//! allocation by the same factor) and that a traced pixel of a finer image
//! costs what one of this image does at the same samples (the box filter
//! averages over the pixel; per-path cost does not depend on the pixel's
//! size); the pilot's cost per pixel does not scale with the factor.
//! The core-seconds are split between pilot and allocated samples by their
//! paths. The last line is `grid_core_hours_per_task: <mean> <max>` over
//! the tasks.
//!
//! With a fixed sample count (`bench --grid --samples N`) every pixel gets
//! N samples instead (no pilot) and the same scaling follows: the figure a
//! fixed-sample render computes, to compare with.

use std::io::Write;
use std::time::Instant;

use crate::error::{Error, Result};
use crate::film::ground_view;
use crate::film::image::{ActivePixels, SkyImage};
use crate::film::quantile::quantile;
use crate::job::{Job, Sensor, Task};
use crate::run::assemble::image_result;
use crate::run::shard::Shard;
use crate::run::task::render_whole;
use crate::sensor::camera::Camera;
use crate::sensor::symmetry::Symmetry;

/// The noise target: median and 99th percentile of the per-pixel relative
/// standard error of I.
pub const TARGET_MEDIAN: f64 = 0.005;
pub const TARGET_P99: f64 = 0.02;

/// The full-size image the figures are scaled to.
const FULL_SIZE: [usize; 2] = [1024, 512];

/// The pixels a full-size image of `task` traces with `symmetry`: half of
/// them with the mirror (the rows above the horizon alone for an observer
/// on the ground), one column's with the rotation.
fn full_size_traced(task: &Task, symmetry: Symmetry) -> f64 {
    let camera = Camera::Sphere {
        width: FULL_SIZE[0],
        height: FULL_SIZE[1],
    };
    let rows = ground_view::traced_rows(&camera, task);
    ActivePixels::new(&camera, rows, symmetry.traced_columns(FULL_SIZE[0])).count() as f64
}

/// The noise target the benchmark renders to, its pilot and its cap.
pub const BENCH_TARGET: f64 = 0.05;
const BENCH_PILOT: u64 = 64;
const BENCH_MAX_SAMPLES: u64 = 16384;

/// The `[render]` keys of the benchmark's noise target.
pub fn target_keys() -> String {
    format!(
        "noise_target = {BENCH_TARGET}\npilot_samples = {BENCH_PILOT}\nmax_samples = {BENCH_MAX_SAMPLES}\n\
         noise_target_albedos = \"above_zero\""
    )
}

/// The benchmark's job: the subset (or the quick one) at `samples` (the
/// `[render]` keys of its sample count), rendered with `seed`.
pub fn job_text(quick: bool, samples: &str, seed: u64) -> String {
    let (suns, visibilities, observers) = if quick {
        ("[-1.0, 10.0, 90.0]", "[20.0]", "[0.0]")
    } else {
        ("[-4.2, -1.0, 2.0, 10.0, 45.0, 90.0]", "[20.0, 131.8]", "[0.0, 15.0]")
    };
    format!(
        "[planet]\nradius_km = 6378.0\ntop_km = 100.0\n\
         [atmosphere]\nprofile = \"us_standard\"\nozone = \"bogumil\"\naerosol = \"continental_average\"\n\
         visibility_km = {visibilities}\n\
         [spectrum]\nwavelengths_nm = [340.0, 380.0, 420.0, 460.0, 500.0, 540.0, 580.0, 620.0, 660.0, 700.0, 740.0]\n\
         band_width_nm = 40.0\n\
         [sun]\nelevation_deg = {suns}\n\
         [observer]\naltitude_km = {observers}\n\
         [ground]\nalbedo = [0.0, 0.3, 0.6, 1.0]\n\
         [sensor]\ntype = \"sphere\"\nresolution = [64, 32]\n\
         [render]\n{samples}\npolarized = true\nseed = {seed}\n"
    )
}

/// One band's noise in one image: the median and 99th percentile of the
/// pixels' relative standard error of I, the worst over the albedos > 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandNoise {
    pub wavelength_nm: f64,
    pub median: f64,
    pub p99: f64,
}

/// Per band, the noise of the pixels of `image` in its first `rows` rows
/// (those with I > 0; an image of a band with no lit pixel gives 0).
pub fn band_noise(image: &SkyImage, rows: usize) -> Vec<BandNoise> {
    let mut out: Vec<BandNoise> = Vec::new();
    let pixels = rows.min(image.height) * image.width;
    for layer in image.layers.iter().filter(|l| l.albedo > 0.0) {
        let mut rel: Vec<f64> = layer.mean[0][..pixels]
            .iter()
            .zip(&layer.se[0][..pixels])
            .filter(|(m, _)| **m > 0.0)
            .map(|(m, s)| s / m)
            .collect();
        let (median, p99) = if rel.is_empty() {
            (0.0, 0.0)
        } else {
            (quantile(&mut rel, 0.5), quantile(&mut rel, 0.99))
        };
        match out.iter_mut().find(|b| b.wavelength_nm == layer.wavelength_nm) {
            Some(b) => {
                b.median = b.median.max(median);
                b.p99 = b.p99.max(p99);
            }
            None => out.push(BandNoise {
                wavelength_nm: layer.wavelength_nm,
                median,
                p99,
            }),
        }
    }
    out
}

/// The factor on the samples that brings every band to the target.
pub fn samples_factor(noise: &[BandNoise]) -> f64 {
    noise
        .iter()
        .map(|b| (b.median / TARGET_MEDIAN).max(b.p99 / TARGET_P99).powi(2))
        .fold(0.0, f64::max)
}

/// The tasks of `job` whose name contains one of `patterns` (all of them
/// for none); a pattern that matches no task is an error naming the
/// tasks there are.
pub fn select_tasks<'a>(job: &'a Job, patterns: &[String]) -> Result<Vec<&'a Task>> {
    if let Some(p) = patterns
        .iter()
        .find(|p| !job.tasks.iter().any(|t| t.name.contains(p.as_str())))
    {
        let names: Vec<&str> = job.tasks.iter().map(|t| t.name.as_str()).collect();
        return Err(Error::InvalidValue {
            file: "<command line>".into(),
            key: "--task".into(),
            value: format!("{p:?}"),
            reason: "matches no task of the benchmark".into(),
            valid: format!("a part of a task's name: {}", names.join(", ")),
        });
    }
    Ok(job
        .tasks
        .iter()
        .filter(|t| patterns.is_empty() || patterns.iter().any(|p| t.name.contains(p.as_str())))
        .collect())
}

/// Renders the subset on the current rayon pool (its tasks whose name
/// contains one of `patterns`, all for none), to the benchmark's noise
/// target or with `fixed` samples per pixel, with render seed `seed`, and
/// writes the report; returns the mean and largest core-hours per task.
pub fn run(quick: bool, fixed: Option<u64>, seed: u64, patterns: &[String], out: &mut dyn Write) -> Result<(f64, f64)> {
    let samples = match fixed {
        Some(n) => format!("samples = {n}"),
        None => target_keys(),
    };
    let text = job_text(quick, &samples, seed);
    let job = Job::parse(&text, "<grid benchmark>", std::path::Path::new("."))?;
    let tasks = select_tasks(&job, patterns)?;
    let Sensor::Image(camera) = &job.render.sensor else {
        return Err(Error::data("<grid benchmark>", "the benchmark renders images"));
    };
    let threads = rayon::current_num_threads() as f64;
    let io = |e: std::io::Error| Error::io(std::path::Path::new("<stdout>"), e);
    let how = match fixed {
        Some(n) => format!("{n} samples per pixel"),
        None => format!(
            "a noise target of {BENCH_TARGET} in every albedo above 0 (pilot {BENCH_PILOT}, at most {BENCH_MAX_SAMPLES} samples per pixel)"
        ),
    };
    writeln!(
        out,
        "grid benchmark: {} tasks, 64x32 full-sphere images to {how}, 11 bands of 40 nm, albedos 0 0.3 0.6 1, \
         seed {seed}, {threads} threads; relative standard error of I per pixel, worst albedo > 0",
        tasks.len()
    )
    .map_err(io)?;
    let mut hours = Vec::new();
    for task in tasks {
        let start = Instant::now();
        let (layout, state) = render_whole(&job, task, &|_| {}, &|_| {})?;
        let core_seconds = start.elapsed().as_secs_f64() * threads;
        let image = image_result(&job, camera, &layout, &state);
        // The pixels with samples of their own: those that share the
        // ground view (below an observer on the ground, each at a quarter
        // of the target) would lower the median without a path traced.
        let noise = band_noise(&image, layout.traced_rows);
        let factor = samples_factor(&noise);
        let (pilot, allocated) = layout.paths_by_stage(Shard::WHOLE);
        let pilot_share = pilot as f64 / (pilot + allocated).max(1) as f64;
        let traced = layout.active.as_ref().map_or(1, |a| a.count().max(1));
        let scale = full_size_traced(task, layout.symmetry) / traced as f64;
        let h = core_seconds * ((1.0 - pilot_share) * factor + pilot_share) * scale / 3600.0;
        hours.push(h);
        let bands: Vec<String> = noise
            .iter()
            .map(|b| format!("{:.0}: {:.3}/{:.3}", b.wavelength_nm, b.median, b.p99))
            .collect();
        writeln!(
            out,
            "{}: {core_seconds:.1} core-s ({:.0} % pilot), {:.0} paths per pixel; median/p99 by band {}; to target \
             x{factor:.0} samples: {h:.1} core-hours at 1024x512",
            task.name,
            100.0 * pilot_share,
            allocated as f64 / traced as f64,
            bands.join(", ")
        )
        .map_err(io)?;
    }
    let mean = hours.iter().sum::<f64>() / hours.len().max(1) as f64;
    let max = hours.iter().copied().fold(0.0, f64::max);
    writeln!(out, "grid_core_hours_per_task: {mean:.1} {max:.1}").map_err(io)?;
    Ok((mean, max))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::image::ImageLayer;

    #[test]
    fn the_factor_brings_the_worst_band_and_albedo_to_the_target() {
        // Two albedos of one band: the worse sets it (albedo 0 is left
        // out); a median of 1 % needs 4× the samples, a 99th percentile
        // (nearest rank: index round(99·0.99) = 98 of 100) of 6 % needs 9×.
        let layer = |albedo: f64, rel: &[f64]| ImageLayer {
            wavelength_nm: 340.0,
            albedo,
            mean: [vec![1.0; rel.len()], vec![], vec![], vec![]],
            se: [rel.to_vec(), vec![], vec![], vec![]],
            non_finite: 0,
        };
        let mut rel = vec![0.01; 100];
        rel[98] = 0.06;
        rel[99] = 0.06;
        let image = SkyImage {
            samples: Vec::new(),
            width: 10,
            height: 10,
            layers: vec![layer(0.0, &[9.0; 100]), layer(0.3, &vec![0.001; 100]), layer(1.0, &rel)],
        };
        let noise = band_noise(&image, 10);
        assert_eq!(noise.len(), 1);
        assert_eq!((noise[0].median, noise[0].p99), (0.01, 0.06));
        assert!((samples_factor(&noise) - 9.0).abs() < 1e-12);
        let job = Job::parse(&job_text(true, "samples = 4", 1), "t", std::path::Path::new(".")).unwrap();
        assert_eq!(job.tasks.len(), 3);
        let job = Job::parse(
            &job_text(false, "noise_target = 0.1", 1),
            "t",
            std::path::Path::new("."),
        )
        .unwrap();
        assert_eq!(job.tasks.len(), 24);
    }

    #[test]
    fn the_example_job_is_the_benchmarks_own() {
        // examples/grid_bench.toml, its comments left out, line for line
        // the job `bench --grid` renders at seed 1, so that rendering it
        // gives the benchmark's images.
        let example = include_str!("../../examples/grid_bench.toml");
        let lines: Vec<&str> = example.lines().filter(|l| !l.starts_with('#')).collect();
        let own = job_text(false, &target_keys(), 1);
        assert_eq!(lines, own.lines().collect::<Vec<_>>());
    }

    #[test]
    fn the_full_size_image_traces_what_its_symmetry_leaves() {
        // From the ground the rows above the horizon (256 of 512), from
        // 15 km all of them; the mirror half of the 1024 columns, or one.
        let job = Job::parse(&job_text(false, "samples = 4", 1), "t", std::path::Path::new(".")).unwrap();
        let task = |name: &str| job.tasks.iter().find(|t| t.name == name).unwrap();
        let ground = task("vis020.0_elev+10.0_alt00000m");
        let high = task("vis020.0_elev+10.0_alt15000m");
        assert_eq!(full_size_traced(ground, Symmetry::Mirror), 512.0 * 256.0);
        assert_eq!(full_size_traced(high, Symmetry::Mirror), 512.0 * 512.0);
        assert_eq!(full_size_traced(high, Symmetry::None), 1024.0 * 512.0);
        assert_eq!(full_size_traced(ground, Symmetry::Rotation), 256.0);
    }
}
