//! The `atmosim` command: parses the command line, calls the library and
//! maps errors to exit codes (2 for bad input, 1 for anything else).

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use cli::signals::Interrupted;

#[derive(Parser)]
#[command(
    name = "atmosim",
    version,
    about = "Spectral, polarised Monte Carlo path tracer for the Earth's atmosphere: skies as Stokes vectors per wavelength (the book: docs/README.md)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Makes uvspec-style output from a libRadtran uvspec input file (docs/uvspec.md).
    Uvspec(cli::uvspec::UvspecArgs),
    /// Makes a report and plots of validation cases against their references (docs/validation.md).
    Validate(cli::validate::ValidateArgs),
    /// Prints the per-layer optical depths of a job's atmosphere, or the default one (docs/atmosphere.md).
    Atmosphere(cli::atmosphere::AtmosphereArgs),
    /// Prints the throughput of the reference case, or with --grid the sky model grid's cost (docs/performance.md).
    Bench(cli::bench::BenchArgs),
    /// Prints a job's tasks with their paths and core-hours; with --slurm writes an array script (docs/clusters.md).
    Plan(cli::plan::PlanArgs),
    /// Makes the final files of tasks rendered in shards (`render --shard K/N`) (docs/clusters.md).
    Merge(cli::merge::MergeArgs),
    /// Makes transmittance tables T(altitude, distance) from the observer: CSV and EXR (docs/transmittance.md).
    Transmittance(cli::transmittance::TransmittanceArgs),
    /// Makes Stokes images (EXR, PNG previews) or radiance and flux CSVs of a job's tasks (docs/outputs.md).
    Render(cli::render::RenderArgs),
    /// Makes a Prague sky model dataset from rendered skies, settings in FIT.toml (docs/sky-models.md).
    Fit(cli::fit::FitArgs),
    /// Makes images of a sky model dataset, or answers a CSV of queries, as its runtime does (docs/sky-models.md).
    Eval(cli::eval::EvalArgs),
    /// Makes a Markdown report of a fitted dataset against its renders (docs/sky-models.md).
    FitReport(cli::fit_report::FitReportArgs),
    /// Makes the OPAC components' Mie tables in atmospheres/opac/mie/ (docs/atmosphere.md).
    OpacTables(cli::opac_tables::OpacTablesArgs),
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
        Command::Render(args) => cli::render::run(args),
        Command::Fit(args) => cli::fit::run(args),
        Command::Eval(args) => cli::eval::run(args),
        Command::FitReport(args) => cli::fit_report::run(args),
        Command::Merge(args) => cli::merge::run(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::Plan(args) => cli::plan::run(args),
        Command::Transmittance(args) => cli::transmittance::run(args),
        Command::Atmosphere(args) => cli::atmosphere::run(args),
        Command::Uvspec(args) => cli::uvspec::run(args),
        Command::Validate(args) => cli::validate::run(args),
        Command::OpacTables(args) => cli::opac_tables::run(args),
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain()
        .find_map(|c| c.downcast_ref::<std::io::Error>())
        .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
}
