//! How the gas densities vary inside one layer of a profile atmosphere (the
//! `smooth` medium): air density exponential between the levels, ozone
//! mixing ratio linear; factors relative to the layer mean.

use crate::physics::profile::{exp_first_moment, exp_mean};

/// The variation of the gas densities inside one layer, from the profile's
/// levels: air density exponential (ratio top/bottom), ozone mixing ratio
/// linear. The layer's mean coefficients are unchanged by it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerShape {
    /// n_air(top) / n_air(bottom).
    pub air_ratio: f64,
    /// Ozone mixing ratio at the bottom and top of the layer.
    pub o3_mixing: (f64, f64),
}

impl LayerShape {
    /// Rayleigh coefficient at fraction `f` (0 bottom, 1 top) of the layer
    /// relative to the layer mean: rᶠ / mean(rᶠ).
    pub fn rayleigh_factor(&self, f: f64) -> f64 {
        self.air_ratio.powf(f) / exp_mean(self.air_ratio)
    }

    /// Ozone coefficient at fraction `f` relative to the layer mean.
    pub fn ozone_factor(&self, f: f64) -> f64 {
        let (x0, x1) = self.o3_mixing;
        let r = self.air_ratio;
        let mean = x0 * exp_mean(r) + (x1 - x0) * exp_first_moment(r);
        if mean <= 0.0 {
            return 1.0;
        }
        (x0 + (x1 - x0) * f) * r.powf(f) / mean
    }

    /// Upper bounds of the two factors over the layer.
    pub fn max_factors(&self) -> (f64, f64) {
        let (x0, x1) = self.o3_mixing;
        let r = self.air_ratio;
        let mean = x0 * exp_mean(r) + (x1 - x0) * exp_first_moment(r);
        let ozone = if mean > 0.0 {
            x0.max(x1) * r.max(1.0) / mean
        } else {
            1.0
        };
        (r.max(1.0) / exp_mean(r), ozone)
    }

    /// Lower bounds of the two factors over the layer.
    pub fn min_factors(&self) -> (f64, f64) {
        let (x0, x1) = self.o3_mixing;
        let r = self.air_ratio;
        let mean = x0 * exp_mean(r) + (x1 - x0) * exp_first_moment(r);
        let ozone = if mean > 0.0 {
            x0.min(x1) * r.min(1.0) / mean
        } else {
            1.0
        };
        (r.min(1.0) / exp_mean(r), ozone)
    }
}
