//! Rendering a whole `directions` task in one go, in the current thread pool.

/// Everything a `directions` render produces.
#[derive(Debug, Clone, Default)]
pub struct RenderResult {
    pub radiance: Vec<crate::io::output::RadianceRow>,
    pub fluxes: Vec<crate::io::output::FluxRow>,
}

/// Renders a `directions` sensor for every albedo and wavelength of one
/// task in one go (in the current rayon pool; see [`crate::run::work_unit`] for runs
/// that checkpoint), calling `log` with a line at the end.
pub fn render_task(job: &crate::job::Job, task: &crate::job::Task, log: &dyn Fn(&str)) -> RenderResult {
    use crate::run::shard::Shard;
    use crate::run::work_unit::{self, Control, Layout};
    let start = std::time::Instant::now();
    let shared = job.spectral_scene(task);
    let layout = Layout::new(job, task, shared.is_some());
    let mut state = layout.empty_state(job, task, Shard::WHOLE);
    let quiet = |_| {};
    // Without a stop flag or checkpoints a run always completes.
    let _ = work_unit::run(job, task, &layout, shared, &mut state, &Control::none(&quiet));
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
    work_unit::directions_result(job, task, &layout, &state)
}
