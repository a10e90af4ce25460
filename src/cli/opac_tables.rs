//! `atmosim opac-tables`: computes the OPAC components' Mie tables (optics
//! and phase matrices, `physics::mie::generate`) and writes them, each
//! component's files as soon as all its jobs are done.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::Context;
use atmosim::io::atomic::write_atomic;
use atmosim::physics::mie::generate::{TABLE_DIR, TableJob, TableResult, component_files, table_jobs};
use atmosim::physics::mie::opac::COMPONENTS;

use super::common::thread_pool;

#[derive(clap::Args)]
pub struct OpacTablesArgs {
    /// Output directory.
    #[arg(long, default_value = TABLE_DIR)]
    out: PathBuf,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
    /// Components to compute, separated by commas (default: all ten, inso,
    /// waso, soot, ssam, sscm, minm, miam, micm, mitr, suso).
    #[arg(long, value_delimiter = ',')]
    components: Option<Vec<String>>,
    /// No progress lines on stderr.
    #[arg(long, short)]
    quiet: bool,
}

/// The jobs' results so far, and how many each component still lacks.
struct Collected {
    results: Vec<TableResult>,
    missing: Vec<(&'static str, usize)>,
    done: usize,
}

pub fn run(args: OpacTablesArgs) -> anyhow::Result<()> {
    let OpacTablesArgs {
        out,
        threads,
        components,
        quiet,
    } = args;
    let components = match components {
        Some(names) => parse_components(&names)?,
        None => COMPONENTS.to_vec(),
    };
    let jobs = table_jobs(&components)?;
    let pool = thread_pool(threads)?;
    let start = Instant::now();
    let collected = Mutex::new(Collected {
        results: Vec::with_capacity(jobs.len()),
        missing: components
            .iter()
            .map(|&c| (c, jobs.iter().filter(|j| j.component == c).count()))
            .collect(),
        done: 0,
    });
    // Workers take the jobs in order, most expensive first, from one
    // counter, so the longest jobs start first and none is left at the end.
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let first_error: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    pool.scope(|scope| {
        for _ in 0..pool.current_num_threads() {
            scope.spawn(|_| {
                while !failed.load(Ordering::Relaxed) {
                    let Some(job) = jobs.get(next.fetch_add(1, Ordering::Relaxed)) else {
                        break;
                    };
                    if let Err(e) = run_job(job, &collected, &out, jobs.len(), start, quiet) {
                        failed.store(true, Ordering::Relaxed);
                        if let Ok(mut slot) = first_error.lock() {
                            slot.get_or_insert(e);
                        }
                    }
                }
            });
        }
    });
    if let Some(e) = first_error.into_inner().ok().flatten() {
        return Err(e);
    }
    if !quiet {
        eprintln!(
            "opac-tables: {} tables of {} components in {:.0} s, written to {}",
            jobs.len(),
            components.len(),
            start.elapsed().as_secs_f64(),
            out.display()
        );
    }
    Ok(())
}

/// Runs one job, records it and, when it completes its component, writes
/// that component's files.
fn run_job(
    job: &TableJob,
    collected: &Mutex<Collected>,
    out: &Path,
    total: usize,
    start: Instant,
    quiet: bool,
) -> anyhow::Result<()> {
    let job_start = Instant::now();
    let optics = job.run().with_context(|| {
        format!(
            "computing {} at {} % and {} nm",
            job.component, job.rh_pct, job.wavelength_nm
        )
    })?;
    let seconds = job_start.elapsed().as_secs_f64();
    let (done, complete) = {
        let mut c = collected.lock().map_err(|_| anyhow::anyhow!("another worker failed"))?;
        c.results.push(TableResult { job: *job, optics });
        c.done += 1;
        let done = c.done;
        let mut complete = None;
        if let Some(m) = c.missing.iter_mut().find(|m| m.0 == job.component) {
            m.1 -= 1;
            if m.1 == 0 {
                let (mine, rest) = std::mem::take(&mut c.results)
                    .into_iter()
                    .partition(|r| r.job.component == job.component);
                c.results = rest;
                complete = Some(mine);
            }
        }
        (done, complete)
    };
    if !quiet {
        eprintln!(
            "opac-tables: {done}/{total} tables, {:.0} s elapsed ({} {} % {} nm: {seconds:.1} s)",
            start.elapsed().as_secs_f64(),
            job.component,
            job.rh_pct,
            job.wavelength_nm
        );
    }
    if let Some(results) = complete {
        let files = component_files(job.component, &results)?;
        for f in &files {
            write_atomic(&out.join(&f.name), f.text.as_bytes())?;
        }
        if !quiet {
            eprintln!(
                "opac-tables: {}: wrote {} files to {}",
                job.component,
                files.len(),
                out.display()
            );
        }
    }
    Ok(())
}

/// The components of `--components`, checked against the OPAC names
/// (duplicates dropped).
fn parse_components(names: &[String]) -> anyhow::Result<Vec<&'static str>> {
    let invalid = |value: &str, reason: &str| atmosim::Error::InvalidValue {
        file: "command line".into(),
        key: "--components".into(),
        value: value.into(),
        reason: reason.into(),
        valid: format!("a comma-separated list of {}", COMPONENTS.join(", ")),
    };
    let mut out: Vec<&'static str> = Vec::new();
    for name in names {
        let name = name.trim();
        let Some(&c) = COMPONENTS.iter().find(|c| **c == name) else {
            let reason = if name.is_empty() {
                "empty component name"
            } else {
                "not an OPAC component"
            };
            anyhow::bail!(invalid(name, reason));
        };
        if !out.contains(&c) {
            out.push(c);
        }
    }
    if out.is_empty() {
        anyhow::bail!(invalid("", "no components"));
    }
    Ok(out)
}
