//! `atmosim plan`: the tasks of a job and what they cost, so a user can size
//! a cluster allocation before rendering. Cost = paths (pixels or
//! directions × samples × wavelengths × albedos, plus the flux estimates of
//! a directions sensor) over a throughput measured by a short single-thread
//! calibration render of the first task (its middle wavelength).

use std::io::{self, Write};
use std::time::Instant;

use crate::job::{Job, Sensor};
use crate::render::{Direction, render_directions};

/// Paths of one task.
pub fn task_paths(job: &Job) -> u64 {
    let spec = &job.render;
    let per_layer = match &spec.sensor {
        Sensor::Directions(d) => d.len() as u64 + if spec.fluxes { 2 } else { 0 },
        // Pixels outside a fisheye's circle cost nothing.
        Sensor::Image(camera) => crate::film::pixel_weights(camera).iter().filter(|w| **w > 0.0).count() as u64,
    };
    // All albedos share the paths.
    per_layer * spec.samples * job.wavelengths_nm.len() as u64
}

/// Paths per second on one core for the first task, from about 0.2 s of
/// rendering over directions spread on the sphere.
pub fn calibrate(job: &Job) -> f64 {
    let task = &job.tasks[0];
    let scene = job.scene_for(task, job.wavelengths_nm.len() / 2);
    let directions: Vec<Direction> = (0..16)
        .map(|k| Direction {
            view_zenith_deg: 5.0 + 170.0 * (k as f64 + 0.5) / 16.0,
            azimuth_deg: 45.0 * k as f64,
        })
        .collect();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build();
    let run = |n: u64| {
        let start = Instant::now();
        let work = || {
            render_directions(
                &scene,
                task.observer_altitude_km,
                &directions,
                n,
                job.render.seed,
                u64::MAX,
            )
        };
        match &pool {
            Ok(p) => p.install(work),
            Err(_) => work(),
        };
        (n * directions.len() as u64, start.elapsed().as_secs_f64())
    };
    let mut n = 64;
    loop {
        let (paths, secs) = run(n);
        if secs > 0.2 || n >= 1 << 20 {
            return paths as f64 / secs.max(1e-9);
        }
        n *= 4;
    }
}

/// Writes the plan: one line per task, then the totals.
pub fn write_plan(job: &Job, out: &mut dyn Write) -> io::Result<()> {
    let paths = task_paths(job);
    let rate = calibrate(job);
    let hours = paths as f64 / rate / 3600.0;
    let sensor = match &job.render.sensor {
        Sensor::Directions(d) => format!("{} directions", d.len()),
        Sensor::Image(c) => {
            let (w, h) = c.size();
            format!("{w}x{h} image")
        }
    };
    writeln!(
        out,
        "# {}: {} tasks; each {sensor}, {} wavelengths ({} albedos from the same paths) × {} samples",
        job.file,
        job.tasks.len(),
        job.wavelengths_nm.len(),
        job.render.albedos.len(),
        job.render.samples
    )?;
    writeln!(
        out,
        "# throughput from a calibration render of task 0: {rate:.0} paths/s per core"
    )?;
    writeln!(
        out,
        "task,name,visibility_km,sun_elevation_deg,observer_altitude_km,paths,core_hours"
    )?;
    for t in &job.tasks {
        writeln!(
            out,
            "{},{},{},{:.3},{},{paths},{hours:.4}",
            t.index,
            t.name,
            t.atmosphere
                .visibility
                .map_or("none".to_string(), |v| format!("{:.1}", v.ground_km)),
            90.0 - t.sun.zenith_deg,
            t.observer_altitude_km
        )?;
    }
    let total = paths as f64 * job.tasks.len() as f64;
    writeln!(
        out,
        "# total: {total:.3e} paths, {:.1} core-hours at the calibrated rate",
        hours * job.tasks.len() as f64
    )?;
    writeln!(
        out,
        "# (low suns and high observers have longer paths: treat the estimate as a guide)"
    )
}
