//! `atmosim transmittance`: writes each transmittance task's table as
//! transmittance.csv and transmittance.exr, with the EXR's metadata.

use std::path::PathBuf;

use atmosim::io::output;
use atmosim::job::{Job, Task};
use atmosim::run::out_dir::Destination;
use atmosim::transport::table_build::transmittance_table;

use super::common::thread_pool;

#[derive(clap::Args)]
pub struct TransmittanceArgs {
    /// Job file (TOML).
    job: PathBuf,
    /// Output directory (default: the job's `[output] directory`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
    /// No progress lines on stderr.
    #[arg(long, short)]
    quiet: bool,
    /// Write into directories that hold another job's tables, replacing
    /// them (without it such a directory is refused).
    #[arg(long)]
    overwrite: bool,
}

pub fn run(args: TransmittanceArgs) -> anyhow::Result<()> {
    let TransmittanceArgs {
        job,
        out,
        threads,
        quiet,
        overwrite,
    } = args;
    let job = Job::from_file(&job)?;
    let pool = thread_pool(threads)?;
    let destination = Destination::of(&job, out.as_deref());
    let base = destination.dir.clone();
    let tasks = job.transmittance_tasks();
    let dir_of = |name: &str| {
        if tasks.len() == 1 {
            base.clone()
        } else {
            base.join(name)
        }
    };
    destination.check_writable()?;
    let dirs: Vec<PathBuf> = tasks.iter().map(|(_, name)| dir_of(name)).collect();
    destination.check_not_another_job(&job, &dirs, overwrite)?;
    for (task, name) in &tasks {
        let start = std::time::Instant::now();
        let table = pool.install(|| transmittance_table(&job, task));
        let spec = &job.transmittance;
        let dir = dir_of(name);
        let csv = output::transmittance_csv(&job.wavelengths_nm, &spec.grid, &table, spec.export_sqrt);
        atmosim::io::atomic::write_atomic(&dir.join("transmittance.csv"), csv.as_bytes())?;
        output::write_transmittance_exr(
            &dir.join("transmittance.exr"),
            &job.wavelengths_nm,
            &spec.grid,
            &table,
            spec.export_sqrt,
            &transmittance_attributes(&job, task, name),
        )?;
        if !quiet {
            let secs = start.elapsed().as_secs_f64();
            eprintln!(
                "{}: {} points × {} wavelengths in {secs:.2} s ({:.0} points/s, {}) → {}",
                name,
                spec.grid.len(),
                job.wavelengths_nm.len(),
                spec.grid.len() as f64 / secs,
                spec.estimator.name(),
                dir.display()
            );
        }
    }
    Ok(())
}

/// Metadata of a transmittance EXR: everything needed to interpret it.
fn transmittance_attributes(job: &Job, task: &Task, name: &str) -> Vec<(String, String)> {
    let spec = &job.transmittance;
    let list = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ");
    vec![
        ("atmosim_version".into(), env!("CARGO_PKG_VERSION").into()),
        ("job_hash".into(), job.hash.clone()),
        ("task".into(), name.to_string()),
        (
            "quantity".into(),
            "transmittance from the observer along the straight line of sight, no refraction".into(),
        ),
        (
            "units".into(),
            "1 (T, T_se, sqrtT); blocked: 1 if the line of sight passes below the ground".into(),
        ),
        (
            "layout".into(),
            "x (columns) = ground distance nodes, y (rows) = altitude nodes, row 0 = lowest altitude".into(),
        ),
        ("grid".into(), spec.grid.definition.clone()),
        ("altitudes_km".into(), list(&spec.grid.altitudes_km)),
        ("distances_km".into(), list(&spec.grid.distances_km)),
        ("wavelengths_nm".into(), list(&job.wavelengths_nm)),
        ("band_width_nm".into(), list(&job.band_widths_nm)),
        ("observer_altitude_km".into(), format!("{}", task.observer_altitude_km)),
        (
            "visibility_km".into(),
            task.atmosphere
                .visibility
                .map_or("none".into(), |v| format!("{}", v.ground_km)),
        ),
        ("planet_radius_km".into(), format!("{}", job.planet.radius_km)),
        ("top_km".into(), format!("{}", job.planet.top_km)),
        ("estimator".into(), spec.estimator.name().into()),
        ("samples".into(), format!("{}", spec.samples)),
        ("seed".into(), format!("{}", job.render.seed)),
    ]
}
