//! A ray through the atmosphere's layers: its origin, direction and layer,
//! and the walk that visits its segment in each layer up to where it reaches
//! the ground or leaves through the top (in closed form through spherical
//! shells, or boundary by boundary).

use std::ops::ControlFlow;

use glam::DVec3;

use crate::geometry::shell::{Geometry, next_boundary};

/// A ray inside the atmosphere: origin, unit direction, and the layer the
/// origin is in (for an origin on a boundary: the layer the ray enters).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
    pub layer: usize,
}

/// The part of a ray inside one layer, t ∈ [t0, t1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub t0: f64,
    pub t1: f64,
    pub layer: usize,
}

/// How a walk along a ray ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WalkEnd {
    /// The ray hits the ground at distance t.
    Ground { t: f64 },
    /// The ray leaves through the top at distance t.
    Top { t: f64 },
    /// A horizontal ray in a plane-parallel layer: it never leaves it.
    Endless,
    /// The callback stopped the walk.
    Stopped,
}

/// Walks the layer segments of `ray` in order, calling `f` for each until it
/// returns `Break` or the ray reaches the ground or the top.
#[inline]
pub fn walk(geometry: &Geometry, levels_km: &[f64], ray: &Ray, f: impl FnMut(Segment) -> ControlFlow<()>) -> WalkEnd {
    match *geometry {
        Geometry::Spherical { radius_km } => walk_spherical(radius_km, levels_km, ray, f),
        Geometry::PlaneParallel => walk_stepwise(geometry, levels_km, ray, f),
    }
}

/// The general walk: one `next_boundary` query per segment from the
/// current point.
pub(crate) fn walk_stepwise(
    geometry: &Geometry,
    levels_km: &[f64],
    ray: &Ray,
    mut f: impl FnMut(Segment) -> ControlFlow<()>,
) -> WalkEnd {
    let top = levels_km.len() - 2;
    let mut t = 0.0;
    let mut layer = ray.layer;
    loop {
        let p = ray.origin + t * ray.dir;
        let Some(c) = next_boundary(geometry, levels_km, p, ray.dir, layer) else {
            return match f(Segment {
                t0: t,
                t1: f64::INFINITY,
                layer,
            }) {
                ControlFlow::Break(()) => WalkEnd::Stopped,
                ControlFlow::Continue(()) => WalkEnd::Endless,
            };
        };
        let t1 = t + c.t;
        if f(Segment { t0: t, t1, layer }).is_break() {
            return WalkEnd::Stopped;
        }
        layer = match cross(layer, c.boundary == layer, top, t1) {
            Ok(next) => next,
            Err(end) => return end,
        };
        t = t1;
    }
}

/// The layer entered after leaving `layer` downward (`down`) or upward at
/// distance `t1`, or how the walk ends (ground below layer 0, top above
/// layer `top`).
#[inline]
pub(crate) fn cross(layer: usize, down: bool, top: usize, t1: f64) -> Result<usize, WalkEnd> {
    match (down, layer) {
        (true, 0) => Err(WalkEnd::Ground { t: t1 }),
        (true, _) => Ok(layer - 1),
        (false, l) if l == top => Err(WalkEnd::Top { t: t1 }),
        (false, _) => Ok(layer + 1),
    }
}

/// The walk through concentric shells, with every crossing computed from
/// the ray's own invariants rather than from the moving point: b = o·d and
/// the distance h of the line from the centre (|o − b·d|, no cancellation).
/// Before the tangent point (t < −b) the ray descends and meets the shell of
/// radius r at t = (|o|² − r²)/(−b + √(r² − h²)) if h < r; after it, it
/// ascends and leaves the shell of radius r at t = −b + √(r² − h²) (or, for
/// b > 0, the equal (r² − |o|²)/(b + √(r² − h²))). Each form adds terms of
/// the same sign, so near-tangent rays keep their digits; the radicand is
/// factored as (r − h)(r + h). One square root per layer crossed.
pub(crate) fn walk_spherical(
    radius_km: f64,
    levels_km: &[f64],
    ray: &Ray,
    mut f: impl FnMut(Segment) -> ControlFlow<()>,
) -> WalkEnd {
    let top = levels_km.len() - 2;
    let o = ray.origin;
    let b = o.dot(ray.dir);
    let h = (o - b * ray.dir).length();
    let o_len = o.length();
    let radicand = |r: f64| (r - h) * (r + h);
    let mut layer = ray.layer;
    let mut descending = b < 0.0;
    let mut t = 0.0;
    loop {
        let (t1, down) = if descending {
            let r = radius_km + levels_km[layer];
            if h < r {
                let q = -b + radicand(r).sqrt();
                (((o_len - r) * (o_len + r) / q).max(t), true)
            } else {
                descending = false;
                continue;
            }
        } else {
            let r = radius_km + levels_km[layer + 1];
            let root = radicand(r).max(0.0).sqrt();
            let t1 = if b > 0.0 {
                (r - o_len) * (r + o_len) / (b + root)
            } else {
                -b + root
            };
            (t1.max(t), false)
        };
        if f(Segment { t0: t, t1, layer }).is_break() {
            return WalkEnd::Stopped;
        }
        layer = match cross(layer, down, top, t1) {
            Ok(next) => next,
            Err(end) => return end,
        };
        t = t1;
    }
}

