//! The `atmosim` command: parses the command line, calls the library and
//! maps errors to exit codes (2 for bad input, 1 for anything else).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};

use std::io::IsTerminal;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

use atmosim::atmosphere::report;
use atmosim::io::output;
use atmosim::job::{Job, Sensor, Task};
use atmosim::run::checkpoint::{self, StateFile};
use atmosim::run::out_dir::Destination;
use atmosim::run::shard::Shard;
use atmosim::run::task_output::{self, RunInfo};
use atmosim::run::work_unit::{self, Control, Layout, Outcome, UnitState};
use atmosim::run::{merge, plan};
use atmosim::transport::medium::Medium;
use atmosim::transport::transmittance;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

#[derive(Parser)]
#[command(
    name = "atmosim",
    version,
    about = "Spectral, polarised Monte Carlo path tracer for the Earth's atmosphere"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a libRadtran uvspec input file (a subset of its keywords, see
    /// README) and print uvspec-style output.
    Uvspec(UvspecArgs),
    /// Run validation cases against external references (published
    /// benchmarks, DISORT, libRadtran) and write a report.
    Validate(ValidateArgs),
    /// Print the per-layer optical depths of a job's atmosphere (the built-in
    /// default atmosphere when no job file is given).
    Atmosphere {
        /// Job file (TOML).
        job: Option<PathBuf>,
        /// Output format.
        #[arg(long, value_enum, default_value_t = FormatArg::Table)]
        format: FormatArg,
    },
    /// Time the throughput reference case (US-standard Rayleigh, 550 nm,
    /// 12 directions, polarised); the last line is
    /// `paths_per_second_per_core: <number>`.
    Bench {
        /// A short run (20,000 paths per direction instead of 400,000).
        #[arg(long)]
        quick: bool,
        /// Worker threads (0 or absent: one per available core).
        #[arg(long)]
        threads: Option<usize>,
        /// Also measure the throughput ratios (four albedos, eleven shared
        /// wavelengths and their errors against dedicated runs, the split
        /// and analog estimators against the default, threads vs one),
        /// printed before the last line.
        #[arg(long)]
        ratios: bool,
    },
    /// List a job's tasks with their cost: paths and core-hours estimated
    /// from a short calibration render of the first task.
    Plan {
        /// Job file (TOML).
        job: PathBuf,
        /// Write a SLURM sbatch script for a job array over every unit
        /// (task × shard) to OUT/slurm/render.sbatch instead.
        #[arg(long)]
        slurm: bool,
        /// Shards per task (with --slurm): each task's samples split into N units.
        #[arg(long, default_value_t = 1, requires = "slurm")]
        shards: u64,
        /// Wall time per unit, HH:MM:SS (with --slurm; default: twice the
        /// calibrated estimate plus 10 minutes).
        #[arg(long, requires = "slurm")]
        time: Option<String>,
        /// CPUs per unit (with --slurm).
        #[arg(long, default_value_t = 4, requires = "slurm")]
        cpus: usize,
        /// Output directory (default: the job's `[output] directory`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Minutes between checkpoints of each unit (with --slurm).
        #[arg(long, default_value_t = 10.0, requires = "slurm")]
        checkpoint_every: f64,
    },
    /// Combine the shards (`render --shard K/N`) of every task under an
    /// output directory into the tasks' final files.
    Merge {
        /// The job's output directory.
        out: PathBuf,
        /// No progress lines on stderr.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Transmittance tables T(altitude, ground distance) from the observer,
    /// per task (visibility × observer altitude), all wavelengths at once:
    /// transmittance.csv and transmittance.exr.
    Transmittance {
        /// Job file (TOML).
        job: PathBuf,
        /// Output directory (default: the job's `[output] directory`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads (0 or absent: one per available core).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress lines on stderr.
        #[arg(long, short)]
        quiet: bool,
        /// Write into directories that hold another job's tables, replacing
        /// them (without it such a directory is refused).
        #[arg(long)]
        overwrite: bool,
    },
    /// Render a job: for a `directions` sensor, a CSV of Stokes radiances
    /// per wavelength and direction (radiance.csv) and the fluxes at the
    /// observer level (fluxes.csv).
    Render {
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
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum FormatArg {
    Table,
    Csv,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`atmosim … | head`) is not an error.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        // Stopped by a signal after a checkpoint: exit as the signal would.
        Err(e) if e.downcast_ref::<Interrupted>().is_some() => {
            let sig = e.downcast_ref::<Interrupted>().map_or(15, |i| i.0);
            ExitCode::from((128 + sig).clamp(0, 255) as u8)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            let user = e
                .chain()
                .find_map(|c| c.downcast_ref::<atmosim::Error>())
                .is_some_and(atmosim::Error::is_user_error);
            ExitCode::from(if user { 2 } else { 1 })
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render {
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
        } => {
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
                checkpoint_every: (checkpoint_every > 0.0)
                    .then(|| std::time::Duration::from_secs_f64(checkpoint_every * 60.0)),
                quiet,
            };
            render_units(&job, &tasks, &destination, &pool, &options)?;
        }
        Command::Merge { out, quiet } => {
            let merged = atmosim::run::merge::merge(&out, &|msg: &str| {
                if !quiet {
                    eprintln!("{msg}");
                }
            })?;
            if !quiet {
                eprintln!(
                    "merged {} tasks × {} shards of job {}",
                    merged.tasks, merged.shards, merged.job_hash
                );
            }
        }
        Command::Bench { quick, threads, ratios } => {
            let pool = thread_pool(threads)?;
            let samples = if quick { 20_000 } else { 400_000 };
            let mut report = Vec::new();
            if ratios {
                let serial = thread_pool(Some(1))?;
                pool.install(|| atmosim::run::bench::ratios(samples, &serial, &mut report))?;
            }
            pool.install(|| atmosim::run::bench::run(samples, &mut report))?;
            let mut out = std::io::stdout().lock();
            out.write_all(&report).context("writing to stdout")?;
        }
        Command::Plan {
            job: job_path,
            slurm,
            shards,
            time,
            cpus,
            out,
            checkpoint_every,
        } => {
            let job = Job::from_file(&job_path)?;
            if slurm {
                write_slurm(&job, &job_path, out, shards, time, cpus, checkpoint_every)?;
            } else {
                let mut out = std::io::stdout().lock();
                plan::write_plan(&job, &mut out).context("writing to stdout")?;
            }
        }
        Command::Transmittance {
            job,
            out,
            threads,
            quiet,
            overwrite,
        } => {
            let job = Job::from_file(&job)?;
            let pool = thread_pool(threads)?;
            let destination = Destination::of(&job, out.as_deref());
            let base = destination.dir.clone();
            let tasks = job.transmittance_tasks();
            let dir_of = |name: &str| {
                if tasks.len() == 1 {
                    base.clone()
                } else {
                    base.join(name)
                }
            };
            destination.check_writable()?;
            let dirs: Vec<PathBuf> = tasks.iter().map(|(_, name)| dir_of(name)).collect();
            destination.check_not_another_job(&job, &dirs, overwrite)?;
            for (task, name) in &tasks {
                let start = std::time::Instant::now();
                let table = pool.install(|| transmittance_table(&job, task));
                let spec = &job.transmittance;
                let dir = dir_of(name);
                let csv = output::transmittance_csv(&job.wavelengths_nm, &spec.grid, &table, spec.export_sqrt);
                atmosim::io::atomic::write_atomic(&dir.join("transmittance.csv"), csv.as_bytes())?;
                output::write_transmittance_exr(
                    &dir.join("transmittance.exr"),
                    &job.wavelengths_nm,
                    &spec.grid,
                    &table,
                    spec.export_sqrt,
                    &transmittance_attributes(&job, task, name),
                )?;
                if !quiet {
                    let secs = start.elapsed().as_secs_f64();
                    eprintln!(
                        "{}: {} points × {} wavelengths in {secs:.2} s ({:.0} points/s, {}) → {}",
                        name,
                        spec.grid.len(),
                        job.wavelengths_nm.len(),
                        spec.grid.len() as f64 / secs,
                        spec.estimator.name(),
                        dir.display()
                    );
                }
            }
        }
        Command::Atmosphere { job, format } => {
            let job = load_job(job.as_ref())?;
            let format = match format {
                FormatArg::Table => report::Format::Table,
                FormatArg::Csv => report::Format::Csv,
            };
            let stdout = std::io::stdout();
            let mut out = stdout.lock();
            report::write_atmosphere(&job.atmosphere, format, &mut out).context("writing to stdout")?;
            out.flush().context("writing to stdout")?;
        }
        Command::Uvspec(args) => run_uvspec(args)?,
        Command::Validate(args) => return run_validate(args),
    }
    Ok(())
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

/// Set by SIGTERM or SIGINT: stop after the current wave, with a checkpoint.
static STOP: AtomicBool = AtomicBool::new(false);
/// The signal that set [`STOP`].
static SIGNAL: AtomicUsize = AtomicUsize::new(0);

/// A render stopped by a signal after writing its checkpoint; the process
/// exits with 128 + the signal's number, as if killed by it.
#[derive(Debug)]
struct Interrupted(i32);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "stopped by signal {}", self.0)
    }
}

