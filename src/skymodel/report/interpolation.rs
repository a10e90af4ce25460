//! The interpolation ratio of the supplement's section 5.2: for a render B
//! between the dataset's nodes, rmse(B, I) / rmse(B, F), with I the dataset
//! interpolated to B's configuration and F B's own fit (the same steps
//! and settings as `atmosim fit`, in double precision). 1 means the
//! interpolation loses nothing over fitting B itself.

use super::score::{compare, each_image, evaluated, parameters_at};
use crate::error::Result;
use crate::skymodel::fit::SphereImage;
use crate::skymodel::fit::breaks::{emph_breaks, eval_piecewise, sun_breaks, zenith_breaks};
use crate::skymodel::fit::image_fit::fit_layer;
use crate::skymodel::fit::renders::RenderGrid;
use crate::skymodel::fit::settings::FitSettings;
use crate::skymodel::runtime::Model;

/// One between-node render's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct InterpolationScore {
    pub visibility_km: f64,
    pub albedo: f64,
    pub altitude_m: f64,
    pub elevation_deg: f64,
    pub wavelength_nm: f64,
    pub rmse_interpolated: f64,
    pub rmse_fit: f64,
    /// The interpolated dataset's own SNR against B (dB), as `fit-report`
    /// scores the dataset against its renders at the nodes.
    pub snr_interpolated_db: f64,
}

impl InterpolationScore {
    /// rmse(B, I) / rmse(B, F).
    pub fn ratio(&self) -> f64 {
        self.rmse_interpolated / self.rmse_fit
    }
}

/// Scores every image of the between-node renders `grid`.
pub fn interpolation(model: &Model, grid: &RenderGrid, settings: &FitSettings) -> Result<Vec<InterpolationScore>> {
    let (sb, zb, eb) = (
        sun_breaks(settings.sun_breaks),
        zenith_breaks(settings.zenith_breaks),
        emph_breaks(settings.emph_breaks),
    );
    each_image(grid, |config, layer| {
        let (interpolated, _) = evaluated(model, config, layer.albedo, layer.wavelength_nm, &layer.radiance);
        let own = fit_layer(
            layer,
            config.elevation_deg,
            config.altitude_km * 1000.0,
            settings,
            false,
        );
        let img = &layer.radiance;
        let mut fitted = SphereImage::zeros(img.width, img.height);
        for j in 0..img.height {
            for i in 0..img.width {
                let p = parameters_at(img.direction(i, j), config, layer.albedo);
                let alpha = if p.elevation < 0.0 { p.shadow } else { p.zero };
                let sum: f64 = own
                    .radiance
                    .components
                    .iter()
                    .map(|c| eval_piecewise(&sb, &c.sun, p.gamma) * eval_piecewise(&zb, &c.zenith, alpha))
                    .sum();
                fitted.values[j * img.width + i] = (sum * eval_piecewise(&eb, &own.radiance.emph, p.zero)).max(0.0);
            }
        }
        let against = compare(layer, &interpolated, None, &[]);
        InterpolationScore {
            visibility_km: config.visibility_km,
            albedo: layer.albedo,
            altitude_m: config.altitude_km * 1000.0,
            elevation_deg: config.elevation_deg,
            wavelength_nm: layer.wavelength_nm,
            rmse_interpolated: against.rmse(),
            rmse_fit: compare(layer, &fitted, None, &[]).rmse(),
            snr_interpolated_db: against.snr_db(),
        }
    })
}
