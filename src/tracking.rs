//! Free flight along a ray through the layers: one routine that walks the
//! layer segments of a ray ([`walk`]) and one that samples tentative
//! collisions against the per-layer majorant ([`sample_t_maj`], after
//! pbrt-v4's `SampleT_maj`). Delta tracking, ratio tracking and analytic
//! transmittance are uses of these two, not copies:
//!
//! - [`delta_track`]: distance to the next real collision (accept a tentative
//!   collision with probability σ_t/σ_maj);
//! - [`ratio_tracking_transmittance`]: T = Π (1 − σ_t/σ_maj) over the
//!   tentative collisions (Novák et al. 2014);
//! - [`analytic_transmittance`]: exp(−Σ τ_segment) with exact (layered) or
//!   quadrature (smooth) segment optical depths.
//!
//! A ray that reaches the ground ends there; one that reaches the top leaves
//! the atmosphere.

use std::ops::ControlFlow;

use glam::DVec3;

use crate::medium::Medium;
use crate::sampler::Sampler;
use crate::shell::{Geometry, next_boundary};

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
pub fn walk(geometry: &Geometry, levels_km: &[f64], ray: &Ray, f: impl FnMut(Segment) -> ControlFlow<()>) -> WalkEnd {
    match *geometry {
        Geometry::Spherical { radius_km } => walk_spherical(radius_km, levels_km, ray, f),
        Geometry::PlaneParallel => walk_stepwise(geometry, levels_km, ray, f),
    }
}

/// The general walk: one `next_boundary` query per segment from the
/// current point.
fn walk_stepwise(
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
fn cross(layer: usize, down: bool, top: usize, t1: f64) -> Result<usize, WalkEnd> {
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
fn walk_spherical(
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

/// A tentative collision at distance `t` in `layer` against `sigma_maj`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Collision {
    pub t: f64,
    pub layer: usize,
    pub sigma_maj: f64,
}

/// How a free flight ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FlightEnd {
    /// The callback accepted this collision.
    Collided(Collision),
    Ground {
        t: f64,
    },
    Top {
        t: f64,
    },
    /// Horizontal plane-parallel ray in an empty layer.
    Endless,
}

/// Samples tentative collisions with density σ_maj along `ray`, calling
/// `on_collision` at each; it returns `true` to go on (a null collision) or
/// `false` to stop there. Exponential free paths are drawn from `sampler`;
/// the optical depth left over at a layer boundary carries into the next
/// layer (memorylessness), so one variate is used per tentative collision.
pub fn sample_t_maj(
    medium: &Medium,
    geometry: &Geometry,
    ray: &Ray,
    sampler: &mut Sampler,
    mut on_collision: impl FnMut(&Collision, &mut Sampler) -> bool,
) -> FlightEnd {
    let mut tau_left = -(1.0 - sampler.next_f64()).ln();
    let mut hit = None;
    let end = walk(geometry, medium.levels_km(), ray, |seg| {
        let sigma = medium.sigma_maj(seg.layer);
        if sigma <= 0.0 {
            return ControlFlow::Continue(());
        }
        let mut t0 = seg.t0;
        loop {
            let t = t0 + tau_left / sigma;
            if t >= seg.t1 {
                tau_left -= sigma * (seg.t1 - t0);
                return ControlFlow::Continue(());
            }
            let c = Collision {
                t,
                layer: seg.layer,
                sigma_maj: sigma,
            };
            if !on_collision(&c, sampler) {
                hit = Some(c);
                return ControlFlow::Break(());
            }
            t0 = t;
            tau_left = -(1.0 - sampler.next_f64()).ln();
        }
    });
    match (hit, end) {
        (Some(c), _) => FlightEnd::Collided(c),
        (None, WalkEnd::Ground { t }) => FlightEnd::Ground { t },
        (None, WalkEnd::Top { t }) => FlightEnd::Top { t },
        (None, _) => FlightEnd::Endless,
    }
}

/// Delta tracking: the next real collision along `ray`, or where the ray
/// leaves the atmosphere.
pub fn delta_track(medium: &Medium, geometry: &Geometry, ray: &Ray, sampler: &mut Sampler) -> FlightEnd {
    sample_t_maj(medium, geometry, ray, sampler, |c, s| {
        if medium.is_exact_majorant(c.layer) {
            return false;
        }
        let z = geometry.altitude(ray.origin + c.t * ray.dir);
        let p_real = medium.at(c.layer, z).sigma_t / c.sigma_maj;
        s.next_f64() >= p_real
    })
}

/// A free flight with forced collisions: where the flight ends and the
/// weight the path carries for it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForcedFlight {
    pub end: FlightEnd,
    pub weight: f64,
    /// The probability 1 − e^(−τ) the collision was forced with (`None`
    /// for an analog flight): distances for further points with the same
    /// distribution come from [`forced_distance`].
    pub forced_probability: Option<f64>,
}