impl std::error::Error for Interrupted {}

/// The first SIGTERM or SIGINT asks for a clean stop; a second one exits at once.
fn catch_signals() -> anyhow::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    for sig in [SIGTERM, SIGINT] {
        signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, &STOP)
            .context("installing signal handlers")?;
        signal_hook::flag::register_usize(sig, &SIGNAL, sig as usize).context("installing signal handlers")?;
        signal_hook::flag::register(sig, &STOP).context("installing signal handlers")?;
    }
    Ok(())
}

/// The task index of `--task`: a number or `env` ($SLURM_ARRAY_TASK_ID).
fn task_index(job: &Job, arg: &str) -> anyhow::Result<usize> {
    let invalid = |value: String, reason: &str| atmosim::Error::InvalidValue {
        file: "command line".into(),
        key: "--task".into(),
        value,
        reason: reason.into(),
        valid: format!(
            "a task index from 0 to {} (as `atmosim plan` lists them) or `env`",
            job.tasks.len() - 1
        ),
    };
    let text = if arg == "env" {
        std::env::var("SLURM_ARRAY_TASK_ID").map_err(|_| {
            invalid(
                "env".into(),
                "$SLURM_ARRAY_TASK_ID is not set (not inside a SLURM job array)",
            )
        })?
    } else {
        arg.to_string()
    };
    let i: usize = text
        .trim()
        .parse()
        .map_err(|_| invalid(text.clone(), "not a task index"))?;
    if i >= job.tasks.len() {
        anyhow::bail!(invalid(text, &format!("the job has {} tasks", job.tasks.len())));
    }
    Ok(i)
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
    catch_signals()?;
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
        let layout = Layout::new(job, task, job.spectral_scene(task).is_some());
        let cp = checkpoint::checkpoint_path(&dir, shard);
        let state = if options.resume && cp.exists() {
            let f = StateFile::read(&cp)?;
            let s = f.state;
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
        let control = Control {
            stop: &STOP,
            checkpoint_every: options.checkpoint_every,
            checkpoint: &checkpoint,
            progress: &inc,
        };
        let shared = job.spectral_scene(task);
        let outcome = pool.install(|| work_unit::run(job, task, layout, shared, state, &control))?;
        if let Outcome::Stopped { checkpoint } = outcome {
            let sig = SIGNAL.load(Ordering::SeqCst) as i32;
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

/// Progress of a render: a bar on a terminal, else a line a minute.
struct Progress {
    bar: Option<ProgressBar>,
    quiet: bool,
    total: u64,
    done: AtomicU64,
    start: std::time::Instant,
    last_line: std::sync::Mutex<std::time::Instant>,
}

impl Progress {
    fn new(total: u64, done: u64, quiet: bool) -> Progress {
        let bar = (std::io::stderr().is_terminal() && !quiet).then(|| {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template("{msg} [{bar:30}] {percent:>3}% {per_sec} ETA {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message("paths");
            bar.set_draw_target(ProgressDrawTarget::stderr());
            bar.set_position(done);
            bar
        });
        Progress {
            bar,
            quiet,
            total,
            done: AtomicU64::new(done),
            start: std::time::Instant::now(),
            last_line: std::sync::Mutex::new(std::time::Instant::now()),
        }
    }

    fn inc(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        if let Some(b) = &self.bar {
            b.inc(n);
        } else if !self.quiet
            && let Ok(mut last) = self.last_line.lock()
            && last.elapsed().as_secs() >= 60
        {
            *last = std::time::Instant::now();
            let secs = self.start.elapsed().as_secs_f64();
            eprintln!(
                "progress: {:.1} % of {} paths, {:.0} s elapsed",
                100.0 * done as f64 / self.total.max(1) as f64,
                self.total,
                secs
            );
        }
    }

    fn println(&self, msg: &str) {
        match &self.bar {
            Some(b) => b.println(msg),
            None if !self.quiet => eprintln!("{msg}"),
            None => {}
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// `plan --slurm`: writes OUT/slurm/render.sbatch and the log directory.
fn write_slurm(
    job: &Job,
    job_path: &Path,
    out: Option<PathBuf>,
    shards: u64,
    time: Option<String>,
    cpus: usize,
    checkpoint_every: f64,
) -> anyhow::Result<()> {
    let invalid = |key: &str, value: String, valid: &str| atmosim::Error::InvalidValue {
        file: "command line".into(),
        key: key.into(),
        value,
        reason: "out of range".into(),
        valid: valid.into(),
    };
    if shards == 0 {
        anyhow::bail!(invalid("--shards", "0".into(), "1 or more"));
    }
    if cpus == 0 {
        anyhow::bail!(invalid("--cpus", "0".into(), "1 or more"));
    }
    if !(checkpoint_every.is_finite() && checkpoint_every >= 0.0) {
        anyhow::bail!(invalid(
            "--checkpoint-every",
            format!("{checkpoint_every}"),
            "0 or more minutes"
        ));
    }
    if let Some(t) = &time
        && plan::time_seconds(t).is_none()
    {
        anyhow::bail!(invalid(
            "--time",
            t.clone(),
            "a SLURM time limit such as 04:00:00 or 1-12:00:00"
        ));
    }
    let absolute = |p: &Path| -> anyhow::Result<PathBuf> {
        Ok(if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::env::current_dir()
                .context("reading the current directory")?
                .join(p)
        })
    };
    let out_dir = absolute(&out.unwrap_or_else(|| job.render.output_directory.clone()))?;
    let options = plan::SlurmOptions {
        exe: std::env::current_exe().context("locating the atmosim binary")?,
        job_file: std::fs::canonicalize(job_path).with_context(|| format!("resolving {}", job_path.display()))?,
        out_dir: out_dir.clone(),
        shards,
        cpus,
        time: time.clone(),
        checkpoint_minutes: checkpoint_every,
    };
    let (time, estimate) = match time {
        Some(t) => (t, None),
        None => {
            let calibration = plan::calibrate(job);
            let secs = plan::unit_seconds(job, shards, &calibration, cpus);
            (plan::hms(secs), Some(calibration))
        }
    };
    let script = plan::slurm_script(job, &options, &time);
    let logs = out_dir.join("slurm").join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let path = out_dir.join("slurm").join("render.sbatch");
    atmosim::io::atomic::write_atomic(&path, script.as_bytes())?;
    let units = plan::units(job, shards);
    if units > 1001 {
        eprintln!(
            "note: {units} units exceed SLURM's default MaxArraySize (1001); submit in slices with ATMOSIM_UNIT_OFFSET (see the script's header)"
        );
    }
    if let Some(calibration) = estimate {
        let hours = calibration.max_task_core_seconds(job) / 3600.0;
        eprintln!(
            "time per unit {time}: twice the estimate of the dearest task ({hours:.1} core-hours, rates calibrated \
             per class of sun elevation) over {shards} shards on {cpus} cpus, plus 10 minutes"
        );
    }
    println!("{}", path.display());
    eprintln!(
        "{units} units ({} tasks × {shards} shards); submit with: sbatch {}",
        job.tasks.len(),
        path.display()
    );
    Ok(())
}

/// A pool of `threads` workers (one per available core when `None` or 0).
fn thread_pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("starting worker threads")
}

fn transmittance_table(job: &Job, task: &atmosim::job::Task) -> transmittance::Table {
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

/// Metadata of a transmittance EXR: everything needed to interpret it.
fn transmittance_attributes(job: &Job, task: &atmosim::job::Task, name: &str) -> Vec<(String, String)> {
    let spec = &job.transmittance;
    let list = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ");
    vec![
        ("atmosim_version".into(), env!("CARGO_PKG_VERSION").into()),
        ("job_hash".into(), job.hash.clone()),
        ("task".into(), name.to_string()),
        (
            "quantity".into(),
            "transmittance from the observer along the straight line of sight, no refraction".into(),
        ),
        (
            "units".into(),
            "1 (T, T_se, sqrtT); blocked: 1 if the line of sight passes below the ground".into(),
        ),
        (
            "layout".into(),
            "x (columns) = ground distance nodes, y (rows) = altitude nodes, row 0 = lowest altitude".into(),
        ),
        ("grid".into(), spec.grid.definition.clone()),
        ("altitudes_km".into(), list(&spec.grid.altitudes_km)),
        ("distances_km".into(), list(&spec.grid.distances_km)),
        ("wavelengths_nm".into(), list(&job.wavelengths_nm)),
        ("band_width_nm".into(), list(&job.band_widths_nm)),
        ("observer_altitude_km".into(), format!("{}", task.observer_altitude_km)),
        (
            "visibility_km".into(),
            task.atmosphere
                .visibility
                .map_or("none".into(), |v| format!("{}", v.ground_km)),
        ),
        ("planet_radius_km".into(), format!("{}", job.planet.radius_km)),
        ("top_km".into(), format!("{}", job.planet.top_km)),
        ("estimator".into(), spec.estimator.name().into()),
        ("samples".into(), format!("{}", spec.samples)),
        ("seed".into(), format!("{}", job.render.seed)),
    ]
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain()
        .find_map(|c| c.downcast_ref::<std::io::Error>())
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}

fn load_job(path: Option<&PathBuf>) -> anyhow::Result<Job> {
    Ok(match path {
        Some(p) => Job::from_file(p)?,
        None => Job::builtin_default()?,
    })
}

#[derive(clap::Args)]
struct UvspecArgs {
    /// uvspec input file.
    input: PathBuf,
    /// Output format: uvspec's text blocks or one CSV row per value.
    #[arg(long, value_enum, default_value_t = UvspecFormat::Uvspec)]
    format: UvspecFormat,
    /// Paths per direction (and per flux estimate).
    #[arg(long, default_value_t = 100_000)]
    samples: u64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run `pseudospherical` inputs in full spherical geometry instead of
    /// atmosim's pseudo-spherical one (which reproduces uvspec).
    #[arg(long)]
    full_spherical: bool,
    /// Print the atmosim job the input maps to and stop.
    #[arg(long)]
    print_job: bool,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
}

#[derive(Clone, Copy, ValueEnum)]
enum UvspecFormat {
    Uvspec,
    Csv,
}

#[derive(clap::Args)]
struct ValidateArgs {
    /// Cases to run (see --list).
    cases: Vec<String>,
    /// Run every case.
    #[arg(long)]
    all: bool,
    /// List the cases and stop.
    #[arg(long)]
    list: bool,
    /// Paths per direction for every case (default: each case's own, sized for CI).
    #[arg(long)]
    samples: Option<u64>,
    /// Directory for report.md and the plots.
    #[arg(long, default_value = "validation-report")]
    out: PathBuf,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
}

fn run_uvspec(args: UvspecArgs) -> anyhow::Result<()> {
    let input = atmosim::compat::uvspec::UvspecInput::from_file(&args.input)?;
    for w in &input.warnings {
        eprintln!("warning: {w}");
    }
    if args.samples == 0 {
        anyhow::bail!(no_samples());
    }
    if args.print_job {
        print!("{}", input.job_toml(args.samples, args.seed, args.full_spherical));
        return Ok(());
    }
    let job = input.job(args.samples, args.seed, args.full_spherical)?;
    let pool = thread_pool(args.threads)?;
    let result = pool.install(|| atmosim::compat::uvspec::run(&input, &job))?;
    let text = match args.format {
        UvspecFormat::Uvspec => atmosim::compat::uvspec::format_uvspec(&input, &result),
        UvspecFormat::Csv => atmosim::compat::uvspec::format_csv(&input, &result),
    };
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes()).context("writing to stdout")?;
    out.flush().context("writing to stdout")?;
    Ok(())
}

/// The error for `--samples 0`.
fn no_samples() -> atmosim::Error {
    atmosim::Error::InvalidValue {
        file: "command line".into(),
        key: "--samples".into(),
        value: "0".into(),
        reason: "no samples".into(),
        valid: "at least 1".into(),
    }
}

/// Runs the validation cases; Err (exit 1) when one fails.
fn run_validate(args: ValidateArgs) -> anyhow::Result<()> {
    use atmosim::compat::validate;
    if args.list {
        for c in validate::cases() {
            let kind = if c.informational { " (informational)" } else { "" };
            println!("{:<24} {}{kind}", c.name, c.title);
        }
        return Ok(());
    }
    let cases = if args.all {
        validate::cases()
    } else if args.cases.is_empty() {
        anyhow::bail!(atmosim::Error::InvalidValue {
            file: "command line".into(),
            key: "CASE".into(),
            value: "(none)".into(),
            reason: "no case named".into(),
            valid: "one or more case names (atmosim validate --list) or --all".into(),
        });
    } else {
        args.cases
            .iter()
            .map(|name| {
                validate::find(name).ok_or_else(|| atmosim::Error::InvalidValue {
                    file: "command line".into(),
                    key: "CASE".into(),
                    value: name.clone(),
                    reason: "unknown case".into(),
                    valid: validate::cases().iter().map(|c| c.name).collect::<Vec<_>>().join(", "),
                })
            })
            .collect::<Result<Vec<_>, _>>()?
    };
    if args.samples == Some(0) {
        anyhow::bail!(no_samples());
    }
    atmosim::run::out_dir::Destination {
        dir: args.out.clone(),
        file: "command line".into(),
        key: "--out".into(),
    }
    .check_writable()?;
    let pool = thread_pool(args.threads)?;
    let mut results = Vec::with_capacity(cases.len());
    for case in &cases {
        let r = pool.install(|| validate::run(case, args.samples))?;
        println!("{}", validate::summary(&r));
        results.push(r);
    }
    validate::write_report(&args.out, &results)?;
    println!("\n{}", validate::TABLE_HEADER);
    for r in &results {
        println!("{}", validate::report_row(r));
    }
    println!("wrote {}", args.out.join("report.md").display());
    let failed: Vec<&str> = results
        .iter()
        .filter(|r| r.verdict == validate::Verdict::Fail)
        .map(|r| r.case.name)
        .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        anyhow::bail!("{} validation case(s) failed: {}", failed.len(), failed.join(", "))
    }
}
