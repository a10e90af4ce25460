//! A whole fit: every configuration of a rendered grid fitted in parallel
//! (each task's images read once, its albedos and channels fitted in
//! turn, each with the tables of the neighbouring sun elevations at hand),
//! the transmittance tables fitted per observer altitude, and the result
//! gathered in the dataset's order.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::breaks::{emph_breaks, sun_breaks, zenith_breaks};
use super::image_fit::{LayerFit, PreparedLayer, fit_prepared, prepare_layer};
use super::render_layers;
use super::renders::RenderGrid;
use super::settings::FitSettings;
use super::transmittance::{self, TransmittanceResult};
use crate::error::Result;
use crate::skymodel::dataset::{Axes, DatasetFit, PolarisationFit, RadianceConfigFit, RadianceFit};

/// A finished fit before it is rounded to the file's precisions.
#[derive(Debug, Clone)]
pub struct GridFit {
    pub fit: DatasetFit,
    /// One entry per image, in the dataset's order.
    pub images: Vec<ImageStats>,
    pub transmittance: TransmittanceResult,
    /// Core-seconds spent in the image fits (reading the images included).
    pub image_core_seconds: f64,
}

/// What the fit of one image (configuration, albedo, channel) found.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageStats {
    pub visibility_km: f64,
    pub albedo: f64,
    pub altitude_m: f64,
    pub elevation_deg: f64,
    pub wavelength_nm: f64,
    /// Explained variance of the (γ, α) table by rank 1, 2, …, over its
    /// cells with data (`image_fit::low_rank_weighted`).
    pub explained: Vec<f64>,
    /// The pre-emphasis's κ (below-horizon brightness over the infill's).
    pub kappa: f64,
    /// The polarisation table's explained variance by rank.
    pub polarisation_explained: Vec<f64>,
}

