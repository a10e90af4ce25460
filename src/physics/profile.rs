//! Gas profiles: pressure, temperature and number densities on altitude
//! levels (the AFGL format of Anderson et al. 1986), and the per-layer
//! integrals libRadtran forms from them.
//!
//! Layers are the intervals between consecutive levels. Inside a layer the
//! air density varies exponentially (logarithmic interpolation between the
//! levels), so the air column of a layer is (n₀ − n₁)·Δz / ln(n₀/n₁); the
//! mixing ratio of every other gas varies linearly. These are libRadtran's
//! rules, and they make a layer cut at any altitude (the top of the model
//! atmosphere) consistent with the uncut one.

use crate::error::{Error, Result};
use crate::physics::constants::{
    BOLTZMANN_J_PER_K, CM_PER_KM, GOFF_GRATCH_STEAM_POINT_K, GOFF_GRATCH_STEAM_PRESSURE_HPA,
};
use crate::physics::data::{self, Table};

/// One level of a gas profile. Densities in cm⁻³.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    pub z_km: f64,
    pub pressure_hpa: f64,
    pub temperature_k: f64,
    pub n_air: f64,
    pub n_o3: f64,
    pub n_o2: f64,
    pub n_h2o: f64,
    pub n_co2: f64,
    pub n_no2: f64,
}

/// A gas profile: levels in ascending altitude, the lowest is the ground.
#[derive(Debug, Clone)]
pub struct GasProfile {
    pub name: String,
    pub levels: Vec<Level>,
}

impl GasProfile {
    /// One of the built-in AFGL profiles by name (`us_standard`, …).
    pub fn builtin(name: &str) -> Option<Result<GasProfile>> {
        data::builtin(data::AFGL_PROFILES, name).map(|text| Self::parse(name, text))
    }

    /// Parses a profile in atmosim's AFGL format (9 columns: z_km p_hPa T_K
    /// and the densities of air, O₃, O₂, H₂O, CO₂, NO₂ in cm⁻³). Levels may
    /// be in either order; they are sorted ascending.
    pub fn parse(name: &str, text: &str) -> Result<GasProfile> {
        let mut table = Table::parse(name, text, 9)?;
        table
            .rows
            .sort_by(|a, b| a[0].partial_cmp(&b[0]).unwrap_or(std::cmp::Ordering::Equal));
        table.require_ascending(0, "altitudes")?;
        if table.rows.len() < 2 {
            return Err(Error::data(name, "a profile needs at least two levels"));
        }
        let levels: Vec<Level> = table
            .rows
            .iter()
            .map(|r| Level {
                z_km: r[0],
                pressure_hpa: r[1],
                temperature_k: r[2],
                n_air: r[3],
                n_o3: r[4],
                n_o2: r[5],
                n_h2o: r[6],
                n_co2: r[7],
                n_no2: r[8],
            })
            .collect();
        for l in &levels {
            if l.n_air <= 0.0 || l.temperature_k <= 0.0 || l.pressure_hpa <= 0.0 {
                return Err(Error::data(
                    name,
                    format!(
                        "level {} km: pressure, temperature and air density must be positive",
                        l.z_km
                    ),
                ));
            }
            if [l.n_o3, l.n_o2, l.n_h2o, l.n_co2, l.n_no2].iter().any(|&n| n < 0.0) {
                return Err(Error::data(name, format!("level {} km: negative density", l.z_km)));
            }
        }
        Ok(GasProfile {
            name: name.to_string(),
            levels,
        })
    }

    /// Altitude of the ground (the lowest level), km.
    pub fn ground_km(&self) -> f64 {
        self.levels[0].z_km
    }

    /// Altitude of the highest level, km.
    pub fn top_km(&self) -> f64 {
        self.levels[self.levels.len() - 1].z_km
    }

    /// Number of layers (levels − 1).
    pub fn layer_count(&self) -> usize {
        self.levels.len() - 1
    }

    /// The profile cut at `top_km`: levels above are dropped and, unless
    /// `top_km` is a level already, a new top level is interpolated with the
    /// layer rules (air density and pressure logarithmic, mixing ratios and
    /// temperature linear). `top_km` must lie inside the profile.
    pub fn truncated(&self, top_km: f64) -> GasProfile {
        let mut levels: Vec<Level> = self.levels.iter().copied().take_while(|l| l.z_km < top_km).collect();
        let i = levels.len();
        if let Some(&exact) = self.levels.get(i).filter(|l| l.z_km == top_km) {
            levels.push(exact);
        } else if i > 0 && i < self.levels.len() {
            levels.push(interpolate_level(&self.levels[i - 1], &self.levels[i], top_km));
        }
        GasProfile {
            name: self.name.clone(),
            levels,
        }
    }

