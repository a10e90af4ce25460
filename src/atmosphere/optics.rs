//! The optics of the atmosphere, one record in the views the code needs
//! (coefficients in km⁻¹, optical depths dimensionless):
//! - [`Optics`]: a layer's constituents at one wavelength (Rayleigh
//!   scattering and its depolarisation, gas absorption, aerosol extinction
//!   and scattering, the aerosol's asymmetry parameter);
//! - [`PointOptics`]: what a collision needs at a point: σ_t, and σ_s split
//!   into Rayleigh and aerosol with their ρ and g;
//! - [`ColumnOptics`]: the constituents' optical depths over a column;
//! - `spectral_terms::TermOptics`: one term's optics per unit amount, in the
//!   additive form (ρ·σ_R, g·σ_A) that sums over terms.

/// Optical properties of one layer at one wavelength. Coefficients in km⁻¹.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Optics {
    pub sigma_rayleigh: f64,
    pub rayleigh_depolarization: f64,
    /// Gas absorption (ozone).
    pub sigma_absorption: f64,
    pub sigma_aerosol_ext: f64,
    pub sigma_aerosol_sca: f64,
    /// Henyey–Greenstein asymmetry parameter of the aerosol.
    pub aerosol_g: f64,
}

impl Optics {
    /// Total extinction coefficient σ_t (km⁻¹).
    pub fn sigma_t(&self) -> f64 {
        self.sigma_rayleigh + self.sigma_absorption + self.sigma_aerosol_ext
    }

    /// Total scattering coefficient σ_s (km⁻¹).
    pub fn sigma_s(&self) -> f64 {
        self.sigma_rayleigh + self.sigma_aerosol_sca
    }
}

/// Column optical depths at one wavelength.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ColumnOptics {
    pub tau_rayleigh: f64,
    pub tau_absorption: f64,
    pub tau_aerosol_ext: f64,
    pub tau_aerosol_sca: f64,
}

impl ColumnOptics {
    /// Column single-scattering albedo of the aerosol.
    pub fn aerosol_ssa(&self) -> f64 {
        if self.tau_aerosol_ext > 0.0 {
            self.tau_aerosol_sca / self.tau_aerosol_ext
        } else {
            0.0
        }
    }
}

/// Coefficients (km⁻¹) at a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointOptics {
    pub sigma_t: f64,
    pub sigma_rayleigh: f64,
    pub sigma_aerosol_sca: f64,
    pub rayleigh_depolarization: f64,
    pub aerosol_g: f64,
}

impl PointOptics {
    /// Scattering coefficient σ_s.
    pub fn sigma_s(&self) -> f64 {
        self.sigma_rayleigh + self.sigma_aerosol_sca
    }
}
