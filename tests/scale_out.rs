//! Scale-out and fault tolerance as a user meets them: `render --task I
//! --shard K/N` and `merge`, checkpoints with `--resume` after kill -9 and
//! SIGTERM, outputs that are never half-written, and the `plan --slurm`
//! script run unit by unit (without SLURM: tests/slurm_e2e.rs submits it to a
//! real one).
//!
//! (Over 600 lines: the jobs, the process helpers and the fault scenarios
//! they share.)

use std::path::{Path, PathBuf};
use std::process::{Child, Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::Command;
use assert_cmd::cargo::CommandCargoExt;
use atmosim::io::exr::read_exr;
use common::csv_values;

mod common;

fn atmosim() -> Command {
    Command::cargo_bin("atmosim").unwrap()
}

fn spawn(dir: &Path, args: &[&str]) -> Child {
    Process::cargo_bin("atmosim")
        .unwrap()
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Two tasks (two suns), two wavelengths along shared paths, fluxes.
const DIRECTIONS: &str = "[spectrum]\nwavelengths_nm = [450.0, 550.0]\n[atmosphere]\nvisibility_km = 40.0\n\
     [sun]\nzenith_deg = [30.0, 70.0]\n[ground]\nalbedo = [0.0, 0.4]\n\
     [sensor]\ntype = \"directions\"\nview_zenith_deg = [0.0, 60.0, 120.0]\nazimuth_deg = [0.0, 90.0]\n\
     [render]\nseed = 3\nsamples = ";

fn job(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn run_ok(dir: &Path, args: &[&str]) -> String {
    let out = atmosim().current_dir(dir).args(args).output().unwrap();
    let log = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "atmosim {args:?} failed:\n{log}");
    log
}

fn assert_close(a: &[(String, Vec<f64>)], b: &[(String, Vec<f64>)], rel: f64) {
    assert_eq!(a.len(), b.len());
    assert!(!a.is_empty());
    for ((na, va), (nb, vb)) in a.iter().zip(b) {
        assert_eq!(na, nb);
        assert_eq!(va.len(), vb.len(), "{na}");
        for (x, y) in va.iter().zip(vb) {
            assert!((x - y).abs() <= rel * x.abs().max(y.abs()), "{na}: {x} vs {y}");
        }
    }
}

#[test]
fn shards_merged_equal_a_single_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    job(d, "job.toml", &format!("{DIRECTIONS}5000\n"));
    run_ok(d, &["render", "job.toml", "--out", "whole", "-q"]);
    // Units in any order, each in its own process, as on a cluster.
    for task in ["1", "0"] {
        for shard in ["3/3", "1/3", "2/3"] {
            run_ok(
                d,
                &[
                    "render", "job.toml", "--out", "sharded", "--task", task, "--shard", shard, "-q",
                ],
            );
        }
    }
    // Nothing final before the merge.
    assert!(csv_values(&d.join("sharded")).is_empty());
    let log = run_ok(d, &["merge", "sharded"]);
    assert!(log.contains("merged 2 tasks × 3 shards"), "{log}");
    // The sums regroup the same additions: equal to rounding. The CSV has
    // 10 significant digits, so 1e-9 bounds a last-digit flip; the sums
    // themselves agree to 1e-12 (unit::tests::shards_add_up_to_the_whole_task).
    assert_close(&csv_values(&d.join("whole")), &csv_values(&d.join("sharded")), 1e-9);
    let meta = std::fs::read_to_string(d.join("sharded/vis040.0_elev+20.0_alt00000m/task.toml")).unwrap();
    assert!(
        meta.contains("shards = 3") && meta.contains("non_finite_samples = 0"),
        "{meta}"
    );
}

/// `img.toml` in `d`: a fisheye of `resolution` pixels at 450 and 600 nm,
/// sun 25° high, with the `[render]` keys `render`.
fn image_job(d: &Path, resolution: u32, render: &str) -> PathBuf {
    job(
        d,
        "img.toml",
        &format!(
            "[spectrum]\nwavelengths_nm = [450.0, 600.0]\n[sun]\nelevation_deg = 25.0\n\
             [sensor]\ntype = \"fisheye\"\nresolution = {resolution}\n[render]\n{render}\n"
        ),
    )
}

#[test]
fn image_shards_merged_equal_a_single_run() {
    // Fixed samples, and a noise target (each pixel's allocated samples
    // split between the shards; every shard traces the whole pilot).
    for render in [
        "samples = 40",
        "noise_target = 0.03\npilot_samples = 16\nmax_samples = 3000",
    ] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        image_job(d, 10, render);
        run_ok(d, &["render", "img.toml", "--out", "whole", "-q"]);
        for shard in ["2/2", "1/2"] {
            run_ok(d, &["render", "img.toml", "--out", "sharded", "--shard", shard, "-q"]);
        }
        run_ok(d, &["merge", "sharded", "-q"]);
        let a = read_exr(&d.join("whole/image.exr")).unwrap();
        let b = read_exr(&d.join("sharded/image.exr")).unwrap();
        assert_eq!(a.channels.len(), b.channels.len());
        let mut nonzero = 0;
        for (x, y) in a.channels.iter().zip(&b.channels) {
            assert_eq!(x.name, y.name);
            for (p, q) in x.samples.iter().zip(&y.samples) {
                // Stored as f32: equal to its rounding (the counts exactly).
                assert!(
                    (p - q).abs() <= 2.0 * f32::EPSILON * p.abs().max(q.abs()),
                    "{render}, {}: {p} vs {q}",
                    x.name
                );
                nonzero += (*p != 0.0) as usize;
            }
        }
        assert!(nonzero > 100);
        // A noise target writes each pixel's samples, the same after merging.
        let samples = |e: &atmosim::io::exr::ExrContents| {
            e.channels
                .iter()
                .find(|c| c.name == "samples")
                .map(|c| c.samples.clone())
        };
        assert_eq!(samples(&a), samples(&b));
        assert_eq!(samples(&a).is_some(), render.contains("noise_target"), "{render}");
    }
}

