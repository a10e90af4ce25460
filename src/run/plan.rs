//! `atmosim plan`: the tasks of a job and what they cost, so a user can size
//! a cluster allocation before rendering. Cost = paths (pixels or
//! directions × samples, plus the flux estimates of a directions sensor;
//! every albedo from the same paths; once for shared spectral paths, else
//! once per wavelength) over throughputs measured by short single-thread
//! calibration renders of the first task of each class of sun elevation
//! ([`SunClass`]: a set sun, a low one, day): one at its middle wavelength,
//! and one along shared paths when the task's wavelengths share them (a
//! shared path carries every channel and costs more than a single one).

use std::io::{self, Write};
use std::time::Instant;

use crate::film::directions::{render_directions, render_directions_all};
use crate::job::{Job, Sensor, Task};
use std::sync::atomic::{AtomicBool, Ordering};

use crate::film::ground_view::GROUND_VIEW_SAMPLES;
use crate::run::allocation::Allocation;
use crate::run::layout::{EstimateKind, Layout, Stage};
use crate::run::shard::Shard;
use crate::run::work_unit::{self, Control};
use crate::sampling::stream::{Channels, Render};
use crate::sensor::direction::Direction;
use crate::sensor::symmetry::{self, SymmetryChoice};

/// Paths of one task (shared spectral paths and single-wavelength paths)
/// at `rates` (whose pilot says what a noise target allocates).
pub fn task_paths(job: &Job, task: &Task, rates: &Rates) -> u64 {
    let (shared, single) = paths_by_channels(job, task, rates);
    shared + single
}

/// Paths of one task along shared spectral paths and at single
/// wavelengths: with a noise target, its pilot's and, per direction or
/// traced pixel, the calibration's mean allocation.
fn paths_by_channels(job: &Job, task: &Task, rates: &Rates) -> (u64, u64) {
    let layout = layout(job, task);
    let mut paths = (0, 0);
    for (e, estimate) in layout.estimates.iter().enumerate() {
        let n = match estimate.stage {
            Stage::Targeted { .. } => {
                let units = match estimate.kind {
                    EstimateKind::Pixels { .. } => layout.active.as_ref().map_or(0, |a| a.count()),
                    // A quarter of a pixel's relative error.
                    EstimateKind::GroundView { .. } => GROUND_VIEW_SAMPLES,
                    _ => 1,
                };
                (units as f64 * rates.samples.unwrap_or(0.0)).round() as u64
            }
            _ => layout.paths_of(e, &layout.range(e, Shard::WHOLE)),
        };
        match estimate.kind.channels() {
            Channels::Shared | Channels::Group(_) => paths.0 += n,
            Channels::One(_) => paths.1 += n,
        }
    }
    paths
}

/// The estimates of a task.
fn layout(job: &Job, task: &Task) -> Layout {
    Layout::new(job, task, job.spectral_scene(task).is_some())
}

/// Sun elevations whose paths cost alike: below the horizon, up to 10°
/// (where `sun_sampling = "auto"` connects along whole flights), and above.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SunClass {
    Set,
    Low,
    Day,
}

impl SunClass {
    /// The class of a task's sun.
    pub fn of(task: &Task) -> SunClass {
        let elevation = 90.0 - task.sun.zenith_deg;
        if elevation < 0.0 {
            SunClass::Set
        } else if elevation < 10.0 {
            SunClass::Low
        } else {
            SunClass::Day
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            SunClass::Set => "sun below the horizon",
            SunClass::Low => "sun 0° to 10°",
            SunClass::Day => "sun 10° and higher",
        }
    }
}

/// Calibrated throughputs per class of sun elevation, each from the
/// class's first task.
#[derive(Debug, Clone)]
pub struct Calibration {
    pub classes: Vec<(SunClass, usize, Rates)>,
}

impl Calibration {
    /// The rates of `task`'s class.
    pub fn rates(&self, task: &Task) -> &Rates {
        let class = SunClass::of(task);
        let found = self.classes.iter().find(|c| c.0 == class).or(self.classes.first());
        &found.expect("a calibration has at least one class").2
    }

    /// Core-seconds of `task`.
    pub fn task_core_seconds(&self, job: &Job, task: &Task) -> f64 {
        task_core_seconds(job, task, self.rates(task))
    }

