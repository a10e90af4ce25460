//! Fitted against rendered, per image: the dataset evaluated at the
//! rendered configuration (no interpolation: every axis on its node) at
//! each pixel centre, compared with the pixel's rendered radiance with
//! solid-angle weights w.
//!
//! - SNR (dB) = 10·log10(Σ w·L² / Σ w·(L − F)²), L rendered, F fitted;
//! - the render's own noise floor, 10·log10(Σ w·L² / Σ w·se²): the SNR a
//!   perfect fit would show against these renders;
//! - NMAE = Σ w·|L − F| / Σ w·|L|;
//! - the polarisation error Σ w·L·|P − P_F| / Σ w·L, P the rendered signed
//!   degree of polarisation in the sun–view frame.

use rayon::prelude::*;

use crate::error::Result;
use crate::skymodel::angles::{SunPosition, ViewAngles};
use crate::skymodel::fit::SphereImage;
use crate::skymodel::fit::render_layers::{self, Layer};
use crate::skymodel::fit::renders::{ConfigRender, RenderGrid};
use crate::skymodel::runtime::{Model, Parameters};

/// The comparison of one image.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageScore {
    pub visibility_km: f64,
    pub albedo: f64,
    pub altitude_m: f64,
    pub elevation_deg: f64,
    pub wavelength_nm: f64,
    pub snr_db: f64,
    pub noise_floor_db: f64,
    pub nmae: f64,
    /// `None` without polarisation in the dataset or the renders.
    pub polarisation_error: Option<f64>,
    /// Root-mean-square difference (solid-angle weighted), for the
    /// interpolation ratio.
    pub rmse: f64,
}

/// The runtime's parameters of the view `v` of a configuration, its
/// altitude exactly the configuration's (the runtime's 50 m offset is part
/// of the grid's altitudes, not added again).
pub fn parameters_at(v: glam::DVec3, config: &ConfigRender, albedo: f64) -> Parameters {
    let elevation = config.elevation_deg.to_radians();
    let altitude_m = config.altitude_km * 1000.0;
    let a = ViewAngles::of(
        v,
        SunPosition {
            elevation,
            azimuth: 0.0,
        },
        altitude_m,
    );
    Parameters {
        theta: a.theta,
        gamma: a.gamma,
        shadow: a.shadow,
        zero: a.zero,
        elevation,
        altitude_m,
        visibility_km: config.visibility_km,
        albedo,
    }
}

/// The sums of one comparison of a rendered image with a fitted one.
pub fn compare(
    layer: &Layer,
    fitted: &SphereImage,
    fitted_pol: Option<&SphereImage>,
) -> (f64, f64, f64, Option<f64>, f64) {
    let img = &layer.radiance;
    let (mut signal, mut error, mut noise, mut abs_err, mut abs_sig, mut weights) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut pol_err, mut pol_w) = (0.0, 0.0);
    for j in 0..img.height {
        let w = img.solid_angle(j);
        for i in 0..img.width {
            let k = j * img.width + i;
            let (l, f) = (img.values[k], fitted.values[k]);
            signal += w * l * l;
            error += w * (l - f) * (l - f);
            noise += w * layer.radiance_se.values[k].powi(2);
            abs_err += w * (l - f).abs();
            abs_sig += w * l.abs();
            weights += w;
            if let (Some(p), Some(fp)) = (layer.polarisation.as_ref(), fitted_pol) {
                pol_err += w * l.max(0.0) * (p.values[k] - fp.values[k]).abs();
                pol_w += w * l.max(0.0);
            }
        }
    }
    let db = |a: f64, b: f64| if b > 0.0 { 10.0 * (a / b).log10() } else { f64::INFINITY };
    (
        db(signal, error),
        db(signal, noise),
        if abs_sig > 0.0 { abs_err / abs_sig } else { 0.0 },
        (fitted_pol.is_some() && pol_w > 0.0).then(|| pol_err / pol_w),
        (error / weights).sqrt(),
    )
}

/// The dataset evaluated at every pixel centre of `like` for `config`.
pub fn evaluated(
    model: &Model,
    config: &ConfigRender,
    albedo: f64,
    lambda: f64,
    like: &SphereImage,
) -> (SphereImage, Option<SphereImage>) {
    let mut f = SphereImage::zeros(like.width, like.height);
    let mut p = model
        .dataset()
        .polarisation
        .as_ref()
        .map(|_| SphereImage::zeros(like.width, like.height));
    for j in 0..like.height {
        for i in 0..like.width {
            let params = parameters_at(like.direction(i, j), config, albedo);
            let k = j * like.width + i;
            f.values[k] = model.sky_radiance(&params, lambda);
            if let Some(p) = p.as_mut() {
                p.values[k] = model.polarisation(&params, lambda).unwrap_or(0.0);
            }
        }
    }
    (f, p)
}

/// `f` of every image of `grid` (its configuration and layer), in the
/// grid's order (configuration, then albedo, then channel), each
/// configuration's images read once, configurations in parallel.
pub fn each_image<T: Send>(grid: &RenderGrid, f: impl Fn(&ConfigRender, &Layer) -> T + Sync) -> Result<Vec<T>> {
    let per_config: Vec<Vec<T>> = grid
        .configs
        .par_iter()
        .map(|config| {
            let layers = render_layers::load(grid, config)?;
            Ok(layers.iter().map(|layer| f(config, layer)).collect())
        })
        .collect::<Result<_>>()?;
    Ok(per_config.into_iter().flatten().collect())
}

/// Scores every image of `grid` against `model`, in the grid's order
/// (configuration, then albedo, then channel).
pub fn score(model: &Model, grid: &RenderGrid) -> Result<Vec<ImageScore>> {
    each_image(grid, |config, layer| {
        let (f, p) = evaluated(model, config, layer.albedo, layer.wavelength_nm, &layer.radiance);
        let (snr_db, noise_floor_db, nmae, polarisation_error, rmse) = compare(layer, &f, p.as_ref());
        ImageScore {
            visibility_km: config.visibility_km,
            albedo: layer.albedo,
            altitude_m: config.altitude_km * 1000.0,
            elevation_deg: config.elevation_deg,
            wavelength_nm: layer.wavelength_nm,
            snr_db,
            noise_floor_db,
            nmae,
            polarisation_error,
            rmse,
        }
    })
}
