//! State files: a work unit's sums on disk, as a checkpoint of a running
//! unit (`checkpoints/<K>-of-<N>.state` in the task's directory) or as a
//! finished shard waiting for `atmosim merge` (`shards/<K>-of-<N>.shard`).
//! Both carry the job text, so `merge` needs nothing but the output
//! directory, and both are written atomically (temporary file, rename).
//!
//! Format (little-endian), version 1:
//! ```text
//! "ATMOSIM-STATE-1\n"                       16 bytes
//! job hash, job file, job directory, job text: each u64 length + UTF-8
//! task, shard index, shard count            3 × u64
//! estimates                                 u64
//!   per estimate: done u64, tallies u64,
//!   per tally: sum[4], sum_sq[4] f64; samples, non_finite u64
//! checksum                                  u64 (FNV-1a over 8-byte words of all the above)
//! ```
//! The sums are stored bit for bit, so a resumed run continues exactly.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::job::Job;
use crate::output::write_atomic;
use crate::render::Tally;
use crate::shard::Shard;
use crate::unit::UnitState;

const MAGIC: &[u8; 16] = b"ATMOSIM-STATE-1\n";

/// A unit's state with the job it belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct StateFile {
    /// The job file's name (for messages), directory (relative paths in
    /// the job resolve from it) and text.
    pub job_file: String,
    pub job_dir: PathBuf,
    pub job_text: String,
    pub state: UnitState,
}

impl StateFile {
    /// The state of a unit of `job`.
    pub fn new(job: &Job, state: UnitState) -> StateFile {
        StateFile {
            job_file: job.file.clone(),
            job_dir: job.dir.clone(),
            job_text: job.text.clone(),
            state,
        }
    }

    /// The job, parsed again from the text the file carries.
    pub fn job(&self) -> Result<Job> {
        Job::parse(&self.job_text, &self.job_file, &self.job_dir)
    }

    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        encode(&self.job_file, &self.job_dir, &self.job_text, &self.state)
    }

    /// Parses a file's bytes; `name` is for messages.
    pub fn from_bytes(bytes: &[u8], name: &str) -> Result<StateFile> {
        let bad = |what: &str| {
            Error::data(
                name,
                format!("not a usable atmosim state file ({what}); delete it to start the unit afresh"),
            )
        };
        if bytes.len() < MAGIC.len() + 8 || &bytes[..MAGIC.len()] != MAGIC {
            return Err(bad("no atmosim state header"));
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        if body.len() % 8 != 0 || checksum(body) != u64::from_le_bytes(tail.try_into().expect("8 bytes")) {
            return Err(bad("checksum mismatch: truncated or damaged"));
        }
        let mut r = Reader {
            bytes: body,
            at: MAGIC.len(),
        };
        let truncated = || bad("truncated");
        let job_hash = r.string().ok_or_else(truncated)?;
        let job_file = r.string().ok_or_else(truncated)?;
        let job_dir = PathBuf::from(r.string().ok_or_else(truncated)?);
        let job_text = r.string().ok_or_else(truncated)?;
        let task = r.u64().ok_or_else(truncated)? as usize;
        let (index, count) = (r.u64().ok_or_else(truncated)?, r.u64().ok_or_else(truncated)?);
        let shard = Shard::new(index, count).ok_or_else(|| bad("invalid shard"))?;
        let estimates = r.u64().ok_or_else(truncated)?;
        let mut done = Vec::new();
        let mut tallies = Vec::new();
        for _ in 0..estimates {
            done.push(r.u64().ok_or_else(truncated)?);
            let n = r.u64().ok_or_else(truncated)?;
            if n.saturating_mul(80) > (r.bytes.len() - r.at) as u64 {
                return Err(truncated());
            }
            let mut list = Vec::with_capacity(n as usize);
            for _ in 0..n {
                let mut t = Tally::default();
                for k in 0..8 {
                    let x = f64::from_bits(r.u64().ok_or_else(truncated)?);
                    if k < 4 {
                        t.sum[k] = x;
                    } else {
                        t.sum_sq[k - 4] = x;
                    }
                }
                t.samples = r.u64().ok_or_else(truncated)?;
                t.non_finite = r.u64().ok_or_else(truncated)?;
                list.push(t);
            }
            tallies.push(list);
        }
        Ok(StateFile {
            job_file,
            job_dir,
            job_text,
            state: UnitState {
                job_hash,
                task,
                shard,
                done,
                tallies,
            },
        })
    }

    /// Writes the file atomically; returns its size in bytes.
    pub fn write(&self, path: &Path) -> Result<u64> {
        let bytes = self.to_bytes();
        write_atomic(path, &bytes)?;
        Ok(bytes.len() as u64)
    }

    /// Reads a state file.
    pub fn read(path: &Path) -> Result<StateFile> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }
}