    /// Core-seconds of the job's dearest task.
    pub fn max_task_core_seconds(&self, job: &Job) -> f64 {
        job.tasks
            .iter()
            .map(|t| self.task_core_seconds(job, t))
            .fold(0.0, f64::max)
    }
}

/// Calibrated throughputs, paths per second on one core, and what a noise
/// target allocates.
#[derive(Debug, Clone, Copy)]
pub struct Rates {
    /// Paths at one wavelength.
    pub single: f64,
    /// Shared spectral paths (all channels), when the task has them.
    pub shared: Option<f64>,
    /// With a noise target: the mean samples its pilot allocates per
    /// direction or traced pixel.
    pub samples: Option<f64>,
}

/// Core-seconds of one task at `rates`.
pub fn task_core_seconds(job: &Job, task: &Task, rates: &Rates) -> f64 {
    let (shared, single) = paths_by_channels(job, task, rates);
    single as f64 / rates.single.max(1e-9) + shared as f64 / rates.shared.unwrap_or(rates.single).max(1e-9)
}

/// Paths per second on one core for the first task of each class of sun
/// elevation in the job.
pub fn calibrate(job: &Job) -> Calibration {
    let mut classes: Vec<(SunClass, usize, Rates)> = Vec::new();
    for task in &job.tasks {
        let class = SunClass::of(task);
        if !classes.iter().any(|c| c.0 == class) {
            classes.push((class, task.index, calibrate_task(job, task)));
        }
    }
    Calibration { classes }
}

/// Paths per second on one core for `task`, from about 0.2 s of rendering
/// over directions spread on the sphere: at its middle wavelength, and
/// along shared paths if its wavelengths share them (those of each of its
/// spectral groups, in equal numbers).
fn calibrate_task(job: &Job, task: &Task) -> Rates {
    let scene = job.scene_for(task, job.wavelengths_nm.len() / 2);
    let directions: Vec<Direction> = (0..16)
        .map(|k| Direction {
            view_zenith_deg: 5.0 + 170.0 * (k as f64 + 0.5) / 16.0,
            azimuth_deg: 45.0 * k as f64,
        })
        .collect();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build();
    let rate = |render: &(dyn Fn(u64) + Sync)| {
        let mut n = 64;
        loop {
            let start = Instant::now();
            match &pool {
                Ok(p) => p.install(|| render(n)),
                Err(_) => render(n),
            };
            let secs = start.elapsed().as_secs_f64();
            if secs > 0.2 || n >= 1 << 20 {
                return (n * directions.len() as u64) as f64 / secs.max(1e-9);
            }
            n *= 4;
        }
    };
    let alt = task.observer_altitude_km;
    let seed = job.render.seed;
    Rates {
        single: rate(&|n| {
            render_directions(&scene, alt, &directions, n, seed, Render::Calibration);
        }),
        // Each spectral group's paths carry its channels alone: the rate is
        // over equal numbers of paths of every group.
        shared: job.spectral_scene(task).map(|shared| {
            let groups = job.spectral_groups(task);
            let scenes: Vec<_> = match groups.len() {
                1 => vec![shared],
                _ => groups.iter().map(|g| job.group_scene(task, g)).collect(),
            };
            rate(&|n| {
                for scene in &scenes {
                    render_directions_all(scene, alt, &directions, n, seed, Render::Calibration);
                }
            }) * scenes.len() as f64
        }),
        samples: job.render.target.map(|_| pilot_allocation(job, task)),
    }
}

/// Largest side of the image whose pilot calibrates a noise target.
const PILOT_IMAGE_WIDTH: usize = 64;

