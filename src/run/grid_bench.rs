//! `atmosim bench --grid`: what the sky model's grid costs. A representative
//! subset of `examples/sky_model_grid.toml` (sun elevation −4.2, −1, 2,
//! 10, 45 and 90°, visibility 20 and 131.8 km, observers at 0 and 15 km;
//! `--quick`: −1, 10 and 90°, 20 km, the ground), rendered as 64×32
//! full-sphere images with everything else as that job states it (its
//! bands, albedos, polarisation, atmosphere and its noise target), and
//! priced at the job's own resolution.
//!
//! The grid's target is one for each image as a whole
//! (`render.noise_target_per = "image"`): its allocation gives a pixel the
//! same samples at any resolution (n_k = λ·σ_k·√Ω_k with λ ∝ Σ √Ω·σ, so
//! n_k ∝ σ_k²·Ω_k·N, and Ω_k·N is fixed), so a finer image of the same
//! task costs in proportion to the pixels it traces, pilot included:
//!
//! core-hours = core-seconds × P_grid / P_64×32 / 3600,
//!
//! P the pixels an image of that size traces (`sensor.symmetry` "auto":
//! the left half, the mirror; with the sun at the zenith one column; an
//! observer on the ground traces the rows above the horizon). That holds
//! where a pixel's per-sample deviation does not depend on its size; a
//! coarse pixel varies more inside, so the figure errs high. Core-seconds
//! are wall time × the pool's threads: run it on an otherwise idle
//! machine. Per task it reports the core-seconds, the pilot's share, the
//! mean samples per traced pixel and per band the image's noise as a
//! whole reached, √(Σ Ω·se² / Σ Ω·I²), the worst over the albedos above 0.
//! The last line is `grid_core_hours_per_task: <mean> <max>`.
//!
//! `--samples N` renders every pixel with N samples instead (no pilot),
//! priced the same way. `--per-pixel` prices the former yardstick, a
//! relative standard error of I per pixel (median ≤ 0.5 %, 99th
//! percentile ≤ 2 % in every band and albedo above 0) at 1024×512, for
//! reference images rather than a sky model's renders: it renders to a
//! per-pixel target ten times looser, [`BENCH_TARGET`], and scales the
//! samples by the square of the ratio, as before 2026-11-29:
//!
//! core-hours = (allocated core-seconds × max_b max(median_b/0.005, p99_b/0.02)²
//!               + pilot core-seconds) × P_1024×512 / P_64×32 / 3600.
//!
//! The target is set so that pixels get thousands of paths: a path's
//! contribution is heavy-tailed (at twilight the paths that carry most of
//! the variance are rarer than one in a thousand), and an estimate of a
//! pixel's variance from a few dozen paths falls short of the variance
//! itself, so a looser target understated the cost (docs/noise-targets.md,
//! heavy tails).

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

/// The former per-pixel yardstick: median and 99th percentile of the
/// per-pixel relative standard error of I.
pub const TARGET_MEDIAN: f64 = 0.005;
pub const TARGET_P99: f64 = 0.02;

/// The full-size image the per-pixel yardstick is scaled to.
const PER_PIXEL_SIZE: [usize; 2] = [1024, 512];

/// The sky model's grid as shipped: the job `bench --grid` prices.
pub const GRID_JOB: &str = include_str!("../../examples/sky_model_grid.toml");

/// The size the benchmark renders at.
const BENCH_SIZE: [usize; 2] = [64, 32];

/// How the benchmark sets each pixel's samples (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// The grid job's own noise target, priced at its resolution.
    Grid,
    /// A fixed count per pixel, priced at the grid job's resolution.
    Fixed(u64),
    /// The former yardstick: each pixel's relative error, at 1024×512.
    PerPixel,
}

/// The pixels a `size` sphere image of `task` traces with `symmetry`: half
/// of them with the mirror (the rows above the horizon alone for an
/// observer on the ground), one column's with the rotation.
fn traced_at(size: [usize; 2], task: &Task, symmetry: Symmetry) -> f64 {
    let camera = Camera::Sphere {
        width: size[0],
        height: size[1],
    };
    let rows = ground_view::traced_rows(&camera, task);
    ActivePixels::new(&camera, rows, symmetry.traced_columns(size[0])).count() as f64
}

