//! The `atmosim` command: parses the command line, calls the library and
//! maps errors to exit codes (2 for bad input, 1 for anything else).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};

use atmosim::job::Job;
use std::io::IsTerminal;

use atmosim::camera::Camera;
use atmosim::job::{Sensor, Task};
use atmosim::medium::Medium;
use atmosim::sky_image;
use atmosim::{output, plan, render, report, transmittance};
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
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// List a job's tasks with their cost: paths and core-hours estimated
    /// from a short calibration render of the first task.
    Plan {
        /// Job file (TOML).
        job: PathBuf,
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
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress lines on stderr.
        #[arg(long, short)]
        quiet: bool,
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
        #[arg(long)]
        stdout: bool,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress lines on stderr.
        #[arg(long, short)]
        quiet: bool,
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
        } => {
            let job = Job::from_file(&job)?;
            let pool = thread_pool(threads)?;
            let log = |msg: &str| {
                if !quiet {
                    eprintln!("{msg}");
                }
            };
            let base = out.unwrap_or_else(|| job.render.output_directory.clone());
            // One task: the files go in the output directory itself; a grid:
            // one sub-directory per task.
            let task_dir = |task: &Task| {
                if job.tasks.len() == 1 {
                    base.clone()
                } else {
                    base.join(&task.name)
                }
            };
            match &job.render.sensor {
                Sensor::Directions(_) => {
                    for task in &job.tasks {
                        let result = pool.install(|| render::render_task(&job, task, &log));
                        let radiance = output::radiance_csv(&result.radiance);
                        if stdout {
                            let mut out = std::io::stdout().lock();
                            if job.tasks.len() > 1 {
                                writeln!(out, "# task {}", task.name).context("writing to stdout")?;
                            }
                            out.write_all(radiance.as_bytes()).context("writing to stdout")?;
                            out.flush().context("writing to stdout")?;
                        } else {
                            let dir = task_dir(task);
                            output::write_atomic(&dir.join("radiance.csv"), radiance.as_bytes())?;
                            if !result.fluxes.is_empty() {
                                output::write_atomic(
                                    &dir.join("fluxes.csv"),
                                    output::flux_csv(&result.fluxes).as_bytes(),
                                )?;
                            }
                            log(&format!("wrote {}", dir.display()));
                        }
                    }
                }
                Sensor::Image(camera) => {
                    if stdout {
                        anyhow::bail!(atmosim::Error::InvalidValue {
                            file: job.file.clone(),
                            key: "sensor.type".into(),
                            value: "an image sensor".into(),
                            reason: "--stdout prints the CSV of a directions sensor; images are written as files"
                                .into(),
                            valid: "sensor.type = \"directions\" with --stdout".into(),
                        });
                    }
                    render_images(&job, camera, &pool, &task_dir, quiet)?;
                }
            }
        }
        Command::Bench { quick, threads } => {
            let pool = thread_pool(threads)?;
            let samples = if quick { 20_000 } else { 400_000 };
            let mut report = Vec::new();
            pool.install(|| atmosim::bench::run(samples, &mut report))?;
            let mut out = std::io::stdout().lock();
            out.write_all(&report).context("writing to stdout")?;
        }
        Command::Plan { job } => {
            let job = Job::from_file(&job)?;
            let mut out = std::io::stdout().lock();
            plan::write_plan(&job, &mut out).context("writing to stdout")?;
        }
        Command::Transmittance {
            job,
            out,
            threads,
            quiet,
        } => {
            let job = Job::from_file(&job)?;
            let pool = thread_pool(threads)?;
            let base = out.unwrap_or_else(|| job.render.output_directory.clone());
            let tasks = job.transmittance_tasks();
            for (task, name) in &tasks {
                let start = std::time::Instant::now();
                let table = pool.install(|| transmittance_table(&job, task));
                let spec = &job.transmittance;
                let dir = if tasks.len() == 1 {
                    base.clone()
                } else {
                    base.join(name)
                };
                let csv = output::transmittance_csv(&job.wavelengths_nm, &spec.grid, &table, spec.export_sqrt);
                output::write_atomic(&dir.join("transmittance.csv"), csv.as_bytes())?;
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

/// Renders the image tasks of a job, skipping those already complete, with
/// a progress bar on a terminal and plain log lines otherwise.
fn render_images(
    job: &Job,
    camera: &Camera,
    pool: &rayon::ThreadPool,
    task_dir: &dyn Fn(&Task) -> PathBuf,
    quiet: bool,
) -> anyhow::Result<()> {
    let (w, h) = camera.size();
    let layers = (job.render.albedos.len() * job.wavelengths_nm.len()) as u64;
    let per_task = (w * h) as u64 * layers;
    let terminal = std::io::stderr().is_terminal() && !quiet;
    let todo: Vec<&Task> = job
        .tasks
        .iter()
        .filter(|t| {
            let done = sky_image::is_complete(&task_dir(t), job);
            if done && !quiet {
                eprintln!("{}: complete (same job hash), skipped", t.name);
            }
            !done
        })
        .collect();
    let bar = if terminal {
        let bar = ProgressBar::new(per_task * todo.len() as u64);
        bar.set_style(
            ProgressStyle::with_template("{msg} [{bar:30}] {percent:>3}% {per_sec} ETA {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_message("pixels");
        bar.set_draw_target(ProgressDrawTarget::stderr());
        Some(bar)
    } else {
        None
    };
    let progress = |n: u64| {
        if let Some(b) = &bar {
            b.inc(n);
        }
    };
    for (k, task) in todo.iter().enumerate() {
        let log = |msg: &str| match &bar {
            Some(b) => b.println(msg),
            None if !quiet => eprintln!("[task {}/{}] {msg}", k + 1, todo.len()),
            None => {}
        };
        let image = pool.install(|| sky_image::render(job, task, camera, &progress, &log));
        let dir = task_dir(task);
        let exposure = sky_image::write(&dir, job, task, camera, &image)?;
        let note = exposure.map_or(String::new(), |e| format!(" (preview exposure {e:.4e})"));
        log(&format!("wrote {}{note}", dir.display()));
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok(())
}

/// A pool of `threads` workers (all cores when `None`).
fn thread_pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("starting worker threads")
}

fn transmittance_table(job: &Job, task: &atmosim::job::Task) -> transmittance::Table {
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
    /// Worker threads (default: all cores).
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
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

fn run_uvspec(args: UvspecArgs) -> anyhow::Result<()> {
    let input = atmosim::uvspec::UvspecInput::from_file(&args.input)?;
    for w in &input.warnings {
        eprintln!("warning: {w}");
    }
    if args.samples == 0 {
        anyhow::bail!(atmosim::Error::InvalidValue {
            file: "command line".into(),
            key: "--samples".into(),
            value: "0".into(),
            reason: "no samples".into(),
            valid: "at least 1".into(),
        });
    }
    if args.print_job {
        print!("{}", input.job_toml(args.samples, args.seed, args.full_spherical));
        return Ok(());
    }
    let job = input.job(args.samples, args.seed, args.full_spherical)?;
    let pool = thread_pool(args.threads)?;
    let result = pool.install(|| atmosim::uvspec::run(&input, &job))?;
    let text = match args.format {
        UvspecFormat::Uvspec => atmosim::uvspec::format_uvspec(&input, &result),
        UvspecFormat::Csv => atmosim::uvspec::format_csv(&input, &result),
    };
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes()).context("writing to stdout")?;
    out.flush().context("writing to stdout")?;
    Ok(())
}

/// Runs the validation cases; Err (exit 1) when one fails.
fn run_validate(args: ValidateArgs) -> anyhow::Result<()> {
    use atmosim::validate;
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
        anyhow::bail!(atmosim::Error::InvalidValue {
            file: "command line".into(),
            key: "--samples".into(),
            value: "0".into(),
            reason: "no samples".into(),
            valid: "at least 1".into(),
        });
    }
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
