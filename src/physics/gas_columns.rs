//! The absorber amounts of a gas profile for the wide range: per layer, the
//! column of each gas (molecules cm⁻²) and its scaled column for a
//! k-distribution band, the O₂–O₂ pair column (cm⁻⁵), and the whole
//! profile's precipitable water and CO₂ mixing ratio with their scalings.
//!
//! The layer rules are libRadtran's of `profile`: air density logarithmic
//! between the levels, each gas's mixing ratio linear, so that the column
//! of layer i is n₀Δz·(x₀·E(r) + (x₁ − x₀)·M(r)) with r = n₁/n₀ the air
//! density ratio, E(r) = ∫₀¹ rᶠ df and M(r) = ∫₀¹ f rᶠ df; except water
//! vapour, whose density falls with its own scale height (about 2 km, a
//! factor of 1.5–2 per kilometre in the tropics), so it is interpolated
//! logarithmically itself, n₀Δz·E(n₁/n₀): the rule under which the AFGL
//! atmospheres' water columns are published (the linear mixing ratio
//! would add 1.3 % to the tropical column). CH₄ and N₂O,
//! which the AFGL files atmosim carries do not hold, have constant mixing
//! ratios ([`CH4_MIXING_RATIO`], [`N2O_MIXING_RATIO`]).
//!
//! The scaled column of a band with exponents (x, y) is ∫ n (p/p₀)ˣ (T₀/T)ʸ
//! ds (LOWTRAN 7's scaling approximation): the layer's column times the
//! density-weighted mean of its two levels' factors.

use crate::physics::constants::{
    AVOGADRO_PER_MOL, CH4_MIXING_RATIO, CM_PER_KM, H2O_MOLAR_MASS_G, LIQUID_WATER_G_PER_CM3, N2O_MIXING_RATIO,
};
use crate::physics::kdistribution::{Gas, Scaling};
use crate::physics::profile::{GasProfile, Level, exp_first_moment, exp_mean};

/// The number density (cm⁻³) of `gas` at a level; O₄ has none of its own
/// (its amount is the square of O₂'s, [`o4_column_cm5`]).
pub fn density(level: &Level, gas: Gas) -> f64 {
    match gas {
        Gas::H2o => level.n_h2o,
        Gas::Co2 => level.n_co2,
        Gas::O2 | Gas::O4 => level.n_o2,
        Gas::Ch4 => CH4_MIXING_RATIO * level.n_air,
        Gas::N2o => N2O_MIXING_RATIO * level.n_air,
        Gas::No2 => level.n_no2,
    }
}

/// The column of `gas` in layer `i` (molecules cm⁻²).
pub fn column_cm2(profile: &GasProfile, i: usize, gas: Gas) -> f64 {
    let (a, b) = (&profile.levels[i], &profile.levels[i + 1]);
    let dz_cm = (b.z_km - a.z_km) * CM_PER_KM;
    if gas == Gas::H2o {
        let (n0, n1) = (a.n_h2o, b.n_h2o);
        return if n0 > 0.0 && n1 > 0.0 {
            n0 * dz_cm * exp_mean(n1 / n0)
        } else {
            0.5 * (n0 + n1) * dz_cm
        };
    }
    let (x0, x1) = (density(a, gas) / a.n_air, density(b, gas) / b.n_air);
    let r = b.n_air / a.n_air;
    a.n_air * dz_cm * (x0 * exp_mean(r) + (x1 - x0) * exp_first_moment(r))
}

/// The scaled column of `gas` in layer `i` for a band's `scaling` about
/// (p₀ hPa, T₀ K).
pub fn scaled_column_cm2(profile: &GasProfile, i: usize, gas: Gas, scaling: Scaling, p0_hpa: f64, t0_k: f64) -> f64 {
    let (a, b) = (&profile.levels[i], &profile.levels[i + 1]);
    let factor =
        |l: &Level| (l.pressure_hpa / p0_hpa).powf(scaling.p_exp) * (t0_k / l.temperature_k).powf(scaling.t_exp);
    let (n0, n1) = (density(a, gas), density(b, gas));
    let mean = if n0 + n1 > 0.0 {
        (n0 * factor(a) + n1 * factor(b)) / (n0 + n1)
    } else {
        0.0
    };
    column_cm2(profile, i, gas) * mean
}

/// ∫ n_O₂² ds over layer `i` (cm⁻⁵): the air density squared is
/// logarithmic too, and the O₂ mixing ratio (constant in the AFGL files)
/// is taken as its two levels' mean.
pub fn o4_column_cm5(profile: &GasProfile, i: usize) -> f64 {
    let (a, b) = (&profile.levels[i], &profile.levels[i + 1]);
    let dz_cm = (b.z_km - a.z_km) * CM_PER_KM;
    let x = 0.5 * (a.n_o2 / a.n_air + b.n_o2 / b.n_air);
    let r = b.n_air / a.n_air;
    (x * a.n_air).powi(2) * dz_cm * exp_mean(r * r)
}

/// The whole profile's column of `gas` (molecules cm⁻²).
pub fn total_column_cm2(profile: &GasProfile, gas: Gas) -> f64 {
    (0..profile.layer_count()).map(|i| column_cm2(profile, i, gas)).sum()
}

/// Precipitable water (cm): the water column as liquid.
pub fn precipitable_water_cm(profile: &GasProfile) -> f64 {
    total_column_cm2(profile, Gas::H2o) * H2O_MOLAR_MASS_G / AVOGADRO_PER_MOL / LIQUID_WATER_G_PER_CM3
}

