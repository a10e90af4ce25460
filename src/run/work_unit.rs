//! A work unit: one task of a job, or one shard of its samples (see
//! [`crate::run::shard`]), rendered in waves so that it can be checkpointed,
//! stopped (SIGTERM) and resumed, and whose sums add up with those of the
//! task's other shards.
//!
//! A task is a fixed list of *estimates* ([`Layout`]): per viewing direction
//! (all wavelengths along shared paths, or one wavelength), the downward and
//! upward fluxes per wavelength, or every pixel of an image. The state of a
//! unit ([`UnitState`]) is, per estimate, how much of the shard's sample
//! range is done and the running sums. Sums always grow in sample order
//! (sample blocks for directions, samples per pixel for images), so a run
//! stopped after any wave and resumed from its checkpoint gives bit for bit
//! the sums of an uninterrupted run. Shards of a task are summed in shard
//! order by [`crate::run::merge`]; that regrouping of the same additions changes
//! the result only by rounding (≲ 1e-15 relative).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::error::Result;
use crate::film::fluxes::{self};
use crate::film::image::{self, PixelSampling};
use crate::film::pixel_counts::PixelCounts;
use crate::film::tally::{self, BLOCK, Tally};
use crate::job::{Job, Sensor, Task};
use crate::run::layout::{EstimateKind, Layout, Stage, UnitState};
use crate::sampling::stream::Channels;
use crate::transport::tracer::{Scene, ViewRay};

/// How a run is steered: when to checkpoint, when to stop, where progress goes.
pub struct Control<'a> {
    /// Set (by a signal handler) to stop after the current wave.
    pub stop: &'a AtomicBool,
    /// Time between checkpoints (`None`: never).
    pub checkpoint_every: Option<Duration>,
    /// Writes a checkpoint of the state.
    pub checkpoint: &'a (dyn Fn(&UnitState) -> Result<()> + Sync),
    /// Called with the paths traced, as they are.
    pub progress: &'a (dyn Fn(u64) + Sync),
    /// Called with the paths a noise target's allocation adds to the
    /// unit's work (known once its pilot is done).
    pub allocated: &'a (dyn Fn(u64) + Sync),
}

impl Control<'_> {
    /// A control that never stops or checkpoints.
    pub fn none(progress: &(dyn Fn(u64) + Sync)) -> Control<'_> {
        static NEVER: AtomicBool = AtomicBool::new(false);
        Control {
            stop: &NEVER,
            checkpoint_every: None,
            checkpoint: &no_checkpoint,
            progress,
            allocated: &|_| {},
        }
    }
}

fn no_checkpoint(_: &UnitState) -> Result<()> {
    Ok(())
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Complete,
    /// Stopped on request, after writing a checkpoint (`checkpoint` true)
    /// or before any sample was traced (nothing to keep).
    Stopped {
        checkpoint: bool,
    },
}

/// The scenes of a task, built on first use.
struct Scenes<'a> {
    job: &'a Job,
    task: &'a Task,
    shared: Option<Scene>,
    single: Vec<Option<Scene>>,
    groups: Vec<Option<Scene>>,
}

impl Scenes<'_> {
    /// The scene of an estimate's channels: all of them, a spectral group
    /// (`layout.groups`), or one alone.
    fn of(&mut self, channels: Channels, layout: &Layout) -> &Scene {
        let (job, task) = (self.job, self.task);
        match channels {
            Channels::Shared => self.shared.as_ref().expect("a shared layout has a shared scene"),
            Channels::One(w) => self.single[w].get_or_insert_with(|| job.scene_for(task, w)),
            Channels::Group(g) => self.groups[g].get_or_insert_with(|| job.group_scene(task, &layout.groups[g])),
        }
    }
}

/// The duration adaptive waves aim at: a stop request (SIGTERM) is
/// honoured within about this long.
pub const WAVE_SECONDS: f64 = 1.0;