/// The subset's sun elevations, visibilities and observer altitudes.
fn subset(quick: bool) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    if quick {
        (vec![-1.0, 10.0, 90.0], vec![20.0], vec![0.0])
    } else {
        (
            vec![-4.2, -1.0, 2.0, 10.0, 45.0, 90.0],
            vec![20.0, 131.8],
            vec![0.0, 15.0],
        )
    }
}

/// The benchmark's job in `Grid` or `Fixed` mode: the grid job with the
/// subset's axes, 64×32 images and render seed `seed`; with
/// fixed samples its noise target's keys give way to `samples`.
pub fn grid_job_text(quick: bool, mode: Mode, seed: u64) -> Result<String> {
    let bad = |what: &str| Error::data("examples/sky_model_grid.toml", what.to_string());
    let mut job: toml::Table = toml::from_str(GRID_JOB).map_err(|e| bad(&e.to_string()))?;
    let (suns, vis, obs) = subset(quick);
    let list = |v: &[f64]| toml::Value::Array(v.iter().map(|&x| toml::Value::Float(x)).collect());
    let size = toml::Value::Array(BENCH_SIZE.iter().map(|&n| toml::Value::Integer(n as i64)).collect());
    for (section, key, value) in [
        ("atmosphere", "visibility_km", list(&vis)),
        ("sun", "elevation_deg", list(&suns)),
        ("observer", "altitude_km", list(&obs)),
        ("sensor", "resolution", size),
        ("render", "seed", toml::Value::Integer(seed as i64)),
    ] {
        job.get_mut(section)
            .and_then(|t| t.as_table_mut())
            .ok_or_else(|| bad(&format!("no [{section}]")))?
            .insert(key.to_string(), value);
    }
    if let Mode::Fixed(n) = mode {
        let render = job
            .get_mut("render")
            .and_then(|t| t.as_table_mut())
            .ok_or_else(|| bad("no [render]"))?;
        for key in [
            "noise_target",
            "noise_target_per",
            "noise_target_albedos",
            "pilot_samples",
            "max_samples",
        ] {
            render.remove(key);
        }
        render.insert("samples".into(), toml::Value::Integer(n as i64));
    }
    toml::to_string(&job).map_err(|e| bad(&e.to_string()))
}

/// The noise target the per-pixel yardstick renders to, its pilot and its
/// cap.
pub const BENCH_TARGET: f64 = 0.05;
const BENCH_PILOT: u64 = 64;
const BENCH_MAX_SAMPLES: u64 = 16384;

/// The `[render]` keys of the per-pixel yardstick's noise target.
pub fn target_keys() -> String {
    format!(
        "noise_target = {BENCH_TARGET}\npilot_samples = {BENCH_PILOT}\nmax_samples = {BENCH_MAX_SAMPLES}\n\
         noise_target_albedos = \"above_zero\""
    )
}

/// The per-pixel yardstick's job: the subset (or the quick one) at
/// `samples` (the `[render]` keys of its sample count), rendered with
/// `seed`.
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