/// The column-mean CO₂ volume mixing ratio in ppm (CO₂ column over air
/// column).
pub fn co2_ppm(profile: &GasProfile) -> f64 {
    let air: f64 = (0..profile.layer_count()).map(|i| profile.air_column_cm2(i)).sum();
    1e6 * total_column_cm2(profile, Gas::Co2) / air
}

/// Scales every level's water vapour density by `factor`.
pub fn scale_h2o(profile: &mut GasProfile, factor: f64) {
    for l in &mut profile.levels {
        l.n_h2o *= factor;
    }
}

/// Scales every level's CO₂ density by `factor`.
pub fn scale_co2(profile: &mut GasProfile, factor: f64) {
    for l in &mut profile.levels {
        l.n_co2 *= factor;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(name: &str) -> GasProfile {
        GasProfile::builtin(name).unwrap().unwrap().truncated(100.0)
    }

    /// Precipitable water of the six AFGL atmospheres (Anderson et al.
    /// 1986) against their water columns as MODTRAN lists them for its
    /// model atmospheres (MODTRAN 6's Table 1 in atm-cm, converted, two
    /// decimals; `atmosim validate gas_columns` compares the columns
    /// themselves, water and O₂): US standard 1.42,
    /// tropical 4.12, mid-latitude summer 2.92, mid-latitude winter 0.85,
    /// subarctic summer 2.08, subarctic winter 0.42. The tolerance is half
    /// a unit in their last place (0.005 cm); the water above 100 km is
    /// nil.
    #[test]
    fn precipitable_water_of_each_afgl_profile_is_the_published_column() {
        for (name, published) in [
            ("us_standard", 1.42),
            ("tropical", 4.12),
            ("midlatitude_summer", 2.92),
            ("midlatitude_winter", 0.85),
            ("subarctic_summer", 2.08),
            ("subarctic_winter", 0.42),
        ] {
            let pw = precipitable_water_cm(&profile(name));
            assert!(
                (pw - published).abs() <= 0.005,
                "{name}: {pw:.4} cm against {published}"
            );
        }
    }

    /// O₂ and CO₂ columns against the hydrostatic closed form: a column of
    /// air over a surface pressure p_s weighs p_s, so it holds
    /// p_s·N_A/(M_air·g) molecules per area (M_air = 28.9644 g mol⁻¹,
    /// g = 9.80665 m s⁻²), and a gas of constant mixing ratio X holds X
    /// times that (AFGL: O₂ 0.209, CO₂ 330 ppm at every level). The
    /// tolerance is the closed form's own error: g falls as (R/(R + z))²,
    /// 0.31 % per 10 km, and the column's mass-weighted mean altitude is
    /// one scale height (7–8 km), so the mean g is 0.25 % below g₀ and the
    /// column 0.25 % above the constant-g one; the profiles' own g₀
    /// (latitude: 9.78–9.83 m s⁻²) moves it by up to ±0.3 %, so
    /// 1.0025 ± 0.005.
    #[test]
    fn o2_and_co2_columns_are_hydrostatic() {
        const M_AIR_G: f64 = 28.9644;
        const G_M_S2: f64 = 9.80665;
        for name in [
            "us_standard",
            "tropical",
            "midlatitude_summer",
            "midlatitude_winter",
            "subarctic_summer",
            "subarctic_winter",
        ] {
            let p = profile(name);
            let ps_pa = p.levels[0].pressure_hpa * 100.0;
            // molecules per m² → per cm².
            let air = ps_pa * AVOGADRO_PER_MOL / (M_AIR_G * 1e-3 * G_M_S2) * 1e-4;
            for (gas, x) in [
                (Gas::O2, p.levels[0].n_o2 / p.levels[0].n_air),
                (Gas::Co2, p.levels[0].n_co2 / p.levels[0].n_air),
            ] {
                let col = total_column_cm2(&p, gas);
                let ratio = col / (x * air);
                assert!(
                    (ratio - 1.0025).abs() < 0.005,
                    "{name} {gas:?}: {col:e} vs {:e}",
                    x * air
                );
            }
        }
    }

    #[test]
    fn scaling_water_and_co2_hits_the_request() {
        let mut p = profile("us_standard");
        let pw = precipitable_water_cm(&p);
        scale_h2o(&mut p, 2.5 / pw);
        assert!((precipitable_water_cm(&p) - 2.5).abs() < 1e-12);
        let ppm = co2_ppm(&p);
        assert!((ppm - 330.0).abs() < 1.0, "{ppm}");
        scale_co2(&mut p, 420.0 / ppm);
        assert!((co2_ppm(&p) - 420.0).abs() < 1e-9);
    }

    /// The scaled column with exponents (1, 0) about p₀ is the column
    /// weighted by pressure: for a well-mixed gas in an isothermal,
    /// exponential atmosphere ∫ n p/p₀ dz = N·p_s/(2 p₀); on the real
    /// profile the layer rule must land within the layering error of
    /// that (temperature varies, so the scale heights of n and p·n differ
    /// by a few per cent).
    #[test]
    fn the_pressure_scaled_column_is_about_half_the_column_for_x_1() {
        let p = profile("us_standard");
        let s = Scaling { p_exp: 1.0, t_exp: 0.0 };
        let scaled: f64 = (0..p.layer_count())
            .map(|i| scaled_column_cm2(&p, i, Gas::O2, s, p.levels[0].pressure_hpa, 273.15))
            .sum();
        let ratio = scaled / total_column_cm2(&p, Gas::O2);
        assert!((ratio - 0.5).abs() < 0.03, "{ratio}");
    }
}
