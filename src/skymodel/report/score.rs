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
//!   degree of polarisation in the sun–view frame;
//! - the debiased SNR, the render's known noise taken out of both sums
//!   ([`Sums::debiased_snr_db`]), with its lower bound where the render's
//!   noise does not resolve the error.
//!
//! The same figures against reference renders (`fit-report --reference`):
//! renders of the grid's configurations made apart from the fit's, whose
//! noise the fit cannot have followed, so that the debiased SNR is the
//! dataset's SNR against the converged sky in expectation.

use rayon::prelude::*;

use crate::error::Result;
use crate::skymodel::angles::{SunPosition, ViewAngles};
use crate::skymodel::fit::SphereImage;
use crate::skymodel::fit::render_layers::{self, Layer};
use crate::skymodel::fit::renders::{ConfigRender, RenderGrid};
use crate::skymodel::report::regions::{Region, RegionSums};
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
    /// The SNR with the render's noise taken out ([`Sums::debiased_snr_db`]);
    /// `None` where the render's noise does not resolve the error.
    pub debiased_snr_db: Option<f64>,
    /// Its lower bound ([`Sums::debiased_snr_lower_db`]) and standard
    /// deviation ([`Sums::debiased_snr_sd_db`]).
    pub debiased_snr_lower_db: f64,
    pub debiased_snr_sd_db: f64,
    pub nmae: f64,
    /// `None` without polarisation in the dataset or the renders.
    pub polarisation_error: Option<f64>,
    /// Root-mean-square difference (solid-angle weighted), for the
    /// interpolation ratio.
    pub rmse: f64,
    /// Each region's share of the error's excess over the render's noise,
    /// Σ w·((L − F)² − se²), in the order of [`Region::ALL`].
    pub excess_by_region: [f64; 4],
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

/// The solid-angle-weighted sums of one comparison of a rendered image L
/// (standard error se per pixel) with a fitted one F.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Sums {
    /// Σ w·L².
    pub signal: f64,
    /// Σ w·(L − F)².
    pub error: f64,
    /// Σ w·se²: the render's own noise power.
    pub noise: f64,
    /// Σ w²·Var((L − F)²), estimated with se² as L's variance and
    /// max((L − F)² − se², 0) as the fit's squared error: the variance of
    /// `error` as an estimate of its expectation.
    pub error_variance: f64,
    /// Σ w·|L − F| and Σ w·|L|.
    pub abs_error: f64,
    pub abs_signal: f64,
    pub weights: f64,
    /// Σ w·L·|P − P_F| and Σ w·L over the pixels with L > 0.
    pub pol_error: f64,
    pub pol_weights: f64,
    /// Σ w·(L − F)² and Σ w·se² per region of the sphere.
    pub error_by_region: RegionSums,
    pub noise_by_region: RegionSums,
}

/// 10·log10(a/b), infinite for b ≤ 0.
pub fn db(a: f64, b: f64) -> f64 {
    if b > 0.0 { 10.0 * (a / b).log10() } else { f64::INFINITY }
}

impl Sums {
    /// The SNR of F against L (dB).
    pub fn snr_db(&self) -> f64 {
        db(self.signal, self.error)
    }

    /// The render's own noise floor, Σ w·L² / Σ w·se² (dB): the SNR that a
    /// perfect fit would show against it.
    pub fn noise_floor_db(&self) -> f64 {
        db(self.signal, self.noise)
    }

    /// The SNR of F against the truth the render estimates, its noise taken
    /// out of both sums: E[Σ w·(L − F)²] = Σ w·(T − F)² + Σ w·se² and
    /// E[Σ w·L²] = Σ w·T² + Σ w·se², exact in expectation where F does not
    /// depend on L's noise (a reference rendered apart from the fit's
    /// renders). `None` where the noise accounts for the whole error within
    /// two standard deviations of the difference (the error is not resolved
    /// by this render: [`Sums::debiased_snr_lower_db`] bounds it).
    pub fn debiased_snr_db(&self) -> Option<f64> {
        let excess = self.error - self.noise;
        (excess > 2.0 * self.error_variance.sqrt()).then(|| db(self.signal - self.noise, excess))
    }

    /// A lower bound on the debiased SNR (dB), about 97.7 % one-sided: the
    /// error's excess over the noise taken two standard deviations high.
    pub fn debiased_snr_lower_db(&self) -> f64 {
        let excess = (self.error - self.noise).max(0.0) + 2.0 * self.error_variance.sqrt();
        db(self.signal - self.noise, excess)
    }