/// The layer holding altitude `z_km`, for a ray going in direction `dir`
/// (`up_dot` = dir · up): a point exactly on a boundary belongs to the layer
/// the ray enters. `None` if the ray starts on the ground going down or at
/// the top going up (it is not in the atmosphere).
#[inline]
pub fn layer_at(levels_km: &[f64], z_km: f64, up_dot: f64) -> Option<usize> {
    let n = levels_km.len();
    let top = levels_km[n - 1];
    if z_km < levels_km[0] || z_km > top || (z_km == top && up_dot >= 0.0) || (z_km == levels_km[0] && up_dot < 0.0) {
        return None;
    }
    let i = levels_km.partition_point(|&l| l <= z_km); // first level above z
    let below = i.saturating_sub(1).min(n - 2);
    if levels_km[below] == z_km && up_dot < 0.0 {
        return Some(below - 1);
    }
    Some(below)
}

/// A tentative collision at distance `t` in `layer` against `sigma_maj`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Collision {
    pub t: f64,
    pub layer: usize,
    pub sigma_maj: f64,
}

/// A ray from altitude `z_km` above a 6378 km planet at `zenith_deg` in the
/// x–z plane, in its layer of `levels` (tests).
#[cfg(test)]
pub(crate) fn test_slant_ray(zenith_deg: f64, z_km: f64, levels: &[f64]) -> Ray {
    let th = zenith_deg.to_radians();
    let dir = DVec3::new(th.sin(), 0.0, th.cos());
    Ray {
        origin: DVec3::new(0.0, 0.0, 6378.0 + z_km),
        dir,
        layer: layer_at(levels, z_km, dir.z).expect("a point inside the atmosphere"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ops::ControlFlow;

    use glam::DVec3;

    use crate::geometry::shell::Geometry;

    use crate::sampling::sampler::Sampler;

    const R: f64 = 6378.0;

    #[test]
    fn spherical_walk_agrees_with_the_stepwise_walk() {
        // The same segments (to 1e-9 km) for rays from every layer in many
        // directions, limb rays included.
        let levels: Vec<f64> = (0..=40).map(|i| (i as f64 * 2.5f64).min(100.0)).collect();
        let g = Geometry::Spherical { radius_km: R };
        let mut s = Sampler::new(&[99]);
        for k in 0..2000 {
            let z = if k % 5 == 0 {
                levels[k % 40]
            } else {
                100.0 * s.next_f64()
            };
            let cos_t = if k % 7 == 0 {
                -0.05 * s.next_f64()
            } else {
                2.0 * s.next_f64() - 1.0
            };
            let dir = DVec3::new((1.0 - cos_t * cos_t).sqrt(), 0.0, cos_t);
            let Some(layer) = layer_at(&levels, z, cos_t) else {
                continue;
            };
            let ray = Ray {
                origin: DVec3::new(0.0, 0.0, R + z),
                dir,
                layer,
            };
            let mut a = Vec::new();
            let end_a = walk_spherical(R, &levels, &ray, |seg| {
                a.push(seg);
                ControlFlow::Continue(())
            });
            let mut b = Vec::new();
            let end_b = walk_stepwise(&g, &levels, &ray, |seg| {
                b.push(seg);
                ControlFlow::Continue(())
            });
            let (ta, tb) = match (end_a, end_b) {
                (WalkEnd::Top { t: x }, WalkEnd::Top { t: y })
                | (WalkEnd::Ground { t: x }, WalkEnd::Ground { t: y }) => (x, y),
                other => panic!("z {z} cos {cos_t}: ends differ {other:?}"),
            };
            assert!((ta - tb).abs() < 1e-9 * ta.max(1.0), "z {z} cos {cos_t}: {ta} vs {tb}");
            // Limb rays may differ by vanishing slivers at a tangent shell.
            let long_a: Vec<_> = a.iter().filter(|g| g.t1 - g.t0 > 1e-6).collect();
            let long_b: Vec<_> = b.iter().filter(|g| g.t1 - g.t0 > 1e-6).collect();
            assert_eq!(long_a.len(), long_b.len(), "z {z} cos {cos_t}");
            for (x, y) in long_a.iter().zip(&long_b) {
                assert_eq!(x.layer, y.layer);
                assert!((x.t1 - y.t1).abs() < 1e-9 * x.t1.max(1.0));
            }
        }
    }

    #[test]
    fn layer_lookup_on_and_between_boundaries() {
        let levels = [0.0, 1.0, 2.0, 5.0];
        assert_eq!(layer_at(&levels, 0.0, 1.0), Some(0));
        assert_eq!(layer_at(&levels, 0.0, -1.0), None);
        assert_eq!(layer_at(&levels, 1.0, 1.0), Some(1));
        assert_eq!(layer_at(&levels, 1.0, -1.0), Some(0));
        assert_eq!(layer_at(&levels, 3.0, -1.0), Some(2));
        assert_eq!(layer_at(&levels, 5.0, -1.0), Some(2));
        assert_eq!(layer_at(&levels, 5.0, 1.0), None);
    }
}
