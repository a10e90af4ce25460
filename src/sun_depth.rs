//! An approximate optical depth toward the sun from any point, for
//! sun-aware sampling of next-event points along a flight (`integrator`).
//! Only the efficiency of that sampling depends on it: every contribution
//! is weighted by its true value over the sampling density, and where the
//! table is only approximate the sampling is mixed with the flight's own
//! density, so that no weight can grow without bound (a sunlit point just
//! outside the shadow, between a blocked node and a sunlit one, gets a
//! depth near 60 from the table).
//!
//! - Plane-parallel: exact, τ_above(z)/μ0 (τ_above linear inside a layer).
//! - Spherical: bilinear in a table over the radius (the levels and their
//!   midpoints) and the cosine of the local solar zenith angle (129 nodes,
//!   denser near the horizon), each node an exact optical depth along the
//!   sun's direction; a ray into the planet gets a large finite depth.

use glam::DVec3;

use crate::medium::Medium;
use crate::shell::Geometry;
use crate::tracking::{self, Ray, WalkEnd};

/// Optical depth given to sun rays that hit the planet (the density must
/// stay positive where the table is only approximate).
const BLOCKED_DEPTH: f64 = 60.0;
const MU_NODES: usize = 129;

/// Approximate optical depth toward the sun.
#[derive(Debug, Clone)]
pub enum SunDepth {
    PlaneParallel {
        levels_km: Vec<f64>,
        tau_above: Vec<f64>,
        mu0: f64,
    },
    Spherical {
        radius_km: f64,
        altitudes_km: Vec<f64>,
        /// depth[altitude][mu node]
        depth: Vec<Vec<f64>>,
    },
}

/// The μ of node k: symmetric, quadratically denser toward μ = 0.
fn mu_node(k: usize) -> f64 {
    let x = 2.0 * k as f64 / (MU_NODES - 1) as f64 - 1.0;
    x * x.abs()
}

/// The fractional node index of μ (inverse of `mu_node`).
fn mu_index(mu: f64) -> f64 {
    let x = mu.signum() * mu.abs().sqrt();
    (x + 1.0) * 0.5 * (MU_NODES - 1) as f64
}

impl SunDepth {
    /// The table for `medium` and sun direction `sun` (observer frame).
    pub fn new(medium: &Medium, geometry: &Geometry, sun: DVec3) -> SunDepth {
        let levels = medium.levels_km().to_vec();
        match *geometry {
            Geometry::PlaneParallel => {
                let n = levels.len() - 1;
                let mut tau_above = vec![0.0; n + 1];
                for i in (0..n).rev() {
                    let z = 0.5 * (levels[i] + levels[i + 1]);
                    tau_above[i] = tau_above[i + 1] + medium.at(i, z).sigma_t * (levels[i + 1] - levels[i]);
                }
                SunDepth::PlaneParallel {
                    levels_km: levels,
                    tau_above,
                    mu0: sun.z,
                }
            }
            Geometry::Spherical { radius_km } => {
                let mut altitudes = Vec::with_capacity(2 * levels.len());
                for w in levels.windows(2) {
                    altitudes.push(w[0]);
                    altitudes.push(0.5 * (w[0] + w[1]));
                }
                altitudes.push(levels[levels.len() - 1]);
                let depth = altitudes
                    .iter()
                    .map(|&z| {
                        (0..MU_NODES)
                            .map(|k| {
                                let mu = mu_node(k);
                                let dir = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
                                match tracking::layer_at(&levels, z, mu) {
                                    None if mu >= 0.0 => 0.0,
                                    None => BLOCKED_DEPTH,
                                    Some(layer) => {
                                        let ray = Ray {
                                            origin: DVec3::new(0.0, 0.0, radius_km + z),
                                            dir,
                                            layer,
                                        };
                                        match tracking::optical_depth(medium, geometry, &ray) {
                                            (tau, WalkEnd::Top { .. }) => tau.min(BLOCKED_DEPTH),
                                            _ => BLOCKED_DEPTH,
                                        }
                                    }
                                }
                            })
                            .collect()
                    })
                    .collect();
                SunDepth::Spherical {
                    radius_km,
                    altitudes_km: altitudes,
                    depth,
                }
            }
        }
    }

