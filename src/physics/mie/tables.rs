//! The text format of the OPAC phase-matrix tables atmosim ships
//! (`atmospheres/opac/mie/<component>_rh<RH>_phase.txt`, written by
//! `atmosim opac-tables`): one file per component and tabulated humidity,
//! every wavelength side by side.
//!
//! Format (the data-table format of [`crate::physics::data`]):
//! - comment lines with the provenance, then the machine-read headers
//!   `# component: <name>`, `# rh_pct: <RH>` and
//!   `# wavelengths_nm: <λ1> <λ2> …` (ascending);
//! - one row per scattering angle Θ (degrees, ascending, 0 first and 180
//!   last): `Θ` then, for each wavelength in header order, `P11 P12/P11
//!   P33/P11 P34/P11`. P11 is normalised so that ½∫₋₁¹P11 dμ = 1 (by the
//!   Mie side's quadrature; atmosim renormalises exactly when it builds a
//!   sampler), the other three are stored as ratios to P11, which lie in
//!   [−1, 1] and need no exponent. Signs as in [`super::phase_matrix`].

use crate::error::{Error, Result};
use crate::physics::data::{self, Table};
use crate::physics::mie::phase_matrix::PhaseMatrix;

/// One component's phase matrices at one humidity, per wavelength.
#[derive(Debug, Clone, PartialEq)]
pub struct PhaseTables {
    pub component: String,
    pub rh_pct: f64,
    /// Ascending.
    pub wavelengths_nm: Vec<f64>,
    /// One per wavelength, all on the same angles.
    pub matrices: Vec<PhaseMatrix>,
}

/// The name of the table of `component` at `rh_pct` (e.g. `waso_rh50`).
pub fn phase_table_name(component: &str, rh_pct: f64) -> String {
    format!("{component}_rh{rh_pct}")
}

/// The shipped phase tables of OPAC component `component` at its
/// tabulated humidity `rh_pct` (`atmospheres/opac/mie/<component>_rh<RH>_phase.txt`,
/// embedded in the binary); `None` when there is no such table.
pub fn builtin_phase(component: &str, rh_pct: f64) -> Option<Result<PhaseTables>> {
    let name = phase_table_name(component, rh_pct);
    data::builtin(data::OPAC_PHASE, &name)
        .map(|text| PhaseTables::parse(&format!("atmospheres/opac/mie/{name}_phase.txt"), text))
}

