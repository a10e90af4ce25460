//! Molecular absorption in the wide range (280–2480 nm) by k-distributions
//! per 40 nm band, laid out as a pseudo-spectrum so that a band's
//! wavelength variate also draws its g-point.
//!
//! For each band-model gas (H₂O, CO₂, O₂, CH₄, N₂O) and each 40 nm band
//! from 280 nm, `spectra/gas_kdistributions.txt` holds a k-distribution:
//! g-points with weights in 1/400ths of the band and cross sections k_j
//! (cm² per molecule) at p₀ = 1013.25 hPa, T₀ = 273.15 K, and the
//! band's scaling exponents (x, y) of the absorber amount, LOWTRAN 7's
//! scaling approximation: a layer's optical depth at g-point j is
//! k_j·∫ n (p/p₀)ˣ (T₀/T)ʸ ds (`scripts/derive_gases.py` fits them to the
//! LOWTRAN 7 band model; docs/gases.md).
//!
//! **The pseudo-spectrum.** A band is cut into 400 slots of 0.1 nm. Slot s
//! holds g-rank r = (aₘ·s + cₘ) mod 400 of gas m, with a stride aₘ coprime
//! to 400 and different for every gas, and rank r belongs to the g-point
//! whose cumulative count range (in ascending k) holds it. So:
//! - a wavelength drawn uniformly in the band picks g-point j with
//!   probability exactly w_j: the tracer's band sampling (a uniform,
//!   stratified wavelength per path and channel) integrates the
//!   k-distribution without bias and without a channel per g-point;
//! - the same slot has the same g-point in every layer (the correlated-k
//!   assumption along a path), and every gas's g-points are spread over
//!   the band (a stride of 0.1 nm·aₘ), so they are nearly independent of
//!   the smooth spectra (Rayleigh, aerosol, the sun) and of each other
//!   (random overlap of the gases);
//! - the band average of the direct beam on 0.05 nm cells (two per slot)
//!   is exact.
//!
//! A monochromatic wavelength sees one slot: one g-point, not the band.
//! That is why jobs with gases take bands (`job`).

use std::sync::OnceLock;

use crate::error::{Error, Result};
use crate::physics::data::{self, Table};

/// Slots per 40 nm band, the weights' quantum.
pub const SLOTS: usize = 400;
/// Width of a band (nm).
pub const BAND_NM: f64 = 40.0;
/// The wide range the tables cover (nm): 55 bands of 40 nm.
pub const RANGE_NM: (f64, f64) = (280.0, 2480.0);
/// Number of 40 nm bands.
pub const BANDS: usize = 55;

/// A molecular absorber of the wide range (closed set). The first five
/// have k-distributions, O₄ and NO₂ smooth cross sections.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Gas {
    H2o,
    Co2,
    O2,
    Ch4,
    N2o,
    O4,
    No2,
}

impl Gas {
    /// Every gas, in report order.
    pub const ALL: [Gas; 7] = [Gas::H2o, Gas::Co2, Gas::O2, Gas::Ch4, Gas::N2o, Gas::O4, Gas::No2];

    /// The job-file spelling (`"h2o"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Gas::H2o => "h2o",
            Gas::Co2 => "co2",
            Gas::O2 => "o2",
            Gas::Ch4 => "ch4",
            Gas::N2o => "n2o",
            Gas::O4 => "o4",
            Gas::No2 => "no2",
        }
    }

    /// The gas of a job-file spelling.
    pub fn parse(name: &str) -> Option<Gas> {
        Gas::ALL.into_iter().find(|g| g.name() == name)
    }

    /// The gas's code in the k-distribution table (`None` for O₄, NO₂).
    fn code(self) -> Option<usize> {
        match self {
            Gas::H2o => Some(1),
            Gas::Co2 => Some(2),
            Gas::O2 => Some(3),
            Gas::Ch4 => Some(4),
            Gas::N2o => Some(5),
            Gas::O4 | Gas::No2 => None,
        }
    }

    /// The stride aₘ and offset cₘ of the gas's slot-to-rank map (strides
    /// coprime to 400: odd and not multiples of 5).
    fn permutation(self) -> (usize, usize) {
        match self {
            Gas::H2o => (147, 0),
            Gas::Co2 => (211, 101),
            Gas::O2 => (233, 37),
            Gas::Ch4 => (263, 173),
            Gas::N2o => (283, 251),
            Gas::O4 | Gas::No2 => (1, 0),
        }
    }
}