    /// True where the depth is exact (plane-parallel geometry), so that
    /// sampling may follow it alone.
    pub fn is_exact(&self) -> bool {
        matches!(self, SunDepth::PlaneParallel { .. })
    }

    /// Approximate optical depth from `x` toward the sun along `sun`.
    pub fn at(&self, x: DVec3, sun: DVec3) -> f64 {
        match self {
            SunDepth::PlaneParallel {
                levels_km,
                tau_above,
                mu0,
            } => {
                if *mu0 <= 0.0 {
                    return BLOCKED_DEPTH;
                }
                let z = x.z.clamp(levels_km[0], levels_km[levels_km.len() - 1]);
                let i = levels_km.partition_point(|&l| l <= z).clamp(1, levels_km.len() - 1) - 1;
                let f = (z - levels_km[i]) / (levels_km[i + 1] - levels_km[i]);
                ((tau_above[i] + (tau_above[i + 1] - tau_above[i]) * f) / mu0).min(BLOCKED_DEPTH)
            }
            SunDepth::Spherical {
                radius_km,
                altitudes_km,
                depth,
            } => {
                let r = x.length();
                let mu = (x.dot(sun) / r).clamp(-1.0, 1.0);
                let z = (r - radius_km).clamp(altitudes_km[0], altitudes_km[altitudes_km.len() - 1]);
                let i = altitudes_km
                    .partition_point(|&a| a <= z)
                    .clamp(1, altitudes_km.len() - 1)
                    - 1;
                let fz = (z - altitudes_km[i]) / (altitudes_km[i + 1] - altitudes_km[i]);
                let m = mu_index(mu).clamp(0.0, (MU_NODES - 1) as f64);
                let k = (m as usize).min(MU_NODES - 2);
                let fm = m - k as f64;
                let at = |row: &Vec<f64>| row[k] + (row[k + 1] - row[k]) * fm;
                at(&depth[i]) + (at(&depth[i + 1]) - at(&depth[i])) * fz
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::Job;
    use crate::medium::MediumModel;
    use std::path::Path;

    #[test]
    fn table_tracks_the_exact_depth() {
        let text = "[spectrum]\nwavelengths_nm = [400.0]\n";
        let atm = Job::parse(text, "t", Path::new(".")).unwrap().atmosphere;
        let m = Medium::new(&atm, 0, MediumModel::Layered, 1.0);
        let g = Geometry::Spherical { radius_km: 6378.0 };
        for elev in [60.0f64, 10.0, 1.0] {
            let e = elev.to_radians();
            let sun = DVec3::new(e.cos(), 0.0, e.sin());
            let table = SunDepth::new(&m, &g, sun);
            for z in [0.3, 2.7, 13.0, 41.0] {
                let x = DVec3::new(0.0, 0.0, 6378.0 + z);
                let layer = tracking::layer_at(m.levels_km(), z, 1.0).unwrap();
                let (exact, _) = tracking::optical_depth(
                    &m,
                    &g,
                    &Ray {
                        origin: x,
                        dir: sun,
                        layer,
                    },
                );
                let approx = table.at(x, sun);
                assert!(
                    (approx - exact).abs() < 0.05 * exact + 1e-3,
                    "elev {elev} z {z}: {approx} vs {exact}"
                );
            }
        }
        assert!((mu_node(0) + 1.0).abs() < 1e-15 && (mu_node(MU_NODES - 1) - 1.0).abs() < 1e-15);
        for k in 0..MU_NODES {
            assert!((mu_index(mu_node(k)) - k as f64).abs() < 1e-9);
        }
    }
}
