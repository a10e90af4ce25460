//! Text reports of an atmosphere: the per-layer optical depths as CSV (for
//! tools) or as an aligned table (for people), then column totals and the
//! ground visibility.

use std::io::{self, Write};

use crate::atmosphere::Atmosphere;
use crate::atmosphere::spectral_terms::Spectrum;
use crate::physics::kdistribution::Gas;

/// Cells per nm of a band's mean gas optical depth (the midpoint rule on
/// 0.05 nm cells, two per slot of the gases' pseudo-spectra: exact).
const CELLS_PER_NM: f64 = 20.0;

/// The gases with terms in `atm`, in report order.
pub fn gases(atm: &Atmosphere) -> Vec<Gas> {
    Gas::ALL
        .into_iter()
        .filter(|g| {
            atm.terms
                .terms
                .iter()
                .any(|t| matches!(t.spectrum, Spectrum::Gas { gas, .. } if gas == *g))
        })
        .collect()
}

/// The wide range's gases of `atm` in one line, as the image attributes
/// and the fitter's consistency check state them: `none`, or their names
/// and the profile's precipitable water and column-mean CO₂.
pub fn gases_text(atm: &Atmosphere) -> String {
    let names: Vec<&str> = gases(atm).iter().map(|g| g.name()).collect();
    match (names.is_empty(), atm.gas_columns) {
        (true, _) => "none".into(),
        (false, Some((pw, co2))) => format!("{}; precipitable water {pw:.4} cm, CO2 {co2:.2} ppm", names.join(" ")),
        (false, None) => names.join(" "),
    }
}

/// The optical depth of `gas` in `layer` for the channel at λ with band
/// width `width_nm`: its terms' amounts times their responses, averaged
/// over the band (at λ for a monochromatic channel). For a k-distribution
/// gas this is the band's mean k times the scaled column, not −ln of the
/// band transmittance.
fn gas_tau(atm: &Atmosphere, gas: Gas, layer: usize, lambda_nm: f64, width_nm: f64) -> f64 {
    let cells = (width_nm * CELLS_PER_NM).ceil().max(1.0) as usize;
    let dz = atm.thickness_km(layer);
    atm.terms
        .terms
        .iter()
        .filter(|t| matches!(t.spectrum, Spectrum::Gas { gas: g, .. } if g == gas))
        .map(|t| {
            let mean = (0..cells)
                .map(|k| {
                    let l = lambda_nm + width_nm * ((k as f64 + 0.5) / cells as f64 - 0.5);
                    t.spectrum.response(l).ext
                })
                .sum::<f64>()
                / cells as f64;
            t.amount[layer] * mean * dz
        })
        .sum()
}

/// The absorption optical depth of every gas term in `layer` at λ exactly
/// (what the layer optics hold besides ozone).
fn gas_tau_at(atm: &Atmosphere, layer: usize, lambda_nm: f64) -> f64 {
    atm.terms
        .terms
        .iter()
        .filter(|t| matches!(t.spectrum, Spectrum::Gas { .. }))
        .map(|t| t.amount[layer] * t.spectrum.response(lambda_nm).ext * atm.thickness_km(layer))
        .sum()
}

/// The CSV header of `atmosim atmosphere --format csv`.
pub const ATMOSPHERE_CSV_HEADER: &str = "wavelength_nm,bottom_km,top_km,tau_rayleigh,tau_ozone,tau_aerosol_ext,tau_aerosol_sca,aerosol_g,rayleigh_depolarization";

/// Output format of a report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Csv,
    Table,
}

/// One row per wavelength and layer (ascending), `tau_ozone` being the
/// ozone absorption optical depth, and with the wide range's gases on, one
/// column more per gas (`tau_h2o`, …: the band mean, see [`gas_tau`]) for
/// channels of band widths `band_widths_nm`; then `#` lines with the
/// column totals per wavelength and the ground visibility, so CSV readers
/// can skip them as comments.
pub fn write_atmosphere(
    atm: &Atmosphere,
    band_widths_nm: &[f64],
    format: Format,
    out: &mut dyn Write,
) -> io::Result<()> {
    let gases = gases(atm);
    let gas_header: Vec<String> = gases.iter().map(|g| format!("tau_{}", g.name())).collect();
    let mut header: Vec<&str> = ATMOSPHERE_CSV_HEADER.split(',').collect();
    header.extend(gas_header.iter().map(String::as_str));
    let width = |w: usize| band_widths_nm.get(w).copied().unwrap_or(0.0);
    let mut rows: Vec<Vec<String>> = Vec::new();
    let mut gas_columns = vec![vec![0.0; gases.len()]; atm.wavelengths_nm.len()];
    for (w, &lambda) in atm.wavelengths_nm.iter().enumerate() {
        for (i, o) in atm.optics[w].iter().enumerate() {
            let dz = atm.thickness_km(i);
            let mut row = vec![
                format!("{lambda}"),
                format!("{}", atm.levels_km[i]),
                format!("{}", atm.levels_km[i + 1]),
                format!("{:.6e}", o.sigma_rayleigh * dz),
                format!(
                    "{:.6e}",
                    (o.sigma_absorption * dz - gas_tau_at(atm, i, lambda)).max(0.0)
                ),
                format!("{:.6e}", o.sigma_aerosol_ext * dz),
                format!("{:.6e}", o.sigma_aerosol_sca * dz),
                format!("{:.6}", o.aerosol_g),
                format!("{:.6}", o.rayleigh_depolarization),
            ];
            for (j, &g) in gases.iter().enumerate() {
                let tau = gas_tau(atm, g, i, lambda, width(w));
                gas_columns[w][j] += tau;
                row.push(format!("{tau:.6e}"));
            }
            rows.push(row);
        }
    }
    match format {
        Format::Csv => {
            writeln!(out, "{}", header.join(","))?;
            for r in &rows {
                writeln!(out, "{}", r.join(","))?;
            }
        }
        Format::Table => {
            let widths: Vec<usize> = (0..header.len())
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
            c.tau_absorption - (0..atm.layer_count()).map(|i| gas_tau_at(atm, i, lambda)).sum::<f64>(),
            c.tau_aerosol_ext,
            c.tau_aerosol_sca,
            c.aerosol_ssa()
        )?;
        if !gases.is_empty() {
            let parts: Vec<String> = gases
                .iter()
                .zip(&gas_columns[w])
                .map(|(g, t)| format!("tau_{}={t:.6}", g.name()))
                .collect();
            writeln!(
                out,
                "# gas column {lambda} nm (band mean, width {} nm): {}",
                width(w),
                parts.join(" ")
            )?;
        }
    }
    if let Some((pw, co2)) = atm.gas_columns {
        writeln!(out, "# precipitable water: {pw:.4} cm; CO2: {co2:.2} ppm")?;
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
