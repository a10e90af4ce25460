//! Refractive indices of the OPAC components (Hess, Koepke & Schult 1998),
//! per tabulated humidity, and their interpolation in wavelength.
//!
//! Sign convention: atmosim's Mie solver takes m = n + i·k with **k ≥ 0 for
//! absorption** (Bohren & Huffman, time dependence e^(−iωt)). The OPAC
//! files, like Wiscombe's MIEV0, write the same medium as n − i·k, so their
//! imaginary column is negative; [`RefractiveIndex::parse`] stores k = −n_im
//! and refuses a row with n_im > 0 (a gain medium, not an OPAC aerosol).
//!
//! Between tabulated wavelengths n and k are interpolated linearly in
//! wavelength. This is what the libRadtran reference tables did: their
//! `n_re`, `n_im` columns at 420, 540 and 620 nm (between the OPAC nodes at
//! 400/450, 500/550 and 600/650 nm) are the linear interpolates, e.g. suso
//! at 50 % RH and 420 nm: n = 1.375 + 0.4·(1.371 − 1.375) = 1.3734.

use num_complex::Complex64;

use crate::error::{Error, Result};
use crate::physics::data::{self, Table};

/// The refractive index of one component at every tabulated humidity.
#[derive(Debug, Clone)]
pub struct RefractiveIndex {
    name: String,
    /// Tabulated humidities (%), ascending.
    rh_pct: Vec<f64>,
    /// Per humidity: wavelengths (nm, ascending) and m = n + i·k at each.
    tables: Vec<(Vec<f64>, Vec<Complex64>)>,
}

impl RefractiveIndex {
    /// The built-in table of an OPAC component (inso, waso, soot, ssam,
    /// sscm, minm, miam, micm, mitr, suso); `None` for an unknown name.
    pub fn builtin(component: &str) -> Option<Result<RefractiveIndex>> {
        data::builtin(data::OPAC_REFRACTIVE, component)
            .map(|text| Self::parse(&format!("atmospheres/opac/refractive/{component}.txt"), text))
    }

    /// Parses columns `wavelength_um rh_pct n_re n_im` (n_im ≤ 0 for an
    /// absorbing medium, as OPAC writes it). `name` is used in errors.
    pub fn parse(name: &str, text: &str) -> Result<RefractiveIndex> {
        let table = Table::parse(name, text, 4)?;
        let mut rh_pct = table.column(1);
        rh_pct.sort_by(f64::total_cmp);
        rh_pct.dedup();
        let mut tables = Vec::with_capacity(rh_pct.len());
        for &rh in &rh_pct {
            let mut wl = Vec::new();
            let mut m = Vec::new();
            for (line, row) in data::row_lines(text).zip(&table.rows) {
                if row[1] != rh {
                    continue;
                }
                let (lambda_um, n_re, n_im) = (row[0], row[2], row[3]);
                if !(lambda_um > 0.0 && n_re > 0.0) {
                    return Err(Error::data(
                        name,
                        format!("line {line}: wavelength and real part must be positive"),
                    ));
                }
                if n_im > 0.0 {
                    return Err(Error::data(
                        name,
                        format!("line {line}: n_im = {n_im} > 0; OPAC writes absorption as n_im ≤ 0"),
                    ));
                }
                if let Some(&last) = wl.last()
                    && lambda_um * 1000.0 <= last
                {
                    return Err(Error::data(
                        name,
                        format!("line {line}: wavelengths must increase within RH {rh} %"),
                    ));
                }
                wl.push(lambda_um * 1000.0);
                m.push(Complex64::new(n_re, -n_im));
            }
            tables.push((wl, m));
        }
        Ok(RefractiveIndex {
            name: name.to_string(),
            rh_pct,
            tables,
        })
    }

    /// The tabulated humidities (%).
    pub fn humidities_pct(&self) -> &[f64] {
        &self.rh_pct
    }

    /// m = n + i·k (k ≥ 0) at `wavelength_nm` and the tabulated humidity
    /// `rh_pct`, linear in wavelength between the table's nodes. Errors name
    /// the table, the humidities and the wavelength range.
    pub fn at(&self, wavelength_nm: f64, rh_pct: f64) -> Result<Complex64> {
        let i = self.rh_pct.iter().position(|&r| r == rh_pct).ok_or_else(|| {
            Error::data(
                &self.name,
                format!("humidity {rh_pct} % is not tabulated (tabulated: {:?} %)", self.rh_pct),
            )
        })?;
        let (wl, m) = &self.tables[i];
        let (lo, f) = data::bracket(wl, wavelength_nm).ok_or_else(|| {
            Error::data(
                &self.name,
                format!(
                    "wavelength {wavelength_nm} nm outside the table ({}–{} nm)",
                    wl[0],
                    wl[wl.len() - 1]
                ),
            )
        })?;
        let hi = (lo + 1).min(wl.len() - 1);
        Ok(m[lo] + (m[hi] - m[lo]) * f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_component_parses_with_k_positive() {
        for (name, _) in data::OPAC_REFRACTIVE {
            let t = RefractiveIndex::builtin(name).unwrap().unwrap();
            for &rh in t.humidities_pct() {
                let m = t.at(550.0, rh).unwrap();
                assert!(m.re > 1.0 && m.im >= 0.0, "{name} {rh}: {m}");
            }
        }
        let waso = RefractiveIndex::builtin("waso").unwrap().unwrap();
        assert_eq!(waso.humidities_pct(), &[0.0, 50.0, 70.0, 80.0, 90.0, 95.0, 98.0, 99.0]);
    }

    /// The libRadtran tables list the index they used; at 420 nm it is the
    /// linear interpolate of the OPAC values at 400 and 450 nm.
    #[test]
    fn interpolation_is_linear_in_wavelength_like_the_references() {
        let suso = RefractiveIndex::builtin("suso").unwrap().unwrap();
        let m = suso.at(420.0, 50.0).unwrap();
        assert!((m.re - 1.3734).abs() < 1e-12, "{m}");
        assert!((m.im - 4.547e-9).abs() < 1e-20, "{m}");
        let soot = RefractiveIndex::builtin("soot").unwrap().unwrap();
        let m = soot.at(540.0, 0.0).unwrap();
        assert!((m.re - 1.75).abs() < 1e-12 && (m.im - 0.442).abs() < 1e-12, "{m}");
    }

    #[test]
    fn errors_name_the_file_line_and_range() {
        let e = RefractiveIndex::parse("f.txt", "# c\n0.3 0 1.5 -0.01\n0.4 0 1.5 0.01\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("f.txt") && e.contains("line 3") && e.contains("n_im"), "{e}");
        let t = RefractiveIndex::parse("f.txt", "0.3 0 1.5 -0.01\n0.4 0 1.5 -0.02\n").unwrap();
        let e = t.at(500.0, 0.0).unwrap_err().to_string();
        assert!(e.contains("300") && e.contains("400"), "{e}");
        let e = t.at(350.0, 50.0).unwrap_err().to_string();
        assert!(e.contains("50 %"), "{e}");
        assert!((t.at(350.0, 0.0).unwrap().im - 0.015).abs() < 1e-15);
    }
}
