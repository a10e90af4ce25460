//! `atmosim uvspec`: runs a libRadtran uvspec input file and prints
//! uvspec-style output (or the atmosim job it maps to).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use atmosim::compat::uvspec;
use clap::ValueEnum;

use super::common::{no_samples, print_text, thread_pool};

#[derive(clap::Args)]
pub struct UvspecArgs {
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

pub fn run(args: UvspecArgs) -> anyhow::Result<()> {
    let input = uvspec::UvspecInput::from_file(&args.input)?;
    for w in &input.warnings {
        eprintln!("warning: {w}");
    }
    if args.samples == 0 {
        anyhow::bail!(no_samples());
    }
    if args.print_job {
        print_text(&input.job_toml(args.samples, args.seed, args.full_spherical))?;
        return Ok(());
    }
    let job = input.job(args.samples, args.seed, args.full_spherical)?;
    let pool = thread_pool(args.threads)?;
    let result = pool.install(|| uvspec::run(&input, &job))?;
    let text = match args.format {
        UvspecFormat::Uvspec => uvspec::format_uvspec(&input, &result),
        UvspecFormat::Csv => uvspec::format_csv(&input, &result),
    };
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes()).context("writing to stdout")?;
    out.flush().context("writing to stdout")?;
    Ok(())
}