/// The mean samples a noise target allocates per direction or traced
/// pixel of `task`, from its pilot: of the task's own directions, or of
/// its camera at a width of at most [`PILOT_IMAGE_WIDTH`] (coarser pixels
/// vary more within, so this errs high).
fn pilot_allocation(job: &Job, task: &Task) -> f64 {
    let mut small = job.clone();
    if let Sensor::Image(camera) = &mut small.render.sensor {
        *camera = camera.with_width_at_most(PILOT_IMAGE_WIDTH);
    }
    let shared = small.spectral_scene(task);
    let mut layout = Layout::new(&small, task, shared.is_some());
    let mut state = layout.empty_state(&small, task, Shard::WHOLE);
    // Stop once the pilot has allocated the samples.
    let stop = AtomicBool::new(false);
    let allocated = |_| stop.store(true, Ordering::SeqCst);
    let control = Control {
        allocated: &allocated,
        stop: &stop,
        ..Control::none(&|_| {})
    };
    if work_unit::run(&small, task, &mut layout, shared, &mut state, &control).is_err() {
        return 0.0;
    }
    let counts: Vec<u64> = layout
        .allocation
        .iter()
        .flatten()
        .flat_map(|a| match a {
            Allocation::Single(n) => vec![*n],
            Allocation::Pixels(n) => n.iter().copied().filter(|&n| n > 0).collect(),
        })
        .collect();
    counts.iter().sum::<u64>() as f64 / counts.len().max(1) as f64
}

