//! Builds a task's transmittance table from a job: the media per wavelength
//! (or the band scene of a banded job) that [`transmittance`] tracks through.

use crate::job::{Job, Task};
use crate::transport::medium::Medium;
use crate::transport::transmittance::{self, Table};

/// The transmittance table T(altitude, ground distance) from `task`'s
/// observer, all of the job's wavelengths at once: band averages over the
/// task's spectral scene for a banded job, else one [`Medium`] per
/// wavelength tracked by `job.transmittance`'s estimator (seeded by the
/// job's seed and the task's index). Runs on the current rayon pool.
pub fn transmittance_table(job: &Job, task: &Task) -> Table {
    if job.banded()
        && let Some(scene) = job.spectral_scene(task)
    {
        return transmittance::compute_bands(&job.transmittance, &scene, task.observer_altitude_km);
    }
    let media: Vec<Medium> = (0..job.wavelengths_nm.len())
        .map(|w| Medium::new(&task.atmosphere, w, job.render.medium, job.render.majorant_scale))
        .collect();
    transmittance::compute(
        &job.transmittance,
        &media,
        &job.geometry(),
        task.observer_altitude_km,
        job.render.seed,
        task.index as u64,
    )
}