/// The scaling exponents of a band's absorber amount, n (p/p₀)ˣ (T₀/T)ʸ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scaling {
    pub p_exp: f64,
    pub t_exp: f64,
}

/// One gas's k-distribution in one 40 nm band, as a pseudo-spectrum.
#[derive(Debug, Clone)]
pub struct BandK {
    pub lo_nm: f64,
    pub scaling: Scaling,
    /// The g-points: (weight, k in cm²), ascending in k.
    pub points: Vec<(f64, f64)>,
    /// k (cm²) of each 0.1 nm slot.
    slot_k: Vec<f64>,
}

impl BandK {
    /// The band's k-distribution mean Σ w_j k_j (cm²).
    pub fn mean_k_cm2(&self) -> f64 {
        self.points.iter().map(|(w, k)| w * k).sum()
    }

    /// k at a wavelength of the band (its slot's g-point).
    pub fn k_cm2(&self, lambda_nm: f64) -> f64 {
        let s = ((lambda_nm - self.lo_nm) * (SLOTS as f64 / BAND_NM)).floor();
        self.slot_k[(s.max(0.0) as usize).min(SLOTS - 1)]
    }

    /// The band transmittance Σ w_j exp(−k_j·u) of a scaled amount u
    /// (molecules cm⁻²).
    pub fn transmittance(&self, amount_cm2: f64) -> f64 {
        self.points.iter().map(|(w, k)| w * (-k * amount_cm2).exp()).sum()
    }
}

/// The k-distributions of every band-model gas and band.
#[derive(Debug, Clone)]
pub struct KDistributions {
    /// `bands[gas code − 1][band index]`.
    bands: Vec<Vec<Option<BandK>>>,
    pub p0_hpa: f64,
    pub t0_k: f64,
}

/// The index of the 40 nm band that holds λ (the upper band at an edge;
/// 2480 nm in the last).
pub fn band_index(lambda_nm: f64) -> Option<usize> {
    if !(RANGE_NM.0..=RANGE_NM.1).contains(&lambda_nm) {
        return None;
    }
    Some((((lambda_nm - RANGE_NM.0) / BAND_NM).floor() as usize).min(BANDS - 1))
}