/// The work of a wave of about `paths` paths: items of an image (a wave
/// may hold less than one sample per pixel), blocks of a direction or flux
/// (at least one per thread).
fn wave_size(e: usize, paths: u64, layout: &Layout) -> u64 {
    let threads = rayon::current_num_threads() as u64;
    match layout.estimates[e].kind {
        // Every item of a targeted image is a path.
        EstimateKind::Pixels { .. } if layout.allocation[e].is_some() => paths.max(threads),
        EstimateKind::Pixels { .. } => {
            let active = layout.active.as_ref().map_or(1, |a| a.count().max(1));
            let items = paths as u128 * layout.pixels as u128 / active as u128;
            (items.min(u64::MAX as u128) as u64).max(rayon::current_num_threads() as u64)
        }
        _ => (paths / BLOCK).max(rayon::current_num_threads() as u64),
    }
}

/// Renders what is left of `state` (in the current rayon pool): estimate
/// after estimate, wave after wave; between waves, writes a checkpoint when
/// `checkpoint_every` has passed since the last, and on a stop request
/// writes one and returns [`Outcome::Stopped`]. A noise target's
/// estimates are allocated (in `layout`) as their pilots finish.
pub fn run(
    job: &Job,
    task: &Task,
    layout: &mut Layout,
    shared: Option<Scene>,
    state: &mut UnitState,
    control: &Control,
) -> Result<Outcome> {
    let altitude_km = task.observer_altitude_km;
    let mut scenes = Scenes {
        job,
        task,
        shared,
        single: (0..job.wavelengths_nm.len()).map(|_| None).collect(),
        groups: layout.groups.iter().map(|_| None).collect(),
    };
    let mut last_checkpoint = Instant::now();
    let mut wave_paths = layout.wave_paths;
    // The pixels' solid angles, computed when an image's first wave needs them.
    let mut weights: Option<Vec<f64>> = None;
    let stop = |layout: &Layout, state: &UnitState| -> Result<Outcome> {
        let checkpoint = layout.done_paths(state) > 0;
        if checkpoint {
            (control.checkpoint)(state)?;
        }
        Ok(Outcome::Stopped { checkpoint })
    };
    for e in 0..layout.estimates.len() {
        if layout.allocation[e].is_none() {
            layout.allocate(state);
            if layout.allocation[e].is_some() {
                (control.allocated)(layout.paths_of(e, &layout.range(e, state.shard)));
            }
        }
        let est = layout.estimates[e];
        let range = layout.range(e, state.shard);
        // A targeted image's samples per pixel in this shard.
        let counts = layout.pixel_counts(e, state.shard);
        while state.done[e] < range.end - range.start {
            if control.stop.load(Ordering::SeqCst) {
                return stop(layout, state);
            }
            if let (Sensor::Image(camera), None) = (&job.render.sensor, &weights) {
                match image::pixel_weights_until(camera, control.stop) {
                    Some(w) => weights = Some(w),
                    None => return stop(layout, state),
                }
            }
            let start = range.start + state.done[e];
            let work = start..(start + wave_size(e, wave_paths, layout)).min(range.end);
            let context = RunContext {
                job,
                task,
                layout,
                weights: weights.as_deref().unwrap_or(&[]),
                counts: counts.as_ref(),
            };
            let clock = Instant::now();
            let tallies = &mut state.tallies[e];
            let scene = scenes.of(est.kind.channels(), layout);
            match est.kind {
                EstimateKind::Direction { .. } | EstimateKind::Pixels { .. } | EstimateKind::GroundView { .. } => {
                    radiance_wave(scene, &context, e, work.clone(), tallies)
                }
                EstimateKind::Flux { up, .. } => {
                    tally::tally_blocks(work.clone(), layout.samples_of(e), est.key, tallies, |s, out| {
                        fluxes::flux_sample(scene, altitude_km, up, s, out)
                    })
                }
            }
            state.done[e] += work.end - work.start;
            let paths = layout.paths_of(e, &work);
            (control.progress)(paths);
            let secs = clock.elapsed().as_secs_f64();
            if layout.adaptive_waves && paths > 0 && secs > 0.0 {
                wave_paths = ((paths as f64 / secs * WAVE_SECONDS) as u64).clamp(1 << 12, 1 << 28);
            }
            if control
                .checkpoint_every
                .is_some_and(|every| last_checkpoint.elapsed() >= every)
            {
                (control.checkpoint)(state)?;
                last_checkpoint = Instant::now();
            }
        }
    }
    Ok(Outcome::Complete)
}