/// Per band, an image's noise as a whole, √(Σ Ω·se² / Σ Ω·I²) over its
/// pixels, the worst over the albedos above 0: (wavelength, noise).
pub fn image_noise(image: &SkyImage, camera: &Camera) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let width = image.width.max(1);
    for layer in image.layers.iter().filter(|l| l.albedo > 0.0) {
        let (mut noise, mut signal) = (0.0, 0.0);
        for (p, (m, se)) in layer.mean[0].iter().zip(&layer.se[0]).enumerate() {
            let w = camera.pixel_solid_angle(p % width, p / width);
            noise += w * se * se;
            signal += w * m * m;
        }
        let rel = if signal > 0.0 { (noise / signal).sqrt() } else { 0.0 };
        match out.iter_mut().find(|b| b.0 == layer.wavelength_nm) {
            Some(b) => b.1 = b.1.max(rel),
            None => out.push((layer.wavelength_nm, rel)),
        }
    }
    out
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
/// contains one of `patterns`, all for none) in `mode` with render seed
/// `seed`, and writes the report; returns the mean and largest core-hours
/// per task.
pub fn run(quick: bool, mode: Mode, seed: u64, patterns: &[String], out: &mut dyn Write) -> Result<(f64, f64)> {
    let text = match mode {
        Mode::PerPixel => job_text(quick, &target_keys(), seed),
        Mode::Grid | Mode::Fixed(_) => grid_job_text(quick, mode, seed)?,
    };
    let job = Job::parse(&text, "<grid benchmark>", std::path::Path::new("."))?;
    let grid = Job::parse(GRID_JOB, "examples/sky_model_grid.toml", std::path::Path::new("."))?;
    let full_size = match (mode, &grid.render.sensor) {
        (Mode::PerPixel, _) => PER_PIXEL_SIZE,
        (_, Sensor::Image(camera)) => {
            let (w, h) = camera.size();
            [w, h]
        }
        _ => return Err(Error::data("examples/sky_model_grid.toml", "the grid renders images")),
    };
    if mode == Mode::Grid && grid.render.target.is_none() {
        return Err(Error::data(
            "examples/sky_model_grid.toml",
            "the grid job states no noise target to price (bench --grid --samples N prices a fixed count)",
        ));
    }
    let tasks = select_tasks(&job, patterns)?;
    let Sensor::Image(camera) = &job.render.sensor else {
        return Err(Error::data("<grid benchmark>", "the benchmark renders images"));
    };
    let threads = rayon::current_num_threads() as f64;
    let io = |e: std::io::Error| Error::io(std::path::Path::new("<stdout>"), e);
    let how = match (mode, job.render.target) {
        (Mode::Fixed(n), _) => format!("{n} samples per pixel"),
        (Mode::PerPixel, _) => format!(
            "the per-pixel yardstick: a noise target of {BENCH_TARGET} per pixel in every albedo above 0 (pilot \
             {BENCH_PILOT}, at most {BENCH_MAX_SAMPLES} samples per pixel), scaled to a median of 0.5 % and a 99th \
             percentile of 2 %"
        ),
        (Mode::Grid, Some(t)) => format!(
            "the grid job's noise target, {} {} in {} (pilot {}, at most {} samples per pixel)",
            t.relative_se,
            t.per.describe(),
            t.albedos.describe(),
            t.pilot,
            t.max_samples
        ),
        (Mode::Grid, None) => String::new(),
    };
    writeln!(
        out,
        "grid benchmark: {} tasks, {}x{} full-sphere images to {how}, {} bands, albedos {}, seed {seed}, \
         {threads} threads; priced at {}x{}",
        tasks.len(),
        BENCH_SIZE[0],
        BENCH_SIZE[1],
        job.wavelengths_nm.len(),
        job.render
            .albedos
            .iter()
            .map(|a| format!("{a}"))
            .collect::<Vec<_>>()
            .join(" "),
        full_size[0],
        full_size[1]
    )
    .map_err(io)?;
    let mut hours = Vec::new();
    for task in tasks {
        let start = Instant::now();
        let (layout, state) = render_whole(&job, task, &|_| {}, &|_| {})?;
        let core_seconds = start.elapsed().as_secs_f64() * threads;
        let image = image_result(&job, camera, &layout, &state);
        let (pilot, allocated) = layout.paths_by_stage(Shard::WHOLE);
        let pilot_share = pilot as f64 / (pilot + allocated).max(1) as f64;
        let traced = layout.active.as_ref().map_or(1, |a| a.count().max(1));
        let scale = traced_at(full_size, task, layout.symmetry) / traced as f64;
        let per_pixel = allocated as f64 / traced as f64;
        let (h, noise) = match mode {
            Mode::PerPixel => {
                // The pixels with samples of their own: those that share
                // the ground view (below an observer on the ground, each at
                // a quarter of the target) would lower the median without a
                // path traced.
                let noise = band_noise(&image, layout.traced_rows);
                let factor = samples_factor(&noise);
                let h = core_seconds * ((1.0 - pilot_share) * factor + pilot_share) * scale / 3600.0;
                let bands: Vec<String> = noise
                    .iter()
                    .map(|b| format!("{:.0}: {:.3}/{:.3}", b.wavelength_nm, b.median, b.p99))
                    .collect();
                (
                    h,
                    format!(
                        "median/p99 by band {}; to target x{factor:.0} samples",
                        bands.join(", ")
                    ),
                )
            }
            Mode::Grid | Mode::Fixed(_) => {
                let bands: Vec<String> = image_noise(&image, camera)
                    .iter()
                    .map(|(w, n)| format!("{w:.0}: {n:.4}"))
                    .collect();
                (
                    core_seconds * scale / 3600.0,
                    format!("image noise by band {}", bands.join(", ")),
                )
            }
        };
        hours.push(h);
        writeln!(
            out,
            "{}: {core_seconds:.1} core-s ({:.0} % pilot), {per_pixel:.0} paths per pixel; {noise}: {h:.3} \
             core-hours at {}x{}",
            task.name,
            100.0 * pilot_share,
            full_size[0],
            full_size[1]
        )
        .map_err(io)?;
    }
    let mean = hours.iter().sum::<f64>() / hours.len().max(1) as f64;
    let max = hours.iter().copied().fold(0.0, f64::max);
    writeln!(out, "grid_core_hours_per_task: {mean:.3} {max:.3}").map_err(io)?;
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
        // examples/grid_bench.toml is the job `bench --grid` renders at seed
        // 1 (the same tables: keys, values; comments and order aside), so
        // that rendering it gives the benchmark's images (random streams
        // depend on the seed and the task, not on the job's text).
        let example: toml::Table = toml::from_str(include_str!("../../examples/grid_bench.toml")).unwrap();
        let mut own: toml::Table = toml::from_str(&grid_job_text(false, Mode::Grid, 1).unwrap()).unwrap();
        // The example writes its images somewhere.
        own.insert("output".into(), example["output"].clone());
        assert_eq!(example, own);
    }

    #[test]
    fn the_benchmarks_job_is_the_grid_job_on_the_subset() {
        // Every key of the grid job but the subset's axes, the size, the
        // seed and the output; a fixed count in place of the target.
        let grid: toml::Table = toml::from_str(GRID_JOB).unwrap();
        let bench: toml::Table = toml::from_str(&grid_job_text(false, Mode::Grid, 7).unwrap()).unwrap();
        for section in ["planet", "spectrum", "ground"] {
            assert_eq!(grid[section], bench[section], "[{section}]");
        }
        assert_eq!(bench["render"]["seed"].as_integer(), Some(7));
        assert_eq!(grid["render"]["noise_target"], bench["render"]["noise_target"]);
        assert_eq!(bench["sensor"]["resolution"].as_array().unwrap().len(), 2);
        let job = Job::parse(
            &grid_job_text(false, Mode::Grid, 1).unwrap(),
            "t",
            std::path::Path::new("."),
        )
        .unwrap();
        assert_eq!(job.tasks.len(), 24);
        let fixed = grid_job_text(true, Mode::Fixed(4), 1).unwrap();
        let job = Job::parse(&fixed, "t", std::path::Path::new(".")).unwrap();
        assert_eq!((job.tasks.len(), job.render.samples, job.render.target), (3, 4, None));
    }

    #[test]
    fn a_full_size_image_traces_what_its_symmetry_leaves() {
        // From the ground the rows above the horizon (256 of 512), from
        // 15 km all of them; the mirror half of the 1024 columns, or one.
        let job = Job::parse(&job_text(false, "samples = 4", 1), "t", std::path::Path::new(".")).unwrap();
        let task = |name: &str| job.tasks.iter().find(|t| t.name == name).unwrap();
        let ground = task("vis020.0_elev+10.0_alt00000m");
        let high = task("vis020.0_elev+10.0_alt15000m");
        let size = [1024, 512];
        assert_eq!(traced_at(size, ground, Symmetry::Mirror), 512.0 * 256.0);
        assert_eq!(traced_at(size, high, Symmetry::Mirror), 512.0 * 512.0);
        assert_eq!(traced_at(size, high, Symmetry::None), 1024.0 * 512.0);
        assert_eq!(traced_at(size, ground, Symmetry::Rotation), 256.0);
    }

    #[test]
    fn an_images_noise_is_its_rms_error_over_its_rms_radiance() {
        // Two pixels of a 2 × 1 sphere (equal solid angles): I 1 and 3, se
        // 0.1 and 0.3 → √((0.01 + 0.09) / (1 + 9)) = 0.1; albedo 0 left out.
        let layer = |albedo: f64, se: [f64; 2]| ImageLayer {
            wavelength_nm: 500.0,
            albedo,
            mean: [vec![1.0, 3.0], vec![], vec![], vec![]],
            se: [se.to_vec(), vec![], vec![], vec![]],
            non_finite: 0,
        };
        let image = SkyImage {
            samples: Vec::new(),
            width: 2,
            height: 1,
            layers: vec![layer(0.0, [9.0, 9.0]), layer(0.5, [0.1, 0.3])],
        };
        let camera = Camera::Sphere { width: 2, height: 1 };
        let noise = image_noise(&image, &camera);
        assert_eq!(noise.len(), 1);
        assert!((noise[0].1 - 0.1).abs() < 1e-12, "{noise:?}");
    }
}
