//! Checking where outputs go before any work is done: that the output
//! directory can be created and written, and that the task directories a
//! run will write hold no other job's results (which it would silently
//! overwrite). Both are user errors (exit code 2) found in a second rather
//! than after hours of rendering.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::io::exr::read_exr_attributes;
use crate::job::Job;
use crate::run::checkpoint;
use crate::run::task_output::{self, TASK_FILE};

/// Where a run's outputs go, and how the user named it (for errors).
#[derive(Debug, Clone)]
pub struct Destination {
    pub dir: PathBuf,
    /// The file that named it (`command line` or the job file).
    pub file: String,
    /// The key that named it (`--out` or `output.directory`).
    pub key: String,
}

impl Destination {
    /// The output directory of a command: `--out` when given, else the
    /// job's `[output] directory`.
    pub fn of(job: &Job, out: Option<&Path>) -> Destination {
        match out {
            Some(dir) => Destination {
                dir: dir.to_path_buf(),
                file: "command line".into(),
                key: "--out".into(),
            },
            None => Destination {
                dir: job.render.output_directory.clone(),
                file: job.file.clone(),
                key: "output.directory".into(),
            },
        }
    }

    /// A user error about this destination.
    fn refuse(&self, dir: &Path, reason: String, valid: &str) -> Error {
        Error::InvalidValue {
            file: self.file.clone(),
            key: self.key.clone(),
            value: format!("\"{}\"", dir.display()),
            reason,
            valid: valid.into(),
        }
    }

    /// Creates the directory (and its parents) and checks that a file can
    /// be written in it; on failure removes the directories it created.
    pub fn check_writable(&self) -> Result<()> {
        check_writable(&self.dir).map_err(|(dir, e)| {
            self.refuse(
                &dir,
                format!("cannot write there: {e}"),
                "a directory that can be created and written",
            )
        })
    }

    /// Refuses (unless `overwrite`) when one of `task_dirs` holds the files of
    /// another job: its `task.toml`, a shard or checkpoint, an image or a
    /// transmittance table with another job hash.
    pub fn check_not_another_job(&self, job: &Job, task_dirs: &[PathBuf], overwrite: bool) -> Result<()> {
        if overwrite {
            return Ok(());
        }
        for dir in task_dirs {
            if let Some((file, hash)) = other_job_in(dir, &job.hash) {
                return Err(self.refuse(
                    dir,
                    format!(
                        "holds the results of another job: {} has job hash {hash}, this job's is {}",
                        file.display(),
                        job.hash
                    ),
                    "a new directory, one of this job, or --overwrite to replace that job's files",
                ));
            }
        }
        Ok(())
    }
}

/// [`Destination::check_writable`]: the directory at fault and the error.
fn check_writable(dir: &Path) -> std::result::Result<(), (PathBuf, std::io::Error)> {
    // The directories this creates, deepest last, to remove on failure.
    let mut created = Vec::new();
    let mut missing = dir.to_path_buf();
    while !missing.as_os_str().is_empty() && !missing.exists() {
        created.push(missing.clone());
        match missing.parent() {
            Some(p) => missing = p.to_path_buf(),
            None => break,
        }
    }
    created.reverse();
    let probe = dir.join(format!(".atmosim-write-test.{}", std::process::id()));
    let result = std::fs::create_dir_all(dir)
        .and_then(|_| {
            let meta = std::fs::metadata(dir)?;
            if !meta.is_dir() {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::NotADirectory,
                    "not a directory",
                ));
            }
            std::fs::write(&probe, b"atmosim")
        })
        .and_then(|_| std::fs::remove_file(&probe));
    result.map_err(|e| {
        for d in created.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
        (dir.to_path_buf(), e)
    })
}

/// The first file in `dir` that belongs to a job other than `hash`, with
/// that job's hash. Every check reads a header only: a checkpoint may hold
/// gigabytes of sums.
fn other_job_in(dir: &Path, hash: &str) -> Option<(PathBuf, String)> {
    let other = |file: PathBuf, found: Option<String>| found.filter(|h| h != hash).map(|h| (file, h));
    if let Some(x) = other(dir.join(TASK_FILE), task_output::job_hash_of(dir)) {
        return Some(x);
    }
    for exr in ["image.exr", "transmittance.exr"] {
        let path = dir.join(exr);
        let found =
            read_exr_attributes(&path).and_then(|a| a.into_iter().find(|(k, _)| k == "job_hash").map(|(_, v)| v));
        if let Some(x) = other(path, found) {
            return Some(x);
        }
    }
    for sub in ["shards", "checkpoints"] {
        let Ok(entries) = std::fs::read_dir(dir.join(sub)) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        files.sort();
        for path in files {
            let found = checkpoint::job_hash_of(&path);
            if let Some(x) = other(path, found) {
                return Some(x);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(text: &str) -> Job {
        Job::parse(text, "job.toml", Path::new(".")).unwrap()
    }

    fn destination(dir: &Path) -> Destination {
        Destination {
            dir: dir.to_path_buf(),
            file: "command line".into(),
            key: "--out".into(),
        }
    }

    #[test]
    fn a_directory_under_a_file_is_refused_and_nothing_is_left() {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::write(tmp.path().join("file"), "x").unwrap();
        let e = destination(&tmp.path().join("file/sub/deeper"))
            .check_writable()
            .unwrap_err();
        assert!(e.is_user_error());
        assert!(
            e.to_string().contains("--out") && e.to_string().contains("cannot write there"),
            "{e}"
        );
        // A plain file as the directory.
        assert!(destination(&tmp.path().join("file")).check_writable().is_err());
        // A new nested directory is created and left empty.
        let new = tmp.path().join("a/b/c");
        destination(&new).check_writable().unwrap();
        assert!(new.is_dir() && std::fs::read_dir(&new).unwrap().next().is_none());
    }

    #[test]
    fn another_jobs_results_are_refused_naming_both_hashes() {
        let tmp = tempfile::tempdir().unwrap();
        let (a, b) = (job("[render]\nseed = 1\n"), job("[render]\nseed = 2\n"));
        std::fs::write(tmp.path().join(TASK_FILE), format!("job_hash = \"{}\"\n", a.hash)).unwrap();
        let dirs = [tmp.path().to_path_buf()];
        let d = destination(tmp.path());
        d.check_not_another_job(&a, &dirs, false).unwrap();
        let e = d.check_not_another_job(&b, &dirs, false).unwrap_err().to_string();
        assert!(
            e.contains(&a.hash) && e.contains(&b.hash) && e.contains("--overwrite"),
            "{e}"
        );
        d.check_not_another_job(&b, &dirs, true).unwrap();
    }
}
