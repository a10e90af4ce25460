//! `atmosim eval DATASET --queries Q.csv`: rows of the runtime's API
//! arguments in, the same rows out with what the runtime returns appended.
//!
//! Input columns (a header row naming them, in any order; other columns are
//! carried through): `view_x_m, view_y_m, view_z_m` (the view point in the
//! runtime's frame, z up, the ground at z = 0), `dir_x, dir_y, dir_z` (the
//! view direction, any length > 0), `sun_elevation_deg, sun_azimuth_deg`
//! (at the origin), `visibility_km`, `albedo`, `wavelength_nm` and
//! `distance_m` (for the transmittance along the direction; `inf` for the
//! whole way). Output: the input row with `sky_radiance, sun_radiance,
//! polarisation, transmittance` appended (polarisation empty for a dataset
//! without it).

use glam::DVec3;

use super::runtime::{Model, Parameters};
use crate::error::{Error, Result};

/// The input columns, in the order the runtime's API takes them.
pub const COLUMNS: [&str; 12] = [
    "view_x_m",
    "view_y_m",
    "view_z_m",
    "dir_x",
    "dir_y",
    "dir_z",
    "sun_elevation_deg",
    "sun_azimuth_deg",
    "visibility_km",
    "albedo",
    "wavelength_nm",
    "distance_m",
];

/// The appended columns.
pub const RESULTS: [&str; 4] = ["sky_radiance", "sun_radiance", "polarisation", "transmittance"];

/// Answers every row of the CSV `text` (`name` names it in errors); the
/// whole input is checked before the first answer.
pub fn answer(model: &Model, text: &str, name: &str) -> Result<String> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
    let (_, header) = lines.next().ok_or_else(|| {
        Error::data(
            name,
            format!("empty: a header row with {} is needed", COLUMNS.join(",")),
        )
    })?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut index = [0usize; 12];
    for (k, c) in COLUMNS.iter().enumerate() {
        index[k] = names.iter().position(|n| n == c).ok_or_else(|| {
            Error::data(
                name,
                format!("no column `{c}` in the header (needed: {})", COLUMNS.join(",")),
            )
        })?;
    }
    let mut rows = Vec::new();
    for (line_no, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(Error::data(
                name,
                format!(
                    "line {}: {} values for {} columns",
                    line_no + 1,
                    cells.len(),
                    names.len()
                ),
            ));
        }
        let mut v = [0.0; 12];
        for (k, &i) in index.iter().enumerate() {
            let parsed: f64 = cells[i].parse().map_err(|_| {
                Error::data(
                    name,
                    format!(
                        "line {}: `{}` = {:?} is not a number",
                        line_no + 1,
                        COLUMNS[k],
                        cells[i]
                    ),
                )
            })?;
            v[k] = parsed;
        }
        check(&v).map_err(|message| Error::data(name, format!("line {}: {message}", line_no + 1)))?;
        rows.push((line.to_string(), v));
    }
    let mut out = format!("{},{}\n", header.trim_end(), RESULTS.join(","));
    for (line, v) in rows {
        let (params, lambda, distance) = parameters(&v);
        let polarisation = model
            .polarisation(&params, lambda)
            .map_or(String::new(), |p| format!("{p:.9e}"));
        out.push_str(&format!(
            "{},{:.9e},{:.9e},{},{:.9e}\n",
            line.trim_end(),
            model.sky_radiance(&params, lambda),
            model.sun_radiance(&params, lambda),
            polarisation,
            model.transmittance(&params, lambda, distance)
        ));
    }
    Ok(out)
}

/// Checks one query, its values in the order of [`COLUMNS`]: every value
/// finite (`distance_m` > 0, `inf` for the whole way), the direction not
/// the zero vector, the view point not below the ground, the albedo in 0
/// to 1 and the visibility not negative. The message names the column.
pub fn check(v: &[f64; 12]) -> std::result::Result<(), String> {
    for (k, &x) in v.iter().enumerate() {
        let ok = match k {
            11 => x > 0.0 && !x.is_nan(),
            _ => x.is_finite(),
        };
        if !ok {
            return Err(format!(
                "`{}` = {x}: {}",
                COLUMNS[k],
                if k == 11 {
                    "must be > 0 (inf for the whole way)"
                } else {
                    "must be finite"
                }
            ));
        }
    }
    if DVec3::new(v[3], v[4], v[5]).length() == 0.0 {
        return Err("the direction is the zero vector".into());
    }
    if v[2] < 0.0 {
        return Err(format!("`view_z_m` = {} is below the ground", v[2]));
    }
    if !(0.0..=1.0).contains(&v[9]) {
        return Err(format!("`albedo` = {} is outside 0 to 1", v[9]));
    }
    if v[8] < 0.0 {
        return Err(format!("`visibility_km` = {} is negative", v[8]));
    }
    Ok(())
}

/// The runtime's arguments of one query that passed [`check`] (values in
/// the order of [`COLUMNS`]): its parameters, the wavelength (nm) and the
/// distance for the transmittance (m; `inf`, the whole way, as `f64::MAX`).
pub fn parameters(v: &[f64; 12]) -> (Parameters, f64, f64) {
    let params = Parameters::new(
        DVec3::new(v[0], v[1], v[2]),
        DVec3::new(v[3], v[4], v[5]),
        v[6].to_radians(),
        v[7].to_radians(),
        v[8],
        v[9],
    );
    let distance = if v[11].is_infinite() { f64::MAX } else { v[11] };
    (params, v[10], distance)
}
