//! Ozone absorption cross sections with a quadratic temperature dependence,
//! σ(λ, T) = (c₀ + c₁(T − T₀) + c₂(T − T₀)²)·10⁻²⁰ cm², tabulated in λ:
//! Bogumil et al. (2003, IUP Bremen, 230–1066 nm, 0.1 nm) and Molina &
//! Molina (1986). Between tabulated wavelengths the coefficients (and so σ
//! at any T) are interpolated linearly, as uvspec does for `crs` absorption.

use crate::error::{Error, Result};
use crate::physics::data::{self, Table};

/// Which ozone cross section a job uses (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OzoneModel {
    Bogumil,
    Molina,
    None,
}

impl OzoneModel {
    /// The job-file spelling.
    pub fn name(self) -> &'static str {
        match self {
            OzoneModel::Bogumil => "bogumil",
            OzoneModel::Molina => "molina",
            OzoneModel::None => "none",
        }
    }
}

/// A temperature-dependent cross-section table.
#[derive(Debug, Clone)]
pub struct CrossSection {
    pub name: String,
    wavelengths_nm: Vec<f64>,
    coefficients: Vec<[f64; 3]>,
    t0_k: f64,
}

impl CrossSection {
    /// The built-in table of a model (`None` for [`OzoneModel::None`]).
    pub fn builtin(model: OzoneModel) -> Option<Result<CrossSection>> {
        let name = match model {
            OzoneModel::None => return None,
            other => other.name(),
        };
        let text = data::builtin(data::OZONE_CROSS_SECTIONS, name)?;
        Some(Self::parse(name, text))
    }

    /// Parses a table with columns `wavelength_nm c0 c1 c2` and a `t0_K:`
    /// header line.
    pub fn parse(name: &str, text: &str) -> Result<CrossSection> {
        let table = Table::parse(name, text, 4)?;
        table.require_ascending(0, "wavelengths")?;
        let t0_k = table
            .header("t0_K")
            .and_then(|v| v.parse::<f64>().ok())
            .ok_or_else(|| Error::data(name, "missing `# t0_K: <kelvin>` header line"))?;
        Ok(CrossSection {
            name: name.to_string(),
            wavelengths_nm: table.column(0),
            coefficients: table.rows.iter().map(|r| [r[1], r[2], r[3]]).collect(),
            t0_k,
        })
    }

    /// The tabulated wavelength range (nm).
    pub fn range_nm(&self) -> (f64, f64) {
        (
            self.wavelengths_nm[0],
            self.wavelengths_nm[self.wavelengths_nm.len() - 1],
        )
    }

    /// The reference temperature T₀ (K) of the quadratic.
    pub fn t0_k(&self) -> f64 {
        self.t0_k
    }

    /// Coefficient `k` (0, 1, 2) of the quadratic in T − T₀ at λ, in cm²
    /// (K⁻ᵏ), interpolated linearly like the cross section itself, so that
    /// Σ_k c_k(λ)(T − T₀)ᵏ is [`Self::sigma_cm2`]; `None` outside the table.
    pub fn coefficient_cm2(&self, lambda_nm: f64, k: usize) -> Option<f64> {
        let (i, f) = data::bracket(&self.wavelengths_nm, lambda_nm)?;
        let c0 = self.coefficients[i][k];
        let c = if f == 0.0 {
            c0
        } else {
            c0 + (self.coefficients[i + 1][k] - c0) * f
        };
        Some(c * 1.0e-20)
    }

    /// Cross section (cm²) at λ (nm) and temperature T (K); `None` outside
    /// the table.
    pub fn sigma_cm2(&self, lambda_nm: f64, t_k: f64) -> Option<f64> {
        let (i, f) = data::bracket(&self.wavelengths_nm, lambda_nm)?;
        let at = |c: &[f64; 3]| {
            let dt = t_k - self.t0_k;
            (c[0] + c[1] * dt + c[2] * dt * dt) * 1.0e-20
        };
        let s0 = at(&self.coefficients[i]);
        Some(if f == 0.0 {
            s0
        } else {
            s0 + (at(&self.coefficients[i + 1]) - s0) * f
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bogumil() -> CrossSection {
        CrossSection::builtin(OzoneModel::Bogumil).unwrap().unwrap()
    }

    #[test]
    fn bogumil_at_a_node_is_the_quadratic_of_its_coefficients() {
        // The 540.0 nm row of spectra/ozone_bogumil.txt, read from the text
        // and evaluated independently of the parser.
        let text = data::builtin(data::OZONE_CROSS_SECTIONS, "bogumil").unwrap();
        let row: Vec<f64> = text
            .lines()
            .find(|l| l.trim_start().starts_with("540.0 "))
            .unwrap()
            .split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect();
        let t = 250.0;
        let dt: f64 = t - 273.15;
        let expect = (row[1] + row[2] * dt + row[3] * dt * dt) * 1e-20;
        assert_eq!(bogumil().sigma_cm2(540.0, t), Some(expect));
    }

    #[test]
    fn bogumil_values_are_those_of_the_literature() {
        // Chappuis band near 600 nm: about 5e-21 cm² at room temperature
        // (Bogumil et al. 2003; Serdyuchenko et al. 2014: 5.1e-21 at 603 nm).
        let s = bogumil().sigma_cm2(603.0, 293.0).unwrap();
        assert!((s / 5.1e-21 - 1.0).abs() < 0.05, "{s:e}");
        // Huggins band at 320 nm, 1e-20 scale, stronger when warm.
        let warm = bogumil().sigma_cm2(320.0, 293.0).unwrap();
        let cold = bogumil().sigma_cm2(320.0, 223.0).unwrap();
        assert!(warm > cold && warm > 1e-20 && warm < 5e-20, "{warm:e} {cold:e}");
    }

    #[test]
    fn interpolates_linearly_between_nodes_and_refuses_outside() {
        let x = bogumil();
        let (a, b) = (x.sigma_cm2(540.0, 230.0).unwrap(), x.sigma_cm2(540.1, 230.0).unwrap());
        let mid = x.sigma_cm2(540.05, 230.0).unwrap();
        assert!((mid - 0.5 * (a + b)).abs() < 1e-12 * a.abs());
        assert_eq!(x.sigma_cm2(200.0, 230.0), None);
        assert_eq!(x.range_nm(), (230.0, 1066.2));
    }

    #[test]
    fn molina_loads_with_its_own_reference_temperature() {
        let m = CrossSection::builtin(OzoneModel::Molina).unwrap().unwrap();
        assert_eq!(m.t0_k, 273.13);
        assert!(m.sigma_cm2(320.0, 250.0).unwrap() > 0.0);
    }
}
