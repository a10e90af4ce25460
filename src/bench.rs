//! `atmosim bench`: the throughput reference case of the transport and
//! throughput issues, rendered and timed. US-standard Rayleigh only (no
//! ozone, no aerosol), spherical R = 6378 km, top 100 km, observer at 1 m,
//! sun zenith 30°, Lambertian albedo 0.3, polarised, 12 directions (view
//! zenith 0, 30, 60, 78.46° × azimuth 0, 90, 180), 550 nm.

use std::io::{self, Write};
use std::path::Path;
use std::time::Instant;

use crate::error::Result;
use crate::job::Job;
use crate::render::render_directions;

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
    render_directions(&scene, job.observer_altitude_km, directions, 256, 7, 7);
    let start = Instant::now();
    let tallies = render_directions(
        &scene,
        job.observer_altitude_km,
        directions,
        samples,
        job.render.seed,
        0,
    );
    let secs = start.elapsed().as_secs_f64();
    let paths = samples * directions.len() as u64;
    let per_core = paths as f64 / secs / threads as f64;
    let io = |e: io::Error| crate::error::Error::Io {
        path: "stdout".into(),
        source: e,
    };
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
