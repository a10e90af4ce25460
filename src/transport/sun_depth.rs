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

use crate::geometry::ray::{Ray, WalkEnd};
use crate::geometry::shell::Geometry;
use crate::transport::medium::Medium;

/// Optical depth given to sun rays that hit the planet (the density must
/// stay positive where the table is only approximate).
pub const BLOCKED_DEPTH: f64 = 60.0;
const MU_NODES: usize = 129;

/// Approximate optical depth toward the sun. A table may hold several
/// extinction profiles at once (the basis of shared spectral paths),
/// interleaved so that one lookup reads them all.
#[derive(Debug, Clone)]
pub enum SunDepth {
    PlaneParallel {
        levels_km: Vec<f64>,
        /// tau_above[level · profiles + profile]
        tau_above: Vec<f64>,
        profiles: usize,
        mu0: f64,
        /// False in pseudo-spherical geometry, where the direct beam is
        /// attenuated along spherical shells and τ_above/μ0 is only an
        /// approximation of its depth.
        exact: bool,
    },
    Spherical {
        radius_km: f64,
        /// The levels and their midpoints: altitude node 2i is level i,
        /// 2i + 1 the middle of layer i.
        altitudes_km: Vec<f64>,
        /// depth[(altitude node · MU_NODES + mu node) · (profiles + 1) + j]:
        /// each profile's depth (0 where blocked), then 1 where the ray
        /// toward the sun meets the planet, else 0.
        depth: Vec<f64>,
        profiles: usize,
        /// Per layer, the square of its middle radius; per level, 1/radius
        /// (for points on a level, see [`SunDepth::at_end_in_layer`]).
        mid_radius_sq: Vec<f64>,
        inv_level_radius: Vec<f64>,
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
    /// The table for a piecewise-constant `medium` and sun direction `sun`
    /// (observer frame); `pseudo_spherical` when the direct beam is
    /// attenuated along spherical shells in an otherwise plane-parallel
    /// `geometry`.
    pub fn new(medium: &Medium, geometry: &Geometry, sun: DVec3, pseudo_spherical: bool) -> SunDepth {
        let levels = medium.levels_km();
        let sigma: Vec<f64> = levels
            .windows(2)
            .enumerate()
            .map(|(i, w)| medium.at(i, 0.5 * (w[0] + w[1])).sigma_t)
            .collect();
        SunDepth::of_profile(levels, &sigma, geometry, sun, pseudo_spherical)
    }

    /// The table for extinction `sigma` (per km, one value per layer of
    /// `levels_km`).
    pub fn of_profile(
        levels_km: &[f64],
        sigma: &[f64],
        geometry: &Geometry,
        sun: DVec3,
        pseudo_spherical: bool,
    ) -> SunDepth {
        SunDepth::of_profiles(levels_km, &[sigma.to_vec()], geometry, sun, pseudo_spherical)
    }

    /// One table for several extinction profiles (each per km, one value
    /// per layer): of the extinction terms per unit amount, whose depths
    /// combine linearly into any channel's.
    pub fn of_profiles(
        levels_km: &[f64],
        sigmas: &[Vec<f64>],
        geometry: &Geometry,
        sun: DVec3,
        pseudo_spherical: bool,
    ) -> SunDepth {
        let levels = levels_km.to_vec();
        let profiles = sigmas.len();
        match *geometry {
            Geometry::PlaneParallel => {
                let n = levels.len() - 1;
                let mut tau_above = vec![0.0; (n + 1) * profiles];
                for i in (0..n).rev() {
                    for (p, sigma) in sigmas.iter().enumerate() {
                        tau_above[i * profiles + p] =
                            tau_above[(i + 1) * profiles + p] + sigma[i] * (levels[i + 1] - levels[i]);
                    }
                }
                SunDepth::PlaneParallel {
                    levels_km: levels,
                    tau_above,
                    profiles,
                    mu0: sun.z,
                    exact: !pseudo_spherical,
                }
            }
            Geometry::Spherical { radius_km } => {
                let mut altitudes = Vec::with_capacity(2 * levels.len());
                for w in levels.windows(2) {
                    altitudes.push(w[0]);
                    altitudes.push(0.5 * (w[0] + w[1]));
                }
                altitudes.push(levels[levels.len() - 1]);
                let mut depth = Vec::with_capacity(altitudes.len() * MU_NODES * profiles);
                let mut tau = vec![0.0; profiles];
                for &z in &altitudes {
                    for k in 0..MU_NODES {
                        let mu = mu_node(k);
                        let dir = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
                        let blocked = |depth: &mut Vec<f64>| {
                            depth.extend(std::iter::repeat_n(0.0, profiles));
                            depth.push(1.0);
                        };
                        match crate::geometry::ray::layer_at(&levels, z, mu) {
                            None if mu >= 0.0 => depth.extend(std::iter::repeat_n(0.0, profiles + 1)),
                            None => blocked(&mut depth),
                            Some(layer) => {
                                let ray = Ray {
                                    origin: DVec3::new(0.0, 0.0, radius_km + z),
                                    dir,
                                    layer,
                                };
                                tau.fill(0.0);
                                let end = crate::geometry::ray::walk(geometry, &levels, &ray, |seg| {
                                    for (t, sigma) in tau.iter_mut().zip(sigmas) {
                                        *t += sigma[seg.layer] * (seg.t1 - seg.t0);
                                    }
                                    std::ops::ControlFlow::Continue(())
                                });
                                match end {
                                    WalkEnd::Top { .. } => {
                                        depth.extend_from_slice(&tau);
                                        depth.push(0.0);
                                    }
                                    _ => blocked(&mut depth),
                                }
                            }
                        }
                    }
                }
                SunDepth::Spherical {
                    radius_km,
                    mid_radius_sq: levels
                        .windows(2)
                        .map(|w| (radius_km + 0.5 * (w[0] + w[1])).powi(2))
                        .collect(),
                    inv_level_radius: levels.iter().map(|&z| 1.0 / (radius_km + z)).collect(),
                    altitudes_km: altitudes,
                    depth,
                    profiles,
                }
            }
        }
    }

    /// The number of extinction profiles in the table.
    pub fn profiles(&self) -> usize {
        match self {
            SunDepth::PlaneParallel { profiles, .. } | SunDepth::Spherical { profiles, .. } => *profiles,
        }
    }

    /// True where the depth is exact (plane-parallel geometry, direct beam
    /// attenuated in the slab), so that sampling may follow it alone.
    pub fn is_exact(&self) -> bool {
        matches!(self, SunDepth::PlaneParallel { exact: true, .. })
    }

    /// Approximate optical depth from `x` toward the sun along `sun`.
    pub fn at(&self, x: DVec3, sun: DVec3) -> f64 {
        let layers = match self {
            SunDepth::PlaneParallel { levels_km, .. } => levels_km.len() - 1,
            SunDepth::Spherical { altitudes_km, .. } => altitudes_km.len() / 2,
        };
        let z = self.altitude(x);
        let levels = |i: usize| match self {
            SunDepth::PlaneParallel { levels_km, .. } => levels_km[i],
            SunDepth::Spherical { altitudes_km, .. } => altitudes_km[2 * i],
        };
        let layer = (0..layers).find(|&i| z < levels(i + 1)).unwrap_or(layers - 1);
        self.at_in_layer(x, sun, layer)
    }

    /// [`SunDepth::at`] for a point `x` known to lie in (or on the
    /// boundary of) `layer`: no search over the altitudes. First profile.
    #[inline]
    pub fn at_in_layer(&self, x: DVec3, sun: DVec3, layer: usize) -> f64 {
        let mut out = [0.0; 2];
        self.at_in_layer_into(x, sun, layer, &mut out);
        SunDepth::combine(&[1.0], &out)
    }

    /// Profile `k`'s approximate depth from a lookup `values` (each
    /// profile's depth, then the blocked fraction): τ_k + 60·blocked, at
    /// most 60.
    #[inline]
    pub fn profile_depth(values: &[f64], k: usize) -> f64 {
        let p = values.len() - 1;
        (values[k].max(0.0) + BLOCKED_DEPTH * values[p]).min(BLOCKED_DEPTH)
    }

    /// A channel's approximate depth from a lookup `values` (each
    /// profile's depth, then the blocked fraction) and the channel's
    /// `weights` on the profiles: Σ w·τ + 60·blocked, at most 60 (the depth
    /// given to rays into the planet; the density must stay positive).
    #[inline]
    pub fn combine(weights: &[f64], values: &[f64]) -> f64 {
        let p = weights.len();
        let tau: f64 = weights.iter().zip(&values[..p]).map(|(w, t)| w * t).sum();
        (tau.max(0.0) + BLOCKED_DEPTH * values[p]).min(BLOCKED_DEPTH)
    }

    /// [`SunDepth::at_in_layer`] of every profile into `out` (profiles + 1
    /// values: each profile's depth, then the blocked fraction; see
    /// [`SunDepth::combine`]).
    #[inline]
    pub fn at_in_layer_into(&self, x: DVec3, sun: DVec3, layer: usize, out: &mut [f64]) {
        match self {
            SunDepth::PlaneParallel {
                levels_km,
                tau_above,
                mu0,
                profiles,
                ..
            } => {
                let p = *profiles;
                if *mu0 <= 0.0 {
                    out[..p].fill(0.0);
                    out[p] = 1.0;
                    return;
                }
                let i = layer.min(levels_km.len() - 2);
                let (z0, z1) = (levels_km[i], levels_km[i + 1]);
                let f = ((x.z - z0) / (z1 - z0)).clamp(0.0, 1.0);
                for (j, o) in out.iter_mut().enumerate().take(p) {
                    let (a, b) = (tau_above[i * p + j], tau_above[(i + 1) * p + j]);
                    *o = (a + (b - a) * f) / mu0;
                }
                out[p] = 0.0;
            }
            SunDepth::Spherical {
                radius_km,
                altitudes_km,
                depth,
                profiles,
                ..
            } => {
                let r = x.length();
                let mu = (x.dot(sun) / r).clamp(-1.0, 1.0);
                let z = r - radius_km;
                // Altitude nodes 2L (bottom), 2L + 1 (middle), 2L + 2 (top).
                let bottom = 2 * layer.min(altitudes_km.len() / 2 - 1);
                let i = if z < altitudes_km[bottom + 1] {
                    bottom
                } else {
                    bottom + 1
                };
                let (z0, z1) = (altitudes_km[i], altitudes_km[i + 1]);
                let fz = ((z - z0) / (z1 - z0)).clamp(0.0, 1.0);
                let m = mu_index(mu).clamp(0.0, (MU_NODES - 1) as f64);
                let k = (m as usize).min(MU_NODES - 2);
                let fm = m - k as f64;
                let stride = *profiles + 1;
                let row0 = (i * MU_NODES + k) * stride;
                let row1 = ((i + 1) * MU_NODES + k) * stride;
                for (j, o) in out.iter_mut().enumerate().take(stride) {
                    let d0 = depth[row0 + j] + (depth[row0 + stride + j] - depth[row0 + j]) * fm;
                    let d1 = depth[row1 + j] + (depth[row1 + stride + j] - depth[row1 + j]) * fm;
                    *o = d0 + (d1 - d0) * fz;
                }
            }
        }
    }

    /// [`SunDepth::at_in_layer`] for a point `x` on the bottom or top level
    /// of `layer` (the end of a flight's segment in it; the nearer level is
    /// taken): the table's row of that level, interpolated in μ only.
    /// First profile.
    #[inline]
    pub fn at_end_in_layer(&self, x: DVec3, sun: DVec3, layer: usize) -> f64 {
        let mut out = [0.0; 2];
        self.at_end_in_layer_into(x, sun, layer, &mut out);
        SunDepth::combine(&[1.0], &out)
    }

    /// [`SunDepth::at_end_in_layer`] of every profile into `out` (as
    /// [`SunDepth::at_in_layer_into`]).
    #[inline]
    pub fn at_end_in_layer_into(&self, x: DVec3, sun: DVec3, layer: usize, out: &mut [f64]) {
        match self {
            SunDepth::PlaneParallel { levels_km, .. } => {
                let i = layer.min(levels_km.len() - 2);
                let level = if 2.0 * x.z < levels_km[i] + levels_km[i + 1] {
                    i
                } else {
                    i + 1
                };
                self.at_in_layer_into(DVec3::new(x.x, x.y, levels_km[level]), sun, i, out)
            }
            SunDepth::Spherical {
                depth,
                mid_radius_sq,
                inv_level_radius,
                profiles,
                ..
            } => {
                let i = layer.min(mid_radius_sq.len() - 1);
                let level = if x.length_squared() < mid_radius_sq[i] {
                    i
                } else {
                    i + 1
                };
                let mu = (x.dot(sun) * inv_level_radius[level]).clamp(-1.0, 1.0);
                let m = mu_index(mu).clamp(0.0, (MU_NODES - 1) as f64);
                let k = (m as usize).min(MU_NODES - 2);
                let fm = m - k as f64;
                let stride = *profiles + 1;
                let row = (2 * level * MU_NODES + k) * stride;
                for (j, o) in out.iter_mut().enumerate().take(stride) {
                    *o = depth[row + j] + (depth[row + stride + j] - depth[row + j]) * fm;
                }
            }
        }
    }

    /// The altitude of `x` in the table's geometry.
    fn altitude(&self, x: DVec3) -> f64 {
        match self {
            SunDepth::PlaneParallel { .. } => x.z,
            SunDepth::Spherical { radius_km, .. } => x.length() - radius_km,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::Job;
    use crate::job::options::MediumModel;
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
            let table = SunDepth::new(&m, &g, sun, false);
            for z in [0.3, 2.7, 13.0, 41.0] {
                let x = DVec3::new(0.0, 0.0, 6378.0 + z);
                let layer = crate::geometry::ray::layer_at(m.levels_km(), z, 1.0).unwrap();
                let (exact, _) = crate::transport::optical_depth::optical_depth(
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

    /// The depth toward the sun, exactly: 0 outside the atmosphere, ∞ into
    /// the planet.
    fn exact_depth(m: &Medium, g: &Geometry, x: DVec3, sun: DVec3, radius_km: f64) -> f64 {
        let z = x.length() - radius_km;
        match crate::geometry::ray::layer_at(m.levels_km(), z, x.normalize().dot(sun)) {
            None => 0.0,
            Some(layer) => match crate::transport::optical_depth::optical_depth(
                m,
                g,
                &Ray {
                    origin: x,
                    dir: sun,
                    layer,
                },
            ) {
                (tau, WalkEnd::Top { .. }) => tau,
                _ => f64::INFINITY,
            },
        }
    }

    #[test]
    fn points_on_levels_read_the_same_from_either_layer() {
        let text = "[spectrum]\nwavelengths_nm = [620.0]\n";
        let atm = Job::parse(text, "t", Path::new(".")).unwrap().atmosphere;
        let m = Medium::new(&atm, 0, MediumModel::Layered, 1.0);
        let radius = 6378.0;
        let e = (-2.0f64).to_radians();
        let sun = DVec3::new(e.cos(), 0.0, e.sin());
        for (g, table) in [
            (
                Geometry::Spherical { radius_km: radius },
                SunDepth::new(&m, &Geometry::Spherical { radius_km: radius }, sun, false),
            ),
            (
                Geometry::PlaneParallel,
                SunDepth::new(&m, &Geometry::PlaneParallel, DVec3::new(0.6, 0.0, 0.8), false),
            ),
        ] {
            let sun = if matches!(g, Geometry::PlaneParallel) {
                DVec3::new(0.6, 0.0, 0.8)
            } else {
                sun
            };
            let levels = m.levels_km();
            for (i, &z) in levels.iter().enumerate() {
                for angle in [-40.0f64, -3.0, 0.0, 1.0, 2.5, 30.0, 120.0] {
                    let a = angle.to_radians();
                    let x = match g {
                        Geometry::Spherical { .. } => (radius + z) * DVec3::new(a.sin(), 0.0, a.cos()),
                        Geometry::PlaneParallel => DVec3::new(angle, 0.0, z),
                    };
                    let general = table.at_in_layer(x, sun, i.min(levels.len() - 2));
                    for layer in [i.saturating_sub(1), i.min(levels.len() - 2)] {
                        let end = table.at_end_in_layer(x, sun, layer);
                        assert!(
                            (end - general).abs() <= 1e-9 * (1.0 + general),
                            "level {i} angle {angle}: {end} vs {general}"
                        );
                    }
                }
            }
        }
    }

    /// The cause of the twilight bias of sun-aware connections: near the
    /// edge of the Earth's shadow the table interpolates between a node
    /// whose ray to the sun is blocked (depth 60) and a sunlit one, and
    /// overstates the depth of sunlit points by tens. A density following
    /// the table alone then draws those points e^(tens) times too rarely;
    /// hence the defensive mixture in spherical geometry (`is_exact`).
    #[test]
    fn the_table_overstates_the_depth_just_outside_the_shadow() {
        let text = "[spectrum]\nwavelengths_nm = [620.0]\n";
        let atm = Job::parse(text, "t", Path::new(".")).unwrap().atmosphere;
        let m = Medium::new(&atm, 0, MediumModel::Layered, 1.0);
        let radius = 6378.0;
        let g = Geometry::Spherical { radius_km: radius };
        let e = (-2.0f64).to_radians();
        let sun = DVec3::new(e.cos(), 0.0, e.sin());
        let table = SunDepth::new(&m, &g, sun, false);
        assert!(!table.is_exact());
        let (mut worst, mut at) = (0.0f64, (0.0, 0.0, 0.0, 0.0));
        for iz in 0..200 {
            let z = 0.25 + 0.5 * iz as f64;
            // Points around the terminator: solar zenith 80°–100°.
            for ia in 0..2000 {
                // The sun is 92° from +z: a point at polar angle 92° − ζ
                // in its plane sees it at solar zenith ζ.
                let a = (92.0 - (80.0 + 0.01 * ia as f64)).to_radians();
                let x = (radius + z) * DVec3::new(a.sin(), 0.0, a.cos());
                let exact = exact_depth(&m, &g, x, sun, radius);
                if exact.is_finite() && exact < 10.0 {
                    let over = table.at(x, sun) - exact;
                    if over > worst {
                        (worst, at) = (over, (z, 80.0 + 0.01 * ia as f64, table.at(x, sun), exact));
                    }
                }
            }
        }
        eprintln!(
            "largest overstatement of a sunlit point's depth: {worst:.1} at z {:.2} km, solar zenith {:.2}° (table {:.2}, exact {:.3})",
            at.0, at.1, at.2, at.3
        );
        assert!(
            worst > 10.0,
            "the table is now close to exact at the shadow's edge ({worst}): revisit SUN_AWARE_SHARE"
        );
    }

    #[test]
    fn profiles_combine_linearly_whatever_their_units() {
        // Shared paths tabulate each extinction term per unit amount (an
        // ozone column in molecules per cm² is ~1e19) and weight it per
        // channel: a profile scaled by 1e19 and weighted by 1e-19 reads as
        // the profile itself, sunlit or blocked, in either geometry.
        let text = "[spectrum]\nwavelengths_nm = [340.0]\n";
        let atm = Job::parse(text, "t", Path::new(".")).unwrap().atmosphere;
        let m = Medium::new(&atm, 0, MediumModel::Layered, 1.0);
        let levels = m.levels_km();
        let sigma: Vec<f64> = (0..levels.len() - 1)
            .map(|i| m.at(i, 0.5 * (levels[i] + levels[i + 1])).sigma_t)
            .collect();
        let scaled: Vec<f64> = sigma.iter().map(|s| s * 1e19).collect();
        let radius = 6378.0;
        for (g, elevation) in [
            (Geometry::Spherical { radius_km: radius }, -2.0f64),
            (Geometry::Spherical { radius_km: radius }, 5.0),
            (Geometry::PlaneParallel, 30.0),
            (Geometry::PlaneParallel, -1.0),
        ] {
            let e = elevation.to_radians();
            let sun = DVec3::new(e.cos(), 0.0, e.sin());
            let one = SunDepth::of_profile(levels, &sigma, &g, sun, false);
            let both = SunDepth::of_profiles(levels, &[scaled.clone(), sigma.clone()], &g, sun, false);
            assert_eq!(both.profiles(), 2);
            for (i, &z) in levels.iter().enumerate().take(levels.len() - 1) {
                for angle in [-4.0f64, 0.0, 3.0, 60.0] {
                    let a = angle.to_radians();
                    let x = match g {
                        Geometry::Spherical { .. } => (radius + z + 0.3) * DVec3::new(a.sin(), 0.0, a.cos()),
                        Geometry::PlaneParallel => DVec3::new(angle, 0.0, z + 0.3),
                    };
                    let expect = one.at_in_layer(x, sun, i);
                    let mut v = [0.0; 3];
                    both.at_in_layer_into(x, sun, i, &mut v);
                    let scaled_only = SunDepth::combine(&[1e-19, 0.0], &v);
                    let unscaled_only = SunDepth::combine(&[0.0, 1.0], &v);
                    for got in [scaled_only, unscaled_only] {
                        assert!(
                            (got - expect).abs() <= 1e-9 * (1.0 + expect),
                            "{g:?} elevation {elevation} level {i} angle {angle}: {got} vs {expect}"
                        );
                    }
                }
            }
        }
    }
}
