//! The transmittance of a dataset against tables of `atmosim transmittance`
//! on any nodes: on the fitted `sky_model` nodes, or elsewhere (a
//! `closed` layout or explicit nodes) to see the interpolation. Each
//! visible table point (altitude a, ground distance d) is asked of the
//! runtime as a view from the table's observer toward it, at its distance.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::film::quantile::quantile;
use crate::io::exr::{read_exr, wavelength_label};
use crate::skymodel::angles::PLANET_RADIUS_M;
use crate::skymodel::runtime::{Model, Parameters};

/// The largest |T_dataset − T_table| over the visible points of every
/// table under `dir`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TransmittanceError {
    pub max_abs: f64,
    /// The 99th percentile and the mean of |ΔT| over the points: where the
    /// largest error is one feature the node layout cannot follow (the
    /// step of an aerosol layer's top), these say how the rest fares.
    pub p99_abs: f64,
    pub mean_abs: f64,
    /// Points compared.
    pub points: usize,
    /// Where the largest error is.
    pub worst_at: String,
}

/// Compares the dataset with every table under `dir`.
pub fn max_abs_error(model: &Model, dir: &Path) -> Result<TransmittanceError> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path().join("transmittance.exr")))
        .filter(|p| p.is_file())
        .collect();
    if dir.join("transmittance.exr").is_file() {
        paths.push(dir.join("transmittance.exr"));
    }
    paths.sort();
    let (mut worst, mut count, mut at) = (0.0f64, 0usize, String::new());
    let mut errors: Vec<f64> = Vec::new();
    let axes = &model.dataset().axes;
    for path in &paths {
        let name = path.display().to_string();
        let exr = read_exr(path)?;
        let attr = |k: &str| -> Result<Vec<f64>> {
            let text = exr
                .attributes
                .iter()
                .find(|(a, _)| a == k)
                .map(|(_, v)| v.clone())
                .ok_or_else(|| Error::data(&name, format!("no `{k}` attribute")))?;
            text.split_whitespace()
                .map(|v| v.parse().map_err(|_| Error::data(&name, format!("`{k}` holds {v:?}"))))
                .collect()
        };
        let (altitudes, distances) = (attr("altitudes_km")?, attr("distances_km")?);
        let observer_m = attr("observer_altitude_km")?[0] * 1000.0;
        let visibility = attr("visibility_km").map(|v| v[0]).unwrap_or(0.0);
        let blocked = &exr
            .channels
            .iter()
            .find(|c| c.name == "blocked")
            .ok_or_else(|| Error::data(&name, "no `blocked` channel"))?
            .samples;
        for c in 0..axes.channels {
            let lambda = axes.channel_start_nm + (c as f64 + 0.5) * axes.channel_width_nm;
            let Some(t) = exr
                .channels
                .iter()
                .find(|ch| ch.name == format!("{}.T", wavelength_label(lambda)))
            else {
                continue;
            };
            for (i, &a) in altitudes.iter().enumerate() {
                for (j, &d) in distances.iter().enumerate() {
                    let k = i * distances.len() + j;
                    if blocked[k] > 0.5 || (i == 0 && j == 0) {
                        continue;
                    }
                    // The point in the observer's vertical plane, the
                    // planet's centre at the origin.
                    let (r_p, angle) = (PLANET_RADIUS_M + a * 1000.0, d * 1000.0 / PLANET_RADIUS_M);
                    let (px, py) = (r_p * angle.sin(), r_p * angle.cos());
                    let (dx, dy) = (px, py - (PLANET_RADIUS_M + observer_m));
                    let distance = dx.hypot(dy);
                    if distance <= 0.0 {
                        continue;
                    }
                    let theta = (dy / distance).clamp(-1.0, 1.0).acos();
                    let p = Parameters {
                        theta,
                        gamma: 0.0,
                        shadow: 0.0,
                        zero: theta,
                        elevation: 0.0,
                        altitude_m: observer_m,
                        visibility_km: visibility,
                        albedo: 0.0,
                    };
                    let fitted = model.transmittance(&p, lambda, distance);
                    let e = (fitted - t.samples[k] as f64).abs();
                    errors.push(e);
                    if e > worst {
                        worst = e;
                        at = format!(
                            "observer {observer_m} m, visibility {visibility} km, point at {a} km altitude and \
                             {d} km ground distance, {lambda} nm: dataset {fitted:.4}, table {:.4}",
                            t.samples[k]
                        );
                    }
                    count += 1;
                }
            }
        }
    }
    if count == 0 {
        return Err(Error::data(
            dir.display().to_string(),
            "no transmittance table with the dataset's channels",
        ));
    }
    let (p99_abs, mean_abs) = percentile_and_mean(&mut errors, 0.99);
    Ok(TransmittanceError {
        max_abs: worst,
        p99_abs,
        mean_abs,
        points: count,
        worst_at: at,
    })
}

/// The `q`-quantile of `values` (the nearest rank, after sorting them in
/// place) and their mean; `values` must not be empty.
fn percentile_and_mean(values: &mut [f64], q: f64) -> (f64, f64) {
    (quantile(values, q), values.iter().sum::<f64>() / values.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_99th_percentile_leaves_out_the_largest_hundredth() {
        // 0, 1, …, 100 shuffled: the 0.99-quantile is 99, the mean 50.
        let mut v: Vec<f64> = (0..=100).map(|k| ((k * 37) % 101) as f64).collect();
        assert_eq!(percentile_and_mean(&mut v, 0.99), (99.0, 50.0));
        assert_eq!(percentile_and_mean(&mut [7.0], 0.99), (7.0, 7.0));
    }
}
