//! State files: a work unit's sums on disk, as a checkpoint of a running
//! unit (`checkpoints/<K>-of-<N>.state` in the task's directory) or as a
//! finished shard waiting for `atmosim merge` (`shards/<K>-of-<N>.shard`).
//! Both carry the job text, so `merge` needs nothing but the output
//! directory, and both are written atomically (temporary file, rename).
//!
//! Format (little-endian), version 5 (version 1 counted an image's work in
//! samples per pixel, version 2 in items, see [`crate::film::image::ActivePixels`];
//! version 3 has the layout of 2, and marks sums made since OPAC aerosol
//! scatters by Mie phase matrices by default, so that no unit mixes them
//! with Henyey–Greenstein sums of the same job text; version 4 marks the
//! layouts in which an image seen from the ground shares the ground view,
//! [`crate::film::ground_view`], and whose pixels below the horizon are not
//! traced; version 5 those in which an image traces the columns its
//! symmetry leaves, [`crate::sensor::symmetry`]: version 4 files are read
//! for `directions` sensors, which did not change, and refused for images,
//! whose noise target would allocate its samples over other pixels):
//! ```text
//! "ATMOSIM-STATE-5\n"                       16 bytes
//! job hash, job file, job directory, job text: each u64 length + UTF-8,
//!                                           zero-padded to whole 8-byte words
//! task, shard index, shard count            3 × u64
//! estimates                                 u64
//!   per estimate: done u64, tallies u64,
//!   per tally: sum[4], sum_sq[4] f64; samples, non_finite u64
//! checksum                                  u64 (FNV-1a over the 8-byte words of all the above)
//! ```
//! The sums are stored bit for bit, so a resumed run continues exactly.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::fnv;
use crate::job::Job;
use std::io::Write;

use crate::film::tally::Tally;
use crate::io::atomic::write_atomic_with;
use crate::run::layout::UnitState;
use crate::run::shard::Shard;

