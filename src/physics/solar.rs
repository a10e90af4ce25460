//! Extraterrestrial solar spectral irradiance: Kurucz (1992) averaged over
//! 1 nm, 250–10000 nm, in W m⁻² nm⁻¹. Radiances are computed per unit
//! irradiance; this spectrum turns them into absolute units on output.

use crate::error::Result;
use crate::physics::data::{self, Table};

/// A tabulated solar spectrum.
#[derive(Debug, Clone)]
pub struct SolarSpectrum {
    wavelengths_nm: Vec<f64>,
    irradiance: Vec<f64>,
}

impl SolarSpectrum {
    /// The built-in Kurucz spectrum.
    pub fn kurucz() -> Result<SolarSpectrum> {
        let t = Table::parse("solar_kurucz_1nm", data::SOLAR_KURUCZ, 2)?;
        t.require_ascending(0, "wavelengths")?;
        Ok(SolarSpectrum {
            wavelengths_nm: t.column(0),
            irradiance: t.column(1),
        })
    }

    /// Irradiance (W m⁻² nm⁻¹) at λ, linear between the 1 nm nodes; `None`
    /// outside the table.
    pub fn irradiance(&self, lambda_nm: f64) -> Option<f64> {
        data::interp_linear(&self.wavelengths_nm, &self.irradiance, lambda_nm)
    }

    /// The tabulated wavelengths (nm), first and last.
    pub fn range_nm(&self) -> (f64, f64) {
        (
            self.wavelengths_nm[0],
            self.wavelengths_nm[self.wavelengths_nm.len() - 1],
        )
    }

    /// Mean irradiance over [λ0, λ1] (trapezoidal on the 1 nm grid plus the
    /// interpolated end points).
    pub fn band_mean(&self, lo_nm: f64, hi_nm: f64) -> Option<f64> {
        if hi_nm <= lo_nm {
            return self.irradiance(lo_nm);
        }
        let mut xs = vec![lo_nm];
        xs.extend(self.wavelengths_nm.iter().copied().filter(|&x| x > lo_nm && x < hi_nm));
        xs.push(hi_nm);
        let mut sum = 0.0;
        for w in xs.windows(2) {
            sum += 0.5 * (self.irradiance(w[0])? + self.irradiance(w[1])?) * (w[1] - w[0]);
        }
        Some(sum / (hi_nm - lo_nm))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kurucz_values_are_those_of_the_source_file() {
        // kurudz_1.0nm.dat: 250 nm 63.52968 and 500 nm in mW m-2 nm-1.
        let s = SolarSpectrum::kurucz().unwrap();
        assert!((s.irradiance(250.0).unwrap() - 0.06352968).abs() < 1e-9);
        assert_eq!(s.irradiance(100.0), None);
    }

    #[test]
    fn integrated_irradiance_is_close_to_the_solar_constant() {
        // 250–10000 nm holds ≈ 98–99 % of the ≈ 1361–1367 W m⁻² total.
        let s = SolarSpectrum::kurucz().unwrap();
        let total = s.band_mean(250.0, 10000.0).unwrap() * 9750.0;
        assert!(total > 1300.0 && total < 1370.0, "{total}");
    }

    #[test]
    fn band_mean_of_a_linear_piece_is_its_midpoint_value() {
        let s = SolarSpectrum::kurucz().unwrap();
        let m = s.band_mean(500.0, 501.0).unwrap();
        let mid = 0.5 * (s.irradiance(500.0).unwrap() + s.irradiance(501.0).unwrap());
        assert!((m - mid).abs() < 1e-12);
    }
}
