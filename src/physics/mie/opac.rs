//! Optical properties of the OPAC aerosol components from first principles:
//! the OPAC log-normal size distributions and refractive indices (Hess,
//! Koepke & Schult 1998, in libRadtran's configuration) through the Mie
//! solver.
//!
//! Per unit mass, as OPAC and libRadtran define it: the extinction
//! coefficient of the distribution divided by its mass density
//! ρ·⟨V⟩ (ρ the particle density of the component at that humidity, ⟨V⟩ the
//! mean particle volume of the truncated distribution):
//!
//!   k_ext = ⟨C_ext⟩ / (ρ ⟨V⟩),
//!
//! in km⁻¹ per (g m⁻³): with C in µm², V in µm³ and ρ in g cm⁻³, the ratio
//! is in µm⁻¹ per (g cm⁻³) = 10³ km⁻¹ per (g m⁻³).

use crate::error::{Error, Result};
use crate::physics::data::{self, Table};
use crate::physics::mie::lognormal::{LogNormal, Quadrature};
use crate::physics::mie::phase_matrix::PhaseMatrix;
use crate::physics::mie::refractive::RefractiveIndex;

/// The OPAC component names in the numbering of `size_distributions.txt`
/// (component 1 is inso, …, 10 is suso).
pub const COMPONENTS: [&str; 10] = [
    "inso", "waso", "soot", "ssam", "sscm", "minm", "miam", "micm", "mitr", "suso",
];

const SIZES_NAME: &str = "atmospheres/opac/size_distributions.txt";

/// µm⁻¹ per (g cm⁻³) in km⁻¹ per (g m⁻³).
const PER_UM_PER_G_CM3_IN_PER_KM_PER_G_M3: f64 = 1.0e3;

/// One row of the size-distribution table: a component at one humidity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SizeDistribution {
    /// Relative humidity (%).
    pub rh_pct: f64,
    /// The radii.
    pub lognormal: LogNormal,
    /// Particle density (g cm⁻³).
    pub density_g_cm3: f64,
}

/// A component's optics at one humidity and wavelength.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentMieOptics {
    /// Extinction per unit aerosol mass, km⁻¹ per (g m⁻³).
    pub k_ext: f64,
    /// Single-scattering albedo.
    pub ssa: f64,
    /// Asymmetry parameter.
    pub g: f64,
    /// Phase matrix at the requested angles.
    pub phase: PhaseMatrix,
}

/// The size distributions of one component at each tabulated humidity,
/// from the built-in table.
pub fn size_distributions(component: &str) -> Result<Vec<SizeDistribution>> {
    parse_size_distributions(SIZES_NAME, data::OPAC_SIZE_DISTRIBUTIONS, component)
}

/// Parses columns `component rh_pct r_min_um r_max_um r_mod_um rho_g_cm-3
/// sigma` and returns the rows of `component` (a name of [`COMPONENTS`]).
pub fn parse_size_distributions(name: &str, text: &str, component: &str) -> Result<Vec<SizeDistribution>> {
    let number = COMPONENTS.iter().position(|c| *c == component).ok_or_else(|| {
        Error::data(
            name,
            format!(
                "unknown OPAC component `{component}` (known: {})",
                COMPONENTS.join(", ")
            ),
        )
    })? + 1;
    let table = Table::parse(name, text, 7)?;
    let mut out = Vec::new();
    for (row, line) in table.rows.iter().zip(data::row_lines(text)) {
        if row[0] != number as f64 {
            continue;
        }
        let d = SizeDistribution {
            rh_pct: row[1],
            lognormal: LogNormal {
                r_min_um: row[2],
                r_max_um: row[3],
                r_mod_um: row[4],
                sigma: row[6],
            },
            density_g_cm3: row[5],
        };
        d.lognormal.validate(&format!("{name}: line {line}"))?;
        if d.density_g_cm3.is_nan() || d.density_g_cm3 <= 0.0 {
            return Err(Error::data(name, format!("line {line}: density must be positive")));
        }
        out.push(d);
    }
    if out.is_empty() {
        return Err(Error::data(
            name,
            format!("no rows for component {number} ({component})"),
        ));
    }
    Ok(out)
}

/// Mie optics of OPAC component `component` at the tabulated humidity
/// `rh_pct` (0 for inso, soot and the mineral components; 0, 50, 70, 80,
/// 90, 95, 98 or 99 for waso, ssam, sscm, suso) and `wavelength_nm`, with
/// the refractive index interpolated linearly in wavelength and the phase
/// matrix at `angles_deg`.
pub fn component_optics(
    component: &str,
    rh_pct: f64,
    wavelength_nm: f64,
    angles_deg: &[f64],
    q: Quadrature,
) -> Result<ComponentMieOptics> {
    let sizes = size_distributions(component)?;
    let size = sizes.iter().find(|s| s.rh_pct == rh_pct).ok_or_else(|| {
        let rhs: Vec<f64> = sizes.iter().map(|s| s.rh_pct).collect();
        Error::data(
            SIZES_NAME,
            format!("{component}: humidity {rh_pct} % is not tabulated (tabulated: {rhs:?} %)"),
        )
    })?;
    let m = RefractiveIndex::builtin(component)
        .ok_or_else(|| Error::data("OPAC refractive indices", format!("no table for `{component}`")))??
        .at(wavelength_nm, rh_pct)?;
    let e = size.lognormal.optics(wavelength_nm / 1000.0, m, angles_deg, q)?;
    Ok(ComponentMieOptics {
        k_ext: e.c_ext_um2 / (size.density_g_cm3 * e.volume_um3) * PER_UM_PER_G_CM3_IN_PER_KM_PER_G_M3,
        ssa: e.ssa(),
        g: e.g,
        phase: e.phase,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_component_has_its_humidities() {
        for c in COMPONENTS {
            let s = size_distributions(c).unwrap();
            let rh: Vec<f64> = s.iter().map(|d| d.rh_pct).collect();
            if ["waso", "ssam", "sscm", "suso"].contains(&c) {
                assert_eq!(rh, [0.0, 50.0, 70.0, 80.0, 90.0, 95.0, 98.0, 99.0], "{c}");
            } else {
                assert_eq!(rh, [0.0], "{c}");
            }
        }
        let waso = size_distributions("waso").unwrap();
        assert_eq!((waso[1].lognormal.r_mod_um, waso[1].density_g_cm3), (0.0262, 1.42));
    }

    #[test]
    fn errors_name_the_component_file_and_line() {
        let e = parse_size_distributions("s.txt", "1 0 0.005 20 0.4 2 2.5\n", "dust").unwrap_err();
        assert!(e.to_string().contains("dust"), "{e}");
        let e = parse_size_distributions("s.txt", "# h\n1 0 0.005 20 0.4 2 0.5\n", "inso").unwrap_err();
        assert!(e.to_string().contains("s.txt: line 2"), "{e}");
        let e = component_optics("waso", 60.0, 550.0, &[], Quadrature::default()).unwrap_err();
        assert!(e.to_string().contains("60 %"), "{e}");
        let e = component_optics("inso", 0.0, 100.0, &[], Quadrature::default()).unwrap_err();
        assert!(e.to_string().contains("100 nm"), "{e}");
    }
}