impl KDistributions {
    /// The built-in tables (parsed once).
    pub fn builtin() -> Result<&'static KDistributions> {
        static TABLES: OnceLock<std::result::Result<KDistributions, String>> = OnceLock::new();
        TABLES
            .get_or_init(|| Self::parse("gas_kdistributions", data::GAS_KDISTRIBUTIONS).map_err(|e| e.to_string()))
            .as_ref()
            .map_err(|e| Error::data("gas_kdistributions", e.clone()))
    }

    /// Parses a table with columns `gas lo_nm hi_nm p_exp t_exp count k_cm2`
    /// (one row per g-point, the counts of a band summing to 400) and
    /// `p0_hPa`, `t0_K` header lines.
    pub fn parse(name: &str, text: &str) -> Result<KDistributions> {
        let table = Table::parse(name, text, 7)?;
        let header = |key: &str| {
            table
                .header(key)
                .and_then(|v| v.parse::<f64>().ok())
                .ok_or_else(|| Error::data(name, format!("missing `# {key}: <number>` header line")))
        };
        let (p0_hpa, t0_k) = (header("p0_hPa")?, header("t0_K")?);
        let mut raw: Vec<Vec<Vec<[f64; 7]>>> = vec![vec![Vec::new(); BANDS]; 5];
        for (row, line) in table.rows.iter().zip(data::row_lines(text)) {
            let code = row[0] as usize;
            let band = band_index(row[1] + 0.5 * BAND_NM);
            let ok = (1..=5).contains(&code)
                && row[0] == code as f64
                && band.is_some_and(|b| row[1] == RANGE_NM.0 + b as f64 * BAND_NM)
                && row[2] == row[1] + BAND_NM
                && row[5] >= 1.0
                && row[5].fract() == 0.0
                && row[6] >= 0.0;
            let (true, Some(b)) = (ok, band) else {
                return Err(Error::data(
                    name,
                    format!("line {line}: not a gas code 1-5 on the 40 nm grid from 280 nm with a count ≥ 1 and k ≥ 0"),
                ));
            };
            raw[code - 1][b].push([row[0], row[1], row[2], row[3], row[4], row[5], row[6]]);
        }
        let gases = [Gas::H2o, Gas::Co2, Gas::O2, Gas::Ch4, Gas::N2o];
        let mut bands = Vec::with_capacity(5);
        for (gas, per_band) in gases.iter().zip(raw) {
            let mut out = Vec::with_capacity(BANDS);
            for (b, mut rows) in per_band.into_iter().enumerate() {
                if rows.is_empty() {
                    out.push(None);
                    continue;
                }
                rows.sort_by(|a, c| a[6].total_cmp(&c[6]));
                let lo_nm = RANGE_NM.0 + b as f64 * BAND_NM;
                let total: f64 = rows.iter().map(|r| r[5]).sum();
                let scaling = Scaling {
                    p_exp: rows[0][3],
                    t_exp: rows[0][4],
                };
                if total != SLOTS as f64 || rows.iter().any(|r| r[3] != scaling.p_exp || r[4] != scaling.t_exp) {
                    return Err(Error::data(
                        name,
                        format!(
                            "{} at {lo_nm} nm: the counts must sum to {SLOTS} and the exponents be the band's",
                            gas.name()
                        ),
                    ));
                }
                out.push(Some(Self::band(*gas, lo_nm, scaling, &rows)));
            }
            bands.push(out);
        }
        Ok(KDistributions { bands, p0_hpa, t0_k })
    }

    /// A band's pseudo-spectrum from its rows (ascending in k).
    fn band(gas: Gas, lo_nm: f64, scaling: Scaling, rows: &[[f64; 7]]) -> BandK {
        let mut rank_k = Vec::with_capacity(SLOTS);
        for r in rows {
            rank_k.extend(std::iter::repeat_n(r[6], r[5] as usize));
        }
        let (a, c) = gas.permutation();
        let slot_k = (0..SLOTS).map(|s| rank_k[(a * s + c) % SLOTS]).collect();
        BandK {
            lo_nm,
            scaling,
            points: rows.iter().map(|r| (r[5] / SLOTS as f64, r[6])).collect(),
            slot_k,
        }
    }

    /// The k-distribution of `gas` in the band that holds λ, if it absorbs
    /// there.
    pub fn band_at(&self, gas: Gas, lambda_nm: f64) -> Option<&BandK> {
        let code = gas.code()?;
        self.bands[code - 1][band_index(lambda_nm)?].as_ref()
    }

    /// Every band of `gas` that absorbs, ascending.
    pub fn bands_of(&self, gas: Gas) -> impl Iterator<Item = &BandK> {
        gas.code()
            .map(|c| self.bands[c - 1].iter().flatten())
            .into_iter()
            .flatten()
    }

    /// The distinct scalings of `gas`'s bands that overlap [lo, hi] nm, in
    /// order of first appearance.
    pub fn scalings(&self, gas: Gas, (lo_nm, hi_nm): (f64, f64)) -> Vec<Scaling> {
        let mut out: Vec<Scaling> = Vec::new();
        for b in self.bands_of(gas) {
            if b.lo_nm < hi_nm && b.lo_nm + BAND_NM > lo_nm && !out.contains(&b.scaling) {
                out.push(b.scaling);
            }
        }
        out
    }
}

/// The O₂–O₂ collision-induced absorption cross section (cm⁵ molecule⁻²),
/// Greenblatt et al. (1990), linear between its wavelengths; zero outside.
#[derive(Debug, Clone)]
pub struct CollisionPairs {
    wavelengths_nm: Vec<f64>,
    sigma_cm5: Vec<f64>,
}