/// Fits the grid of `settings.renders`; `done` is called with the number
/// of configurations finished so far (for progress).
pub fn fit_grid(settings: &FitSettings, grid: &RenderGrid, done: &(dyn Fn(usize) + Sync)) -> Result<GridFit> {
    let tables = match settings.transmittance.as_deref() {
        Some(dir) => transmittance::read(dir, &grid.wavelengths_nm)?,
        None => transmittance::compute(&grid.jobs, &grid.wavelengths_nm)?,
    };
    let transmittance = transmittance::fit_rank(&tables, &grid.wavelengths_nm, settings.transmittance_rank)?;
    let finished = AtomicUsize::new(0);
    let polarised = grid.polarised && settings.polarisation_rank > 0;
    // One (visibility, altitude) column of sun elevations at a time: its
    // images are prepared in parallel, then each image is completed with
    // its neighbouring elevations' tables (same albedo and channel) and
    // fitted, in parallel again. Only one column's tables are held.
    let n_elev = grid.elevations_deg.len();
    let mut per_config: Vec<(Vec<LayerFit>, f64)> = Vec::with_capacity(grid.configs.len());
    for column in grid.configs.chunks(n_elev) {
        let prepared: Vec<(Vec<PreparedLayer>, f64)> = column
            .par_iter()
            .map(|config| {
                let start = std::time::Instant::now();
                let layers = render_layers::load(grid, config)?;
                let prepared = layers
                    .iter()
                    .map(|layer| {
                        prepare_layer(
                            layer,
                            config.elevation_deg,
                            config.altitude_km * 1000.0,
                            settings,
                            polarised,
                        )
                    })
                    .collect::<Vec<_>>();
                Ok((prepared, start.elapsed().as_secs_f64()))
            })
            .collect::<Result<_>>()?;
        let fitted: Vec<(Vec<LayerFit>, f64)> = (0..column.len())
            .into_par_iter()
            .map(|e| {
                let start = std::time::Instant::now();
                let fits = (0..prepared[e].0.len())
                    .map(|l| {
                        let neighbours: Vec<&PreparedLayer> = [e.checked_sub(1), Some(e + 1)]
                            .into_iter()
                            .flatten()
                            .filter_map(|k| prepared.get(k).map(|(layers, _)| &layers[l]))
                            .collect();
                        fit_prepared(&prepared[e].0[l], &neighbours, settings)
                    })
                    .collect::<Vec<_>>();
                done(finished.fetch_add(1, Ordering::Relaxed) + 1);
                (fits, prepared[e].1 + start.elapsed().as_secs_f64())
            })
            .collect();
        per_config.extend(fitted);
    }
    let axes = Axes {
        visibilities_km: grid.visibilities_km.clone(),
        albedos: grid.albedos.clone(),
        altitudes_m: grid.altitudes_km.iter().map(|a| a * 1000.0).collect(),
        elevations_deg: grid.elevations_deg.clone(),
        channels: grid.wavelengths_nm.len(),
        channel_start_nm: grid.channel_start_nm,
        channel_width_nm: grid.channel_width_nm,
    };
    let n = axes.configurations();
    let mut configs: Vec<Option<RadianceConfigFit>> = vec![None; n];
    let mut pol: Vec<Option<Vec<_>>> = vec![None; n];
    let mut images: Vec<Option<ImageStats>> = vec![None; n];
    let (n_alt, n_elev, n_ch) = (
        grid.altitudes_km.len(),
        grid.elevations_deg.len(),
        grid.wavelengths_nm.len(),
    );
    for (k, (fits, _)) in per_config.iter().enumerate() {
        let (v, h, e) = (k / (n_alt * n_elev), (k / n_elev) % n_alt, k % n_elev);
        for (l, fit) in fits.iter().enumerate() {
            let (a, c) = (l / n_ch, l % n_ch);
            let index = axes.configuration([v, a, h, e, c]);
            configs[index] = Some(fit.radiance.clone());
            pol[index] = fit.polarisation.clone();
            images[index] = Some(ImageStats {
                visibility_km: axes.visibilities_km[v],
                albedo: axes.albedos[a],
                altitude_m: axes.altitudes_m[h],
                elevation_deg: axes.elevations_deg[e],
                wavelength_nm: grid.wavelengths_nm[c],
                explained: fit.explained.clone(),
                kappa: fit.kappa,
                polarisation_explained: fit.polarisation_explained.clone(),
            });
        }
    }
    let configs: Vec<RadianceConfigFit> = configs.into_iter().map(|c| c.expect("every image fitted")).collect();
    let polarisation = polarised.then(|| PolarisationFit {
        sun_breaks: sun_breaks(settings.sun_breaks),
        zenith_breaks: zenith_breaks(settings.zenith_breaks),
        configs: pol.into_iter().map(|p| p.expect("every image fitted")).collect(),
    });
    Ok(GridFit {
        fit: DatasetFit {
            axes,
            radiance: RadianceFit {
                sun_breaks: sun_breaks(settings.sun_breaks),
                zenith_breaks: zenith_breaks(settings.zenith_breaks),
                emph_breaks: emph_breaks(settings.emph_breaks),
                configs,
            },
            transmittance: transmittance.part.clone(),
            polarisation,
        },
        images: images.into_iter().map(|i| i.expect("every image fitted")).collect(),
        transmittance,
        image_core_seconds: per_config.iter().map(|(_, s)| s).sum(),
    })
}

/// The provenance sidecar of a dataset (`<dataset>.toml`): the render jobs,
/// the atmosphere, the samples, the fit settings and the fit's figures.
pub fn provenance(settings: &FitSettings, grid: &RenderGrid, fit: &GridFit, dataset: &Path) -> String {
    let mut s = String::from("# atmosim sky-model dataset: where it came from\n");
    s.push_str(&format!("atmosim_version = \"{}\"\n", env!("CARGO_PKG_VERSION")));
    s.push_str(&format!("dataset = {:?}\n", dataset.display().to_string()));
    s.push_str(&format!("atmosphere = {:?}\n", grid.atmosphere));
    let jobs: Vec<String> = grid
        .jobs
        .iter()
        .map(|(h, f)| format!("{{ hash = {h:?}, file = {f:?} }}"))
        .collect();
    s.push_str(&format!("render_jobs = [{}]\n", jobs.join(", ")));
    let samples: Vec<u64> = grid.configs.iter().map(|c| c.samples).collect();
    s.push_str(&format!(
        "samples_per_pixel = {{ min = {}, max = {} }}\n",
        samples.iter().min().unwrap_or(&0),
        samples.iter().max().unwrap_or(&0)
    ));
    s.push_str(&format!("transmittance_tables = {:?}\n", fit.transmittance.source));
    s.push_str(&format!(
        "images = {}\nimage_core_seconds = {:.3}\ntransmittance_rank = {}\ntransmittance_max_abs_error = {:.6e}\n",
        fit.images.len(),
        fit.image_core_seconds,
        fit.transmittance.part.rank,
        fit.transmittance.max_abs_error
    ));
    s.push_str("\n[settings]\n");
    s.push_str(&settings.to_toml());
    s
}
