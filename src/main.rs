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
    Uvspec(cli::uvspec::UvspecArgs),
    /// Run validation cases against external references (published
    /// benchmarks, DISORT, libRadtran) and write a report.
    Validate(cli::validate::ValidateArgs),
    /// Print the per-layer optical depths of a job's atmosphere (the built-in
    /// default atmosphere when no job file is given).
    Atmosphere(cli::atmosphere::AtmosphereArgs),
    /// Time the throughput reference case (US-standard Rayleigh, 550 nm,
    /// 12 directions, polarised); the last line is
    /// `paths_per_second_per_core: <number>`.
    Bench(cli::bench::BenchArgs),
    /// List a job's tasks with their cost: paths and core-hours estimated
    /// from a short calibration render of the first task.
    Plan(cli::plan::PlanArgs),
    /// Combine the shards (`render --shard K/N`) of every task under an
    /// output directory into the tasks' final files.
    Merge(cli::merge::MergeArgs),
    /// Transmittance tables T(altitude, ground distance) from the observer,
    /// per task (visibility × observer altitude), all wavelengths at once:
    /// transmittance.csv and transmittance.exr.
    Transmittance(cli::transmittance::TransmittanceArgs),
    /// Render a job: for a `directions` sensor, a CSV of Stokes radiances
    /// per wavelength and direction (radiance.csv) and the fluxes at the
    /// observer level (fluxes.csv).
    Render(cli::render::RenderArgs),
    /// Fit rendered skies and transmittance tables into a dataset file the
    /// Prague sky model's runtime reads (settings in FIT.toml).
    Fit(cli::fit::FitArgs),
    /// Evaluate a sky-model dataset with the runtime's semantics: a
    /// summary, answers to a CSV of queries, or sphere/fisheye images.
    Eval(cli::eval::EvalArgs),
    /// Compare a fitted dataset with its renders: SNR, errors by axis,
    /// interpolation ratio, transmittance error; a Markdown report.
    FitReport(cli::fit_report::FitReportArgs),
    /// Compute the OPAC components' Mie tables (k_ext, ssa, g and phase
    /// matrices at every tabulated humidity, 300-800 nm) into
    /// atmospheres/opac/mie/ (see README).
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
