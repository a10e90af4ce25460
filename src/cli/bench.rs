//! `atmosim bench`: times the throughput reference case and, on request,
//! the throughput ratios.

use std::io::Write;

use anyhow::Context;

use super::common::thread_pool;

#[derive(clap::Args)]
pub struct BenchArgs {
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
    /// Instead, the sky model grid's benchmark: a subset of the tasks of
    /// examples/sky_model_grid.toml at 64×32 (with --quick a smaller
    /// subset), to that job's noise target, priced at its resolution; the
    /// last line is `grid_core_hours_per_task: <mean> <max>`.
    #[arg(long, conflicts_with = "ratios")]
    grid: bool,
    /// Instead, the figure-of-merit suite: seven single-direction cases
    /// (day, low sun with its aureole, twilight, from 15 km, 11 bands × 4
    /// albedos, a 1000-level profile, Mie aerosol), per direction the FOM
    /// of I and Q, 1 / (relative variance × core-seconds); the last line
    /// is `suite_cases: <count>` (docs/performance.md).
    #[arg(long, conflicts_with_all = ["ratios", "grid"])]
    suite: bool,
    /// With --suite: only this case (repeat for several).
    #[arg(long = "case", value_name = "NAME", requires = "suite")]
    cases: Vec<String>,
    /// With --suite: write the cases' job files (and the 1000-level
    /// profile they read) into DIR and render nothing, to pair two builds
    /// on them with scripts/bench_pair.py.
    #[arg(long, value_name = "DIR", requires = "suite")]
    write_jobs: Option<std::path::PathBuf>,
    /// With --grid: render every task with this many samples per pixel
    /// instead of to the noise target (priced the same way).
    #[arg(long, requires = "grid", value_parser = clap::value_parser!(u64).range(2..=1_048_576))]
    samples: Option<u64>,
    /// With --grid: the former yardstick instead, each pixel's relative
    /// error (median 0.5 %, 99th percentile 2 %) at 1024×512, for reference
    /// images rather than a sky model's renders.
    #[arg(long, requires = "grid", conflicts_with = "samples")]
    per_pixel: bool,
    /// With --grid: only the tasks whose name contains PATTERN (repeat
    /// for several; names as printed, e.g. `elev-04.2` or
    /// `vis020.0_elev+10.0_alt15000m`); the last line is over those.
    #[arg(long = "task", value_name = "PATTERN", requires = "grid")]
    tasks: Vec<String>,
    /// With --grid: the render seed (`render.seed`) of every task, 1 by
    /// default; another seed renders other paths, so a comparison can be
    /// repeated on independent realisations.
    #[arg(long, requires = "grid", default_value_t = 1)]
    seed: u64,
}

pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let BenchArgs {
        quick,
        threads,
        ratios,
        grid,
        suite,
        cases,
        write_jobs,
        samples: fixed,
        per_pixel,
        tasks,
        seed,
    } = args;
    if let Some(dir) = write_jobs {
        let written = atmosim::run::bench_suite::write_jobs(&dir, quick)?;
        println!("wrote {} job files to {}", written.len(), dir.display());
        return Ok(());
    }
    let pool = thread_pool(threads)?;
    if suite {
        let dir = std::env::temp_dir().join(format!("atmosim-suite-{}", std::process::id()));
        let mut out = std::io::stdout();
        let result = pool.install(|| atmosim::run::bench_suite::run(&dir, quick, &cases, &mut out));
        let _ = std::fs::remove_dir_all(&dir);
        result?;
        return Ok(());
    }
    if grid {
        // Unlocked: each task's line appears when it is done.
        let mut out = std::io::stdout();
        use atmosim::run::grid_bench::{Mode, run};
        let mode = match (fixed, per_pixel) {
            (Some(n), _) => Mode::Fixed(n),
            (None, true) => Mode::PerPixel,
            (None, false) => Mode::Grid,
        };
        pool.install(|| run(quick, mode, seed, &tasks, &mut out))?;
        return Ok(());
    }
    let samples = if quick { 20_000 } else { 400_000 };
    let mut report = Vec::new();
    if ratios {
        let serial = thread_pool(Some(1))?;
        pool.install(|| atmosim::run::bench::ratios(samples, &serial, &mut report))?;
    }
    pool.install(|| atmosim::run::bench::run(samples, &mut report))?;
    let mut out = std::io::stdout().lock();
    out.write_all(&report).context("writing to stdout")?;
    Ok(())
}