const MAGIC: &[u8; 16] = b"ATMOSIM-STATE-5\n";
/// The header of the previous format, read for `directions` sensors.
const MAGIC_V4: &[u8; 16] = b"ATMOSIM-STATE-4\n";
/// The headers of the older formats, refused with their own messages.
const MAGIC_V1: &[u8; 16] = b"ATMOSIM-STATE-1\n";
const MAGIC_V2: &[u8; 16] = b"ATMOSIM-STATE-2\n";
const MAGIC_V3: &[u8; 16] = b"ATMOSIM-STATE-3\n";

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
        let mut e = Encoder {
            w: Vec::new(),
            hash: fnv::OFFSET,
            bytes: 0,
        };
        encode(&mut e, &self.job_file, &self.job_dir, &self.job_text, &self.state).expect("writing to memory");
        e.w
    }

    /// Parses a file's bytes; `name` is for messages.
    pub fn from_bytes(bytes: &[u8], name: &str) -> Result<StateFile> {
        let bad = |what: &str| {
            Error::data(
                name,
                format!("not a usable atmosim state file ({what}); delete it to start the unit afresh"),
            )
        };
        if bytes.starts_with(MAGIC_V1) {
            return Err(bad(
                "written by an older atmosim (state format 1), which counted an image's work \
                            differently; finish it with that version, or render the unit again",
            ));
        }
        if bytes.starts_with(MAGIC_V2) {
            return Err(bad(
                "written by an older atmosim (state format 2), whose OPAC aerosol scattered by \
                 Henyey–Greenstein; finish it with that version (or with aerosol_phase = \"hg\" in a \
                 new render), or render the unit again",
            ));
        }
        if bytes.starts_with(MAGIC_V3) {
            return Err(bad(
                "written by an older atmosim (state format 3), which traced every pixel below the horizon of an \
                 observer on the ground and sampled paths differently; finish it with that version, or render \
                 the unit again",
            ));
        }
        let v4 = bytes.starts_with(MAGIC_V4);
        if bytes.len() < MAGIC.len() + 8 || (&bytes[..MAGIC.len()] != MAGIC && !v4) {
            return Err(bad("no atmosim state header"));
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        if body.len() % 8 != 0 || fnv::words(body) != u64::from_le_bytes(tail.try_into().expect("8 bytes")) {
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
        if v4 {
            let image = Job::parse(&job_text, &job_file, &job_dir).map_or(true, |job| {
                !matches!(job.render.sensor, crate::job::Sensor::Directions(_))
            });
            if image {
                return Err(bad(
                    "written by an older atmosim (state format 4), whose images traced every column (now the \
                     columns the sky's symmetry leaves, sensor.symmetry); finish it with that version, or render \
                     the unit again",
                ));
            }
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

    /// Reads a state file.
    pub fn read(path: &Path) -> Result<StateFile> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }
}

/// The job hash a state file names, read from its header alone (the
/// sums, which may be gigabytes, are not read or checked); `None` if it is
/// not a state file of this format.
pub fn job_hash_of(path: &Path) -> Option<String> {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take((MAGIC.len() + 8 + 64) as u64)
        .read_to_end(&mut head)
        .ok()?;
    if !head.starts_with(MAGIC) && !head.starts_with(MAGIC_V4) {
        return None;
    }
    Reader {
        bytes: &head,
        at: MAGIC.len(),
    }
    .string()
}

/// Writes the state of a unit of `job` atomically, streaming it (no copy
/// of the sums in memory); returns the file's size in bytes.
pub fn write_state(job: &Job, state: &UnitState, path: &Path) -> Result<u64> {
    let mut size = 0;
    write_atomic_with(path, |w| {
        let mut e = Encoder {
            w: std::io::BufWriter::with_capacity(1 << 20, w),
            hash: fnv::OFFSET,
            bytes: 0,
        };
        encode(&mut e, &job.file, &job.dir, &job.text, state)?;
        size = e.bytes;
        e.w.flush()
    })?;
    Ok(size)
}

/// Encodes a state: every field a whole number of 8-byte words, each word
/// fed to the checksum, which comes last.
fn encode<W: Write>(
    e: &mut Encoder<W>,
    job_file: &str,
    job_dir: &Path,
    job_text: &str,
    s: &UnitState,
) -> std::io::Result<()> {
    e.bytes(MAGIC)?;
    for text in [s.job_hash.as_str(), job_file, &job_dir.to_string_lossy(), job_text] {
        e.string(text)?;
    }
    for v in [s.task as u64, s.shard.index, s.shard.count, s.done.len() as u64] {
        e.word(v)?;
    }
    for (done, list) in s.done.iter().zip(&s.tallies) {
        e.word(*done)?;
        e.word(list.len() as u64)?;
        for t in list {
            for x in t.sum.iter().chain(&t.sum_sq) {
                e.word(x.to_bits())?;
            }
            e.word(t.samples)?;
            e.word(t.non_finite)?;
        }
    }
    let sum = e.hash;
    e.w.write_all(&sum.to_le_bytes())?;
    e.bytes += 8;
    Ok(())
}

/// Writes little-endian words and hashes them (FNV-1a over words).
struct Encoder<W: Write> {
    w: W,
    hash: u64,
    bytes: u64,
}

impl<W: Write> Encoder<W> {
    fn word(&mut self, v: u64) -> std::io::Result<()> {
        self.hash = fnv::step(self.hash, v);
        self.bytes += 8;
        self.w.write_all(&v.to_le_bytes())
    }

    /// Bytes, zero-padded to whole words.
    fn bytes(&mut self, b: &[u8]) -> std::io::Result<()> {
        for chunk in b.chunks(8) {
            let mut w = [0u8; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            self.word(u64::from_le_bytes(w))?;
        }
        Ok(())
    }

    fn string(&mut self, s: &str) -> std::io::Result<()> {
        self.word(s.len() as u64)?;
        self.bytes(s.as_bytes())
    }
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

    /// A length-prefixed string, zero-padded to whole words.
    fn string(&mut self) -> Option<String> {
        let n = usize::try_from(self.u64()?).ok()?;
        let b = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n.div_ceil(8) * 8;
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
    fn states_of_the_older_formats_are_refused_with_their_reason() {
        // A format-2 file (same layout, sums made with Henyey–Greenstein
        // OPAC aerosol) is named as such, not resumed.
        let mut bytes = sample().to_bytes();
        bytes[..16].copy_from_slice(MAGIC_V2);
        let e = StateFile::from_bytes(&bytes, "x").unwrap_err().to_string();
        assert!(e.contains("state format 2") && e.contains("Henyey–Greenstein"), "{e}");
        bytes[..16].copy_from_slice(MAGIC_V3);
        let e = StateFile::from_bytes(&bytes, "x").unwrap_err().to_string();
        assert!(e.contains("state format 3") && e.contains("below the horizon"), "{e}");
        bytes[..16].copy_from_slice(MAGIC_V1);
        let e = StateFile::from_bytes(&bytes, "x").unwrap_err().to_string();
        assert!(e.contains("state format 1"), "{e}");
    }

    /// The bytes of `f` as format 4 wrote them (the same layout under its
    /// header, the checksum over that header).
    fn as_format_4(f: &StateFile) -> Vec<u8> {
        let mut bytes = f.to_bytes();
        bytes[..16].copy_from_slice(MAGIC_V4);
        let n = bytes.len() - 8;
        let sum = fnv::words(&bytes[..n]);
        bytes[n..].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    #[test]
    fn format_4_states_are_read_for_directions_and_refused_for_images() {
        // Directions did not change: such a checkpoint resumes. An image's
        // would allocate over the columns it no longer traces.
        let directions = sample();
        assert_eq!(
            StateFile::from_bytes(&as_format_4(&directions), "x").unwrap(),
            directions
        );
        let mut image = sample();
        image.job_text = "[sensor]\ntype = \"sphere\"\nresolution = 8\n[render]\nsamples = 5\n".into();
        let e = StateFile::from_bytes(&as_format_4(&image), "x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("state format 4") && e.contains("sensor.symmetry"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.state");
        std::fs::write(&path, as_format_4(&directions)).unwrap();
        assert_eq!(job_hash_of(&path).as_deref(), Some("0123456789abcdef"));
    }

    #[test]
    fn the_job_hash_reads_from_the_header_alone() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.state");
        let mut bytes = sample().to_bytes();
        // Damage past the header does not hide the hash.
        let n = bytes.len();
        bytes.truncate(n - 100);
        std::fs::write(&p, &bytes).unwrap();
        assert_eq!(job_hash_of(&p).as_deref(), Some("0123456789abcdef"));
        std::fs::write(&p, b"not a state file").unwrap();
        assert_eq!(job_hash_of(&p), None);
        assert_eq!(job_hash_of(&dir.path().join("missing")), None);
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
