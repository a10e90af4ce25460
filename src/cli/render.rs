//! `atmosim render`: renders a job's tasks, or one task or shard of them,
//! as units that skip finished work, resume from checkpoints, checkpoint on
//! an interval and on SIGTERM/SIGINT, and write the final files; or prints
//! the radiance CSV on stdout.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use atmosim::io::output;
use atmosim::job::{Job, Sensor, Task};
use atmosim::run::checkpoint::{self, StateFile};
use atmosim::run::layout::{Layout, UnitState};
use atmosim::run::merge;
use atmosim::run::out_dir::Destination;
use atmosim::run::shard::Shard;
use atmosim::run::task_output::{self, RunInfo};
use atmosim::run::work_unit::{self, Control, Outcome};

use super::common::{task_index, thread_pool};
use super::progress::Progress;
use super::signals::{self, Interrupted};

#[derive(clap::Args)]
pub struct RenderArgs {
    /// Job file (TOML).
    job: PathBuf,
    /// Output directory (default: the job's `[output] directory`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the radiance CSV on stdout instead of writing files.
    #[arg(long, conflicts_with_all = ["shard", "resume"])]
    stdout: bool,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
    /// No progress lines on stderr.
    #[arg(long, short)]
    quiet: bool,
    /// Render only task I (from 0, in the order `plan` lists them);
    /// `env` takes I from $SLURM_ARRAY_TASK_ID.
    #[arg(long, value_name = "I|env")]
    task: Option<String>,
    /// Render only shard K of N of each task's samples, into
    /// shards/K-of-N.shard for `atmosim merge`.
    #[arg(long, value_name = "K/N")]
    shard: Option<Shard>,
    /// Continue interrupted units from their checkpoints.
    #[arg(long)]
    resume: bool,
    /// Minutes between checkpoints (0: none; a stop by SIGTERM or
    /// Ctrl-C always writes one).
    #[arg(long, value_name = "MINUTES", default_value_t = 10.0)]
    checkpoint_every: f64,
    /// Render tasks again that are already complete.
    #[arg(long)]
    force: bool,
    /// Write into task directories that hold another job's results,
    /// replacing them (without it such a directory is refused).
    #[arg(long)]
    overwrite: bool,
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let RenderArgs {
        job,
        out,
        stdout,
        threads,
        quiet,
        task,
        shard,
        resume,
        checkpoint_every,
        force,
        overwrite,
    } = args;
    let job = Job::from_file(&job)?;
    if !(checkpoint_every.is_finite() && checkpoint_every >= 0.0) {
        anyhow::bail!(atmosim::Error::InvalidValue {
            file: "command line".into(),
            key: "--checkpoint-every".into(),
            value: format!("{checkpoint_every}"),
            reason: "not a number of minutes".into(),
            valid: "0 (no periodic checkpoints) or more minutes".into(),
        });
    }
    let tasks: Vec<&Task> = match task {
        Some(t) => vec![&job.tasks[task_index(&job, &t)?]],
        None => job.tasks.iter().collect(),
    };
    let pool = thread_pool(threads)?;
    if stdout {
        return render_stdout(&job, &tasks, &pool, quiet);
    }
    let destination = Destination::of(&job, out.as_deref());
    let options = UnitOptions {
        shard: shard.unwrap_or(Shard::WHOLE),
        resume,
        force,
        overwrite,
        checkpoint_every: (checkpoint_every > 0.0).then(|| std::time::Duration::from_secs_f64(checkpoint_every * 60.0)),
        quiet,
    };
    render_units(&job, &tasks, &destination, &pool, &options)
}

/// How `render` runs its units.
struct UnitOptions {
    shard: Shard,
    resume: bool,
    force: bool,
    overwrite: bool,
    checkpoint_every: Option<std::time::Duration>,
    quiet: bool,
}