    /// The profile on levels every `step_km` from its ground up to
    /// `top_km` (a level there too), each interpolated with the layer rules
    /// like [`GasProfile::truncated`]: the same atmosphere, finely layered,
    /// as a radiosonde or model profile is (the fine-profile benchmark and
    /// tests). `step_km` must be positive and `top_km` inside the profile.
    pub fn resampled(&self, step_km: f64, top_km: f64) -> GasProfile {
        let ground = self.ground_km();
        let count = ((top_km - ground) / step_km).ceil() as usize;
        let mut levels = Vec::with_capacity(count + 1);
        let mut i = 0;
        for k in 0..=count {
            let z = (ground + k as f64 * step_km).min(top_km);
            while i + 2 < self.levels.len() && self.levels[i + 1].z_km <= z {
                i += 1;
            }
            levels.push(interpolate_level(&self.levels[i], &self.levels[i + 1], z));
        }
        levels.dedup_by(|b, a| b.z_km <= a.z_km);
        GasProfile {
            name: format!("{} every {step_km} km", self.name),
            levels,
        }
    }

    /// The profile in the AFGL format [`GasProfile::parse`] reads (and
    /// `atmosphere.profile_file`), highest level first as libRadtran
    /// writes it.
    pub fn to_afgl_text(&self) -> String {
        let mut text = format!(
            "# {}\n# z_km p_hPa T_K n_air_cm-3 n_o3_cm-3 n_o2_cm-3 n_h2o_cm-3 n_co2_cm-3 n_no2_cm-3\n",
            self.name
        );
        for l in self.levels.iter().rev() {
            text += &format!(
                "{:.6} {:.9e} {:.6} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e}\n",
                l.z_km, l.pressure_hpa, l.temperature_k, l.n_air, l.n_o3, l.n_o2, l.n_h2o, l.n_co2, l.n_no2
            );
        }
        text
    }

    /// CO₂ volume mixing ratio at the ground, the value libRadtran's
    /// Rayleigh cross section uses for the whole column.
    pub fn surface_co2_ratio(&self) -> f64 {
        self.levels[0].n_co2 / self.levels[0].n_air
    }

    /// Air column of layer `i` in molecules cm⁻² (logarithmic interpolation
    /// of the air density between the levels).
    pub fn air_column_cm2(&self, i: usize) -> f64 {
        let (a, b) = (&self.levels[i], &self.levels[i + 1]);
        let dz_cm = (b.z_km - a.z_km) * CM_PER_KM;
        a.n_air * dz_cm * exp_mean(b.n_air / a.n_air)
    }

    /// Ozone column of layer `i` in molecules cm⁻²: air density logarithmic,
    /// ozone mixing ratio linear between the levels (closed-form integral).
    pub fn o3_column_cm2(&self, i: usize) -> f64 {
        let (a, b) = (&self.levels[i], &self.levels[i + 1]);
        let dz_cm = (b.z_km - a.z_km) * CM_PER_KM;
        let (x0, x1) = (a.n_o3 / a.n_air, b.n_o3 / b.n_air);
        let ratio = b.n_air / a.n_air;
        // ∫₀¹ n₀ rᶠ (x₀ + (x₁ − x₀) f) df with r = n₁/n₀.
        a.n_air * dz_cm * (x0 * exp_mean(ratio) + (x1 - x0) * exp_first_moment(ratio))
    }

    /// Total ozone column in Dobson units.
    pub fn o3_column_du(&self) -> f64 {
        (0..self.layer_count()).map(|i| self.o3_column_cm2(i)).sum::<f64>() / crate::physics::constants::DOBSON_UNIT_CM2
    }

    /// Mean temperature of layer `i` (K): the mean of its two levels.
    pub fn layer_temperature_k(&self, i: usize) -> f64 {
        0.5 * (self.levels[i].temperature_k + self.levels[i + 1].temperature_k)
    }

