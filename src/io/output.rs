//! Writing results: CSV tables for the `directions` sensor and the fluxes,
//! always through a temporary file renamed into place, so a crash never
//! leaves a file that looks complete.

use std::path::Path;

use crate::error::Result;
use crate::film::noise::Noise;
use crate::film::results::{FluxRow, RadianceRow};
use crate::io::exr::{Channel, wavelength_label, write_exr};
use crate::job::transmittance::Grid;
use crate::transport::transmittance::Table as TransmittanceTable;

/// Header of the radiance CSV of a `directions` sensor.
pub const RADIANCE_CSV_HEADER: &str =
    "wavelength_nm,albedo,view_zenith_deg,azimuth_deg,I,Q,U,V,I_se,Q_se,U_se,V_se,samples";
/// Header of the flux CSV.
pub const FLUX_CSV_HEADER: &str = "wavelength_nm,albedo,altitude_km,e_dir,e_down,e_up,e_down_se,e_up_se,samples";

/// The radiance CSV text.
pub fn radiance_csv(rows: &[RadianceRow]) -> String {
    let mut s = String::from(RADIANCE_CSV_HEADER);
    s.push('\n');
    for r in rows {
        let (m, se) = (r.tally.mean(), r.tally.standard_error());
        s.push_str(&format!(
            "{},{},{},{},{:.9e},{:.9e},{:.9e},{:.9e},{:.4e},{:.4e},{:.4e},{:.4e},{}\n",
            r.wavelength_nm,
            r.albedo,
            r.direction.view_zenith_deg,
            r.direction.azimuth_deg,
            m[0],
            m[1],
            m[2],
            m[3],
            se[0],
            se[1],
            se[2],
            se[3],
            r.tally.samples
        ));
    }
    s
}

/// The flux CSV text.
pub fn flux_csv(rows: &[FluxRow]) -> String {
    let mut s = String::from(FLUX_CSV_HEADER);
    s.push('\n');
    for r in rows {
        let f = &r.fluxes;
        s.push_str(&format!(
            "{},{},{},{:.9e},{:.9e},{:.9e},{:.4e},{:.4e},{}\n",
            r.wavelength_nm, r.albedo, r.altitude_km, f.e_dir, f.e_down, f.e_up, f.e_down_se, f.e_up_se, f.samples
        ));
    }
    s
}

/// Header of the noise CSV of a render with a noise target.
pub const NOISE_CSV_HEADER: &str = "wavelength_nm,albedo,counted,median_rel_se_I,p99_rel_se_I,max_rel_se_I,above_target,samples_min,samples_median,samples_max,targeted,image_rel_noise";

/// The noise CSV text: per (wavelength, albedo), the relative standard
/// error of I over the pixels or directions with a non-zero mean
/// (`counted`), how many are above the target, their samples, and
/// whether the target counts the albedo (1) or it only rides along (0,
/// `render.noise_target_albedos`), and for an image its noise as a whole,
/// √(Σ Ω·se² / Σ Ω·I²) (empty for directions).
pub fn noise_csv(rows: &[(f64, f64, bool, Noise)]) -> String {
    let mut s = String::from(NOISE_CSV_HEADER);
    s.push('\n');
    for (wavelength_nm, albedo, targeted, n) in rows {
        s.push_str(&format!(
            "{wavelength_nm},{albedo},{},{:.4e},{:.4e},{:.4e},{},{},{},{},{},{}\n",
            n.counted,
            n.median,
            n.p99,
            n.max,
            n.above,
            n.samples[0],
            n.samples[1],
            n.samples[2],
            u8::from(*targeted),
            n.image_rel_noise.map_or(String::new(), |r| format!("{r:.4e}"))
        ));
    }
    s
}

/// Header of the transmittance CSV (with `sqrt_T` appended when exported).
pub const TRANSMITTANCE_CSV_HEADER: &str = "wavelength_nm,altitude_km,distance_km,T,T_se,blocked";

/// The transmittance CSV of one task: one row per wavelength, altitude and
/// distance (in that nesting).
pub fn transmittance_csv(wavelengths_nm: &[f64], grid: &Grid, table: &TransmittanceTable, sqrt: bool) -> String {
    let mut s = String::from(TRANSMITTANCE_CSV_HEADER);
    s.push_str(if sqrt { ",sqrt_T\n" } else { "\n" });
    let n_d = grid.distances_km.len();
    for (w, lambda) in wavelengths_nm.iter().enumerate() {
        for (k, (&t, &se)) in table.t[w].iter().zip(&table.se[w]).enumerate() {
            let (a, d) = (grid.altitudes_km[k / n_d], grid.distances_km[k % n_d]);
            s.push_str(&format!(
                "{lambda},{a},{d},{t:.9e},{se:.4e},{}",
                u8::from(table.blocked[k])
            ));
            if sqrt {
                s.push_str(&format!(",{:.9e}", t.max(0.0).sqrt()));
            }
            s.push('\n');
        }
    }
    s
}

/// The transmittance EXR of one task: width = distance nodes, height =
/// altitude nodes (row 0 = the lowest altitude), channels `<λ>nm.T`,
/// `<λ>nm.T_se` (and `<λ>nm.sqrtT`) per wavelength and `blocked`.
pub fn write_transmittance_exr(
    path: &Path,
    wavelengths_nm: &[f64],
    grid: &Grid,
    table: &TransmittanceTable,
    sqrt: bool,
    attributes: &[(String, String)],
) -> Result<()> {
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let mut channels = Vec::new();
    for (w, lambda) in wavelengths_nm.iter().enumerate() {
        channels.push(Channel {
            name: format!("{}.T", wavelength_label(*lambda)),
            samples: f32s(&table.t[w]),
        });
        channels.push(Channel {
            name: format!("{}.T_se", wavelength_label(*lambda)),
            samples: f32s(&table.se[w]),
        });
        if sqrt {
            let r: Vec<f64> = table.t[w].iter().map(|t| t.max(0.0).sqrt()).collect();
            channels.push(Channel {
                name: format!("{}.sqrtT", wavelength_label(*lambda)),
                samples: f32s(&r),
            });
        }
    }
    channels.push(Channel {
        name: "blocked".into(),
        samples: table.blocked.iter().map(|&b| f32::from(u8::from(b))).collect(),
    });
    write_exr(
        path,
        grid.distances_km.len(),
        grid.altitudes_km.len(),
        channels,
        attributes,
    )
}
