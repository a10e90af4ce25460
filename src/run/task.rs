//! Rendering one whole task in one go, in the current thread pool, without
//! checkpoints or a stop flag (`atmosim render` to stdout, the library's
//! callers and tests). Runs that checkpoint, resume or shard drive
//! [`work_unit::run`] themselves.

use std::time::Instant;

use crate::error::Result;
use crate::film::image::SkyImage;
use crate::film::results::RenderResult;
use crate::job::{Job, Task};
use crate::run::layout::{Layout, UnitState};
use crate::run::shard::Shard;
use crate::run::work_unit::{self, Control, Outcome};
use crate::sensor::camera::Camera;

/// Renders every estimate of `task` (all its wavelengths and albedos);
/// `progress(n)` is called with the paths traced, `log` once at the end
/// with the task's paths and rate.
pub fn render_whole(
    job: &Job,
    task: &Task,
    progress: &(dyn Fn(u64) + Sync),
    log: &dyn Fn(&str),
) -> Result<(Layout, UnitState)> {
    let start = Instant::now();
    let shared = job.spectral_scene(task);
    let mut layout = Layout::new(job, task, shared.is_some());
    let mut state = layout.empty_state(job, task, Shard::WHOLE);
    let outcome = work_unit::run(job, task, &mut layout, shared, &mut state, &Control::none(progress))?;
    debug_assert!(
        matches!(outcome, Outcome::Complete),
        "a run without a stop flag completes"
    );
    let paths = layout.paths(Shard::WHOLE);
    let secs = start.elapsed().as_secs_f64();
    log(&format!(
        "{}: {} wavelengths × {} albedos{}: {paths} paths in {secs:.2} s ({:.0} paths/s on {} threads)",
        task.name,
        job.wavelengths_nm.len(),
        job.render.albedos.len(),
        if layout.shared { " along shared paths" } else { "" },
        paths as f64 / secs,
        rayon::current_num_threads()
    ));
    if let Some(warning) = state.non_finite_warning(&layout, &task.name) {
        log(&warning);
    }
    Ok((layout, state))
}

/// Renders a task of a `directions` sensor: radiances and fluxes.
pub fn render_directions(job: &Job, task: &Task, log: &dyn Fn(&str)) -> Result<RenderResult> {
    let (layout, state) = render_whole(job, task, &|_| {}, log)?;
    Ok(crate::run::assemble::directions_result(job, task, &layout, &state))
}

/// Renders a task of an image sensor with `camera`: every (albedo,
/// wavelength) layer.
pub fn render_image(
    job: &Job,
    task: &Task,
    camera: &Camera,
    progress: &(dyn Fn(u64) + Sync),
    log: &dyn Fn(&str),
) -> Result<SkyImage> {
    let (layout, state) = render_whole(job, task, progress, log)?;
    Ok(crate::run::assemble::image_result(job, camera, &layout, &state))
}