impl PhaseTables {
    /// Parses a table; `name` names it in errors.
    pub fn parse(name: &str, text: &str) -> Result<PhaseTables> {
        let table = Table::parse(name, text, 0)?;
        let header = |key: &str| {
            table
                .header(key)
                .ok_or_else(|| Error::data(name, format!("missing `# {key}: …` header line")))
        };
        let component = header("component")?.to_string();
        let rh_pct: f64 = header("rh_pct")?
            .parse()
            .map_err(|_| Error::data(name, "`# rh_pct:` is not a number"))?;
        let wavelengths_nm = header("wavelengths_nm")?
            .split_whitespace()
            .map(|w| {
                w.parse::<f64>()
                    .map_err(|_| Error::data(name, format!("wavelength `{w}` is not a number")))
            })
            .collect::<Result<Vec<f64>>>()?;
        if wavelengths_nm.is_empty() || wavelengths_nm.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::data(name, "wavelengths must be given and increase strictly"));
        }
        let columns = 1 + 4 * wavelengths_nm.len();
        if table.rows[0].len() != columns {
            return Err(Error::data(
                name,
                format!(
                    "{} columns, expected {columns} (angle, then 4 per wavelength)",
                    table.rows[0].len()
                ),
            ));
        }
        table.require_ascending(0, "scattering angles")?;
        let angles_deg = table.column(0);
        let matrices = (0..wavelengths_nm.len())
            .map(|w| {
                let c = 1 + 4 * w;
                let p11 = table.column(c);
                let times_p11 = |j: usize| {
                    table
                        .column(c + j)
                        .iter()
                        .zip(&p11)
                        .map(|(r, p)| r * p)
                        .collect::<Vec<f64>>()
                };
                PhaseMatrix {
                    angles_deg: angles_deg.clone(),
                    p12: times_p11(1),
                    p33: times_p11(2),
                    p34: times_p11(3),
                    p11,
                }
            })
            .collect();
        Ok(PhaseTables {
            component,
            rh_pct,
            wavelengths_nm,
            matrices,
        })
    }

    /// The table as text, after the comment lines `provenance` (each
    /// written behind `# `).
    pub fn to_text(&self, provenance: &[String]) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        for line in provenance {
            let _ = writeln!(s, "# {line}");
        }
        let _ = writeln!(s, "# component: {}", self.component);
        let _ = writeln!(s, "# rh_pct: {}", self.rh_pct);
        let wl: Vec<String> = self.wavelengths_nm.iter().map(|w| format!("{w}")).collect();
        let _ = writeln!(s, "# wavelengths_nm: {}", wl.join(" "));
        let _ = writeln!(
            s,
            "# columns: angle_deg, then per wavelength: p11 p12/p11 p33/p11 p34/p11"
        );
        let Some(first) = self.matrices.first() else {
            return s;
        };
        for (i, angle) in first.angles_deg.iter().enumerate() {
            let _ = write!(s, "{angle}");
            for m in &self.matrices {
                let p11 = m.p11[i];
                // Ratios that print as zero are written as 0.000000, never
                // -0.000000: the sign of a rounding residue is noise.
                let ratio = |v: f64| {
                    let r = if p11 > 0.0 { v / p11 } else { 0.0 };
                    if r.abs() < 5e-7 { 0.0 } else { r }
                };
                let _ = write!(
                    s,
                    " {p11:.6e} {:.6} {:.6} {:.6}",
                    ratio(m.p12[i]),
                    ratio(m.p33[i]),
                    ratio(m.p34[i])
                );
            }
            s.push('\n');
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PhaseTables {
        let angles_deg = vec![0.0, 0.5, 90.0, 180.0];
        let m = |k: f64| PhaseMatrix {
            angles_deg: angles_deg.clone(),
            p11: vec![120.0 * k, 50.0, 0.25, 0.125],
            p12: vec![0.0, -0.5, -0.125, 0.0],
            p33: vec![120.0 * k, 49.0, 0.0625, -0.125],
            p34: vec![0.0, 0.25, 0.03125, 0.0],
        };
        PhaseTables {
            component: "waso".into(),
            rh_pct: 50.0,
            wavelengths_nm: vec![400.0, 550.0],
            matrices: vec![m(1.0), m(2.0)],
        }
    }

    #[test]
    fn text_round_trips_to_the_printed_digits() {
        let t = sample();
        let text = t.to_text(&["test table".into()]);
        let back = PhaseTables::parse("t", &text).unwrap();
        assert_eq!(back.component, "waso");
        assert_eq!(back.rh_pct, 50.0);
        assert_eq!(back.wavelengths_nm, t.wavelengths_nm);
        for (a, b) in back.matrices.iter().zip(&t.matrices) {
            assert_eq!(a.angles_deg, b.angles_deg);
            for (x, y) in [(&a.p11, &b.p11), (&a.p12, &b.p12), (&a.p33, &b.p33), (&a.p34, &b.p34)] {
                for (u, v) in x.iter().zip(y) {
                    assert!((u - v).abs() <= 1e-6 * v.abs().max(1e-3), "{u} vs {v}");
                }
            }
        }
        assert_eq!(phase_table_name("waso", 50.0), "waso_rh50");
    }

    #[test]
    fn malformed_tables_are_refused_with_their_name() {
        let text = sample().to_text(&[]);
        let no_wl = text.replace("# wavelengths_nm: 400 550\n", "");
        let e = PhaseTables::parse("x.txt", &no_wl).unwrap_err().to_string();
        assert!(e.contains("x.txt") && e.contains("wavelengths_nm"), "{e}");
        let one_wl = text.replace("# wavelengths_nm: 400 550", "# wavelengths_nm: 400");
        let e = PhaseTables::parse("x.txt", &one_wl).unwrap_err().to_string();
        assert!(e.contains("expected 5"), "{e}");
    }
}
