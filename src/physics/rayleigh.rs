//! Rayleigh scattering by air: the cross section of Bodhaine et al. (1999),
//! "On Rayleigh optical depth calculations", J. Atmos. Oceanic Technol. 16,
//! 1854–1861, and the depolarisation factor that goes with it.
//!
//! - Refractive index of standard air (300 ppm CO₂): Peck & Reeder (1972),
//!   Bodhaine Eq. 18; scaled to the actual CO₂ ratio by Eq. 19.
//! - King factor of air: Eq. 23, a volume-weighted mean of N₂, O₂, Ar and CO₂
//!   King factors (Bates 1984).
//! - Cross section per molecule: Eq. 22,
//!   σ = 24π³(n² − 1)² / (λ⁴ N_s² (n² + 2)²) · F_air.
//! - Depolarisation factor: ρ = 6(F − 1)/(3 + 7F), the inverse of
//!   F = (6 + 3ρ)/(6 − 7ρ).

use crate::physics::constants::{AIR_DENSITY_STP_CM3, PECK_REEDER_CO2_RATIO};

/// Valid wavelength range (nm) of the refractive-index and King-factor
/// formulas (Bodhaine et al. 1999 fit them over 0.2–4 µm; Peck & Reeder's
/// dispersion formula holds from 0.23 µm).
pub const WAVELENGTH_RANGE_NM: (f64, f64) = (230.0, 4000.0);

/// Which Rayleigh model a job uses (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RayleighModel {
    /// Bodhaine et al. (1999) with the profile's surface CO₂.
    Bodhaine,
    /// No Rayleigh scattering.
    None,
}

/// (n − 1) of standard air with 300 ppm CO₂ at wavelength λ (µm):
/// Peck & Reeder (1972), Bodhaine Eq. 18.
pub fn refractivity_300ppm(lambda_um: f64) -> f64 {
    let s2 = 1.0 / (lambda_um * lambda_um);
    1.0e-8 * (8060.51 + 2_480_990.0 / (132.274 - s2) + 17_455.7 / (39.32957 - s2))
}

/// (n − 1) of air with CO₂ volume mixing ratio `co2_ratio` (Bodhaine Eq. 19).
pub fn refractivity(lambda_um: f64, co2_ratio: f64) -> f64 {
    refractivity_300ppm(lambda_um) * (1.0 + 0.54 * (co2_ratio - PECK_REEDER_CO2_RATIO))
}

/// King factor of air (Bodhaine Eq. 23) for CO₂ volume mixing ratio
/// `co2_ratio` (e.g. 3.3e-4 for 330 ppm).
pub fn king_factor(lambda_nm: f64, co2_ratio: f64) -> f64 {
    let lambda_um = lambda_nm / 1000.0;
    let s2 = 1.0 / (lambda_um * lambda_um);
    let f_n2 = 1.034 + 3.17e-4 * s2;
    let f_o2 = 1.096 + 1.385e-3 * s2 + 1.448e-4 * s2 * s2;
    let (f_ar, f_co2) = (1.00, 1.15);
    // Volume percentages of dry air (Bodhaine Table 1).
    let (c_n2, c_o2, c_ar, c_co2) = (78.084, 20.946, 0.934, co2_ratio * 100.0);
    (c_n2 * f_n2 + c_o2 * f_o2 + c_ar * f_ar + c_co2 * f_co2) / (c_n2 + c_o2 + c_ar + c_co2)
}

/// Rayleigh scattering cross section per air molecule in cm² (Bodhaine Eq. 22).
pub fn cross_section_cm2(lambda_nm: f64, co2_ratio: f64) -> f64 {
    let n = 1.0 + refractivity(lambda_nm / 1000.0, co2_ratio);
    let n2 = n * n;
    let lambda_cm = lambda_nm * 1.0e-7;
    let ns = AIR_DENSITY_STP_CM3;
    24.0 * std::f64::consts::PI.powi(3) * (n2 - 1.0).powi(2) / (lambda_cm.powi(4) * ns * ns * (n2 + 2.0).powi(2))
        * king_factor(lambda_nm, co2_ratio)
}

/// Depolarisation factor ρ from the King factor F: ρ = 6(F − 1)/(3 + 7F).
pub fn depolarization_from_king(king: f64) -> f64 {
    6.0 * (king - 1.0) / (3.0 + 7.0 * king)
}

/// Depolarisation factor of air at λ (nm) and CO₂ ratio.
pub fn depolarization(lambda_nm: f64, co2_ratio: f64) -> f64 {
    depolarization_from_king(king_factor(lambda_nm, co2_ratio))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bodhaine et al. 1999, Eq. 29: their four-parameter fit of Eq. 22 for
    /// 360 ppm CO₂ (σ in cm², λ in µm), an independent check of the chain.
    fn bodhaine_fit_360ppm(lambda_um: f64) -> f64 {
        let l2 = lambda_um * lambda_um;
        1.0e-28 * (1.0455996 - 341.29061 / l2 - 0.90230850 * l2) / (1.0 + 0.0027059889 / l2 - 85.968563 * l2)
    }

    #[test]
    fn cross_section_matches_bodhaine_fit_from_250_to_850_nm() {
        // Bodhaine state that Eq. 29 reproduces Eq. 22 to about 0.01 %.
        for lambda in [250.0, 320.0, 400.0, 450.0, 550.0, 650.0, 760.0, 850.0] {
            let s = cross_section_cm2(lambda, 3.6e-4);
            let fit = bodhaine_fit_360ppm(lambda / 1000.0);
            assert!((s / fit - 1.0).abs() < 1e-4, "{lambda} nm: {s:e} vs {fit:e}");
        }
    }

    #[test]
    fn cross_section_at_540_nm_matches_libradtran() {
        // uvspec (libRadtran 2.0.3) for afglus: 4.861341e-27 cm² with the
        // profile's surface CO₂ of 8.4084e15 / 2.545818e19.
        let co2 = 8.408400e15 / 2.545818e19;
        let s = cross_section_cm2(540.0, co2);
        assert!((s / 4.861341e-27 - 1.0).abs() < 2e-7, "{s:e}");
    }

    #[test]
    fn depolarization_near_550_nm_is_0_0283() {
        let rho = depolarization(550.0, 3.3e-4);
        assert!((rho - 0.0283).abs() < 5e-5, "{rho}");
        // uvspec's chi2 = 0.095804 at 540 nm implies ρ = 0.02837.
        let rho = depolarization(540.0, 3.3e-4);
        assert!((rho - 0.02837).abs() < 5e-6, "{rho}");
    }

    #[test]
    fn king_factor_and_depolarization_are_inverse() {
        for rho in [0.0, 0.0279, 0.1] {
            let f = (6.0 + 3.0 * rho) / (6.0 - 7.0 * rho);
            assert!((depolarization_from_king(f) - rho).abs() < 1e-15);
        }
    }

    #[test]
    fn more_co2_scatters_more() {
        assert!(cross_section_cm2(500.0, 4e-4) > cross_section_cm2(500.0, 3e-4));
    }
}
