//! `atmosim bench`: the throughput reference case of the transport and
//! throughput issues, rendered and timed. US-standard Rayleigh only (no
//! ozone, no aerosol), spherical R = 6378 km, top 100 km, observer at 1 m,
//! sun zenith 30°, Lambertian albedo 0.3, polarised, 12 directions (view
//! zenith 0, 30, 60, 78.46° × azimuth 0, 90, 180), 550 nm.
//!
//! `--ratios` adds, each measured in the same run on the same pool, the
//! throughput issue's ratios: four albedos against one; eleven wavelengths
//! (320–760 nm by 44) and eleven 40 nm bands from 320 nm along shared
//! paths against 550 nm alone at the same path count, with the relative
//! standard errors of the first and last channels against dedicated runs
//! of those channels alone scaled to equal time; the first vertex split
//! (the default) against an analog first vertex, cost and variance; every
//! flight analog too (no forced collisions: the estimator of a generic
//! volumetric path tracer), its throughput and its time × variance
//! against the default; and the throughput of the pool against one thread.

use std::io::{self, Write};
use std::path::Path;
use std::time::Instant;

use crate::error::Result;
use crate::film::directions::{render_directions, render_directions_all};
use crate::film::tally::Tally;
use crate::job::Job;
use crate::sampling::stream::Render;

/// The reference case as a job file (also `examples/throughput_reference.toml`).
pub const REFERENCE_JOB: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/throughput_reference.toml"
));

/// Renders the reference case with `samples` paths per direction on the
/// current rayon pool and writes the report; the last line is
/// `paths_per_second_per_core: <number>`.
pub fn run(samples: u64, out: &mut dyn Write) -> Result<f64> {
    let job = Job::parse(REFERENCE_JOB, "throughput_reference.toml", Path::new("."))?;
    let scene = job.scene(0);
    let directions = job.render.directions();
    let threads = rayon::current_num_threads();
    // A short warm-up (page faults, thread start) outside the timing.
    render_directions(
        &scene,
        job.observer_altitude_km,
        directions,
        256,
        7,
        Render::channel(0, 7),
    );
    let start = Instant::now();
    let tallies = render_directions(
        &scene,
        job.observer_altitude_km,
        directions,
        samples,
        job.render.seed,
        Render::channel(0, 0),
    );
    let secs = start.elapsed().as_secs_f64();
    let paths = samples * directions.len() as u64;
    let per_core = paths as f64 / secs / threads as f64;
    writeln!(
        out,
        "# reference case: US-standard Rayleigh, 550 nm, spherical, sun zenith 30°, albedo 0.3, polarised"
    )
    .map_err(io)?;
    writeln!(out, "view_zenith_deg,azimuth_deg,I,I_rel_se,Q_rel_se_of_I").map_err(io)?;
    for (d, t) in directions.iter().zip(&tallies) {
        let (m, se) = (t.mean(), t.standard_error());
        writeln!(
            out,
            "{},{},{:.6e},{:.3e},{:.3e}",
            d.view_zenith_deg,
            d.azimuth_deg,
            m[0],
            se[0] / m[0],
            se[1] / m[0]
        )
        .map_err(io)?;
    }
    writeln!(out, "threads: {threads}").map_err(io)?;
    writeln!(out, "paths: {paths} in {secs:.3} s").map_err(io)?;
    writeln!(out, "paths_per_second_per_core: {per_core:.0}").map_err(io)?;
    Ok(per_core)
}

/// The reference job with its spectrum (and band widths) and albedos
/// replaced.
fn variant(wavelengths: &str, albedos: &str) -> Result<Job> {
    let text = REFERENCE_JOB
        .replace("wavelengths_nm = [550.0]", &format!("wavelengths_nm = [{wavelengths}]"))
        .replace("albedo = 0.3", &format!("albedo = {albedos}"));
    Job::parse(&text, "throughput_reference.toml", Path::new("."))
}

/// A spectrum of the reference case: `[spectrum]` values and a name.
struct SharedCase {
    what: &'static str,
    wavelengths: Vec<f64>,
    band_width_nm: f64,
}

impl SharedCase {
    /// The `wavelengths_nm` value (and `band_width_nm` line) of channels
    /// `channels`.
    fn keys(&self, channels: &[f64]) -> String {
        let list = channels
            .iter()
            .map(|l| format!("{l:.1}"))
            .collect::<Vec<_>>()
            .join(", ");
        format!(
            "{list}]\nband_width_nm = [{}",
            vec![format!("{:.1}", self.band_width_nm); channels.len()].join(", ")
        )
    }

    fn label(&self, lambda: f64) -> String {
        if self.band_width_nm > 0.0 {
            let h = 0.5 * self.band_width_nm;
            format!("{:.0}–{:.0} nm band", lambda - h, lambda + h)
        } else {
            format!("{lambda:.1} nm")
        }
    }
}

