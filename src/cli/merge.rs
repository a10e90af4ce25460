//! `atmosim merge`: combines the shards of every task under an output
//! directory into the tasks' final files.

use std::path::PathBuf;

#[derive(clap::Args)]
pub struct MergeArgs {
    /// The job's output directory.
    out: PathBuf,
    /// No progress lines on stderr.
    #[arg(long, short)]
    quiet: bool,
}

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    let MergeArgs { out, quiet } = args;
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
    Ok(())
}