/// Collision sampling with forced collisions in a piecewise-constant medium
/// (Cashwell & Everett 1959; Mayer 2009 uses it in MYSTIC): when the end of
/// the ray contributes nothing (it leaves through the top, or hits a black
/// ground: `ground_counts = false`), the collision distance is drawn from
/// the exponential truncated to the ray's optical depth τ and the path
/// carries the weight 1 − e^(−τ), so every path scatters. Otherwise the
/// flight is analog (the same distribution as delta tracking). The layer
/// segments of the ray are walked once into `segments` (a reusable buffer).
pub fn forced_flight(
    medium: &Medium,
    geometry: &Geometry,
    ray: &Ray,
    sampler: &mut Sampler,
    ground_counts: bool,
    segments: &mut Vec<(Segment, f64)>,
) -> ForcedFlight {
    segments.clear();
    let mut tau_exit = 0.0;
    let end = walk(geometry, medium.levels_km(), ray, |seg| {
        let tau = if seg.t1.is_infinite() {
            if medium.sigma_maj(seg.layer) > 0.0 {
                f64::INFINITY
            } else {
                0.0
            }
        } else {
            medium.sigma_maj(seg.layer) * (seg.t1 - seg.t0)
        };
        tau_exit += tau;
        segments.push((seg, tau));
        ControlFlow::Continue(())
    });
    let u = sampler.next_f64();
    let (tau_target, weight, forced_probability) = match end {
        WalkEnd::Ground { t } if ground_counts => {
            let tau = -(1.0 - u).ln();
            if tau >= tau_exit {
                return ForcedFlight {
                    end: FlightEnd::Ground { t },
                    weight: 1.0,
                    forced_probability: None,
                };
            }
            (tau, 1.0, None)
        }
        _ => {
            if tau_exit <= 0.0 {
                let end = match end {
                    WalkEnd::Ground { t } => FlightEnd::Ground { t },
                    WalkEnd::Top { t } => FlightEnd::Top { t },
                    _ => FlightEnd::Endless,
                };
                return ForcedFlight {
                    end,
                    weight: 1.0,
                    forced_probability: None,
                };
            }
            // P(collide before the end) = 1 − e^(−τ), computed without cancellation.
            let p = -(-tau_exit).exp_m1();
            (forced_distance(u, p), p, Some(p))
        }
    };
    ForcedFlight {
        end: FlightEnd::Collided(locate(medium, segments, tau_target)),
        weight,
        forced_probability,
    }
}

/// The point at optical depth `tau_target` along the walked `segments`.
pub fn locate(medium: &Medium, segments: &[(Segment, f64)], tau_target: f64) -> Collision {
    let mut acc = 0.0;
    for &(seg, tau) in segments {
        if acc + tau >= tau_target {
            let sigma = medium.sigma_maj(seg.layer);
            let t = (seg.t0 + (tau_target - acc) / sigma).min(seg.t1);
            return Collision {
                t,
                layer: seg.layer,
                sigma_maj: sigma,
            };
        }
        acc += tau;
    }
    // Rounding left the target just beyond the last segment: its end.
    let (seg, _) = segments[segments.len() - 1];
    Collision {
        t: seg.t1,
        layer: seg.layer,
        sigma_maj: medium.sigma_maj(seg.layer),
    }
}

/// The optical depth of a forced collision for the uniform variate `u`,
/// with forcing probability `p` = 1 − e^(−τ_exit): the inverse of the
/// truncated exponential.
pub fn forced_distance(u: f64, p: f64) -> f64 {
    -(-u * p).ln_1p()
}

/// Ratio-tracking estimate of the transmittance from the ray's origin to
/// where it leaves through the top (0 if it hits the ground).
pub fn ratio_tracking_transmittance(medium: &Medium, geometry: &Geometry, ray: &Ray, sampler: &mut Sampler) -> f64 {
    let mut tr = 1.0;
    let end = sample_t_maj(medium, geometry, ray, sampler, |c, _| {
        let z = geometry.altitude(ray.origin + c.t * ray.dir);
        tr *= 1.0 - medium.at(c.layer, z).sigma_t / c.sigma_maj;
        tr > 0.0
    });
    match end {
        FlightEnd::Top { .. } => tr,
        _ => 0.0,
    }
}

