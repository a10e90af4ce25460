//! `atmosim fit FIT.toml`: rendered skies and transmittance tables → one
//! dataset file the Prague sky model's runtime reads, with its provenance
//! (`<out>.toml`) and the per-image fit figures (`<out>.fit.csv`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use atmosim::io::atomic::write_atomic;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::fit::grid::{GridFit, fit_grid, provenance};
use atmosim::skymodel::fit::renders;
use atmosim::skymodel::fit::settings::FitSettings;
use atmosim::skymodel::report::half_loss::half_float_snr_db;
use atmosim::skymodel::runtime::Model;

use super::common::thread_pool;

#[derive(clap::Args)]
pub struct FitArgs {
    /// Fit settings (TOML): `renders`, `out` and optionally `transmittance` (see README).
    settings: PathBuf,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
    /// No progress lines on stderr.
    #[arg(long, short)]
    quiet: bool,
}

/// The sidecar paths of a dataset: `<out>.toml` and `<out>.fit.csv`.
pub fn sidecars(out: &Path) -> (PathBuf, PathBuf) {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    (
        out.with_file_name(format!("{name}.toml")),
        out.with_file_name(format!("{name}.fit.csv")),
    )
}

pub fn run(args: FitArgs) -> anyhow::Result<()> {
    let settings = FitSettings::from_file(&args.settings)?;
    let grid = renders::scan(&settings.renders)?;
    if let Some(parent) = settings.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
    }
    let configs = grid.configs.len();
    let images = configs * grid.albedos.len() * grid.wavelengths_nm.len();
    if !args.quiet {
        eprintln!(
            "fitting {configs} configurations ({} visibilities × {} altitudes × {} elevations) × {} albedos × {} channels \
             = {images} images{}",
            grid.visibilities_km.len(),
            grid.altitudes_km.len(),
            grid.elevations_deg.len(),
            grid.albedos.len(),
            grid.wavelengths_nm.len(),
            if grid.polarised && settings.polarisation_rank > 0 {
                ", with polarisation"
            } else {
                ""
            }
        );
    }
    let pool = thread_pool(args.threads)?;
    let start = std::time::Instant::now();
    let quiet = args.quiet;
    let progress = move |done: usize| {
        if !quiet {
            eprintln!(
                "  {done}/{configs} configurations, {:.1} s",
                start.elapsed().as_secs_f64()
            );
        }
    };
    let fit = pool.install(|| fit_grid(&settings, &grid, &progress))?;
    let name = settings.out.display().to_string();
    let dataset = Dataset::encode(&fit.fit, &name)?;
    let half_snr = {
        let solar = SolarSpectrum::kurucz()?;
        let halves = Model::new(&name, dataset.clone(), solar.clone())?;
        let unrounded = Model::new(&name, Dataset::unrounded(&fit.fit, &name)?, solar)?;
        pool.install(|| half_float_snr_db(&halves, &unrounded, &grid, HALF_LOSS_WIDTH))
    };
    dataset.write(&settings.out)?;
    let (toml, csv) = sidecars(&settings.out);
    write_atomic(&toml, provenance(&settings, &grid, &fit, &settings.out).as_bytes())?;
    write_atomic(&csv, stats_csv(&fit, &half_snr).as_bytes())?;
    let wall = start.elapsed().as_secs_f64();
    let min_explained = fit
        .images
        .iter()
        .filter_map(|i| i.explained.get(settings.rank - 1))
        .fold(1.0f64, |m, &e| m.min(e));
    println!(
        "{}: {images} images in {wall:.1} s ({:.3} core-seconds per image); explained variance at rank {} ≥ {:.5}; \
         transmittance max |ΔT| at the nodes {:.2e}; {} bytes",
        settings.out.display(),
        fit.image_core_seconds / images as f64,
        settings.rank,
        min_explained,
        fit.transmittance.max_abs_error,
        std::fs::metadata(&settings.out).map(|m| m.len()).unwrap_or(0)
    );
    println!("provenance: {}\nper-image figures: {}", toml.display(), csv.display());
    Ok(())
}

/// The width of the sphere on which the halves' loss is measured (a
/// pixel of 2.8°).
const HALF_LOSS_WIDTH: usize = 128;

/// One row per image: its configuration, κ, the SNR of the written
/// dataset against its unrounded fit (the halves' loss), and the explained
/// variance by rank.
fn stats_csv(fit: &GridFit, half_snr_db: &[f64]) -> String {
    let ranks = fit.images.first().map_or(0, |i| i.explained.len());
    let pol_ranks = fit.images.first().map_or(0, |i| i.polarisation_explained.len());
    let mut s = String::from("visibility_km,albedo,altitude_m,elevation_deg,wavelength_nm,kappa,half_float_snr_db");
    for r in 1..=ranks {
        s.push_str(&format!(",explained_r{r}"));
    }
    for r in 1..=pol_ranks {
        s.push_str(&format!(",pol_explained_r{r}"));
    }
    s.push('\n');
    for (i, snr) in fit.images.iter().zip(half_snr_db) {
        s.push_str(&format!(
            "{},{},{},{},{},{:.6},{snr:.3}",
            i.visibility_km, i.albedo, i.altitude_m, i.elevation_deg, i.wavelength_nm, i.kappa
        ));
        for e in i.explained.iter().chain(&i.polarisation_explained) {
            s.push_str(&format!(",{e:.8}"));
        }
        s.push('\n');
    }
    s
}
