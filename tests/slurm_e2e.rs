//! End to end on a real SLURM: `plan --slurm` for a small job (2 tasks × 2
//! shards), submitted with `sbatch --wait`, merged, and compared with a
//! single-process render; then the script submitted again, where every unit
//! must find its work done.
//!
//! `.ci/run` starts a one-node SLURM on localhost
//! (scripts/slurm/start_local_cluster.sh) and builds the tests with
//! ATMOSIM_SLURM=required (see build.rs), so there the test runs and fails
//! without a working cluster. Elsewhere it is compiled as ignored: a plain
//! `cargo test` reports it as ignored, and `cargo test --test slurm_e2e --
//! --ignored` runs it against a cluster that is up.

use std::path::Path;
use std::process::Command as Process;
use std::time::Instant;

use assert_cmd::Command;
use common::csv_values;

mod common;

fn atmosim() -> Command {
    Command::cargo_bin("atmosim").unwrap()
}

/// Panics unless an idle SLURM node answers.
fn assert_slurm_answers() {
    let answer = Process::new("sinfo").args(["-h", "-o", "%t"]).output();
    let ok = matches!(&answer, Ok(o) if o.status.success() && String::from_utf8_lossy(&o.stdout).contains("idle"));
    if !ok {
        let why = match &answer {
            Ok(o) => format!(
                "sinfo: {} {}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
            Err(e) => format!("sinfo: {e}"),
        };
        panic!("no idle SLURM node answers ({why}); run scripts/slurm/start_local_cluster.sh");
    }
}

fn sbatch_wait(script: &Path) -> String {
    let start = Instant::now();
    let out = Process::new("timeout")
        .args(["600", "sbatch", "--wait", "--parsable"])
        .arg(script)
        .output()
        .unwrap();
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "sbatch --wait failed: {log}");
    eprintln!("sbatch --wait: {:.1} s", start.elapsed().as_secs_f64());
    log
}

#[test]
#[cfg_attr(
    not(atmosim_slurm),
    ignore = "needs a SLURM cluster: scripts/slurm/start_local_cluster.sh, then ATMOSIM_SLURM=required cargo test"
)]
fn slurm_array_of_tasks_and_shards_merges_to_a_single_render() {
    assert_slurm_answers();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("job.toml"),
        "[spectrum]\nwavelengths_nm = [450.0, 550.0]\n[atmosphere]\nvisibility_km = 40.0\n\
         [sun]\nzenith_deg = [30.0, 70.0]\n[ground]\nalbedo = [0.0, 0.4]\n\
         [sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0, 60.0, 120.0]\nazimuth_deg = [0.0, 90.0]\n\
         [render]\nseed = 3\nsamples = 20000\n",
    )
    .unwrap();
    let start = Instant::now();
    let o = atmosim()
        .current_dir(d)
        .args([
            "plan", "job.toml", "--slurm", "--shards", "2", "--cpus", "1", "--time", "00:05:00", "--out", "cluster",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let script = d.join("cluster/slurm/render.sbatch");
    sbatch_wait(&script);
    let logs: Vec<String> = std::fs::read_dir(d.join("cluster/slurm/logs"))
        .unwrap()
        .map(|e| std::fs::read_to_string(e.unwrap().path()).unwrap())
        .collect();
    assert_eq!(logs.len(), 4, "one log per unit: {logs:?}");
    for log in &logs {
        assert!(log.contains("shard") && log.contains("wrote"), "{log}");
    }
    let o = atmosim().current_dir(d).args(["merge", "cluster"]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    eprintln!(
        "SLURM end to end (plan, 4 units, merge): {:.1} s",
        start.elapsed().as_secs_f64()
    );
    let o = atmosim()
        .current_dir(d)
        .args(["render", "job.toml", "--out", "single", "-q"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let (a, b) = (csv_values(&d.join("single")), csv_values(&d.join("cluster")));
    assert_eq!(a.len(), 4);
    assert_eq!(a.len(), b.len());
    for ((na, va), (nb, vb)) in a.iter().zip(&b) {
        assert_eq!(na, nb);
        assert_eq!(va.len(), vb.len());
        for (x, y) in va.iter().zip(vb) {
            // 10 printed digits: 1e-9 bounds a last-digit flip.
            assert!((x - y).abs() <= 1e-9 * x.abs().max(y.abs()), "{na}: {x} vs {y}");
        }
    }
    // Submitted again (a rerun of every unit): nothing is rendered twice.
    sbatch_wait(&script);
    let reruns: Vec<String> = std::fs::read_dir(d.join("cluster/slurm/logs"))
        .unwrap()
        .map(|e| std::fs::read_to_string(e.unwrap().path()).unwrap())
        .collect();
    let skipped = reruns.iter().filter(|l| l.contains("skipped")).count();
    assert_eq!(skipped, 4, "{reruns:?}");
}