fn merge_fails(d: &Path, out: &str, expect: &str) {
    let o = atmosim().current_dir(d).args(["merge", out]).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(expect), "expected `{expect}` in: {err}");
    // Nothing written.
    let mut stack = vec![d.join(out)];
    while let Some(p) = stack.pop() {
        for e in std::fs::read_dir(&p).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            assert!(
                name != "task.toml" && !name.ends_with(".csv"),
                "merge wrote {}",
                p.display()
            );
            if p.is_dir() {
                stack.push(p);
            }
        }
    }
}

#[test]
fn merge_refuses_mismatched_or_incomplete_shard_sets() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    job(d, "a.toml", &format!("{DIRECTIONS}1100\n"));
    job(d, "b.toml", &format!("{DIRECTIONS}1200\n"));
    let unit = |job: &str, out: &str, task: &str, shard: &str| {
        run_ok(
            d,
            &["render", job, "--out", out, "--task", task, "--shard", shard, "-q"],
        );
    };
    // A gap: shard 2/2 of task 1 missing.
    for (t, s) in [("0", "1/2"), ("0", "2/2"), ("1", "1/2")] {
        unit("a.toml", "gap", t, s);
    }
    merge_fails(d, "gap", "missing shard(s) 2/2");
    // A whole task missing.
    for s in ["1/2", "2/2"] {
        unit("a.toml", "task_missing", "0", s);
    }
    merge_fails(d, "task_missing", "no shards for task(s) 1");
    // Another job's shard in the set.
    for (t, s) in [("0", "1/2"), ("0", "2/2"), ("1", "1/2")] {
        unit("a.toml", "mixed", t, s);
    }
    // (render refuses to write into another job's task directory unless
    // told to overwrite: merge must refuse the mix all the same)
    run_ok(
        d,
        &[
            "render",
            "b.toml",
            "--out",
            "mixed",
            "--task",
            "1",
            "--shard",
            "2/2",
            "-q",
            "--overwrite",
        ],
    );
    merge_fails(d, "mixed", "shards of different jobs");
    // Different shard counts for one task.
    for (t, s) in [("0", "1/2"), ("1", "1/2"), ("1", "2/2")] {
        unit("a.toml", "counts", t, s);
    }
    unit("a.toml", "counts", "0", "2/3");
    merge_fails(d, "counts", "mixes shard counts");
    // The same shard twice (a copy under another name).
    for (t, s) in [("0", "1/2"), ("0", "2/2"), ("1", "1/2"), ("1", "2/2")] {
        unit("a.toml", "dup", t, s);
    }
    let task0 = d.join("dup").join(TASK0);
    std::fs::copy(task0.join("shards/0001-of-0002.shard"), task0.join("shards/copy.shard")).unwrap();
    merge_fails(d, "dup", "twice");
    // A damaged shard file.
    std::fs::remove_file(task0.join("shards/copy.shard")).unwrap();
    let f = task0.join("shards/0001-of-0002.shard");
    let mut bytes = std::fs::read(&f).unwrap();
    let n = bytes.len();
    bytes.truncate(n - 100);
    std::fs::write(&f, bytes).unwrap();
    merge_fails(d, "dup", "checksum mismatch");
    // Nothing to merge.
    std::fs::create_dir(d.join("empty")).unwrap();
    merge_fails(d, "empty", "no shard files");
}

