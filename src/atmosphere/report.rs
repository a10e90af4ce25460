//! Text reports of an atmosphere: the per-layer optical depths as CSV (for
//! tools) or as an aligned table (for people), then column totals and the
//! ground visibility.

use std::io::{self, Write};

use crate::atmosphere::Atmosphere;

/// The CSV header of `atmosim atmosphere --format csv`.
pub const ATMOSPHERE_CSV_HEADER: &str = "wavelength_nm,bottom_km,top_km,tau_rayleigh,tau_ozone,tau_aerosol_ext,tau_aerosol_sca,aerosol_g,rayleigh_depolarization";

/// Output format of a report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Csv,
    Table,
}

/// One row per wavelength and layer (ascending), `tau_ozone` being the gas
/// absorption optical depth; then `#` lines with the column totals per
/// wavelength and the ground visibility, so CSV readers can skip them as
/// comments.
pub fn write_atmosphere(atm: &Atmosphere, format: Format, out: &mut dyn Write) -> io::Result<()> {
    let header: Vec<&str> = ATMOSPHERE_CSV_HEADER.split(',').collect();
    let mut rows: Vec<[String; 9]> = Vec::new();
    for (w, &lambda) in atm.wavelengths_nm.iter().enumerate() {
        for (i, o) in atm.optics[w].iter().enumerate() {
            let dz = atm.thickness_km(i);
            rows.push([
                format!("{lambda}"),
                format!("{}", atm.levels_km[i]),
                format!("{}", atm.levels_km[i + 1]),
                format!("{:.6e}", o.sigma_rayleigh * dz),
                format!("{:.6e}", o.sigma_absorption * dz),
                format!("{:.6e}", o.sigma_aerosol_ext * dz),
                format!("{:.6e}", o.sigma_aerosol_sca * dz),
                format!("{:.6}", o.aerosol_g),
                format!("{:.6}", o.rayleigh_depolarization),
            ]);
        }
    }
    match format {
        Format::Csv => {
            writeln!(out, "{ATMOSPHERE_CSV_HEADER}")?;
            for r in &rows {
                writeln!(out, "{}", r.join(","))?;
            }
        }
        Format::Table => {
            let widths: Vec<usize> = (0..9)
                .map(|j| {
                    rows.iter()
                        .map(|r| r[j].len())
                        .chain([header[j].len()])
                        .max()
                        .unwrap_or(0)
                })
                .collect();
            let line = |cells: &[&str]| {
                cells
                    .iter()
                    .zip(&widths)
                    .map(|(c, w)| format!("{c:>w$}"))
                    .collect::<Vec<_>>()
                    .join("  ")
            };
            writeln!(out, "{}", line(&header))?;
            for r in &rows {
                let cells: Vec<&str> = r.iter().map(String::as_str).collect();
                writeln!(out, "{}", line(&cells))?;
            }
        }
    }
    for (w, &lambda) in atm.wavelengths_nm.iter().enumerate() {
        let c = atm.column(w);
        writeln!(
            out,
            "# column {lambda} nm: tau_rayleigh={:.6} tau_ozone={:.6} tau_aerosol_ext={:.6} tau_aerosol_sca={:.6} aerosol_ssa={:.4}",
            c.tau_rayleigh,
            c.tau_absorption,
            c.tau_aerosol_ext,
            c.tau_aerosol_sca,
            c.aerosol_ssa()
        )?;
    }
    if let Some(du) = atm.ozone_column_du {
        writeln!(out, "# ozone column: {du:.1} DU")?;
    }
    match atm.visibility {
        Some(v) => writeln!(
            out,
            "# ground visibility (550 nm, Koschmieder): {:.2} km; unscaled mixture: {:.2} km; boundary-layer scale: {:.4}",
            v.ground_km, v.unscaled_km, v.boundary_scale
        )?,
        None => writeln!(out, "# ground visibility: no aerosol")?,
    }
    Ok(())
}
