//! The OPAC tables atmosim ships in `atmospheres/opac/mie/`, computed by its
//! own Mie solver (`atmosim opac-tables`): for every component at every
//! tabulated humidity and at [`TABLE_WAVELENGTHS_NM`],
//!
//! - `<component>_optics.txt`: extinction per unit mass, single-scattering
//!   albedo and asymmetry parameter, in the format of
//!   `atmospheres/opac/components/` (columns `wavelength_nm rh_pct
//!   ext_km-1_per_g_m-3 ssa g`, rows by wavelength, then humidity);
//! - `<component>_rh<RH>_phase.txt`: the phase matrices on the default
//!   angle grid, in the format of [`super::tables`].
//!
//! The work is split into [`TableJob`]s (one component, humidity and
//! wavelength each) that a caller may run in parallel; [`component_files`]
//! turns one component's results into the files' text. Nothing here writes
//! files.

use std::fmt::Write;

use crate::error::{Error, Result};
use crate::physics::mie::lognormal::Quadrature;
use crate::physics::mie::opac::{ComponentMieOptics, component_optics, size_distributions};
use crate::physics::mie::phase_matrix::default_angles_deg;
use crate::physics::mie::tables::{PhaseTables, phase_table_name};

/// The wavelengths (nm) of the shipped tables: the OPAC wavelengths from
/// 250 to 2500 nm (the nodes of its refractive indices) plus 420, 540 and
/// 620 nm, the grid of the libRadtran component tables in
/// `atmospheres/opac/components/` (waso, suso) between 300 and 800 nm.
/// They span the wide range's bands (280–2480 nm): 250 nm is the node
/// below the 280–320 nm band, 2500 nm the one above the 2440–2480 nm band.
pub const TABLE_WAVELENGTHS_NM: [f64; 22] = [
    250.0, 300.0, 350.0, 400.0, 420.0, 450.0, 500.0, 540.0, 550.0, 600.0, 620.0, 650.0, 700.0, 750.0, 800.0, 900.0,
    1000.0, 1250.0, 1500.0, 1750.0, 2000.0, 2500.0,
];

/// The directory the tables are shipped in, relative to the repository.
pub const TABLE_DIR: &str = "atmospheres/opac/mie";

/// One Mie computation: a component at one humidity and wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableJob {
    /// A name of [`COMPONENTS`](crate::physics::mie::opac::COMPONENTS).
    pub component: &'static str,
    /// A tabulated humidity of the component (%).
    pub rh_pct: f64,
    pub wavelength_nm: f64,
    /// The largest size parameter of the size distribution, 2π·r_max/λ.
    pub x_max: f64,
}

impl TableJob {
    /// Relative cost, ∝ x_max²: the phase-matrix sums over the sizes cost
    /// (nodes × terms) ∝ (x_max/Δx)·x_max above the switch to steps in x,
    /// which is where nearly all the work is.
    pub fn cost(&self) -> f64 {
        self.x_max * self.x_max
    }

    /// The Mie optics with the phase matrix on the default angle grid and
    /// the default size quadrature.
    pub fn run(&self) -> Result<ComponentMieOptics> {
        component_optics(
            self.component,
            self.rh_pct,
            self.wavelength_nm,
            &default_angles_deg(),
            Quadrature::default(),
        )
    }
}

/// A job's result.
#[derive(Debug, Clone, PartialEq)]
pub struct TableResult {
    pub job: TableJob,
    pub optics: ComponentMieOptics,
}

/// One file's name (inside [`TABLE_DIR`]) and text.
#[derive(Debug, Clone, PartialEq)]
pub struct TableFile {
    pub name: String,
    pub text: String,
}

