//! The `atmosim` command: parses the command line, calls the library and
//! maps errors to exit codes (2 for bad input, 1 for anything else).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};

use atmosim::job::Job;
use atmosim::report;

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
    /// Print the per-layer optical depths of a job's atmosphere (the built-in
    /// default atmosphere when no job file is given).
    Atmosphere {
        /// Job file (TOML).
        job: Option<PathBuf>,
        /// Output format.
        #[arg(long, value_enum, default_value_t = FormatArg::Table)]
        format: FormatArg,
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
        Command::Atmosphere { job, format } => {
            let job = load_job(job.as_ref())?;
            let format = match format {
                FormatArg::Table => report::Format::Table,
                FormatArg::Csv => report::Format::Csv,
            };
            let stdout = std::io::stdout();
            let mut out = stdout.lock();
            report::write_atmosphere(&job.atmosphere, format, &mut out)
                .context("writing to stdout")?;
            out.flush().context("writing to stdout")?;
        }
    }
    Ok(())
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