/// `render --stdout`: the radiance CSV of a `directions` sensor.
fn render_stdout(job: &Job, tasks: &[&Task], pool: &rayon::ThreadPool, quiet: bool) -> anyhow::Result<()> {
    if let Sensor::Image(_) = job.render.sensor {
        anyhow::bail!(atmosim::Error::InvalidValue {
            file: job.file.clone(),
            key: "sensor.type".into(),
            value: "an image sensor".into(),
            reason: "--stdout prints the CSV of a directions sensor; images are written as files".into(),
            valid: "sensor.type = \"directions\" with --stdout".into(),
        });
    }
    let log = |msg: &str| {
        if !quiet {
            eprintln!("{msg}");
        }
    };
    let mut out = std::io::stdout().lock();
    for task in tasks {
        let result = pool.install(|| atmosim::run::task::render_directions(job, task, &log))?;
        if job.tasks.len() > 1 {
            writeln!(out, "# task {}", task.name).context("writing to stdout")?;
        }
        out.write_all(output::radiance_csv(&result.radiance).as_bytes())
            .context("writing to stdout")?;
        out.flush().context("writing to stdout")?;
    }
    Ok(())
}

/// One unit to render: a task, where its files go, its layout and its
/// state (fresh or from a checkpoint).
struct Unit<'a> {
    task: &'a Task,
    dir: PathBuf,
    layout: Layout,
    state: UnitState,
}