/// Every job of `components` (names of [`COMPONENTS`](crate::physics::mie::opac::COMPONENTS)) at their tabulated
/// humidities and [`TABLE_WAVELENGTHS_NM`], the most expensive first, so
/// that parallel workers do not end waiting on one long job started last.
pub fn table_jobs(components: &[&'static str]) -> Result<Vec<TableJob>> {
    let mut jobs = Vec::new();
    for &component in components {
        for size in size_distributions(component)? {
            for wavelength_nm in TABLE_WAVELENGTHS_NM {
                jobs.push(TableJob {
                    component,
                    rh_pct: size.rh_pct,
                    wavelength_nm,
                    x_max: 2.0 * std::f64::consts::PI * size.lognormal.r_max_um / (wavelength_nm / 1000.0),
                });
            }
        }
    }
    jobs.sort_by(|a, b| b.cost().total_cmp(&a.cost()));
    Ok(jobs)
}

/// The files of one component from the results of all its jobs (in any
/// order): its optics table, then one phase table per humidity. Errors if
/// a job of [`table_jobs`] is missing or duplicated.
pub fn component_files(component: &'static str, results: &[TableResult]) -> Result<Vec<TableFile>> {
    let mut mine: Vec<&TableResult> = results.iter().filter(|r| r.job.component == component).collect();
    mine.sort_by(|a, b| {
        (a.job.wavelength_nm, a.job.rh_pct)
            .partial_cmp(&(b.job.wavelength_nm, b.job.rh_pct))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let humidities: Vec<f64> = size_distributions(component)?.iter().map(|s| s.rh_pct).collect();
    let expected: Vec<(f64, f64)> = TABLE_WAVELENGTHS_NM
        .iter()
        .flat_map(|&wl| humidities.iter().map(move |&rh| (wl, rh)))
        .collect();
    let got: Vec<(f64, f64)> = mine.iter().map(|r| (r.job.wavelength_nm, r.job.rh_pct)).collect();
    if got != expected {
        return Err(Error::data(
            format!("OPAC Mie tables of {component}"),
            format!(
                "{} results for {} (wavelength, humidity) pairs: every tabulated humidity at every \
                 table wavelength is needed once",
                got.len(),
                expected.len()
            ),
        ));
    }

    let mut files = vec![TableFile {
        name: format!("{component}_optics.txt"),
        text: optics_text(component, &mine),
    }];
    for &rh_pct in &humidities {
        let at_rh: Vec<&&TableResult> = mine.iter().filter(|r| r.job.rh_pct == rh_pct).collect();
        let tables = PhaseTables {
            component: component.to_string(),
            rh_pct,
            wavelengths_nm: at_rh.iter().map(|r| r.job.wavelength_nm).collect(),
            matrices: at_rh.iter().map(|r| r.optics.phase.clone()).collect(),
        };
        files.push(TableFile {
            name: format!("{}_phase.txt", phase_table_name(component, rh_pct)),
            text: tables.to_text(&phase_provenance(component, rh_pct)),
        });
    }
    Ok(files)
}

/// The provenance lines both kinds of file share.
fn method_lines(component: &str) -> Vec<String> {
    let q = Quadrature::default();
    vec![
        format!(
            "computed by atmosim's Lorenz-Mie solver (src/physics/mie; Bohren & Huffman 1983, series length and \
             recurrences of Wiscombe 1980) from the OPAC truncated log-normal size distribution of '{component}' \
             (atmospheres/opac/size_distributions.txt; Hess, Koepke & Schult 1998)"
        ),
        format!(
            "size quadrature: trapezoidal rule with steps of {} in ln r for small spheres and {} in size \
             parameter for large ones (mie::lognormal::Quadrature::default())",
            q.h_ln_r, q.dx
        ),
        format!(
            "refractive index: atmospheres/opac/refractive/{component}.txt at the humidity, interpolated \
             linearly in wavelength between its nodes (420, 540, 620 nm are not nodes)"
        ),
        format!(
            "written by `atmosim opac-tables` (atmosim {}); regenerate with that command",
            env!("CARGO_PKG_VERSION")
        ),
    ]
}

/// The optics table: the header of `atmospheres/opac/components/*.txt` and
/// its number format (k_ext %.6e, ssa and g %.6f). `rows` are sorted by
/// wavelength, then humidity.
fn optics_text(component: &str, rows: &[&TableResult]) -> String {
    let mut s = format!("# atmosim OPAC component '{component}': optical properties per unit aerosol mass\n");
    for line in method_lines(component) {
        let _ = writeln!(s, "# {line}");
    }
    let _ = writeln!(
        s,
        "# ext: extinction per unit aerosol mass at that humidity, km^-1 per (g m^-3), with the particle density of \
         the size-distribution table"
    );
    s.push_str("# columns: wavelength_nm rh_pct ext_km-1_per_g_m-3 ssa g\n");
    for r in rows {
        let o = &r.optics;
        let _ = writeln!(
            s,
            "{:.1}  {}  {}  {:.6}  {:.6}",
            r.job.wavelength_nm,
            r.job.rh_pct,
            c_exponent(o.k_ext),
            o.ssa,
            o.g
        );
    }
    s
}

/// `v` as C's `%.6e` writes it (`6.100603e+03`), the notation of the
/// libRadtran-derived tables; Rust's `{:.6e}` would write `6.100603e3`.
fn c_exponent(v: f64) -> String {
    let s = format!("{v:.6e}");
    match s.split_once('e').and_then(|(m, e)| Some((m, e.parse::<i32>().ok()?))) {
        Some((mantissa, e)) => format!("{mantissa}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs()),
        None => s,
    }
}

/// The comment lines above a phase table's machine-read headers.
fn phase_provenance(component: &str, rh_pct: f64) -> Vec<String> {
    let mut lines = vec![format!(
        "atmosim OPAC component '{component}' at {rh_pct} % relative humidity: phase matrix of the size \
         distribution (P11 and the ratios P12/P11, P33/P11, P34/P11; conventions in src/physics/mie/phase_matrix.rs \
         and CONVENTIONS.md section 11)"
    )];
    lines.extend(method_lines(component));
    lines.push(format!(
        "angles: mie::phase_matrix::default_angles_deg(), {} angles (steps of 0.01 deg to 1 deg, 0.05 to 5, \
         0.25 to 20, 0.5 to 180)",
        default_angles_deg().len()
    ));
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::mie::opac::COMPONENTS;

    #[test]
    fn jobs_cover_every_humidity_and_wavelength_most_expensive_first() {
        let jobs = table_jobs(&COMPONENTS).unwrap();
        // 4 components with 8 humidities, 6 with one.
        assert_eq!(jobs.len(), (4 * 8 + 6) * TABLE_WAVELENGTHS_NM.len());
        assert!(jobs.windows(2).all(|w| w[0].cost() >= w[1].cost()));
        let first = jobs[0];
        assert_eq!((first.component, first.wavelength_nm), ("sscm", 250.0));
    }

    #[test]
    fn exponents_as_c_writes_them() {
        assert_eq!(c_exponent(6100.603), "6.100603e+03");
        assert_eq!(c_exponent(0.0123), "1.230000e-02");
        assert_eq!(c_exponent(1.0e-100), "1.000000e-100");
    }

    /// Files from made-up results: the optics rows in the format of the
    /// libRadtran component tables, one phase table per humidity that
    /// parses back, and an error when a result is missing.
    #[test]
    fn files_of_a_component() {
        let angles_deg = vec![0.0, 90.0, 180.0];
        let jobs = table_jobs(&["waso"]).unwrap();
        let results: Vec<TableResult> = jobs
            .iter()
            .map(|&job| TableResult {
                job,
                optics: ComponentMieOptics {
                    k_ext: 6100.603 + job.rh_pct,
                    ssa: 0.949265,
                    g: 0.659689,
                    phase: crate::physics::mie::phase_matrix::PhaseMatrix {
                        angles_deg: angles_deg.clone(),
                        p11: vec![10.0, 0.5, job.wavelength_nm / 1000.0],
                        p12: vec![0.0, -0.25, 0.0],
                        p33: vec![10.0, 0.1, -0.3],
                        p34: vec![0.0, 0.05, 0.0],
                    },
                },
            })
            .collect();
        let files = component_files("waso", &results).unwrap();
        assert_eq!(files.len(), 1 + 8);
        assert_eq!(files[0].name, "waso_optics.txt");
        let rows: Vec<&str> = files[0].text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(rows.len(), 8 * 22);
        assert_eq!(rows[0], "250.0  0  6.100603e+03  0.949265  0.659689");
        assert_eq!(rows[1], "250.0  50  6.150603e+03  0.949265  0.659689");
        assert!(
            files[0]
                .text
                .contains("# columns: wavelength_nm rh_pct ext_km-1_per_g_m-3 ssa g\n")
        );
        assert_eq!(files[2].name, "waso_rh50_phase.txt");
        let t = PhaseTables::parse(&files[2].name, &files[2].text).unwrap();
        assert_eq!((t.rh_pct, t.wavelengths_nm.len()), (50.0, 22));
        assert_eq!(t.matrices[14].p11[2], 0.8);
        assert_eq!(t.matrices[21].p11[2], 2.5);
        let e = component_files("waso", &results[1..]).unwrap_err().to_string();
        assert!(e.contains("175 results for 176"), "{e}");
    }
}