/// Waits until `path` exists (or panics after a minute).
fn wait_for(path: &Path, child: &mut Child) {
    let start = Instant::now();
    while !path.exists() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("atmosim ended ({status}) before {} appeared", path.display());
        }
        assert!(start.elapsed() < Duration::from_secs(60), "no {}", path.display());
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The first task's directory of the DIRECTIONS job (sun zenith 30°).
const TASK0: &str = "vis040.0_elev+60.0_alt00000m";

#[test]
fn kill_9_then_resume_equals_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    job(d, "job.toml", &format!("{DIRECTIONS}120000\n"));
    run_ok(d, &["render", "job.toml", "--out", "whole", "-q"]);
    // Checkpoints every 60 ms; kill -9 once the first exists. One thread
    // keeps the first task running well past that on any machine.
    let mut child = spawn(
        d,
        &[
            "render",
            "job.toml",
            "--out",
            "killed",
            "--checkpoint-every",
            "0.001",
            "--threads",
            "1",
            "-q",
        ],
    );
    let cp = d.join("killed").join(TASK0).join("checkpoints/0001-of-0001.state");
    wait_for(&cp, &mut child);
    std::thread::sleep(Duration::from_millis(100));
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(
        !d.join("killed").join(TASK0).join("task.toml").exists(),
        "the render finished before the kill: make it longer"
    );
    let log = run_ok(d, &["render", "job.toml", "--out", "killed", "--resume"]);
    assert!(log.contains("resuming from"), "{log}");
    // Same blocks summed in the same order: bit-identical files.
    for task in [TASK0, "vis040.0_elev+20.0_alt00000m"] {
        for f in ["radiance.csv", "fluxes.csv"] {
            let a = std::fs::read(d.join("whole").join(task).join(f)).unwrap();
            let b = std::fs::read(d.join("killed").join(task).join(f)).unwrap();
            assert!(a == b, "{task}/{f} differs after resume");
        }
    }
    assert!(!cp.exists(), "the checkpoint is removed once the task is written");
}

#[test]
fn sigterm_writes_a_checkpoint_and_resume_completes_exactly() {
    // Fixed samples, and a noise target (the checkpoint holds the pilot,
    // and the resumed run allocates from it again).
    for render in [
        "samples = 8000",
        "noise_target = 0.01\npilot_samples = 16\nmax_samples = 20000",
    ] {
        sigterm_then_resume(render);
    }
}