/// Renders `options.shard` of every task in `tasks`: skips finished units,
/// resumes from checkpoints (`--resume`), checkpoints on the interval and
/// on SIGTERM/SIGINT, and writes the final files (a whole task) or the
/// shard's file.
fn render_units(
    job: &Job,
    tasks: &[&Task],
    destination: &Destination,
    pool: &rayon::ThreadPool,
    options: &UnitOptions,
) -> anyhow::Result<()> {
    signals::catch_signals()?;
    let shard = options.shard;
    let base = destination.dir.as_path();
    // Where the outputs go, checked before any work.
    destination.check_writable()?;
    let task_dirs: Vec<PathBuf> = tasks.iter().map(|t| merge::task_dir(base, job, t)).collect();
    destination.check_not_another_job(job, &task_dirs, options.overwrite)?;
    let log = |msg: &str| {
        if !options.quiet {
            eprintln!("{msg}");
        }
    };
    // What is left to do.
    let mut units = Vec::new();
    for &task in tasks {
        let dir = merge::task_dir(base, job, task);
        let finished = if shard.is_whole() {
            task_output::is_complete(&dir, job)
        } else {
            StateFile::read(&checkpoint::shard_path(&dir, shard)).is_ok_and(|f| f.state.job_hash == job.hash)
        };
        if finished && !options.force {
            log(&format!(
                "{} (shard {shard}): complete (same job hash), skipped; --force renders it again",
                task.name
            ));
            continue;
        }
        let mut layout = Layout::new(job, task, job.spectral_scene(task).is_some());
        let cp = checkpoint::checkpoint_path(&dir, shard);
        let state = if options.resume && cp.exists() {
            let f = StateFile::read(&cp)?;
            let s = f.state;
            // A noise target's allocation, from the checkpoint's pilot.
            layout.allocate(&s);
            if s.job_hash != job.hash || s.task != task.index || s.shard != shard || !layout.fits(&s) {
                anyhow::bail!(atmosim::Error::data(
                    cp.display().to_string(),
                    format!(
                        "this checkpoint is of job {} task {} shard {}, not of job {} task {} shard {shard}: \
                         delete it, or run without --resume to start the unit afresh",
                        s.job_hash, s.task, s.shard, job.hash, task.index
                    )
                ));
            }
            log(&format!(
                "{} (shard {shard}): resuming from {} ({:.2} % done)",
                task.name,
                cp.display(),
                100.0 * layout.done_paths(&s) as f64 / layout.paths(shard).max(1) as f64
            ));
            s
        } else {
            if cp.exists() {
                log(&format!(
                    "{}: starting afresh; the checkpoint {} will be replaced (--resume continues it)",
                    task.name,
                    cp.display()
                ));
            }
            layout.empty_state(job, task, shard)
        };
        units.push(Unit {
            task,
            dir,
            layout,
            state,
        });
    }
    let total: u64 = units.iter().map(|u| u.layout.paths(shard)).sum();
    let done: u64 = units.iter().map(|u| u.layout.done_paths(&u.state)).sum();
    let progress = Progress::new(total, done, options.quiet);
    let count = units.len();
    for (k, unit) in units.iter_mut().enumerate() {
        let Unit {
            task,
            dir,
            layout,
            state,
        } = unit;
        let start = std::time::Instant::now();
        let before = layout.done_paths(state);
        let cp = checkpoint::checkpoint_path(dir, shard);
        let checkpoint = |s: &UnitState| -> atmosim::Result<()> {
            let t = std::time::Instant::now();
            let bytes = checkpoint::write_state(job, s, &cp)?;
            progress.println(&format!(
                "{}: checkpoint {} ({:.1} MB in {:.2} s)",
                task.name,
                cp.display(),
                bytes as f64 / 1e6,
                t.elapsed().as_secs_f64()
            ));
            Ok(())
        };
        let inc = |n: u64| progress.inc(n);
        let grow = |n: u64| progress.grow(n);
        let control = Control {
            stop: &signals::STOP,
            checkpoint_every: options.checkpoint_every,
            checkpoint: &checkpoint,
            progress: &inc,
            allocated: &grow,
        };
        let shared = job.spectral_scene(task);
        let outcome = pool.install(|| work_unit::run(job, task, layout, shared, state, &control))?;
        if let Outcome::Stopped { checkpoint } = outcome {
            let sig = signals::signal();
            progress.finish();
            if checkpoint {
                eprintln!(
                    "{}: stopped by signal {sig}; checkpoint written to {}; rerun with --resume to continue",
                    task.name,
                    cp.display()
                );
            } else {
                eprintln!(
                    "{}: stopped by signal {sig} before any sample was traced; nothing to keep",
                    task.name
                );
            }
            return Err(Interrupted(sig).into());
        }
        let secs = start.elapsed().as_secs_f64();
        let paths = layout.paths(shard) - before;
        let rate = format!(
            "{paths} paths in {secs:.1} s ({:.0} paths/s on {} threads)",
            paths as f64 / secs.max(1e-9),
            pool.current_num_threads()
        );
        if let Some(warning) = state.non_finite_warning(layout, &task.name) {
            progress.println(&warning);
        }
        if shard.is_whole() {
            let info = RunInfo { shards: 1 };
            let note =
                task_output::write(dir, job, task, layout, state, info).map_err(|e| keep_sums(e, job, state, &cp))?;
            progress.println(&format!(
                "[task {}/{}] {}: {rate}; wrote {}{note}",
                k + 1,
                count,
                task.name,
                dir.display()
            ));
        } else {
            let path = checkpoint::shard_path(dir, shard);
            checkpoint::write_state(job, state, &path).map_err(|e| keep_sums(e, job, state, &cp))?;
            progress.println(&format!(
                "[task {}/{}] {} shard {shard}: {rate}; wrote {}",
                k + 1,
                count,
                task.name,
                path.display()
            ));
        }
        // The unit's files are in place: its checkpoint has served.
        match std::fs::remove_file(&cp) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(e).with_context(|| format!("removing {}", cp.display()));
            }
            _ => {
                // Only when empty: other shards' checkpoints may be there.
                if let Some(parent) = cp.parent() {
                    let _ = std::fs::remove_dir(parent);
                }
            }
        }
    }
    progress.finish();
    Ok(())
}

/// A unit's final files could not be written (`error`): keeps its
/// finished sums as a checkpoint at `cp` (or, where that cannot be written
/// either, in the temporary directory), so that `--resume` only writes.
fn keep_sums(error: atmosim::Error, job: &Job, state: &UnitState, cp: &Path) -> anyhow::Error {
    let kept = match checkpoint::write_state(job, state, cp) {
        Ok(_) => format!(
            "the finished sums are kept in {}: remove the cause and rerun with --resume, which only writes the files",
            cp.display()
        ),
        Err(cp_error) => {
            let name = cp
                .file_name()
                .map_or("unit.state".into(), |n| n.to_string_lossy().into_owned());
            let fallback = std::env::temp_dir().join(format!("atmosim-{}-task{}-{name}", job.hash, state.task));
            match checkpoint::write_state(job, state, &fallback) {
                Ok(_) => format!(
                    "the checkpoint could not be written either ({cp_error}); the finished sums are kept in {}: \
                     move it to {} and rerun with --resume",
                    fallback.display(),
                    cp.display()
                ),
                Err(e) => format!("the finished sums could not be kept ({cp_error}; {e})"),
            }
        }
    };
    anyhow::Error::new(error).context(format!("writing the task's files failed; {kept}"))
}
