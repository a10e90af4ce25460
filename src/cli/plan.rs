//! `atmosim plan`: lists a job's tasks with their estimated cost, or with
//! `--slurm` writes the SLURM job-array script that renders every unit.

use std::path::{Path, PathBuf};

use anyhow::Context;
use atmosim::job::Job;
use atmosim::run::plan;

use super::common::print_text;

#[derive(clap::Args)]
pub struct PlanArgs {
    /// Job file (TOML).
    job: PathBuf,
    /// Write a SLURM sbatch script for a job array over every unit
    /// (task × shard) to OUT/slurm/render.sbatch instead.
    #[arg(long)]
    slurm: bool,
    /// Shards per task (with --slurm): each task's samples split into N units.
    #[arg(long, default_value_t = 1, requires = "slurm")]
    shards: u64,
    /// Wall time per unit, HH:MM:SS (with --slurm; default: twice the
    /// calibrated estimate plus 10 minutes).
    #[arg(long, requires = "slurm")]
    time: Option<String>,
    /// CPUs per unit (with --slurm).
    #[arg(long, default_value_t = 4, requires = "slurm")]
    cpus: usize,
    /// Output directory (default: the job's `[output] directory`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Minutes between checkpoints of each unit (with --slurm).
    #[arg(long, default_value_t = 10.0, requires = "slurm")]
    checkpoint_every: f64,
}

pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    let PlanArgs {
        job: job_path,
        slurm,
        shards,
        time,
        cpus,
        out,
        checkpoint_every,
    } = args;
    let job = Job::from_file(&job_path)?;
    if slurm {
        write_slurm(&job, &job_path, out, shards, time, cpus, checkpoint_every)?;
    } else {
        let mut out = std::io::stdout().lock();
        plan::write_plan(&job, &mut out).context("writing to stdout")?;
    }
    Ok(())
}

/// `plan --slurm`: writes OUT/slurm/render.sbatch and the log directory.
fn write_slurm(
    job: &Job,
    job_path: &Path,
    out: Option<PathBuf>,
    shards: u64,
    time: Option<String>,
    cpus: usize,
    checkpoint_every: f64,
) -> anyhow::Result<()> {
    let invalid = |key: &str, value: String, valid: &str| atmosim::Error::InvalidValue {
        file: "command line".into(),
        key: key.into(),
        value,
        reason: "out of range".into(),
        valid: valid.into(),
    };
    if shards == 0 {
        anyhow::bail!(invalid("--shards", "0".into(), "1 or more"));
    }
    if cpus == 0 {
        anyhow::bail!(invalid("--cpus", "0".into(), "1 or more"));
    }
    if !(checkpoint_every.is_finite() && checkpoint_every >= 0.0) {
        anyhow::bail!(invalid(
            "--checkpoint-every",
            format!("{checkpoint_every}"),
            "0 or more minutes"
        ));
    }
    if let Some(t) = &time
        && plan::time_seconds(t).is_none()
    {
        anyhow::bail!(invalid(
            "--time",
            t.clone(),
            "a SLURM time limit such as 04:00:00 or 1-12:00:00"
        ));
    }
    let absolute = |p: &Path| -> anyhow::Result<PathBuf> {
        Ok(if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::env::current_dir()
                .context("reading the current directory")?
                .join(p)
        })
    };
    let out_dir = absolute(&out.unwrap_or_else(|| job.render.output_directory.clone()))?;
    let options = plan::SlurmOptions {
        exe: std::env::current_exe().context("locating the atmosim binary")?,
        job_file: std::fs::canonicalize(job_path).with_context(|| format!("resolving {}", job_path.display()))?,
        out_dir: out_dir.clone(),
        shards,
        cpus,
        time: time.clone(),
        checkpoint_minutes: checkpoint_every,
    };
    let (time, estimate) = match time {
        Some(t) => (t, None),
        None => {
            let calibration = plan::calibrate(job);
            let secs = plan::unit_seconds(job, shards, &calibration, cpus);
            (plan::hms(secs), Some(calibration))
        }
    };
    let script = plan::slurm_script(job, &options, &time);
    let logs = out_dir.join("slurm").join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let path = out_dir.join("slurm").join("render.sbatch");
    atmosim::io::atomic::write_atomic(&path, script.as_bytes())?;
    let units = plan::units(job, shards);
    if units > 1001 {
        eprintln!(
            "note: {units} units exceed SLURM's default MaxArraySize (1001); submit in slices with ATMOSIM_UNIT_OFFSET (see the script's header)"
        );
    }
    if let Some(calibration) = estimate {
        let hours = calibration.max_task_core_seconds(job) / 3600.0;
        eprintln!(
            "time per unit {time}: twice the estimate of the dearest task ({hours:.1} core-hours, rates calibrated \
             per class of sun elevation) over {shards} shards on {cpus} cpus, plus 10 minutes"
        );
    }
    print_text(&format!("{}\n", path.display()))?;
    eprintln!(
        "{units} units ({} tasks × {shards} shards); submit with: sbatch {}",
        job.tasks.len(),
        path.display()
    );
    Ok(())
}
