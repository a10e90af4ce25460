//! The noise a dataset inherits from its renders: the same configurations
//! rendered again with an independent seed and fitted (the twin), both
//! datasets evaluated at the pixel centres of each image, with
//! solid-angle weights w:
//!
//!   seed-to-seed SNR = 10·log10(Σ w·F̄² / Σ w·(F₁ − F₂)²),  F̄ = (F₁ + F₂)/2.
//!
//! Where the fit passes render noise linearly (its error small against the
//! sky, as it is here), F₁ − F₂ is the difference of two independent draws
//! of the inherited noise, whose power is twice one dataset's: one
//! dataset's inherited noise is 3.01 dB below the difference,
//! [`TwinScore::inherited_snr_db`]. The fit's own error (the same in both)
//! cancels, so this is the render noise alone, whatever the fit's bias.
//! Also the radiance-weighted mean absolute difference of the degree of
//! polarisation, Σ w·F̄·|P₁ − P₂| / Σ w·F̄.

use super::regions::RegionSums;
use super::score::{db, each_image, evaluated, regions_of};
use crate::error::{Error, Result};
use crate::skymodel::fit::renders::RenderGrid;
use crate::skymodel::runtime::Model;

/// 10·log10(2): one dataset's inherited noise against the difference of two.
pub const TWO_DRAWS_DB: f64 = 3.010_299_956_639_812;

/// One image's seed-to-seed comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct TwinScore {
    pub visibility_km: f64,
    pub albedo: f64,
    pub altitude_m: f64,
    pub elevation_deg: f64,
    pub wavelength_nm: f64,
    /// 10·log10(Σ w·F̄² / Σ w·(F₁ − F₂)²).
    pub seed_to_seed_snr_db: f64,
    /// Σ w·F̄·|P₁ − P₂| / Σ w·F̄; `None` without polarisation in both.
    pub polarisation_difference: Option<f64>,
    /// Each region's share of Σ w·(F₁ − F₂)², in the order of
    /// [`super::regions::Region::ALL`].
    pub difference_by_region: [f64; 4],
}

impl TwinScore {
    /// The SNR of one dataset against its own inherited noise.
    pub fn inherited_snr_db(&self) -> f64 {
        self.seed_to_seed_snr_db + TWO_DRAWS_DB
    }
}

/// Refuses a twin whose configuration axes or channels differ from the
/// dataset's: the two must be fits of the same grid.
pub fn check_same_grid(model: &Model, twin: &Model, twin_name: &str) -> Result<()> {
    let (a, b) = (&model.dataset().axes, &twin.dataset().axes);
    if a != b {
        return Err(Error::data(
            twin_name,
            format!(
                "not a fit of the same grid as the dataset (visibilities {:?} / {:?}, albedos {:?} / {:?}, \
                 altitudes {:?} / {:?} m, elevations {:?} / {:?}°, {} / {} channels)",
                a.visibilities_km,
                b.visibilities_km,
                a.albedos,
                b.albedos,
                a.altitudes_m,
                b.altitudes_m,
                a.elevations_deg,
                b.elevations_deg,
                a.channels,
                b.channels
            ),
        ));
    }
    Ok(())
}

/// Each image of `grid` (the renders the dataset was fitted from: their
/// configurations and pixel centres) evaluated in `model` and `twin`.
pub fn seed_to_seed(model: &Model, twin: &Model, grid: &RenderGrid) -> Result<Vec<TwinScore>> {
    each_image(grid, |config, layer| {
        let like = &layer.radiance;
        let (f1, p1) = evaluated(model, config, layer.albedo, layer.wavelength_nm, like);
        let (f2, p2) = evaluated(twin, config, layer.albedo, layer.wavelength_nm, like);
        let regions = regions_of(config, like);
        let mut by_region = RegionSums::default();
        let (mut signal, mut difference, mut pol, mut pol_w) = (0.0, 0.0, 0.0, 0.0);
        for j in 0..like.height {
            let w = like.solid_angle(j);
            for i in 0..like.width {
                let k = j * like.width + i;
                let mean = 0.5 * (f1.values[k] + f2.values[k]);
                let d = f1.values[k] - f2.values[k];
                signal += w * mean * mean;
                difference += w * d * d;
                by_region.add(regions[k], w * d * d);
                if let (Some(p1), Some(p2)) = (&p1, &p2) {
                    pol += w * mean.max(0.0) * (p1.values[k] - p2.values[k]).abs();
                    pol_w += w * mean.max(0.0);
                }
            }
        }
        TwinScore {
            visibility_km: config.visibility_km,
            albedo: layer.albedo,
            altitude_m: config.altitude_km * 1000.0,
            elevation_deg: config.elevation_deg,
            wavelength_nm: layer.wavelength_nm,
            seed_to_seed_snr_db: db(signal, difference),
            polarisation_difference: (pol_w > 0.0).then(|| pol / pol_w),
            difference_by_region: by_region.shares(),
        }
    })
}