/// An image render with the `[render]` keys `render`, stopped by SIGTERM
/// and resumed, against an uninterrupted one.
fn sigterm_then_resume(render: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image_job(d, 24, render);
    // No periodic checkpoints: the one found must come from SIGTERM. One
    // thread, so the render lasts about 7 s on any machine with cores to
    // spare (CI's two included) and SIGTERM after 1 s lands mid-render.
    let mut child = spawn(
        d,
        &[
            "render",
            "img.toml",
            "--out",
            "sky",
            "--checkpoint-every",
            "0",
            "--threads",
            "1",
        ],
    );
    std::thread::sleep(Duration::from_millis(1000));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the render ended before SIGTERM: make it longer"
    );
    common::sigterm(&child);
    let out = child.wait_with_output().unwrap();
    let log = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(143), "{log}");
    assert!(
        log.contains("stopped by signal 15") && log.contains("--resume"),
        "{log}"
    );
    let cp = d.join("sky/checkpoints/0001-of-0001.state");
    assert!(cp.exists(), "{log}");
    assert!(!d.join("sky/image.exr").exists() && !d.join("sky/task.toml").exists());
    // Resuming finishes it; the result is the uninterrupted render's.
    run_ok(d, &["render", "img.toml", "--out", "sky", "--resume", "-q"]);
    run_ok(d, &["render", "img.toml", "--out", "whole", "-q"]);
    let a = read_exr(&d.join("whole/image.exr")).unwrap();
    let b = read_exr(&d.join("sky/image.exr")).unwrap();
    for (x, y) in a.channels.iter().zip(&b.channels) {
        assert_eq!(x.name, y.name);
        assert!(x.samples == y.samples, "{} differs after resume", x.name);
    }
    for f in ["task.toml", "noise.csv"] {
        let (a, b) = (
            std::fs::read(d.join("whole").join(f)),
            std::fs::read(d.join("sky").join(f)),
        );
        assert_eq!(a.ok(), b.ok(), "{render}: {f} differs after resume");
    }
    assert_eq!(d.join("sky/noise.csv").exists(), render.contains("noise_target"));
    let meta = std::fs::read_to_string(d.join("sky/task.toml")).unwrap();
    assert!(meta.contains("non_finite_samples = 0"));
}

#[test]
fn resume_refuses_another_jobs_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    job(d, "a.toml", &format!("{DIRECTIONS}300000\n"));
    job(d, "b.toml", &format!("{DIRECTIONS}300001\n"));
    let mut child = spawn(
        d,
        &["render", "a.toml", "--out", "o", "--checkpoint-every", "0.001", "-q"],
    );
    let cp = d.join("o").join(TASK0).join("checkpoints/0001-of-0001.state");
    wait_for(&cp, &mut child);
    child.kill().unwrap();
    child.wait().unwrap();
    // Refused as another job's directory, and with --overwrite as another
    // job's checkpoint to resume.
    let o = atmosim()
        .current_dir(d)
        .args(["render", "b.toml", "--out", "o", "--resume", "-q"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("holds the results of another job"), "{err}");
    let o = atmosim()
        .current_dir(d)
        .args(["render", "b.toml", "--out", "o", "--resume", "-q", "--overwrite"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("this checkpoint is of job") && err.contains("delete it"),
        "{err}"
    );
}

/// Every file a task directory holds is complete: a CSV has all its rows,
/// an EXR reads back, a task.toml only next to complete outputs.
fn assert_nothing_half_written(out: &Path, tasks: &[&str], rows: usize) -> usize {
    let mut complete = 0;
    for t in tasks {
        let dir = out.join(t);
        if !dir.exists() {
            continue;
        }
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            match name.as_str() {
                "radiance.csv" => {
                    let text = std::fs::read_to_string(&p).unwrap();
                    assert_eq!(text.lines().count(), rows + 1, "{} is cut short", p.display());
                    assert!(text.ends_with('\n'));
                }
                "image.exr" => {
                    read_exr(&p).unwrap_or_else(|e| panic!("{} unreadable: {e}", p.display()));
                }
                _ => {}
            }
        }
        if dir.join("task.toml").exists() {
            assert!(dir.join("radiance.csv").exists() || dir.join("image.exr").exists());
            complete += 1;
        }
    }
    complete
}

