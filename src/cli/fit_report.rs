//! `atmosim fit-report FIT.toml`: the dataset that `atmosim fit FIT.toml`
//! wrote, compared with the renders it came from (and optionally with
//! reference renders of the same configurations, a twin dataset fitted
//! from renders with another seed, renders between the nodes and
//! transmittance tables off the nodes); writes `report.md` with box plots
//! and the per-image figures as CSV.

use std::path::PathBuf;

use anyhow::Context;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::fit::renders;
use atmosim::skymodel::fit::settings::FitSettings;
use atmosim::skymodel::report::interpolation::interpolation;
use atmosim::skymodel::report::score::score;
use atmosim::skymodel::report::transmittance_check::TransmittanceError;
use atmosim::skymodel::report::twin::{check_same_grid, seed_to_seed};
use atmosim::skymodel::report::{
    ReportExtras, reference_summary, snr_summary, transmittance_check, twin_summary, write_report,
};
use atmosim::skymodel::runtime::Model;

use super::common::thread_pool;
use atmosim::skymodel::fit_files::sidecars;

#[derive(clap::Args)]
pub struct FitReportArgs {
    /// The fit settings the dataset was made with.
    settings: PathBuf,
    /// A render job's output directory with renders between the grid's
    /// nodes, for the interpolation ratio.
    #[arg(long)]
    mid: Option<PathBuf>,
    /// A render job's output directory with reference renders of the
    /// grid's configurations, made apart from the fit's renders (another
    /// seed, more samples, any resolution): the dataset against the
    /// converged sky. Repeat for several.
    #[arg(long)]
    reference: Vec<PathBuf>,
    /// A dataset fitted with the same settings from the same configurations
    /// rendered with another seed: the render noise the dataset inherits.
    #[arg(long)]
    twin: Option<PathBuf>,
    /// A transmittance job's output directory with tables off the fitted
    /// nodes.
    #[arg(long)]
    transmittance_check: Option<PathBuf>,
    /// Report directory (default: `<out>.report` beside the dataset).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
}