/// Writes the plan: one line per task, then the totals.
pub fn write_plan(job: &Job, out: &mut dyn Write) -> io::Result<()> {
    let calibration = calibrate(job);
    let sensor = match &job.render.sensor {
        Sensor::Directions(d) => format!("{} directions", d.len()),
        Sensor::Image(c) => {
            let (w, h) = c.size();
            let traced = match job.render.symmetry {
                SymmetryChoice::Auto if symmetry::rotates(c) => {
                    " (its left half traced, the mirror; one column under a sun at the zenith)"
                }
                SymmetryChoice::Auto | SymmetryChoice::Mirror => " (its left half traced, the mirror)",
                SymmetryChoice::None => "",
            };
            format!("{w}x{h} image{traced}")
        }
    };
    let samples = match job.render.target {
        None => format!("{} samples", job.render.samples),
        Some(t) => format!(
            "samples to a relative standard error of I of {} {} in {} (pilot {}, at most {})",
            t.relative_se,
            t.per.describe(),
            t.albedos.describe(),
            t.pilot,
            t.max_samples
        ),
    };
    writeln!(
        out,
        "# {}: {} tasks; each {sensor}, {} wavelengths ({} albedos from the same paths) × {samples}",
        job.file,
        job.tasks.len(),
        job.wavelengths_nm.len(),
        job.render.albedos.len(),
    )?;
    for (class, task, rates) in &calibration.classes {
        let tasks = job.tasks.iter().filter(|t| SunClass::of(t) == *class).count();
        if let Some(n) = rates.samples {
            writeln!(
                out,
                "# {} ({tasks} tasks): the pilot of task {task} allocates {n:.0} samples per direction or pixel \
                 on average (an image's pilot at a width of at most {PILOT_IMAGE_WIDTH} pixels: coarse pixels \
                 vary more within, so this errs high)",
                class.label()
            )?;
        }
        match rates.shared {
            Some(shared) => writeln!(
                out,
                "# {} ({tasks} tasks): calibrated on task {task}: {shared:.0} shared spectral paths/s per core \
                 ({:.0} at one wavelength)",
                class.label(),
                rates.single
            )?,
            None => writeln!(
                out,
                "# {} ({tasks} tasks): calibrated on task {task}: {:.0} paths/s per core",
                class.label(),
                rates.single
            )?,
        }
    }
    writeln!(
        out,
        "task,name,visibility_km,sun_elevation_deg,observer_altitude_km,paths,core_hours"
    )?;
    let (mut total_paths, mut total_hours) = (0.0, 0.0);
    for t in &job.tasks {
        let paths = task_paths(job, t, calibration.rates(t));
        let hours = calibration.task_core_seconds(job, t) / 3600.0;
        total_paths += paths as f64;
        total_hours += hours;
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
    writeln!(
        out,
        "# total: {total_paths:.3e} paths, {total_hours:.1} core-hours at the calibrated rates"
    )?;
    writeln!(
        out,
        "# (visibility and the observer's altitude change the cost too, within a class: treat the estimate as a guide)"
    )
}

/// What `plan --slurm` needs besides the job.
#[derive(Debug, Clone)]
pub struct SlurmOptions {
    /// Absolute paths of the atmosim binary, the job file and the output directory.
    pub exe: std::path::PathBuf,
    pub job_file: std::path::PathBuf,
    pub out_dir: std::path::PathBuf,
    /// Shards per task.
    pub shards: u64,
    /// CPUs per unit.
    pub cpus: usize,
    /// Wall time per unit (`HH:MM:SS`); `None`: estimated.
    pub time: Option<String>,
    /// Minutes between checkpoints.
    pub checkpoint_minutes: f64,
}

/// Units of a job: tasks × shards.
pub fn units(job: &Job, shards: u64) -> u64 {
    job.tasks.len() as u64 * shards
}

/// Memory a unit needs, in MiB: its sums twice (the live state and, on
/// `--resume`, the checkpoint read back) plus the binary, the atmosphere
/// and the rest.
pub fn unit_memory_mib(job: &Job) -> u64 {
    let task = &job.tasks[0];
    let layout = crate::run::layout::Layout::new(job, task, job.spectral_scene(task).is_some());
    let tallies: u64 = (0..layout.estimates.len()).map(|e| layout.tallies(e) as u64).sum();
    let bytes = tallies * std::mem::size_of::<crate::film::tally::Tally>() as u64 * 2 + layout.pixels as u64 * 8;
    256 + bytes.div_ceil(1 << 20) * 5 / 4
}

/// `HH:MM:SS` of a number of seconds (hours may exceed 24).
pub fn hms(seconds: f64) -> String {
    let s = seconds.max(0.0).ceil() as u64;
    format!("{:02}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// Seconds of a SLURM time limit: `minutes`, `minutes:seconds`,
/// `hours:minutes:seconds`, `days-hours`, `days-hours:minutes` or
/// `days-hours:minutes:seconds`; `None` for anything else.
pub fn time_seconds(t: &str) -> Option<u64> {
    let num =
        |p: &str| -> Option<u64> { (!p.is_empty() && p.bytes().all(|b| b.is_ascii_digit())).then(|| p.parse().ok())? };
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(num(d)?), r),
        None => (None, t),
    };
    let parts: Vec<u64> = rest.split(':').map(num).collect::<Option<_>>()?;
    let secs = match (days, parts.as_slice()) {
        (None, [m]) => m * 60,
        (None, [m, s]) => m * 60 + s,
        (None, [h, m, s]) => h * 3600 + m * 60 + s,
        (Some(d), [h]) => d * 86400 + h * 3600,
        (Some(d), [h, m]) => d * 86400 + h * 3600 + m * 60,
        (Some(d), [h, m, s]) => d * 86400 + h * 3600 + m * 60 + s,
        _ => return None,
    };
    (secs > 0).then_some(secs)
}

/// Seconds before the time limit at which SLURM sends SIGTERM: a tenth
/// of the limit, between 10 s and 3 minutes (time to finish a wave and
/// write the checkpoint before SIGKILL).
pub fn signal_lead(limit_seconds: u64) -> u64 {
    (limit_seconds / 10).clamp(10, 180)
}

/// The wall time a unit needs on `cpus` cores: twice the estimate of the
/// dearest task plus 10 minutes (for startup, checkpoints and slow corners
/// of a class: visibility and altitude change the cost too).
pub fn unit_seconds(job: &Job, shards: u64, calibration: &Calibration, cpus: usize) -> f64 {
    2.0 * calibration.max_task_core_seconds(job) / shards as f64 / cpus as f64 + 600.0
}

/// A ready sbatch script for an array over every unit of the job (task ×
/// shard). Array index i is unit i: task ⌊i / N⌋, shard (i mod N) + 1.
/// Each unit runs `render --resume`, so a rerun (requeue, resubmission)
/// skips finished units and continues interrupted ones from their last
/// checkpoint; SIGTERM, which SLURM sends before the time limit
/// (`--signal`) and on `scancel`, makes atmosim write a checkpoint and stop.
pub fn slurm_script(job: &Job, o: &SlurmOptions, time: &str) -> String {
    let units = units(job, o.shards);
    let q = |p: &std::path::Path| shell_quote(&p.display().to_string());
    let logs = o.out_dir.join("slurm").join("logs");
    let merge = if o.shards > 1 {
        format!(
            "# When every unit has finished, combine the shards:\n#   {} merge {}\n\
             # or let SLURM do it: sbatch --dependency=afterok:<array job id> --wrap '{} merge {}'\n",
            q(&o.exe),
            q(&o.out_dir),
            q(&o.exe),
            q(&o.out_dir)
        )
    } else {
        "# One shard per task: every unit writes its task's final files; nothing to merge.\n".to_string()
    };
    let mut s = String::new();
    s.push_str("#!/bin/bash\n");
    s.push_str(&format!(
        "# atmosim render array for {} (job hash {}): {} tasks x {} shards = {units} units.\n",
        job.file,
        job.hash,
        job.tasks.len(),
        o.shards
    ));
    s.push_str("# Written by `atmosim plan --slurm`. Submit with: sbatch <this file>\n");
    s.push_str(&merge);
    s.push_str(
        "# Rerunning is safe: a finished unit is skipped, an interrupted one resumes from its\n\
         # checkpoint (written every few minutes and on SIGTERM), so `scontrol requeue`, a\n\
         # pre-emption or resubmitting this script (all of it or `--array=<i>`) loses no samples.\n\
         # More than MaxArraySize units: submit in slices with an offset, e.g.\n\
         #   sbatch --array=0-999 --export=ALL,ATMOSIM_UNIT_OFFSET=1000 <this file>\n",
    );
    s.push_str(&format!(
        "#SBATCH --job-name=atmosim-{}\n",
        &job.hash[..8.min(job.hash.len())]
    ));
    s.push_str(&format!("#SBATCH --array=0-{}\n", units.saturating_sub(1)));
    s.push_str("#SBATCH --ntasks=1\n");
    s.push_str(&format!("#SBATCH --cpus-per-task={}\n", o.cpus));
    s.push_str(&format!("#SBATCH --mem={}M\n", unit_memory_mib(job)));
    s.push_str(&format!("#SBATCH --time={time}\n"));
    s.push_str(&format!("#SBATCH --output={}\n", q(&logs.join("%A_%a.out"))));
    s.push_str("#SBATCH --open-mode=append\n");
    s.push_str("#SBATCH --requeue\n");
    // SIGTERM to the batch shell (which `exec`s atmosim) before the limit.
    let lead = signal_lead(time_seconds(time).unwrap_or(3600));
    s.push_str(&format!("#SBATCH --signal=B:TERM@{lead}\n"));
    s.push_str("set -euo pipefail\n");
    s.push_str(&format!("SHARDS={}\n", o.shards));
    s.push_str("UNIT=$(( SLURM_ARRAY_TASK_ID + ${ATMOSIM_UNIT_OFFSET:-0} ))\n");
    s.push_str("TASK=$(( UNIT / SHARDS ))\n");
    s.push_str("SHARD=$(( UNIT % SHARDS + 1 ))\n");
    s.push_str(
        "echo \"$(date -Is) unit $UNIT: task $TASK, shard $SHARD/$SHARDS on $(hostname), ${SLURM_CPUS_PER_TASK:-1} cpus (restart ${SLURM_RESTART_COUNT:-0})\"\n",
    );
    s.push_str(&format!(
        "exec {} render {} --out {} --task \"$TASK\" --shard \"$SHARD/$SHARDS\" --resume \\\n    --threads \"${{SLURM_CPUS_PER_TASK:-1}}\" --checkpoint-every {}\n",
        q(&o.exe),
        q(&o.job_file),
        q(&o.out_dir),
        o.checkpoint_minutes
    ));
    s
}

/// Single-quotes a word for the shell when it needs it.
fn shell_quote(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "/._-+:,=%@".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

#[cfg(test)]
mod slurm_tests {
    use super::*;

    #[test]
    fn times_and_quotes() {
        assert_eq!(hms(3661.2), "01:01:02");
        assert_eq!(hms(100.0 * 3600.0), "100:00:00");
        for (good, secs) in [
            ("01:00:00", 3600),
            ("2-00:00:00", 172800),
            ("30", 1800),
            ("10:05", 605),
            ("1-2", 93600),
            ("1-2:03", 93780),
        ] {
            assert_eq!(time_seconds(good), Some(secs), "{good}");
        }
        for bad in ["", "1h", "01:00:00:00", "a-01:00:00", "01::00", "00:00:00", "-5", "1-"] {
            assert_eq!(time_seconds(bad), None, "{bad}");
        }
        assert_eq!(signal_lead(600), 60);
        assert_eq!(signal_lead(36000), 180);
        assert_eq!(signal_lead(60), 10);
        assert_eq!(shell_quote("/a/b.toml"), "/a/b.toml");
        assert_eq!(shell_quote("/a b/it's"), "'/a b/it'\\''s'");
    }
}
