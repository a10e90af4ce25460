//! Pieces the subcommands share: the worker pool, loading a job, the
//! `--task` index, the `--samples 0` error and writing to stdout.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use atmosim::job::Job;

/// A pool of `threads` workers (one per available core when `None` or 0).
pub fn thread_pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("starting worker threads")
}

/// The job in `path`, or the built-in default job when there is none.
pub fn load_job(path: Option<&PathBuf>) -> anyhow::Result<Job> {
    Ok(match path {
        Some(p) => Job::from_file(p)?,
        None => Job::builtin_default()?,
    })
}

/// The task index of `--task`: a number or `env` ($SLURM_ARRAY_TASK_ID).
pub fn task_index(job: &Job, arg: &str) -> anyhow::Result<usize> {
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

/// The error for `--samples 0`.
pub fn no_samples() -> atmosim::Error {
    atmosim::Error::InvalidValue {
        file: "command line".into(),
        key: "--samples".into(),
        value: "0".into(),
        reason: "no samples".into(),
        valid: "at least 1".into(),
    }
}

/// Writes `text` to stdout. A reader that has gone away (`| head`) gives a
/// broken-pipe error, which `main` ends quietly with success, where
/// `print!` would panic.
pub fn print_text(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .context("writing to stdout")
}