/// Renders `spectrum` along shared paths and reports its cost against
/// `t_one` (550 nm alone, same path count) and the relative standard
/// errors of its first and last channels against dedicated runs of those
/// channels alone, scaled to the shared run's time.
fn shared_ratios(spectrum: &SharedCase, samples: u64, t_one: f64, out: &mut dyn Write) -> Result<()> {
    let seed = 1;
    let job = variant(&spectrum.keys(&spectrum.wavelengths), "0.3")?;
    let (dirs, alt) = (job.render.directions(), job.observer_altitude_km);
    let shared = job
        .spectral_scene(&job.tasks[0])
        .expect("the reference atmosphere is piecewise constant");
    let (t_shared, tallies) = timed(|| render_directions_all(&shared, alt, dirs, samples, seed, Render::channel(0, 0)));
    writeln!(
        out,
        "{} along shared paths: {t_shared:.3} s, cost ratio {:.3} to 550 nm alone",
        spectrum.what,
        t_shared / t_one
    )
    .map_err(io)?;
    let last = spectrum.wavelengths.len() - 1;
    for index in [0, last] {
        let lambda = spectrum.wavelengths[index];
        let alone = variant(&spectrum.keys(&[lambda]), "0.3")?;
        let (t, dedicated) =
            timed(|| render_directions(&alone.scene(0), alt, dirs, samples, seed, Render::channel(0, 0)));
        let dedicated_se = mean_rel_se(&dedicated);
        let shared_se = mean_rel_se(&tallies[index][0]);
        // A dedicated run of the shared run's time: its error scales as 1/√time.
        let equal_time = dedicated_se * (t / t_shared).sqrt();
        writeln!(
            out,
            "{}: shared relative standard error {shared_se:.3e}; dedicated run {t:.3} s, {dedicated_se:.3e}, at the shared run's time {equal_time:.3e}; ratio {:.3}",
            spectrum.label(lambda),
            shared_se / equal_time
        )
        .map_err(io)?;
    }
    Ok(())
}

/// Mean over the directions of (a's standard error / b's)² for Stokes
/// component `s`.
fn variance_ratio(a: &[Tally], b: &[Tally], s: usize) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a.standard_error()[s] / b.standard_error()[s]).powi(2))
        .sum::<f64>()
        / a.len() as f64
}

/// Mean over directions of the relative standard error of I.
fn mean_rel_se(tallies: &[Tally]) -> f64 {
    tallies.iter().map(|t| t.standard_error()[0] / t.mean()[0]).sum::<f64>() / tallies.len() as f64
}

/// Times `f` (seconds) and returns its value.
fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let start = Instant::now();
    let value = f();
    (start.elapsed().as_secs_f64(), value)
}

/// The throughput issue's ratios on the reference case, `samples` paths per
/// direction (each configuration rendered once, on the current pool; the
/// one-thread figure on `serial`, a pool of one thread).
pub fn ratios(samples: u64, serial: &rayon::ThreadPool, out: &mut dyn Write) -> Result<()> {
    let seed = 1;
    let threads = rayon::current_num_threads();
    let single = variant("550.0", "0.3")?;
    let dirs = single.render.directions();
    let alt = single.observer_altitude_km;
    let scene = single.scene(0);
    render_directions(&scene, alt, dirs, 256, 7, Render::channel(0, 7));
    let (t_one, split) = timed(|| render_directions(&scene, alt, dirs, samples, seed, Render::channel(0, 0)));
    let albedos = variant("550.0", "[0.0, 0.3, 0.6, 1.0]")?;
    let scene4 = albedos.scene(0);
    let (t_four, _) = timed(|| render_directions_all(&scene4, alt, dirs, samples, seed, Render::channel(0, 0)));
    let paths = samples * dirs.len() as u64;
    writeln!(
        out,
        "# ratios on the reference case, {paths} paths each, {threads} threads"
    )
    .map_err(io)?;
    writeln!(out, "one albedo (0.3): {t_one:.3} s").map_err(io)?;
    writeln!(
        out,
        "four albedos (0, 0.3, 0.6, 1) from the same paths: {t_four:.3} s, cost ratio {:.3}",
        t_four / t_one
    )
    .map_err(io)?;
    let spectra = [
        SharedCase {
            what: "eleven wavelengths (320 to 760 nm by 44)",
            wavelengths: (0..11).map(|k| 320.0 + 44.0 * k as f64).collect(),
            band_width_nm: 0.0,
        },
        SharedCase {
            what: "eleven bands of 40 nm from 320 nm",
            wavelengths: (0..11).map(|k| 340.0 + 40.0 * k as f64).collect(),
            band_width_nm: 40.0,
        },
    ];
    for spectrum in &spectra {
        shared_ratios(spectrum, samples, t_one, out)?;
    }
    // The same case with extra [render] keys, rendered and timed.
    let with_keys = |keys: &str| -> Result<(f64, Vec<Tally>)> {
        let job = Job::parse(
            &REFERENCE_JOB.replace("polarized = true", &format!("polarized = true\n{keys}")),
            "throughput_reference.toml",
            Path::new("."),
        )?;
        let scene = job.scene(0);
        Ok(timed(|| {
            render_directions(&scene, alt, dirs, samples, seed, Render::channel(0, 0))
        }))
    };
    let (t_analog, unsplit) = with_keys("first_vertex_splitting = false")?;
    writeln!(
        out,
        "analog first vertex: {t_analog:.3} s; split/analog cost ratio {:.3}, variance ratio (mean over directions) I {:.3}, Q {:.3}, U {:.3}",
        t_one / t_analog,
        variance_ratio(&split, &unsplit, 0),
        variance_ratio(&split, &unsplit, 1),
        variance_ratio(&split, &unsplit, 2)
    )
    .map_err(io)?;
    // The estimator of a generic volumetric path tracer: every flight
    // analog (a collision or the path's end, by chance), no split.
    let (t_free, free) = with_keys("first_vertex_splitting = false\nforced_collisions = false")?;
    let efficiency = |s: usize| variance_ratio(&free, &split, s) * t_free / t_one;
    writeln!(
        out,
        "analog flights (forced_collisions = false, first_vertex_splitting = false): {t_free:.3} s, {:.0} paths/s per core; time × variance against the default (mean over directions) I {:.2}, Q {:.2}, U {:.2}",
        paths as f64 / t_free / threads as f64,
        efficiency(0),
        efficiency(1),
        efficiency(2)
    )
    .map_err(io)?;
    fine_profile_ratios(samples, (t_one, &split), out)?;
    let (t_serial, _) =
        serial.install(|| timed(|| render_directions(&scene, alt, dirs, samples, seed, Render::channel(0, 0))));
    writeln!(
        out,
        "one thread: {t_serial:.3} s; {threads} threads vs 1: throughput ratio {:.3}",
        t_serial / t_one
    )
    .map_err(io)?;
    Ok(())
}

