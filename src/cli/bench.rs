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
}

pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let BenchArgs { quick, threads, ratios } = args;
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
    Ok(())
}