    /// Relative humidity over liquid water (%) at level `i`: the water
    /// vapour partial pressure n_H₂O·k·T over the Goff–Gratch saturation
    /// pressure.
    pub fn level_relative_humidity_pct(&self, i: usize) -> f64 {
        let l = &self.levels[i];
        let e_hpa = l.n_h2o * 1.0e6 * BOLTZMANN_J_PER_K * l.temperature_k / 100.0;
        100.0 * e_hpa / saturation_vapour_pressure_hpa(l.temperature_k)
    }

    /// Relative humidity (%) of layer `i`: the mean of its two levels. This
    /// reproduces the layer humidities of libRadtran's OPAC layering for
    /// afglus to within 0.2 %-points (validation/libradtran).
    pub fn layer_relative_humidity_pct(&self, i: usize) -> f64 {
        0.5 * (self.level_relative_humidity_pct(i) + self.level_relative_humidity_pct(i + 1))
    }

    /// Scales every level's ozone density by `factor`.
    pub fn scale_ozone(&mut self, factor: f64) {
        for l in &mut self.levels {
            l.n_o3 *= factor;
        }
    }
}

/// Saturation vapour pressure over liquid water (hPa), Goff & Gratch (1946)
/// in the WMO form.
pub fn saturation_vapour_pressure_hpa(t_k: f64) -> f64 {
    let ts = GOFF_GRATCH_STEAM_POINT_K;
    let log10_e = -7.90298 * (ts / t_k - 1.0) + 5.02808 * (ts / t_k).log10()
        - 1.3816e-7 * (10f64.powf(11.344 * (1.0 - t_k / ts)) - 1.0)
        + 8.1328e-3 * (10f64.powf(-3.49149 * (ts / t_k - 1.0)) - 1.0);
    GOFF_GRATCH_STEAM_PRESSURE_HPA * 10f64.powf(log10_e)
}

/// ∫₀¹ rᶠ df = (r − 1)/ln r, with its limit 1 at r = 1.
pub(crate) fn exp_mean(r: f64) -> f64 {
    let l = r.ln();
    if l.abs() < 1e-6 {
        1.0 + l / 2.0 + l * l / 6.0
    } else {
        (r - 1.0) / l
    }
}

/// ∫₀¹ f·rᶠ df = r/ln r − (r − 1)/ln² r, with its limit 1/2 at r = 1.
pub(crate) fn exp_first_moment(r: f64) -> f64 {
    let l = r.ln();
    if l.abs() < 1e-4 {
        0.5 + l / 3.0 + l * l / 8.0
    } else {
        r / l - (r - 1.0) / (l * l)
    }
}