    /// The standard deviation of [`Sums::debiased_snr_db`] (dB), to first
    /// order: 10/ln 10 · sd(error) / (error − noise).
    pub fn debiased_snr_sd_db(&self) -> f64 {
        let excess = self.error - self.noise;
        if excess > 0.0 {
            10.0 / std::f64::consts::LN_10 * self.error_variance.sqrt() / excess
        } else {
            f64::INFINITY
        }
    }

    /// The debiased SNR where resolved, else its lower bound (dB).
    pub fn debiased_or_lower_db(&self) -> f64 {
        self.debiased_snr_db().unwrap_or_else(|| self.debiased_snr_lower_db())
    }

    /// Σ w·|L − F| / Σ w·|L|.
    pub fn nmae(&self) -> f64 {
        if self.abs_signal > 0.0 {
            self.abs_error / self.abs_signal
        } else {
            0.0
        }
    }

    /// The radiance-weighted mean absolute error of the degree of
    /// polarisation, where both sides have one.
    pub fn polarisation_error(&self) -> Option<f64> {
        (self.pol_weights > 0.0).then(|| self.pol_error / self.pol_weights)
    }

    /// The solid-angle-weighted root-mean-square difference.
    pub fn rmse(&self) -> f64 {
        if self.weights > 0.0 {
            (self.error / self.weights).sqrt()
        } else {
            0.0
        }
    }
}

/// The region of every pixel centre of `like` for `config`.
pub fn regions_of(config: &ConfigRender, like: &SphereImage) -> Vec<Region> {
    let mut out = Vec::with_capacity(like.width * like.height);
    for j in 0..like.height {
        for i in 0..like.width {
            out.push(Region::of(&parameters_at(like.direction(i, j), config, 0.0)));
        }
    }
    out
}

/// The sums of one comparison of a rendered image with a fitted one;
/// `regions` (one per pixel, or empty) splits the error and noise.
pub fn compare(layer: &Layer, fitted: &SphereImage, fitted_pol: Option<&SphereImage>, regions: &[Region]) -> Sums {
    let img = &layer.radiance;
    let mut s = Sums::default();
    for j in 0..img.height {
        let w = img.solid_angle(j);
        for i in 0..img.width {
            let k = j * img.width + i;
            let (l, f) = (img.values[k], fitted.values[k]);
            let var = layer.radiance_se.values[k].powi(2);
            let d2 = (l - f) * (l - f);
            s.signal += w * l * l;
            s.error += w * d2;
            s.noise += w * var;
            // (L − F)² with L = T + n, n ~ (0, se²): variance 4·b²·se² + 2·se⁴,
            // doubled because a mirrored render's two halves are one estimate.
            s.error_variance += 2.0 * w * w * (4.0 * (d2 - var).max(0.0) * var + 2.0 * var * var);
            if let Some(&r) = regions.get(k) {
                s.error_by_region.add(r, w * d2);
                s.noise_by_region.add(r, w * var);
            }
            s.abs_error += w * (l - f).abs();
            s.abs_signal += w * l.abs();
            s.weights += w;
            if let (Some(p), Some(fp)) = (layer.polarisation.as_ref(), fitted_pol) {
                s.pol_error += w * l.max(0.0) * (p.values[k] - fp.values[k]).abs();
                s.pol_weights += w * l.max(0.0);
            }
        }
    }
    s
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
        let regions = regions_of(config, &layer.radiance);
        let sums = compare(layer, &f, p.as_ref(), &regions);
        ImageScore {
            visibility_km: config.visibility_km,
            albedo: layer.albedo,
            altitude_m: config.altitude_km * 1000.0,
            elevation_deg: config.elevation_deg,
            wavelength_nm: layer.wavelength_nm,
            snr_db: sums.snr_db(),
            noise_floor_db: sums.noise_floor_db(),
            debiased_snr_db: sums.debiased_snr_db(),
            debiased_snr_lower_db: sums.debiased_snr_lower_db(),
            debiased_snr_sd_db: sums.debiased_snr_sd_db(),
            nmae: sums.nmae(),
            polarisation_error: sums.polarisation_error(),
            rmse: sums.rmse(),
            excess_by_region: {
                let (e, n) = (sums.error_by_region.0, sums.noise_by_region.0);
                RegionSums([0, 1, 2, 3].map(|k| e[k] - n[k])).shares()
            },
        }
    })
}
