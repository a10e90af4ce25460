//! The files of a fit, named from its dataset path `<out>`: the provenance
//! `<out>.toml`, the per-image figures `<out>.fit.csv`, and the shards'
//! datasets `<out>.shard-KKKK-of-NNNN.dat` (each with its own sidecars).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::run::shard::Shard;

/// The file name of `out` (empty when it has none).
fn file_name(out: &Path) -> String {
    out.file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default()
}

/// The sidecar paths of a dataset: `<out>.toml` and `<out>.fit.csv`.
pub fn sidecars(out: &Path) -> (PathBuf, PathBuf) {
    let name = file_name(out);
    (
        out.with_file_name(format!("{name}.toml")),
        out.with_file_name(format!("{name}.fit.csv")),
    )
}

/// A shard's dataset file: `<out>.shard-KKKK-of-NNNN.dat`.
pub fn shard_path(out: &Path, shard: Shard) -> PathBuf {
    out.with_file_name(format!("{}.shard-{}.dat", file_name(out), shard.file_stem()))
}

/// The shard datasets next to `out`, in shard order: every K of one N.
/// Refused: none found, some missing, or shards of two counts mixed.
pub fn find_shards(out: &Path) -> Result<Vec<(Shard, PathBuf)>> {
    let dir = match out.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(p) => p.to_path_buf(),
        None => PathBuf::from("."),
    };
    let prefix = format!("{}.shard-", file_name(out));
    let mut found: Vec<(Shard, PathBuf)> = std::fs::read_dir(&dir)
        .map_err(|e| Error::io(&dir, e))?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let file = e.file_name().to_string_lossy().to_string();
            let stem = file.strip_prefix(&prefix)?.strip_suffix(".dat")?;
            let (k, n) = stem.split_once("-of-")?;
            let shard = Shard::new(k.parse().ok()?, n.parse().ok()?)?;
            Some((shard, e.path()))
        })
        .collect();
    found.sort_by_key(|(s, _)| (s.count, s.index));
    let Some(count) = found.first().map(|(s, _)| s.count) else {
        return Err(Error::data(
            out.display().to_string(),
            format!("no shard files {prefix}K-of-N.dat next to it (fit them with `atmosim fit FIT.toml --shard K/N`)"),
        ));
    };
    let missing: Vec<String> = (1..=count)
        .filter(|&k| !found.iter().any(|(s, _)| s.count == count && s.index == k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() || found.iter().any(|(s, _)| s.count != count) {
        return Err(Error::data(
            out.display().to_string(),
            format!(
                "the shards of {count} are incomplete (missing {}) or mixed with shards of another count",
                if missing.is_empty() {
                    "none".to_string()
                } else {
                    missing.join(", ")
                }
            ),
        ));
    }
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_dataset() {
        let (toml, csv) = sidecars(Path::new("out/a.dat"));
        assert_eq!(toml, Path::new("out/a.dat.toml"));
        assert_eq!(csv, Path::new("out/a.dat.fit.csv"));
        let shard = Shard::new(2, 3).expect("2/3 is a shard");
        let path = shard_path(Path::new("out/a.dat"), shard);
        assert_eq!(
            path,
            PathBuf::from(format!("out/a.dat.shard-{}.dat", shard.file_stem()))
        );
    }

    #[test]
    fn shards_must_be_complete_and_of_one_count() {
        let dir = std::env::temp_dir().join(format!("atmosim-fit-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let out = dir.join("g.dat");
        assert!(find_shards(&out).is_err(), "no shards at all");
        let touch = |k, n| {
            let p = shard_path(&out, Shard::new(k, n).expect("valid shard"));
            std::fs::write(&p, b"").expect("write");
        };
        touch(1, 3);
        touch(3, 3);
        let err = find_shards(&out).expect_err("shard 2 missing").to_string();
        assert!(err.contains("missing 2"), "{err}");
        touch(2, 3);
        let found = find_shards(&out).expect("complete");
        assert_eq!(found.iter().map(|(s, _)| s.index).collect::<Vec<_>>(), [1, 2, 3]);
        touch(1, 2);
        let err = find_shards(&out).expect_err("two counts").to_string();
        assert!(err.contains("another count"), "{err}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
