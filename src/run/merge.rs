//! `atmosim merge OUT_DIR`: the finished shards of every task of a job
//! (`shards/*.shard` in each task's directory) summed in shard order into
//! the task's final files: sample-weighted means, standard errors from the
//! pooled sums of squares. Everything is checked before anything is
//! written: one job (same hash) throughout, one shard count per task, no
//! shard twice, none missing, every one complete, every task present.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::job::Job;
use crate::run::checkpoint::{SHARD_EXTENSION, StateFile};
use crate::run::layout::Layout;
use crate::run::task_output::{self, RunInfo};

/// Most missing shards a refusal names.
const MAX_NAMED: usize = 10;

/// What a merge did.
#[derive(Debug, Clone, PartialEq)]
pub struct Merged {
    pub job_hash: String,
    pub tasks: usize,
    /// Shards per task.
    pub shards: u64,
    /// The task directories written.
    pub directories: Vec<PathBuf>,
}

/// The directory of `task` under the output directory `base`: `base` itself
/// for a job of one task, else `base/<task name>`.
pub fn task_dir(base: &Path, job: &Job, task: &crate::job::Task) -> PathBuf {
    if job.tasks.len() == 1 {
        base.to_path_buf()
    } else {
        base.join(&task.name)
    }
}

/// The shard files under `out_dir`: `out_dir/shards/` and
/// `out_dir/*/shards/`.
fn shard_files(out_dir: &Path) -> Result<Vec<PathBuf>> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |e| Error::io(path, e)
    };
    let mut dirs = vec![out_dir.join("shards")];
    for entry in std::fs::read_dir(out_dir).map_err(io(out_dir))? {
        let entry = entry.map_err(io(out_dir))?;
        if entry.path().is_dir() {
            dirs.push(entry.path().join("shards"));
        }
    }
    let mut files = Vec::new();
    for dir in dirs.iter().filter(|d| d.is_dir()) {
        for entry in std::fs::read_dir(dir).map_err(io(dir))? {
            let path = entry.map_err(io(dir))?.path();
            if path.extension().is_some_and(|e| e == SHARD_EXTENSION) {
                files.push(path);
            }
        }
    }
    files.sort();
    Ok(files)
}