#[test]
fn outputs_are_never_half_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Six cheap tasks with a large radiance.csv each (many directions):
    // kills at spread-out times land in renders and in writes.
    let zeniths: Vec<String> = (0..90).map(|k| format!("{}.0", k * 2)).collect();
    let text = format!(
        "[spectrum]\nwavelengths_nm = [400.0, 450.0, 500.0, 550.0]\n[atmosphere]\naerosol = \"none\"\n\
         [sun]\nzenith_deg = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0]\n[ground]\nalbedo = [0.0, 0.2, 0.5, 1.0]\n\
         [sensor]\ntype = \"directions\"\nview_zenith_deg = [{}]\nazimuth_deg = [0.0, 45.0, 90.0, 135.0, 180.0]\n\
         [render]\nsamples = 40\n",
        zeniths.join(", ")
    );
    job(d, "job.toml", &text);
    let tasks: Vec<String> = [80, 70, 60, 50, 40, 30]
        .iter()
        .map(|e| format!("novis_elev+{e}.0_alt00000m"))
        .collect();
    let names: Vec<&str> = tasks.iter().map(String::as_str).collect();
    let rows = 90 * 5 * 4 * 4;
    // How long an uninterrupted run takes.
    let start = Instant::now();
    run_ok(d, &["render", "job.toml", "--out", "ref", "-q"]);
    let full = start.elapsed();
    assert_eq!(assert_nothing_half_written(&d.join("ref"), &names, rows), 6);
    let mut partial = 0;
    for k in 1..=12u32 {
        let out = format!("k{k}");
        let mut child = spawn(d, &["render", "job.toml", "--out", &out, "-q"]);
        std::thread::sleep(full * k / 13);
        child.kill().unwrap();
        child.wait().unwrap();
        let complete = assert_nothing_half_written(&d.join(&out), &names, rows);
        partial += (complete > 0 && complete < 6) as u32;
        // What was cut off is finished by a rerun, and equals the reference.
        run_ok(d, &["render", "job.toml", "--out", &out, "-q"]);
        assert_eq!(csv_values(&d.join(&out)), csv_values(&d.join("ref")));
    }
    assert!(partial >= 1, "no kill landed mid-job; timing off");
}

#[test]
fn task_selection_and_bad_unit_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    job(d, "job.toml", &format!("{DIRECTIONS}1000\n"));
    // --task env reads the array index.
    let o = atmosim()
        .current_dir(d)
        .env("SLURM_ARRAY_TASK_ID", "1")
        .args(["render", "job.toml", "--out", "o", "--task", "env", "-q"])
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(d.join("o/vis040.0_elev+20.0_alt00000m/radiance.csv").exists());
    assert!(!d.join("o").join(TASK0).exists());
    for (args, expect) in [
        (vec!["--task", "2"], "the job has 2 tasks"),
        (vec!["--task", "x"], "not a task index"),
        (vec!["--task", "env"], "SLURM_ARRAY_TASK_ID is not set"),
        (vec!["--shard", "4/3"], "1 ≤ K ≤ N"),
        (vec!["--shard", "0/3"], "1 ≤ K ≤ N"),
        (vec!["--checkpoint-every=-1"], "--checkpoint-every"),
    ] {
        let o = atmosim()
            .current_dir(d)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .args(["render", "job.toml", "--out", "bad"])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(expect), "{args:?}: {err}");
        assert!(!d.join("bad").exists(), "{args:?} wrote output");
    }
}

