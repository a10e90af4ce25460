//! `atmosim fit FIT.toml`: rendered skies and transmittance tables → one
//! dataset file the Prague sky model's runtime reads, with its provenance
//! (`<out>.toml`) and the per-image fit figures (`<out>.fit.csv`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use atmosim::Error;
use atmosim::io::atomic::write_atomic;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::run::shard::Shard;
use atmosim::skymodel::combine::combine_files;
use atmosim::skymodel::dataset::Dataset;
use atmosim::skymodel::fit::grid::{GridFit, fit_grid, provenance};
use atmosim::skymodel::fit::renders;
use atmosim::skymodel::fit::settings::FitSettings;
use atmosim::skymodel::fit_files::{shard_path, sidecars};
use atmosim::skymodel::report::half_loss::half_float_snr_db;
use atmosim::skymodel::runtime::Model;

use super::common::thread_pool;

#[derive(clap::Args)]
pub struct FitArgs {
    /// Fit settings (TOML): `renders`, `out` and optionally `transmittance` (docs/sky-models.md).
    settings: PathBuf,
    /// Worker threads (0 or absent: one per available core).
    #[arg(long)]
    threads: Option<usize>,
    /// No progress lines on stderr.
    #[arg(long, short)]
    quiet: bool,
    /// Fit only shard K of N of the grid (a contiguous range of its
    /// visibilities) into `<out>.shard-KKKK-of-NNNN.dat`; join the shards
    /// with `--combine`.
    #[arg(long, value_name = "K/N", conflicts_with = "combine")]
    shard: Option<Shard>,
    /// Join the shard datasets `<out>.shard-*-of-NNNN.dat` (every K of one
    /// N) into `out`, with their figures and provenance.
    #[arg(long)]
    combine: bool,
}

pub fn run(args: FitArgs) -> anyhow::Result<()> {
    let settings = FitSettings::from_file(&args.settings)?;
    if let Some(parent) = settings.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
    }
    if args.combine {
        return combine_shards(&settings.out);
    }
    let full = renders::scan(&settings.renders)?;
    let (grid, out) = match args.shard {
        None => (full, settings.out.clone()),
        Some(shard) => {
            let n = full.visibilities_km.len();
            if shard.count as usize > n {
                return Err(Error::data(
                    "--shard",
                    format!(
                        "{shard}: a shard is a range of visibilities, and the grid has {n} (use at most {n} shards)"
                    ),
                )
                .into());
            }
            let r = shard.range(n as u64);
            (
                full.visibilities(r.start as usize..r.end as usize),
                shard_path(&settings.out, shard),
            )
        }
    };
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
    if let Some((below, above)) = grid.horizon_gap() {
        eprintln!(
            "warning: the sun elevations jump from {below}° to {above}° with no 0° node: between them the runtime \
             reads one of the two tables in the other's angles (shadow angle below the horizon, zenith angle above), \
             so the sky there is wrong; render the 0° elevation too"
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
    let name = out.display().to_string();
    let dataset = Dataset::encode(&fit.fit, &name)?;
    let half_snr = {
        let solar = SolarSpectrum::kurucz()?;
        let halves = Model::new(&name, dataset.clone(), solar.clone())?;
        let unrounded = Model::new(&name, Dataset::unrounded(&fit.fit, &name)?, solar)?;
        pool.install(|| half_float_snr_db(&halves, &unrounded, &grid, HALF_LOSS_WIDTH))
    };
    dataset.write(&out)?;
    let (toml, csv) = sidecars(&out);
    write_atomic(&toml, provenance(&settings, &grid, &fit, &out).as_bytes())?;
    write_atomic(&csv, stats_csv(&fit, &half_snr).as_bytes())?;
    let wall = start.elapsed().as_secs_f64();
    let min_explained = fit
        .images
        .iter()
        .filter_map(|i| i.explained.get(settings.rank - 1))
        .fold(1.0f64, |m, &e| m.min(e));
    println!(
        "{}: {images} images in {wall:.1} s ({:.3} core-seconds per image); explained variance at rank {} ≥ {:.5}; \
         transmittance rank {}, max |ΔT| at the nodes {:.2e}; {} bytes",
        out.display(),
        fit.image_core_seconds / images as f64,
        settings.rank,
        min_explained,
        fit.transmittance.part.rank,
        fit.transmittance.max_abs_error,
        std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0)
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

/// `--combine`: the shards of `out` joined into `out`, their figures
/// concatenated in visibility order, their provenance summed.
fn combine_shards(out: &Path) -> anyhow::Result<()> {
    let joined = combine_files(out)?;
    joined.dataset.write(out)?;
    let (toml, csv) = sidecars(out);
    write_atomic(&toml, joined.provenance.as_bytes())?;
    write_atomic(&csv, joined.figures.as_bytes())?;
    println!(
        "{}: {} shards joined, {} visibilities; provenance {}, figures {}",
        out.display(),
        joined.shards,
        joined.dataset.axes.visibilities_km.len(),
        toml.display(),
        csv.display()
    );
    Ok(())
}