/// Merges every task's shards under `out_dir`; `log` gets a line per task.
pub fn merge(out_dir: &Path, log: &dyn Fn(&str)) -> Result<Merged> {
    let refuse = |message: String| Error::data(out_dir.display().to_string(), format!("cannot merge: {message}"));
    let files = shard_files(out_dir)?;
    if files.is_empty() {
        return Err(refuse(
            "no shard files (shards/*.shard) in this directory or its task directories; \
             render with `--shard K/N` first"
                .into(),
        ));
    }
    let mut shards: Vec<(PathBuf, StateFile)> = Vec::new();
    for path in files {
        let f = StateFile::read(&path)?;
        shards.push((path, f));
    }
    // One job throughout.
    let hash = shards[0].1.state.job_hash.clone();
    if let Some((path, f)) = shards.iter().find(|(_, f)| f.state.job_hash != hash) {
        return Err(refuse(format!(
            "shards of different jobs: {} has job hash {} but {} has {}; \
             remove the shards of the other job",
            path.display(),
            f.state.job_hash,
            shards[0].0.display(),
            hash
        )));
    }
    let job = shards[0].1.job()?;
    if job.hash != hash {
        return Err(refuse(format!(
            "the job text in {} does not hash to its job hash {hash}",
            shards[0].0.display()
        )));
    }
    // Group by task; check counts, duplicates and gaps.
    let mut by_task: BTreeMap<usize, Vec<&(PathBuf, StateFile)>> = BTreeMap::new();
    for s in &shards {
        if s.1.state.task >= job.tasks.len() {
            return Err(refuse(format!(
                "{} is task {}, but the job has {} tasks",
                s.0.display(),
                s.1.state.task,
                job.tasks.len()
            )));
        }
        by_task.entry(s.1.state.task).or_default().push(s);
    }
    let missing: Vec<String> = job
        .tasks
        .iter()
        .filter(|t| !by_task.contains_key(&t.index))
        .map(|t| format!("{} ({})", t.index, t.name))
        .collect();
    if !missing.is_empty() {
        return Err(refuse(format!("no shards for task(s) {}", missing.join(", "))));
    }
    let mut plans = Vec::new();
    let mut count = 0;
    for (&t, list) in &by_task {
        let task = &job.tasks[t];
        let n = list[0].1.state.shard.count;
        if let Some((path, f)) = list
            .iter()
            .map(|s| (&s.0, &s.1))
            .find(|(_, f)| f.state.shard.count != n)
        {
            return Err(refuse(format!(
                "task {t} ({}) mixes shard counts: {} is shard {} but {} is shard {}",
                task.name,
                path.display(),
                f.state.shard,
                list[0].0.display(),
                list[0].1.state.shard
            )));
        }
        let mut seen: BTreeMap<u64, &PathBuf> = BTreeMap::new();
        for (path, f) in list.iter().map(|s| (&s.0, &s.1)) {
            if let Some(first) = seen.insert(f.state.shard.index, path) {
                return Err(refuse(format!(
                    "task {t} ({}): shard {} twice, in {} and {}",
                    task.name,
                    f.state.shard,
                    first.display(),
                    path.display()
                )));
            }
        }
        // The count comes from the files: name the first few missing
        // shards only, never walk all of a count that may be 2⁶³.
        let missing = n - seen.len() as u64;
        if missing > 0 {
            let named: Vec<String> = (1..=n)
                .filter(|k| !seen.contains_key(k))
                .take(MAX_NAMED)
                .map(|k| format!("{k}/{n}"))
                .collect();
            let more = missing - named.len() as u64;
            return Err(refuse(format!(
                "task {t} ({}): missing shard(s) {}{}",
                task.name,
                named.join(", "),
                if more > 0 {
                    format!(" and {more} more")
                } else {
                    String::new()
                }
            )));
        }
        let shared = job.spectral_scene(task).is_some();
        let mut layout = Layout::new(&job, task, shared);
        let mut ordered: Vec<&(PathBuf, StateFile)> = list.clone();
        ordered.sort_by_key(|s| s.1.state.shard.index);
        // A noise target's allocation comes from the pilot, which every
        // shard traced whole and must hold bit for bit alike.
        layout.allocate(&ordered[0].1.state);
        for (path, f) in ordered.iter().map(|s| (&s.0, &s.1)) {
            if !layout.fits(&f.state) || !f.state.is_complete(&layout) {
                return Err(refuse(format!(
                    "{} is not a complete shard of task {t} (an unfinished or damaged render): rerun that unit",
                    path.display()
                )));
            }
            if !layout.same_pilot(&f.state, &ordered[0].1.state) {
                return Err(refuse(format!(
                    "{} and {} traced different pilots for their noise target (made by different \
                     atmosim versions?): render every shard of task {t} with one version",
                    path.display(),
                    ordered[0].0.display()
                )));
            }
        }
        let mut total = ordered[0].1.state.clone();
        for s in &ordered[1..] {
            total.add(&s.1.state, &layout);
        }
        count = n;
        plans.push((task, layout, total, n));
    }
    let mut directories = Vec::new();
    for (task, layout, total, n) in &plans {
        let dir = task_dir(out_dir, &job, task);
        let info = RunInfo { shards: *n };
        let note = task_output::write(&dir, &job, task, layout, total, info)?;
        log(&format!("{}: merged {n} shards → {}{note}", task.name, dir.display()));
        directories.push(dir);
    }
    Ok(Merged {
        job_hash: hash,
        tasks: plans.len(),
        shards: count,
        directories,
    })
}
