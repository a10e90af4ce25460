//! The same job gives the same bytes: every file of `render` (image and
//! directions sensors), `merge` and `transmittance`, run twice with
//! different thread counts, has the same checksum.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{atmosim, files_under};

const IMAGE_JOB: &str = "[spectrum]\nwavelengths_nm = [450.0, 550.0]\n[sun]\nelevation_deg = 20.0\n\
                         angular_radius_deg = 0.2666\n[ground]\nalbedo = [0.0, 0.5]\n\
                         [sensor]\ntype = \"fisheye\"\nresolution = 10\n[render]\nsamples = 8\n\
                         [output]\nsun = true\n";
const DIRECTIONS_JOB: &str = "[atmosphere]\nvisibility_km = [30.0, 60.0]\n[spectrum]\nwavelengths_nm = [450.0]\n\
                              [sensor]\nview_zenith_deg = [0.0, 60.0]\nazimuth_deg = [0.0, 90.0]\n\
                              [render]\nsamples = 2000\n\
                              [transmittance]\naltitude_nodes = 3\ndistance_nodes = 4\nsamples = 20\n";

/// FNV-1a (64 bit) of a file's bytes.
fn checksum(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The checksum of every file under `dir`, by relative path.
fn checksums(dir: &Path) -> BTreeMap<String, u64> {
    files_under(dir)
        .iter()
        .map(|p| {
            let rel = p.strip_prefix(dir).unwrap().display().to_string();
            (rel, checksum(&std::fs::read(p).unwrap()))
        })
        .collect()
}

/// Runs `atmosim ARGS` in `dir`; panics unless it succeeds.
fn run(dir: &Path, args: &[&str]) {
    let out = atmosim().current_dir(dir).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Checksums of the outputs of `commands` (each run in a fresh copy of the
/// job's directory, the output directory `out`) for thread counts 1 and 2.
fn twice(job: &str, commands: &[&[&str]]) -> [BTreeMap<String, u64>; 2] {
    ["1", "2"].map(|threads| {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("job.toml"), job).unwrap();
        for command in commands {
            let mut args = command.to_vec();
            if args[0] != "merge" {
                args.extend(["--threads", threads]);
            }
            run(dir.path(), &args);
        }
        checksums(&dir.path().join("out"))
    })
}

#[test]
fn an_image_render_gives_the_same_bytes_every_time() {
    let [a, b] = twice(IMAGE_JOB, &[&["render", "job.toml", "--out", "out", "--quiet"]]);
    for file in ["image.exr", "preview.png", "dolp.png", "sun.csv", "task.toml"] {
        assert!(a.contains_key(file), "{file} not written: {a:?}");
    }
    assert_eq!(a, b);
}

#[test]
fn directions_shards_merged_and_transmittance_give_the_same_bytes_every_time() {
    let [a, b] = twice(
        DIRECTIONS_JOB,
        &[
            &["render", "job.toml", "--out", "out", "--quiet", "--shard", "1/2"],
            &["render", "job.toml", "--out", "out", "--quiet", "--shard", "2/2"],
            &["merge", "out", "--quiet"],
            &["transmittance", "job.toml", "--out", "out/transmittance", "--quiet"],
        ],
    );
    let task = "vis030.0_elev+45.0_alt00000m";
    for file in [
        format!("{task}/radiance.csv"),
        format!("{task}/fluxes.csv"),
        format!("{task}/task.toml"),
        format!("{task}/shards/0001-of-0002.shard"),
        "transmittance/vis030.0_alt00000m/transmittance.exr".to_string(),
        "transmittance/vis030.0_alt00000m/transmittance.csv".to_string(),
    ] {
        assert!(a.contains_key(&file), "{file} not written: {a:?}");
    }
    assert_eq!(a, b);
}