#[test]
fn the_slurm_script_runs_every_unit_and_reruns_safely() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    job(d, "job.toml", &format!("{DIRECTIONS}3000\n"));
    let o = atmosim()
        .current_dir(d)
        .args([
            "plan", "job.toml", "--slurm", "--shards", "3", "--cpus", "2", "--time", "00:10:00", "--out", "cluster",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{err}");
    let script = d.join("cluster/slurm/render.sbatch");
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), script.display().to_string());
    assert!(err.contains("6 units (2 tasks × 3 shards)"), "{err}");
    assert!(
        d.join("cluster/slurm/logs").is_dir(),
        "SLURM needs the log directory to exist"
    );
    let text = std::fs::read_to_string(&script).unwrap();
    for line in [
        "#SBATCH --array=0-5",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --time=00:10:00",
        "#SBATCH --requeue",
        "#SBATCH --signal=B:TERM@60",
        "SHARDS=3",
    ] {
        assert!(text.contains(line), "missing `{line}` in\n{text}");
    }
    assert!(text.contains("--resume") && text.contains("exec "), "{text}");
    // Run the array by hand, as SLURM would, twice (a rerun skips).
    for pass in 0..2 {
        for i in 0..6 {
            let out = Process::new("bash")
                .arg(&script)
                .current_dir(d)
                .env("SLURM_ARRAY_TASK_ID", i.to_string())
                .env("SLURM_CPUS_PER_TASK", "1")
                .output()
                .unwrap();
            let log = String::from_utf8_lossy(&out.stderr).to_string();
            assert!(out.status.success(), "unit {i}: {log}");
            if pass == 1 {
                assert!(log.contains("skipped"), "rerun of unit {i} did not skip: {log}");
            }
        }
    }
    run_ok(d, &["merge", "cluster", "-q"]);
    run_ok(d, &["render", "job.toml", "--out", "whole", "-q"]);
    assert_close(&csv_values(&d.join("whole")), &csv_values(&d.join("cluster")), 1e-9);
    // Bad plan arguments.
    for (args, expect) in [
        (vec!["--shards", "0"], "--shards"),
        (vec!["--time", "1h"], "--time"),
        (vec!["--cpus", "0"], "--cpus"),
    ] {
        let o = atmosim()
            .current_dir(d)
            .args(["plan", "job.toml", "--slurm", "--out", "bad"])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(expect), "{err}");
    }
}

#[test]
fn a_kill_during_a_write_leaves_no_file_that_looks_complete() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A cheap render with a large EXR (≈ 23 MB): its write and fsync take
    // long enough to be caught while the temporary file exists.
    job(
        d,
        "big.toml",
        "[spectrum]\nwavelengths_nm = [450.0, 550.0, 650.0]\n[atmosphere]\naerosol = \"none\"\n\
         [sun]\nelevation_deg = 30.0\n[sensor]\ntype = \"sphere\"\nresolution = [1600, 800]\n\
         [render]\nsamples = 1\nmax_scattering_order = 1\n[output]\npreview = false\n",
    );
    let mut caught = 0;
    for attempt in 0..5 {
        let out = d.join(format!("o{attempt}"));
        let mut child = spawn(d, &["render", "big.toml", "--out", &format!("o{attempt}"), "-q"]);
        // Poll for the temporary file of image.exr, then kill -9 at once.
        let start = Instant::now();
        let mut seen = false;
        while child.try_wait().unwrap().is_none() && start.elapsed() < Duration::from_secs(60) {
            let tmp = std::fs::read_dir(&out).ok().is_some_and(|entries| {
                entries
                    .filter_map(|e| e.ok())
                    .any(|e| e.file_name().to_string_lossy().starts_with(".image.exr.tmp"))
            });
            if tmp {
                child.kill().unwrap();
                seen = true;
                break;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        child.wait().unwrap();
        if !seen {
            continue;
        }
        caught += 1;
        // Killed mid-write: no image.exr (the rename never happened) and no
        // task.toml; the temporary file is not an output.
        assert!(!out.join("image.exr").exists(), "a partial image.exr is in place");
        assert!(!out.join("task.toml").exists());
        // A rerun completes the task.
        run_ok(d, &["render", "big.toml", "--out", &format!("o{attempt}"), "-q"]);
        read_exr(&out.join("image.exr")).unwrap();
        assert!(out.join("task.toml").exists());
        if caught == 2 {
            break;
        }
    }
    assert!(caught >= 1, "never caught a write in progress in 5 attempts");
}
