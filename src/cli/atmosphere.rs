//! `atmosim atmosphere`: prints the per-layer optical depths of a job's
//! atmosphere (or the built-in default's).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use atmosim::atmosphere::report;
use clap::ValueEnum;

use super::common::load_job;

#[derive(clap::Args)]
pub struct AtmosphereArgs {
    /// Job file (TOML).
    job: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = FormatArg::Table)]
    format: FormatArg,
}

#[derive(Clone, Copy, ValueEnum)]
enum FormatArg {
    Table,
    Csv,
}

pub fn run(args: AtmosphereArgs) -> anyhow::Result<()> {
    let job = load_job(args.job.as_ref())?;
    let format = match args.format {
        FormatArg::Table => report::Format::Table,
        FormatArg::Csv => report::Format::Csv,
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    report::write_atmosphere(&job.atmosphere, &job.band_widths_nm, format, &mut out).context("writing to stdout")?;
    out.flush().context("writing to stdout")?;
    Ok(())
}