pub fn run(args: FitReportArgs) -> anyhow::Result<()> {
    let settings = FitSettings::from_file(&args.settings)?;
    let name = settings.out.display().to_string();
    let model = Model::new(&name, Dataset::read(&settings.out)?, SolarSpectrum::kurucz()?)?;
    let grid = renders::scan(&settings.renders)?;
    let mid = args
        .mid
        .as_ref()
        .map(|d| renders::scan(std::slice::from_ref(d)))
        .transpose()?;
    let reference = if args.reference.is_empty() {
        None
    } else {
        Some(renders::scan(&args.reference).context("--reference: the reference renders")?)
    };
    let twin = args
        .twin
        .as_ref()
        .map(|p| -> anyhow::Result<Model> {
            let name = p.display().to_string();
            let twin = Model::new(&name, Dataset::read(p)?, SolarSpectrum::kurucz()?)?;
            check_same_grid(&model, &twin, &name)?;
            Ok(twin)
        })
        .transpose()?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{name}.report")));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let pool = thread_pool(args.threads)?;
    let scores = pool.install(|| score(&model, &grid))?;
    let mut extras = ReportExtras {
        dataset: name.clone(),
        ..Default::default()
    };
    if let Some(reference) = &reference {
        extras.reference = pool.install(|| score(&model, reference))?;
        let samples: Vec<u64> = reference.configs.iter().map(|c| c.samples).collect();
        let (w, h) = reference.configs.first().map_or((0, 0), |c| match &c.source {
            renders::Source::Sphere { camera, .. } => camera.size(),
            renders::Source::Fisheyes { up_camera, .. } => {
                let n = up_camera.size().0;
                (2 * n, n)
            }
        });
        extras.reference_source = format!(
            "{}; {w}x{h}, {} to {} samples per pixel",
            args.reference
                .iter()
                .map(|p| format!("`{}`", p.display()))
                .collect::<Vec<_>>()
                .join(", "),
            samples.iter().min().unwrap_or(&0),
            samples.iter().max().unwrap_or(&0)
        );
    }
    if let Some(twin) = &twin {
        extras.twin = pool.install(|| seed_to_seed(&model, twin, &grid))?;
        extras.twin_source = format!(
            "`{}`",
            args.twin.as_ref().map_or(String::new(), |p| p.display().to_string())
        );
    }
    if let Some(mid) = &mid {
        extras.interpolation = pool.install(|| interpolation(&model, mid, &settings))?;
    }
    if let Some(t) = &settings.transmittance {
        extras.transmittance_on_nodes = Some(transmittance_check::max_abs_error(&model, t)?);
    }
    if let Some(t) = &args.transmittance_check {
        extras.transmittance_off_nodes = Some(transmittance_check::max_abs_error(&model, t)?);
    }
    let (provenance, figures) = sidecars(&settings.out);
    if let Ok(text) = std::fs::read_to_string(&figures) {
        extras.explained = explained_by_rank(&text);
        let half = column(&text, |c| c == "half_float_snr_db").pop().map(|(_, v)| v);
        extras.half_float_snr_db = half.filter(|v| !v.is_empty()).map(|v| {
            (
                v.iter().sum::<f64>() / v.len() as f64,
                v.iter().fold(f64::INFINITY, |m, &x| m.min(x)),
            )
        });
    }
    if let Ok(text) = std::fs::read_to_string(&provenance) {
        let value = |k: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(k).and_then(|r| r.trim_start().strip_prefix('=')))
                .and_then(|v| v.trim().parse::<f64>().ok())
        };
        if let (Some(s), Some(n)) = (value("image_core_seconds"), value("images")) {
            extras.core_seconds_per_image = Some(s / n);
        }
        // Tables the fit computed itself are not on disk: its own figure.
        if let (None, Some(max_abs)) = (&extras.transmittance_on_nodes, value("transmittance_max_abs_error")) {
            extras.transmittance_on_nodes = Some(TransmittanceError {
                max_abs,
                worst_at: "as the fit measured it on the tables it computed".into(),
                ..Default::default()
            });
        }
    }
    write_report(&out, &scores, &extras)?;
    let (mean, min, _) = snr_summary(&scores);
    println!(
        "{}: {} images, SNR mean {mean:.2} dB, minimum {min:.2} dB",
        out.join("report.md").display(),
        scores.len()
    );
    if let Some(r) = reference_summary(&extras.reference) {
        println!(
            "against the references ({} images): SNR mean {:.2} dB, minimum {:.2} dB; their noise floor mean {:.2} dB, \
             minimum {:.2} dB; debiased SNR mean {:.2} dB, minimum {:.2} dB ({} unresolved, at their lower bound); \
             polarisation error mean {}",
            r.images,
            r.snr_db.0,
            r.snr_db.1,
            r.noise_floor_db.0,
            r.noise_floor_db.1,
            r.debiased_snr_db.0,
            r.debiased_snr_db.1,
            r.unresolved,
            r.polarisation_error.map_or("—".into(), |p| format!("{:.4}", p.0))
        );
    }
    if let Some(((m, lo), pol)) = twin_summary(&extras.twin) {
        println!(
            "seed to seed ({} images): SNR mean {m:.2} dB, minimum {lo:.2} dB; polarisation difference mean {}",
            extras.twin.len(),
            pol.map_or("—".into(), |p| format!("{:.4}", p.0))
        );
    }
    if !extras.interpolation.is_empty() {
        let max = extras.interpolation.iter().map(|s| s.ratio()).fold(0.0f64, f64::max);
        let snr = extras.interpolation.iter().map(|s| s.snr_interpolated_db);
        let n = extras.interpolation.len();
        let mean = snr.clone().sum::<f64>() / n as f64;
        let min = snr.fold(f64::INFINITY, f64::min);
        println!(
            "interpolation ratio max {max:.3} over {n} images; the interpolated dataset's SNR against them mean {mean:.2} dB, minimum {min:.2} dB"
        );
    }
    for (what, t) in [
        ("on", &extras.transmittance_on_nodes),
        ("off", &extras.transmittance_off_nodes),
    ] {
        if let Some(t) = t {
            if t.points == 0 {
                // The fit's own measure (no points of a check table).
                println!(
                    "transmittance max |ΔT| {what} the nodes {:.2e} ({})",
                    t.max_abs, t.worst_at
                );
            } else {
                println!(
                    "transmittance max |ΔT| {what} the nodes {:.2e} ({} points; largest at {})",
                    t.max_abs, t.points, t.worst_at
                );
            }
            if t.points > 0 {
                println!(
                    "transmittance |ΔT| {what} the nodes: 99th percentile {:.2e}, mean {:.2e}",
                    t.p99_abs, t.mean_abs
                );
            }
        }
    }
    Ok(())
}

/// The columns of a fit's figures whose header `pick`s, each as (header,
/// values).
fn column(csv: &str, pick: impl Fn(&str) -> bool) -> Vec<(&str, Vec<f64>)> {
    let mut lines = csv.lines();
    let Some(header) = lines.next() else { return Vec::new() };
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap_or(f64::NAN)).collect())
        .collect();
    header
        .split(',')
        .enumerate()
        .filter(|(_, c)| pick(c))
        .map(|(i, c)| (c, rows.iter().filter_map(|row| row.get(i).copied()).collect()))
        .collect()
}

/// (rank, mean, minimum) of the `explained_r<k>` columns of a fit's figures.
fn explained_by_rank(csv: &str) -> Vec<(usize, f64, f64)> {
    column(csv, |c| c.starts_with("explained_r"))
        .into_iter()
        .filter_map(|(c, v)| {
            let r: usize = c.strip_prefix("explained_r")?.parse().ok()?;
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            Some((r, mean, v.iter().fold(1.0f64, |m, &x| m.min(x))))
        })
        .collect()
}