/// The reference case over a fine profile: US standard every 100 m to the
/// top (1000 layers, from `GasProfile::resampled`, in a temporary file),
/// tracked through its own layers and through merged ones (`render.
/// tracking_layers`), each against the 45-level profile (`t_one`, `split`:
/// its time and tallies at the same path count).
fn fine_profile_ratios(samples: u64, (t_one, coarse): (f64, &[Tally]), out: &mut dyn Write) -> Result<()> {
    let profile = crate::physics::profile::GasProfile::builtin("us_standard")
        .expect("a built-in profile")?
        .resampled(0.1, 100.0);
    let dir = std::env::temp_dir().join(format!("atmosim-bench-{}", std::process::id()));
    let file = dir.join("us_standard_100m.dat");
    std::fs::create_dir_all(&dir).map_err(|e| crate::error::Error::io(&dir, e))?;
    let written = std::fs::write(&file, profile.to_afgl_text()).map_err(|e| crate::error::Error::io(&file, e));
    let jobs = written.and_then(|()| {
        let text = REFERENCE_JOB.replace(
            "profile = \"us_standard\"",
            &format!("profile_file = {:?}", file.display().to_string()),
        );
        let job = |layers: &str| {
            let text = text.replace(
                "polarized = true",
                &format!("polarized = true\ntracking_layers = \"{layers}\""),
            );
            Job::parse(&text, "throughput_reference.toml", Path::new("."))
        };
        Ok((job("profile")?, job("merged")?))
    });
    let _ = std::fs::remove_dir_all(&dir);
    let (own, merged) = jobs?;
    let (dirs, alt) = (own.render.directions(), own.observer_altitude_km);
    let coarse_layers = Job::parse(REFERENCE_JOB, "throughput_reference.toml", Path::new("."))?
        .scene(0)
        .levels_km()
        .len()
        - 1;
    for job in [&own, &merged] {
        let scene = job.scene(0);
        let what = match scene.tracked_layers() {
            n if n == profile.layer_count() => "its own layers".to_string(),
            n => format!("{n} merged layers"),
        };
        let (t, tallies) = timed(|| render_directions(&scene, alt, dirs, samples, 1, Render::channel(0, 0)));
        writeln!(
            out,
            "fine profile (US standard every 100 m, {} layers) through {what}: {t:.3} s, cost ratio {:.3} to the {}-layer profile; time × variance against it (mean over directions) I {:.2}, Q {:.2}, U {:.2}",
            profile.layer_count(),
            t / t_one,
            coarse_layers,
            t / t_one * variance_ratio(&tallies, coarse, 0),
            t / t_one * variance_ratio(&tallies, coarse, 1),
            t / t_one * variance_ratio(&tallies, coarse, 2)
        )
        .map_err(io)?;
    }
    Ok(())
}

/// A failed write of the report.
pub(super) fn io(e: io::Error) -> crate::error::Error {
    crate::error::Error::io("stdout", e)
}