/// Writes the state of a unit of `job` atomically (without copying it);
/// returns the file's size in bytes.
pub fn write_state(job: &Job, state: &UnitState, path: &Path) -> Result<u64> {
    let bytes = encode(&job.file, &job.dir, &job.text, state);
    write_atomic(path, &bytes)?;
    Ok(bytes.len() as u64)
}

fn encode(job_file: &str, job_dir: &Path, job_text: &str, s: &UnitState) -> Vec<u8> {
    let tallies: usize = s.tallies.iter().map(Vec::len).sum();
    let mut out = Vec::with_capacity(256 + job_text.len() + tallies * 80 + s.done.len() * 16);
    out.extend_from_slice(MAGIC);
    for text in [s.job_hash.as_str(), job_file, &job_dir.to_string_lossy(), job_text] {
        put_str(&mut out, text);
    }
    for v in [s.task as u64, s.shard.index, s.shard.count, s.done.len() as u64] {
        put_u64(&mut out, v);
    }
    for (done, list) in s.done.iter().zip(&s.tallies) {
        put_u64(&mut out, *done);
        put_u64(&mut out, list.len() as u64);
        for t in list {
            for x in t.sum.iter().chain(&t.sum_sq) {
                out.extend_from_slice(&x.to_bits().to_le_bytes());
            }
            put_u64(&mut out, t.samples);
            put_u64(&mut out, t.non_finite);
        }
    }
    // Pad to whole words so the checksum covers every byte.
    while out.len() % 8 != 0 {
        out.push(0);
    }
    let sum = checksum(&out);
    put_u64(&mut out, sum);
    out
}

/// The checkpoint of `shard` in a task's directory.
pub fn checkpoint_path(task_dir: &Path, shard: Shard) -> PathBuf {
    task_dir
        .join("checkpoints")
        .join(format!("{}.state", shard.file_stem()))
}

/// The finished shard `shard` in a task's directory.
pub fn shard_path(task_dir: &Path, shard: Shard) -> PathBuf {
    task_dir.join("shards").join(format!("{}.shard", shard.file_stem()))
}

/// The extension of finished shard files.
pub const SHARD_EXTENSION: &str = "shard";

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    put_u64(out, s.len() as u64);
    out.extend_from_slice(s.as_bytes());
}

/// FNV-1a over little-endian 8-byte words (`bytes.len()` a multiple of 8).
fn checksum(bytes: &[u8]) -> u64 {
    bytes.chunks_exact(8).fold(0xcbf2_9ce4_8422_2325, |h, w| {
        (h ^ u64::from_le_bytes(w.try_into().expect("8 bytes"))).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn u64(&mut self) -> Option<u64> {
        let b = self.bytes.get(self.at..self.at + 8)?;
        self.at += 8;
        Some(u64::from_le_bytes(b.try_into().ok()?))
    }

    fn string(&mut self) -> Option<String> {
        let n = usize::try_from(self.u64()?).ok()?;
        let b = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        String::from_utf8(b.to_vec()).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> StateFile {
        let t = Tally {
            sum: [1.5, -2.0, f64::MIN_POSITIVE, 0.1 + 0.2],
            sum_sq: [3.0, 4.0, 5.0, 6.0],
            samples: 12345,
            non_finite: 2,
        };
        StateFile {
            job_file: "a job.toml".into(),
            job_dir: PathBuf::from("/tmp/x"),
            job_text: "[render]\nsamples = 5 # ünïcode\n".into(),
            state: UnitState {
                job_hash: "0123456789abcdef".into(),
                task: 7,
                shard: Shard::new(3, 8).unwrap(),
                done: vec![4, 0],
                tallies: vec![vec![t, Tally::default()], vec![]],
            },
        }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let f = sample();
        let back = StateFile::from_bytes(&f.to_bytes(), "x").unwrap();
        assert_eq!(back, f);
        assert_eq!(
            back.state.tallies[0][0].sum[3].to_bits(),
            f.state.tallies[0][0].sum[3].to_bits()
        );
    }

    #[test]
    fn damage_is_detected() {
        let bytes = sample().to_bytes();
        // Every truncation and a flipped bit anywhere.
        for n in [0, 10, 16, 40, bytes.len() / 2, bytes.len() - 8, bytes.len() - 1] {
            assert!(StateFile::from_bytes(&bytes[..n], "x").is_err(), "truncated to {n}");
        }
        for at in [0, 20, bytes.len() / 2, bytes.len() - 9] {
            let mut b = bytes.clone();
            b[at] ^= 0x10;
            let err = StateFile::from_bytes(&b, "cp.state").unwrap_err().to_string();
            assert!(err.contains("cp.state") && err.contains("delete it"), "{err}");
        }
    }

    #[test]
    fn paths_name_the_shard() {
        let s = Shard::new(2, 16).unwrap();
        assert_eq!(
            checkpoint_path(Path::new("out/t"), s),
            Path::new("out/t/checkpoints/0002-of-0016.state")
        );
        assert_eq!(
            shard_path(Path::new("out"), s),
            Path::new("out/shards/0002-of-0016.shard")
        );
    }
}