/// Optical depth from the ray's origin to the top, and how the walk ended
/// (a ray that hits the ground returns its optical depth to the ground).
pub fn optical_depth(medium: &Medium, geometry: &Geometry, ray: &Ray) -> (f64, WalkEnd) {
    let mut tau = 0.0;
    let end = walk(geometry, medium.levels_km(), ray, |seg| {
        if seg.t1.is_infinite() {
            tau = if medium.sigma_maj(seg.layer) > 0.0 {
                f64::INFINITY
            } else {
                tau
            };
        } else {
            tau += medium.segment_optical_depth(geometry, ray.origin, ray.dir, seg.layer, seg.t0, seg.t1);
        }
        ControlFlow::Continue(())
    });
    (tau, end)
}

/// Optical depth along `ray` from its origin to distance `length` (km).
pub fn optical_depth_to(medium: &Medium, geometry: &Geometry, ray: &Ray, length: f64) -> f64 {
    let mut tau = 0.0;
    walk(geometry, medium.levels_km(), ray, |seg| {
        let t1 = seg.t1.min(length);
        if t1 > seg.t0 {
            tau += medium.segment_optical_depth(geometry, ray.origin, ray.dir, seg.layer, seg.t0, t1);
        }
        if seg.t1 >= length {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    tau
}

/// Exact transmittance from the ray's origin to the top (0 if the ray hits
/// the ground).
pub fn analytic_transmittance(medium: &Medium, geometry: &Geometry, ray: &Ray) -> f64 {
    match optical_depth(medium, geometry, ray) {
        (tau, WalkEnd::Top { .. }) => (-tau).exp(),
        (tau, WalkEnd::Endless) => (-tau).exp(),
        _ => 0.0,
    }
}

/// The layer holding altitude `z_km`, for a ray going in direction `dir`
/// (`up_dot` = dir · up): a point exactly on a boundary belongs to the layer
/// the ray enters. `None` if the ray starts on the ground going down or at
/// the top going up (it is not in the atmosphere).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::Job;
    use crate::medium::MediumModel;
    use std::path::Path;

    const R: f64 = 6378.0;

    fn medium(model: MediumModel, scale: f64) -> Medium {
        let text = "[atmosphere]\naerosol = \"continental_average\"\n[spectrum]\nwavelengths_nm = [340.0]\n";
        let atm = Job::parse(text, "t", Path::new(".")).unwrap().atmosphere;
        Medium::new(&atm, 0, model, scale)
    }

    fn slant_ray(zenith_deg: f64, z_km: f64, levels: &[f64]) -> Ray {
        let th = zenith_deg.to_radians();
        let dir = DVec3::new(th.sin(), 0.0, th.cos());
        Ray {
            origin: DVec3::new(0.0, 0.0, R + z_km),
            dir,
            layer: layer_at(levels, z_km, dir.z).unwrap(),
        }
    }

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

    #[test]
    fn analytic_vertical_optical_depth_is_the_column() {
        let m = medium(MediumModel::Layered, 1.0);
        let ray = slant_ray(0.0, 0.0, m.levels_km());
        let (tau, end) = optical_depth(&m, &Geometry::Spherical { radius_km: R }, &ray);
        assert!(matches!(end, WalkEnd::Top { .. }));
        let column: f64 = (0..m.levels_km().len() - 1)
            .map(|i| m.at(i, 0.0).sigma_t * (m.levels_km()[i + 1] - m.levels_km()[i]))
            .sum();
        assert!((tau / column - 1.0).abs() < 1e-12);
        let down = Ray {
            dir: -DVec3::Z,
            ..slant_ray(0.0, 3.0, m.levels_km())
        };
        let down = Ray {
            layer: layer_at(m.levels_km(), 3.0, -1.0).unwrap(),
            ..down
        };
        assert_eq!(
            analytic_transmittance(&m, &Geometry::Spherical { radius_km: R }, &down),
            0.0
        );
    }

    /// Mean and standard error of `n` estimates.
    fn mean_se(xs: impl Iterator<Item = f64>) -> (f64, f64, usize) {
        let (mut s, mut s2, mut n) = (0.0, 0.0, 0usize);
        for x in xs {
            s += x;
            s2 += x * x;
            n += 1;
        }
        let m = s / n as f64;
        (m, ((s2 / n as f64 - m * m).max(0.0) / (n as f64 - 1.0)).sqrt(), n)
    }

    #[test]
    fn delta_and_ratio_tracking_match_the_exact_transmittance() {
        let g = Geometry::Spherical { radius_km: R };
        for model in [MediumModel::Layered, MediumModel::Smooth] {
            for scale in [1.0, 2.0, 10.0] {
                let m = medium(model, scale);
                // A slant path from 1.5 km at 80° zenith (τ ≈ 3 at 340 nm).
                let ray = slant_ray(80.0, 1.5, m.levels_km());
                let exact = analytic_transmittance(&m, &g, &ray);
                let n = 40_000u64;
                let (mr, ser, _) = mean_se((0..n).map(|k| {
                    let mut s = Sampler::new(&[11, k]);
                    ratio_tracking_transmittance(&m, &g, &ray, &mut s)
                }));
                assert!(
                    (mr - exact).abs() < 4.0 * ser,
                    "ratio {model:?} ×{scale}: {mr} ± {ser} vs {exact}"
                );
                let (md, sed, _) = mean_se((0..n).map(|k| {
                    let mut s = Sampler::new(&[12, k]);
                    match delta_track(&m, &g, &ray, &mut s) {
                        FlightEnd::Top { .. } => 1.0,
                        _ => 0.0,
                    }
                }));
                assert!(
                    (md - exact).abs() < 4.0 * sed,
                    "delta {model:?} ×{scale}: {md} ± {sed} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn forced_flights_weight_the_truncated_distribution_exactly() {
        // E[weight · 1(t > s)] must equal e^(−τ(s)) − e^(−τ_exit) for a ray
        // that leaves through the top, and the weight is 1 − e^(−τ_exit).
        let g = Geometry::Spherical { radius_km: R };
        let m = medium(MediumModel::Layered, 1.0);
        let ray = slant_ray(70.0, 0.2, m.levels_km());
        let (tau_exit, _) = optical_depth(&m, &g, &ray);
        let n = 40_000u64;
        let mut buf = Vec::new();
        let flights: Vec<ForcedFlight> = (0..n)
            .map(|k| forced_flight(&m, &g, &ray, &mut Sampler::new(&[14, k]), false, &mut buf))
            .collect();
        for f in &flights {
            assert!((f.weight - (1.0 - (-tau_exit).exp())).abs() < 1e-14);
            assert!(matches!(f.end, FlightEnd::Collided(_)));
        }
        for dist in [0.5, 2.0, 10.0] {
            let tau = optical_depth_to(&m, &g, &ray, dist);
            let exact = (-tau).exp() - (-tau_exit).exp();
            let (mean, se, _) = mean_se(flights.iter().map(|f| match f.end {
                FlightEnd::Collided(c) if c.t > dist => f.weight,
                _ => 0.0,
            }));
            assert!((mean - exact).abs() < 4.0 * se, "{dist} km: {mean} ± {se} vs {exact}");
        }
        // Looking down at a reflecting ground the flight is analog.
        let down = Ray {
            dir: -ray.dir,
            layer: layer_at(m.levels_km(), 0.2, -1.0).unwrap(),
            ..ray
        };
        let (tau_g, _) = optical_depth(&m, &g, &down);
        let (mean, se, _) = mean_se((0..n).map(|k| {
            let f = forced_flight(&m, &g, &down, &mut Sampler::new(&[15, k]), true, &mut buf);
            assert_eq!(f.weight, 1.0);
            if matches!(f.end, FlightEnd::Ground { .. }) {
                1.0
            } else {
                0.0
            }
        }));
        assert!((mean - (-tau_g).exp()).abs() < 4.0 * se);
    }

    #[test]
    fn delta_tracking_free_paths_follow_beer_lambert() {
        // P(t > s) = exp(−τ(s)) at a few distances along a horizontal ray.
        let g = Geometry::Spherical { radius_km: R };
        let m = medium(MediumModel::Smooth, 2.0);
        let ray = slant_ray(90.0, 0.5, m.levels_km());
        let n = 40_000u64;
        let ts: Vec<f64> = (0..n)
            .map(|k| {
                let mut s = Sampler::new(&[13, k]);
                match delta_track(&m, &g, &ray, &mut s) {
                    FlightEnd::Collided(c) => c.t,
                    _ => f64::INFINITY,
                }
            })
            .collect();
        for dist in [1.0, 5.0, 20.0] {
            let tau = optical_depth_to(&m, &g, &ray, dist);
            let p = (-tau).exp();
            let frac = ts.iter().filter(|&&t| t > dist).count() as f64 / n as f64;
            let se = (p * (1.0 - p) / n as f64).sqrt();
            assert!((frac - p).abs() < 4.0 * se, "{dist} km: {frac} vs {p}");
        }
    }
}