fn interpolate_level(a: &Level, b: &Level, z_km: f64) -> Level {
    let f = (z_km - a.z_km) / (b.z_km - a.z_km);
    let log_lerp = |x0: f64, x1: f64| x0 * (x1 / x0).powf(f);
    let lerp = |x0: f64, x1: f64| x0 + (x1 - x0) * f;
    let n_air = log_lerp(a.n_air, b.n_air);
    let mix = |n0: f64, n1: f64| lerp(n0 / a.n_air, n1 / b.n_air) * n_air;
    Level {
        z_km,
        pressure_hpa: log_lerp(a.pressure_hpa, b.pressure_hpa),
        temperature_k: lerp(a.temperature_k, b.temperature_k),
        n_air,
        n_o3: mix(a.n_o3, b.n_o3),
        n_o2: mix(a.n_o2, b.n_o2),
        n_h2o: mix(a.n_h2o, b.n_h2o),
        n_co2: mix(a.n_co2, b.n_co2),
        n_no2: mix(a.n_no2, b.n_no2),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn us() -> GasProfile {
        GasProfile::builtin("us_standard").unwrap().unwrap()
    }

    #[test]
    fn a_resampled_profile_keeps_the_levels_it_passes_and_its_columns() {
        // Every 100 m to 100 km: 1001 levels; the AFGL levels it meets are
        // kept exactly, the air column (exact for log-linear air) to 1e-9,
        // and the text it writes reads back.
        let p = us();
        let fine = p.resampled(0.1, 100.0);
        assert_eq!(fine.levels.len(), 1001);
        assert_eq!(fine.top_km(), 100.0);
        let at = |q: &GasProfile, z: f64| *q.levels.iter().find(|l| (l.z_km - z).abs() < 1e-9).unwrap();
        for z in [0.0, 1.0, 25.0, 50.0, 100.0] {
            let (a, b) = (at(&p, z), at(&fine, z));
            assert!((a.n_air - b.n_air).abs() <= 1e-12 * a.n_air, "{z} km");
            assert!((a.n_o3 - b.n_o3).abs() <= 1e-12 * a.n_o3, "{z} km");
        }
        let column = |q: &GasProfile| (0..q.layer_count()).map(|i| q.air_column_cm2(i)).sum::<f64>();
        let coarse = p.truncated(100.0);
        assert!((column(&fine) / column(&coarse) - 1.0).abs() < 1e-9);
        let back = GasProfile::parse("fine", &fine.to_afgl_text()).unwrap();
        assert_eq!(back.levels.len(), 1001);
        assert!((column(&back) / column(&fine) - 1.0).abs() < 1e-8);
    }

    #[test]
    fn all_six_afgl_profiles_load_from_ground_to_120_km() {
        for (name, _) in data::AFGL_PROFILES {
            let p = GasProfile::builtin(name).unwrap().unwrap();
            assert_eq!(p.levels.len(), 50, "{name}");
            assert_eq!(p.ground_km(), 0.0);
            assert_eq!(p.top_km(), 120.0);
        }
    }

    #[test]
    fn us_standard_ozone_column_is_345_dobson() {
        // The afglus header states 345.3 DU.
        let du = us().o3_column_du();
        assert!((du - 345.3).abs() < 0.5, "{du}");
    }

    #[test]
    fn layer_integrals_match_midpoint_quadrature() {
        let p = us();
        for i in [0, 10, 30] {
            let (a, b) = (p.levels[i], p.levels[i + 1]);
            let n = 20_000;
            let (mut air, mut o3) = (0.0, 0.0);
            for k in 0..n {
                let f = (k as f64 + 0.5) / n as f64;
                let na = a.n_air * (b.n_air / a.n_air).powf(f);
                let x = a.n_o3 / a.n_air + (b.n_o3 / b.n_air - a.n_o3 / a.n_air) * f;
                air += na;
                o3 += na * x;
            }
            let dz = (b.z_km - a.z_km) * CM_PER_KM / n as f64;
            assert!((air * dz / p.air_column_cm2(i) - 1.0).abs() < 1e-8);
            assert!((o3 * dz / p.o3_column_cm2(i) - 1.0).abs() < 1e-8);
        }
    }

    #[test]
    fn truncation_splits_a_layer_without_changing_its_column() {
        let p = us();
        // 95–100 km is one layer; cutting at 97.5 and adding the rest back
        // must give the same air and ozone columns.
        let cut = p.truncated(97.5);
        assert_eq!(cut.top_km(), 97.5);
        let full = p.truncated(100.0);
        let i = full.layer_count() - 1;
        let j = cut.layer_count() - 1;
        let top = cut.levels[j + 1];
        let upper = GasProfile {
            name: "upper".into(),
            levels: vec![top, full.levels[i + 1]],
        };
        let sum = cut.air_column_cm2(j) + upper.air_column_cm2(0);
        assert!((sum / full.air_column_cm2(i) - 1.0).abs() < 1e-12);
        let sum = cut.o3_column_cm2(j) + upper.o3_column_cm2(0);
        assert!((sum / full.o3_column_cm2(i) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn goff_gratch_matches_tabulated_saturation_pressures() {
        // WMO / Smithsonian tables: 6.1078 hPa at 0 °C, 23.37 hPa at 20 °C,
        // 1013.25 hPa at the boiling point.
        assert!((saturation_vapour_pressure_hpa(273.15) - 6.1078).abs() < 0.005);
        assert!((saturation_vapour_pressure_hpa(293.15) - 23.37).abs() < 0.03);
        assert!((saturation_vapour_pressure_hpa(373.15) - 1013.25).abs() < 0.5);
    }

    #[test]
    fn layer_humidity_reproduces_libradtran_layering() {
        // RH of the OPAC layers in validation/libradtran/B_540nm_aerosol_fullprec.txt.
        let p = us();
        let text = include_str!("../../validation/libradtran/B_540nm_aerosol_fullprec.txt");
        let t = Table::parse("fullprec", text, 7).unwrap();
        for row in t.rows.iter().filter(|r| r[1] - r[0] == 1.0) {
            let i = p.levels.iter().position(|l| l.z_km == row[0]).unwrap();
            let rh = p.layer_relative_humidity_pct(i);
            assert!((rh - row[2]).abs() < 0.2, "layer {}: {rh} vs {}", row[0], row[2]);
        }
    }
}
