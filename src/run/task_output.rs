//! A finished task's files, from its sums: `radiance.csv` and `fluxes.csv`
//! for a `directions` sensor, `image.exr` and the previews for an image,
//! `noise.csv` with a noise target, then `task.toml` (the task's metadata: job hash, samples, non-finite
//! samples, shards), written last. Every file is written atomically, and a
//! task counts as complete only when its `task.toml` names the same job
//! hash, so a crash at any point never leaves a task that looks complete.
//! Every file is a function of the job and its sums alone (no times, thread
//! counts or dates), so the same job gives the same bytes on every run.

use std::path::Path;

use crate::error::Result;
use crate::io::atomic::write_atomic;
use crate::io::output::{self};
use crate::io::sky_image;
use crate::io::sun_table::{SUN_FILE, sun_csv};
use crate::job::{Job, Sensor, Task};
use crate::run::layout::{Layout, UnitState};

/// The metadata file of a task.
pub const TASK_FILE: &str = "task.toml";
/// The noise a task with a noise target reached, per channel and albedo.
pub const NOISE_FILE: &str = "noise.csv";

/// How the sums were made, for the metadata (only what the results
/// depend on: the wall time and thread count go to the log, not the files).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunInfo {
    /// Shards merged (1: rendered in one unit).
    pub shards: u64,
}

/// Writes the task's files into `dir`; returns a note for the log (the
/// preview exposure of an image).
pub fn write(dir: &Path, job: &Job, task: &Task, layout: &Layout, state: &UnitState, info: RunInfo) -> Result<String> {
    let non_finite = state.non_finite(layout);
    let note = match &job.render.sensor {
        Sensor::Directions(_) => {
            let result = crate::run::assemble::directions_result(job, task, layout, state);
            write_atomic(
                &dir.join("radiance.csv"),
                output::radiance_csv(&result.radiance).as_bytes(),
            )?;
            if !result.fluxes.is_empty() {
                write_atomic(&dir.join("fluxes.csv"), output::flux_csv(&result.fluxes).as_bytes())?;
            }
            if job.render.output_sun {
                write_atomic(&dir.join(SUN_FILE), sun_csv(job, task, None).as_bytes())?;
            }
            String::new()
        }
        Sensor::Image(camera) => {
            let image = crate::run::assemble::image_result(job, camera, layout, state);
            sky_image::write(dir, job, task, camera, &image)?
                .map_or(String::new(), |e| format!(" (preview exposure {e:.4e})"))
        }
    };
    if job.render.target.is_some() {
        let noise = crate::run::assemble::noise(job, layout, state);
        write_atomic(&dir.join(NOISE_FILE), output::noise_csv(&noise).as_bytes())?;
    }
    write_atomic(
        &dir.join(TASK_FILE),
        metadata(job, task, layout, non_finite, info).as_bytes(),
    )?;
    Ok(note)
}

/// True when `dir` holds this task of the same job, complete.
pub fn is_complete(dir: &Path, job: &Job) -> bool {
    job_hash_of(dir).is_some_and(|h| h == job.hash)
}

/// The job hash of the complete task in `dir` (its `task.toml`), if any.
pub fn job_hash_of(dir: &Path) -> Option<String> {
    let text = std::fs::read_to_string(dir.join(TASK_FILE)).ok()?;
    text.lines().find_map(|l| {
        let v = l.trim().strip_prefix("job_hash = ")?;
        Some(v.trim_matches('"').to_string())
    })
}

fn metadata(job: &Job, task: &Task, layout: &Layout, non_finite: u64, info: RunInfo) -> String {
    let quote = |s: &str| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""));
    let mut s = String::from("# atmosim task metadata, written after every other file of the task\n");
    let mut put = |k: &str, v: String| s.push_str(&format!("{k} = {v}\n"));
    put("atmosim_version", quote(env!("CARGO_PKG_VERSION")));
    put("job_hash", quote(&job.hash));
    put("job_file", quote(&job.file));
    put("task", quote(&task.name));
    put("task_index", task.index.to_string());
    match job.render.target {
        None => put("samples", job.render.samples.to_string()),
        Some(t) => {
            put("noise_target", format!("{:?}", t.relative_se));
            put("pilot_samples", t.pilot.to_string());
            put("max_samples", t.max_samples.to_string());
            put("noise_target_albedos", quote(t.albedos.key_value()));
            put("noise_target_per", quote(t.per.key_value()));
        }
    }
    put("paths", layout.paths(crate::run::shard::Shard::WHOLE).to_string());
    put("non_finite_samples", non_finite.to_string());
    put("shards", info.shards.to_string());
    put("shared_wavelengths", layout.shared.to_string());
    let list = |v: &[f64]| {
        format!(
            "[{}]",
            v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ")
        )
    };
    put("wavelengths_nm", list(&job.wavelengths_nm));
    // Each channel's full band width (0: one wavelength): a band's values
    // are the radiance averaged uniformly over [λ − w/2, λ + w/2].
    put("band_width_nm", list(&job.band_widths_nm));
    // The units of radiance.csv, fluxes.csv and the image.
    put(
        "units",
        quote(if job.solar.is_some() {
            "absolute: W m-2 sr-1 nm-1 (fluxes W m-2 nm-1), Kurucz 1992 extraterrestrial irradiance"
        } else {
            "normalized: per unit extraterrestrial solar irradiance (E0 = 1)"
        }),
    );
    s
}