/// What a wave needs besides its scene and its work: the job and task, the
/// layout, the pixels' solid angles (empty for directions) and a targeted
/// image's samples per pixel.
struct RunContext<'a> {
    job: &'a Job,
    task: &'a Task,
    layout: &'a Layout,
    weights: &'a [f64],
    counts: Option<&'a PixelCounts>,
}

/// One wave (`work`) of estimate `e`'s sample blocks (a direction) or
/// items (an image), added to `tallies`.
fn radiance_wave(scene: &Scene, context: &RunContext, e: usize, work: std::ops::Range<u64>, tallies: &mut [Tally]) {
    let RunContext {
        job,
        task,
        layout,
        weights,
        counts,
    } = *context;
    let est = &layout.estimates[e];
    let (altitude_km, sun) = (task.observer_altitude_km, task.sun.direction);
    match (&job.render.sensor, est.kind) {
        (Sensor::Directions(directions), EstimateKind::Direction { direction, .. }) => {
            let dir = directions[direction];
            let (v, e1) = (dir.vector(), dir.axis(job.render.stokes_frame, sun));
            tally::tally_blocks(work, layout.samples_of(e), est.key, tallies, |s, out| {
                scene.radiance_sample(altitude_km, v, e1, ViewRay::Repeated, s, out)
            })
        }
        (Sensor::Image(_), EstimateKind::GroundView { .. }) => {
            // Straight down: every direction below the horizon sees the
            // same unpolarised radiance (any axis will do).
            let (v, e1) = (glam::DVec3::NEG_Z, glam::DVec3::X);
            tally::tally_blocks(work, layout.samples_of(e), est.key, tallies, |s, out| {
                scene.radiance_sample(altitude_km, v, e1, ViewRay::Repeated, s, out)
            })
        }
        (Sensor::Image(camera), EstimateKind::Pixels { .. }) => {
            let sampling = PixelSampling {
                camera,
                traced_rows: layout.traced_rows,
                traced_columns: layout.traced_columns,
                weights,
                filter: job.render.pixel_filter,
                frame: job.render.stokes_frame,
                sun,
                samples: layout.samples_of(e),
                seed: est.key.seed,
                render: est.key.render,
                pilot: est.stage == Stage::Pilot,
            };
            let ray = sampling.view_ray();
            let radiance = |v, e1, s: &mut _, out: &mut _| scene.radiance_sample(altitude_km, v, e1, ray, s, out);
            match counts {
                Some(counts) => image::render_counted_into(&sampling, counts, work, tallies, est.values, radiance),
                None => image::render_pixels_into(&sampling, work, tallies, est.values, &|_| {}, radiance),
            }
        }
        _ => unreachable!("direction estimates belong to directions sensors, pixels to images"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::Job;
    use crate::run::allocation::Allocation;
    use crate::run::layout::{Layout, UnitState};
    use crate::run::shard::Shard;

    fn job(extra: &str) -> Job {
        job_with("samples = 3000", extra)
    }

    /// A job with `samples` (the `[render]` keys of its sample count) and
    /// the sections `extra`.
    fn job_with(samples: &str, extra: &str) -> Job {
        let text = format!(
            "[spectrum]\nwavelengths_nm = [450.0, 550.0]\n[atmosphere]\naerosol = \"none\"\n[render]\n{samples}\nseed = 5\n{extra}"
        );
        Job::parse(&text, "test.toml", std::path::Path::new(".")).unwrap()
    }

    /// Sample counts of the tests: fixed, and a noise target.
    const SAMPLES: [&str; 2] = [
        "samples = 3000",
        "noise_target = 0.05\npilot_samples = 16\nmax_samples = 5000",
    ];

    fn run_all(job: &Job, shard: Shard, control: &Control) -> (Layout, UnitState, Outcome) {
        let task = &job.tasks[0];
        let shared = job.spectral_scene(task);
        let mut layout = Layout::new(job, task, shared.is_some());
        let mut state = layout.empty_state(job, task, shard);
        let outcome = run(job, task, &mut layout, shared, &mut state, control).unwrap();
        (layout, state, outcome)
    }

    #[test]
    fn shards_add_up_to_the_whole_task() {
        for (samples, extra) in SAMPLES.into_iter().flat_map(|s| {
            [
                "[sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0, 60.0]\nazimuth_deg = [0.0, 90.0]\n",
                "shared_wavelengths = false\n[sensor]\ntype = \"directions\"\nview_zenith_deg = [30.0]\nazimuth_deg = [180.0]\n",
                "[sensor]\ntype = \"fisheye\"\nresolution = 6\n",
                "shared_wavelengths = false\n[sensor]\ntype = \"fisheye\"\nresolution = 5\n",
                // Two spectral groups, each with paths of its own.
                "spectral_groups = 2\n[sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0, 60.0]\nazimuth_deg = [0.0]\n",
                "spectral_groups = 2\n[sensor]\ntype = \"fisheye\"\nresolution = 5\n",
                // From the ground: the lower rows share the ground view.
                "[sensor]\ntype = \"sphere\"\nresolution = [6, 4]\n[ground]\nalbedo = [0.0, 0.3]\n",
                "shared_wavelengths = false\n[sensor]\ntype = \"fisheye\"\nresolution = 4\nhemisphere = \"down\"\n\
                 [ground]\nalbedo = 0.3\n",
            ]
            .map(move |e| (s, e))
        }) {
            let j = job_with(samples, extra);
            let quiet = |_| {};
            let (layout, whole, _) = run_all(&j, Shard::WHOLE, &Control::none(&quiet));
            assert!(whole.is_complete(&layout));
            let mut merged: Option<UnitState> = None;
            for k in 1..=3 {
                let (part_layout, part, _) = run_all(&j, Shard::new(k, 3).unwrap(), &Control::none(&quiet));
                // Every shard allocates alike, from the same pilot.
                assert_eq!(part_layout.allocation, layout.allocation);
                match &mut merged {
                    None => merged = Some(part),
                    Some(m) => m.add(&part, &layout),
                }
            }
            let merged = merged.unwrap();
            let mut compared = 0;
            for (a, b) in whole.tallies.iter().flatten().zip(merged.tallies.iter().flatten()) {
                assert_eq!(a.samples, b.samples);
                for k in 0..4 {
                    let scale = a.sum[k].abs().max(1e-300);
                    assert!((a.sum[k] - b.sum[k]).abs() <= 1e-12 * scale, "{extra}: {a:?} vs {b:?}");
                    assert!((a.sum_sq[k] - b.sum_sq[k]).abs() <= 1e-12 * a.sum_sq[k].abs().max(1e-300));
                }
                compared += 1;
            }
            assert!(compared > 0);
            assert!(whole.tallies.iter().flatten().any(|t| t.sum[0] > 0.0));
            if layout.target.is_some() {
                // The allocation varies, so shards split uneven counts.
                assert!(layout.is_allocated());
                assert!(layout.allocation.iter().flatten().any(|a| match a {
                    Allocation::Single(n) => *n > 16 && *n < 5000,
                    Allocation::Pixels(n) => n.iter().max() > n.iter().filter(|&&n| n > 0).min(),
                }));
            }
        }
    }

    #[test]
    fn stopping_and_resuming_is_bit_identical() {
        for (samples, extra) in SAMPLES.into_iter().flat_map(|s| {
            [
                "[sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0, 60.0]\nazimuth_deg = [0.0]\n",
                "[sensor]\ntype = \"fisheye\"\nresolution = 4\n",
                "[sensor]\ntype = \"sphere\"\nresolution = [6, 4]\n[ground]\nalbedo = 0.3\n",
                "spectral_groups = 2\n[sensor]\ntype = \"fisheye\"\nresolution = 4\n",
            ]
            .map(move |e| (s, e))
        }) {
            let j = job_with(samples, extra);
            let quiet = |_| {};
            let (_, whole, _) = run_all(&j, Shard::WHOLE, &Control::none(&quiet));
            let task = &j.tasks[0];
            // A fresh layout (a resumed run allocates from its checkpoint),
            // with small waves, so that an image stops several times.
            let mut layout = Layout::new(&j, task, j.spectral_scene(task).is_some());
            layout.wave_paths = 1000;
            layout.adaptive_waves = false;
            let mut state = layout.empty_state(&j, task, Shard::WHOLE);
            let stop = AtomicBool::new(false);
            let saved = std::sync::Mutex::new(Vec::new());
            let waves = std::sync::atomic::AtomicU64::new(0);
            let progress = |_| {
                // Ask to stop after every second wave.
                if waves.fetch_add(1, Ordering::SeqCst) % 2 == 1 {
                    stop.store(true, Ordering::SeqCst);
                }
            };
            let checkpoint = |s: &UnitState| {
                saved.lock().unwrap().push(s.clone());
                Ok(())
            };
            let control = Control {
                stop: &stop,
                checkpoint_every: None,
                checkpoint: &checkpoint,
                progress: &progress,
                allocated: &|_| {},
            };
            let mut stops = 0;
            loop {
                let outcome = run(&j, task, &mut layout, j.spectral_scene(task), &mut state, &control).unwrap();
                if outcome == Outcome::Complete {
                    break;
                }
                stops += 1;
                // Resume from the checkpoint, not from the live state, with
                // the layout a new process makes of it.
                state = saved.lock().unwrap().last().unwrap().clone();
                let (wave_paths, adaptive_waves) = (layout.wave_paths, layout.adaptive_waves);
                layout = Layout::new(&j, task, j.spectral_scene(task).is_some());
                (layout.wave_paths, layout.adaptive_waves) = (wave_paths, adaptive_waves);
                layout.allocate(&state);
                assert!(layout.fits(&state));
                stop.store(false, Ordering::SeqCst);
            }
            assert!(stops >= 1, "{extra}: never stopped");
            assert_eq!(state, whole, "{extra}");
        }
    }

    #[test]
    fn non_finite_samples_are_counted_once_per_path_and_never_summed() {
        let j = job("[sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0]\nazimuth_deg = [0.0]\n");
        let task = &j.tasks[0];
        let layout = Layout::new(&j, task, true);
        let mut state = layout.empty_state(&j, task, Shard::WHOLE);
        let nan = crate::polarization::stokes::Stokes::new(f64::NAN, 0.0, 0.0, 0.0);
        let one = crate::polarization::stokes::Stokes::new(1.0, 0.5, 0.0, 0.0);
        // One path: every value of the first estimate non-finite.
        for t in state.tallies[0].iter_mut() {
            t.add(&nan);
            t.add(&one);
        }
        assert_eq!(state.non_finite(&layout), 1);
        let t = state.tallies[0][0];
        assert_eq!((t.sum[0], t.sum[1], t.samples, t.non_finite), (1.0, 0.5, 2, 1));
        assert!(t.mean().iter().chain(&t.standard_error()).all(|x| x.is_finite()));
    }

    #[test]
    fn checkpoints_follow_the_interval() {
        let j = job("[sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0]\nazimuth_deg = [0.0]\n");
        let count = std::sync::atomic::AtomicU64::new(0);
        let checkpoint = |_: &UnitState| {
            count.fetch_add(1, Ordering::SeqCst);
            Ok(())
        };
        let stop = AtomicBool::new(false);
        let waves = std::sync::atomic::AtomicU64::new(0);
        let progress = |_| {
            waves.fetch_add(1, Ordering::SeqCst);
        };
        let control = Control {
            stop: &stop,
            checkpoint_every: Some(Duration::ZERO),
            checkpoint: &checkpoint,
            progress: &progress,
            allocated: &|_| {},
        };
        let (layout, state, outcome) = run_all(&j, Shard::WHOLE, &control);
        assert_eq!(outcome, Outcome::Complete);
        // One checkpoint after every wave of every estimate.
        assert!(waves.load(Ordering::SeqCst) >= layout.estimates.len() as u64);
        assert_eq!(count.load(Ordering::SeqCst), waves.load(Ordering::SeqCst));
        assert!(state.is_complete(&layout));
    }
}