impl CollisionPairs {
    /// The built-in table (parsed once).
    pub fn builtin() -> Result<&'static CollisionPairs> {
        static TABLE: OnceLock<std::result::Result<CollisionPairs, String>> = OnceLock::new();
        TABLE
            .get_or_init(|| {
                let table = Table::parse("o4_greenblatt", data::O4_CROSS_SECTION, 2).map_err(|e| e.to_string())?;
                table.require_ascending(0, "wavelengths").map_err(|e| e.to_string())?;
                Ok(CollisionPairs {
                    wavelengths_nm: table.column(0),
                    sigma_cm5: table.column(1),
                })
            })
            .as_ref()
            .map_err(|e| Error::data("o4_greenblatt", e.clone()))
    }

    /// σ (cm⁵) at λ; 0 outside the table.
    pub fn sigma_cm5(&self, lambda_nm: f64) -> f64 {
        data::interp_linear(&self.wavelengths_nm, &self.sigma_cm5, lambda_nm).unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The permutation is a bijection for every gas, so a uniform slot is a
    /// g-point with probability exactly its weight.
    #[test]
    fn every_band_holds_each_g_point_in_proportion_to_its_weight() {
        let k = KDistributions::builtin().unwrap();
        let mut checked = 0;
        for gas in [Gas::H2o, Gas::Co2, Gas::O2, Gas::Ch4, Gas::N2o] {
            for b in k.bands_of(gas) {
                for &(w, kj) in &b.points {
                    let n = (0..SLOTS)
                        .filter(|&s| b.k_cm2(b.lo_nm + (s as f64 + 0.5) * BAND_NM / SLOTS as f64) == kj)
                        .count();
                    let same: f64 = b.points.iter().filter(|p| p.1 == kj).map(|p| p.0).sum();
                    assert_eq!(n, (same * SLOTS as f64).round() as usize, "{gas:?} {} nm", b.lo_nm);
                    assert!(w > 0.0);
                }
                // The slot mean of k is the distribution's mean.
                let slot_mean = (0..SLOTS)
                    .map(|s| b.k_cm2(b.lo_nm + (s as f64 + 0.5) * 0.1))
                    .sum::<f64>()
                    / SLOTS as f64;
                assert!((slot_mean - b.mean_k_cm2()).abs() <= 1e-12 * b.mean_k_cm2().max(1e-300));
                checked += 1;
            }
        }
        // H2O alone absorbs in 48 of the 55 bands (560 nm onward).
        assert!(checked > 80, "{checked} bands");
    }

    /// Each gas's g-points are spread over its band: every quarter of a
    /// band holds each of the gas's g-ranks' quarters within a few slots of
    /// a quarter of them (what makes sub-band wavelengths and the smooth
    /// spectra nearly independent of g).
    #[test]
    fn g_ranks_are_spread_over_the_band() {
        for gas in [Gas::H2o, Gas::Co2, Gas::O2, Gas::Ch4, Gas::N2o] {
            let (a, c) = gas.permutation();
            for quarter in 0..4 {
                let slots = (quarter * 100)..(quarter * 100 + 100);
                for rank_quarter in 0..4 {
                    let n = slots
                        .clone()
                        .filter(|&s| (a * s + c) % SLOTS / 100 == rank_quarter)
                        .count();
                    assert!(
                        (20..=30).contains(&n),
                        "{gas:?}: {n} of 100 slots in rank quarter {rank_quarter}"
                    );
                }
            }
        }
    }

    #[test]
    fn band_index_covers_280_to_2480_nm() {
        assert_eq!(band_index(280.0), Some(0));
        assert_eq!(band_index(319.99), Some(0));
        assert_eq!(band_index(320.0), Some(1));
        assert_eq!(band_index(2480.0), Some(54));
        assert_eq!(band_index(279.9), None);
        assert_eq!(band_index(2480.1), None);
    }

    /// The A band of O₂ (759–771 nm) absorbs far more than the 600–640 nm γ
    /// band, and water's 1360–1400 nm band is nearly opaque through a
    /// vertical US-standard column (4.8e22 cm⁻² of scaled water, about
    /// 1.4 cm precipitable): facts of the source that the table keeps.
    #[test]
    fn the_table_keeps_the_strong_bands() {
        let k = KDistributions::builtin().unwrap();
        let o2_a = k.band_at(Gas::O2, 770.0).unwrap().mean_k_cm2();
        let o2_gamma = k.band_at(Gas::O2, 620.0).unwrap().mean_k_cm2();
        assert!(o2_a > 10.0 * o2_gamma, "{o2_a:e} {o2_gamma:e}");
        let t = k.band_at(Gas::H2o, 1380.0).unwrap().transmittance(4.8e22);
        assert!(t < 0.05, "{t}");
        assert!(k.band_at(Gas::H2o, 500.0).is_none());
    }
}
