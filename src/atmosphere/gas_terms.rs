//! The molecular absorbers of the wide range (280–2480 nm) on a gas
//! profile: which are on, the column scalings a job asks for, and their
//! spectral terms (see `spectral_terms`).
//!
//! Each k-distribution gas adds one term per distinct amount scaling of
//! its bands that overlap the job's channels: amount = the layer's scaled
//! column per km (`physics::gas_columns`), response = the pseudo-spectrum
//! of the band at λ (`physics::kdistribution`). O₄ adds one term (∫n_O₂²
//! per km times Greenblatt's cross section), NO₂ three (its column times
//! (T − T₀)ᵏ, as ozone).

use std::sync::Arc;

use crate::atmosphere::spectral_terms::{GasResponse, SpectralTerms, Spectrum};
use crate::error::{Error, Result};
use crate::physics::data;
use crate::physics::gas_columns::{self, o4_column_cm5, scaled_column_cm2};
use crate::physics::kdistribution::{self, CollisionPairs, Gas, KDistributions};
use crate::physics::ozone::CrossSection;
use crate::physics::profile::GasProfile;

/// Where O₄'s and NO₂'s tables absorb (nm; zero outside).
const O4_RANGE_NM: (f64, f64) = (301.4, 1338.2);
/// See [`O4_RANGE_NM`].
const NO2_RANGE_NM: (f64, f64) = (280.0, 760.0);

/// The wide range's absorbers of a profile atmosphere.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GasSpec {
    /// The gases on (none by default: the visible range's atmosphere).
    pub gases: Vec<Gas>,
    /// Scale the water vapour column to this precipitable water (cm).
    pub precipitable_water_cm: Option<f64>,
    /// Scale the CO₂ column to this column-mean mixing ratio (ppm).
    pub co2_ppm: Option<f64>,
    /// The wavelengths the job's channels cover (nm): only terms that
    /// absorb there are added.
    pub range_nm: (f64, f64),
}

impl GasSpec {
    /// Whether any gas is on.
    pub fn any(&self) -> bool {
        !self.gases.is_empty()
    }

    /// Whether `gas` is on.
    pub fn has(&self, gas: Gas) -> bool {
        self.gases.contains(&gas)
    }

    /// The data range of the gases (nm), checked against every band edge.
    pub fn range_nm() -> (f64, f64) {
        kdistribution::RANGE_NM
    }

    /// Scales the profile's water and CO₂ as asked; the precipitable water
    /// and CO₂ mixing ratio it then has (for reports).
    pub fn scale(&self, profile: &mut GasProfile) -> Result<(f64, f64)> {
        if let Some(target) = self.precipitable_water_cm {
            let pw = gas_columns::precipitable_water_cm(profile);
            if pw <= 0.0 && target > 0.0 {
                return Err(Error::data(&profile.name, "the profile holds no water vapour to scale"));
            }
            gas_columns::scale_h2o(profile, if pw > 0.0 { target / pw } else { 0.0 });
        }
        if let Some(target) = self.co2_ppm {
            let ppm = gas_columns::co2_ppm(profile);
            if ppm <= 0.0 && target > 0.0 {
                return Err(Error::data(&profile.name, "the profile holds no CO₂ to scale"));
            }
            gas_columns::scale_co2(profile, if ppm > 0.0 { target / ppm } else { 0.0 });
        }
        Ok((
            gas_columns::precipitable_water_cm(profile),
            gas_columns::co2_ppm(profile),
        ))
    }

    /// Adds the terms of the gases that are on to `terms`.
    pub fn push_terms(&self, profile: &GasProfile, terms: &mut SpectralTerms) -> Result<()> {
        if !self.any() {
            return Ok(());
        }
        let table = KDistributions::builtin()?;
        let layers = 0..profile.layer_count();
        let per_km = |i: usize| 1.0 / (profile.levels[i + 1].z_km - profile.levels[i].z_km);
        let (lo, hi) = self.range_nm;
        let overlaps = |(a, b): (f64, f64)| a <= hi && b >= lo;
        for &gas in &self.gases {
            match gas {
                Gas::O4 if !overlaps(O4_RANGE_NM) => {}
                Gas::No2 if !overlaps(NO2_RANGE_NM) => {}
                Gas::O4 => {
                    let pairs = CollisionPairs::builtin()?;
                    let amount = layers.clone().map(|i| o4_column_cm5(profile, i) * per_km(i)).collect();
                    terms.push(
                        amount,
                        Spectrum::Gas {
                            gas,
                            response: GasResponse::Pairs(pairs),
                        },
                    );
                }
                Gas::No2 => {
                    let table = Arc::new(CrossSection::parse("no2_bogumil", data::NO2_CROSS_SECTION)?);
                    for power in 0..3 {
                        let amount = layers
                            .clone()
                            .map(|i| {
                                let dt = profile.layer_temperature_k(i) - table.t0_k();
                                gas_columns::column_cm2(profile, i, Gas::No2) * per_km(i) * dt.powi(power as i32)
                            })
                            .collect();
                        terms.push(
                            amount,
                            Spectrum::Gas {
                                gas,
                                response: GasResponse::CrossSection {
                                    table: table.clone(),
                                    power,
                                },
                            },
                        );
                    }
                }
                _ => {
                    for scaling in table.scalings(gas, self.range_nm) {
                        let amount = layers
                            .clone()
                            .map(|i| scaled_column_cm2(profile, i, gas, scaling, table.p0_hpa, table.t0_k) * per_km(i))
                            .collect();
                        terms.push(
                            amount,
                            Spectrum::Gas {
                                gas,
                                response: GasResponse::Bands { table, scaling },
                            },
                        );
                    }
                }
            }
        }
        Ok(())
    }
}
