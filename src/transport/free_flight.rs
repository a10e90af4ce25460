//! Free flight along a ray: the one routine that samples tentative collisions
//! against a majorant per layer (`sample_t_maj`, after pbrt-v4's
//! `SampleT_maj`), of which delta tracking, ratio tracking and the tracer's
//! flights are uses; locating an optical depth on a ray; forced (truncated
//! exponential) distances.

use std::ops::ControlFlow;

use crate::geometry::ray::{Collision, Ray, Segment, WalkEnd, walk};
use crate::geometry::shell::Geometry;
use crate::sampling::sampler::Sampler;
use crate::transport::medium::Medium;

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
    majorant: impl Fn(usize) -> f64,
    geometry: &Geometry,
    levels_km: &[f64],
    ray: &Ray,
    sampler: &mut Sampler,
    mut on_collision: impl FnMut(&Collision, &mut Sampler) -> bool,
) -> FlightEnd {
    let mut tau_left = -(1.0 - sampler.next_f64()).ln();
    let mut hit = None;
    let end = walk(geometry, levels_km, ray, |seg| {
        let sigma = majorant(seg.layer);
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

/// The layer segments of `ray` with their majorant optical depths, into
/// `segments` (cleared first); an endless segment has depth ∞ unless empty.
#[inline]
pub fn segments_of(medium: &Medium, geometry: &Geometry, ray: &Ray, segments: &mut Vec<(Segment, f64)>) -> WalkEnd {
    segments.clear();
    walk(geometry, medium.levels_km(), ray, |seg| {
        segments.push((seg, majorant_depth(medium, &seg)));
        ControlFlow::Continue(())
    })
}

/// σ_maj × length of a segment (∞ for an endless segment of a non-empty layer).
#[inline]
pub(crate) fn majorant_depth(medium: &Medium, seg: &Segment) -> f64 {
    let sigma = medium.sigma_maj(seg.layer);
    if seg.t1.is_infinite() {
        if sigma > 0.0 { f64::INFINITY } else { 0.0 }
    } else {
        sigma * (seg.t1 - seg.t0)
    }
}

/// The point at optical depth `tau_target` along `ray` for σ per layer
/// `sigma` (finite segments only), walking its segments until it is
/// reached.
#[inline]
pub fn locate_with(sigma: &[f64], geometry: &Geometry, levels_km: &[f64], ray: &Ray, tau_target: f64) -> Collision {
    let mut search = DepthSearch::new(tau_target);
    let mut hit = None;
    walk(geometry, levels_km, ray, |seg| {
        let s = sigma[seg.layer];
        hit = search.step(s, seg, s * (seg.t1 - seg.t0));
        if hit.is_some() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    hit.unwrap_or_else(|| search.beyond(sigma))
}

/// The search for the point at a target optical depth, segment by segment.
pub(crate) struct DepthSearch {
    target: f64,
    acc: f64,
    last: Option<Segment>,
}

impl DepthSearch {
    #[inline]
    fn new(target: f64) -> DepthSearch {
        DepthSearch {
            target,
            acc: 0.0,
            last: None,
        }
    }

    /// The collision if the target lies in `seg` (σ `sigma`, depth `tau`).
    #[inline]
    fn step(&mut self, sigma: f64, seg: Segment, tau: f64) -> Option<Collision> {
        if sigma > 0.0 && self.acc + tau >= self.target {
            return Some(Collision {
                t: (seg.t0 + (self.target - self.acc) / sigma).min(seg.t1),
                layer: seg.layer,
                sigma_maj: sigma,
            });
        }
        self.acc += tau;
        self.last = Some(seg);
        None
    }

    /// Rounding left the target just beyond the last segment: its end.
    #[inline]
    fn beyond(&self, sigma: &[f64]) -> Collision {
        let seg = self.last.expect("a located flight has a segment");
        Collision {
            t: seg.t1,
            layer: seg.layer,
            sigma_maj: sigma[seg.layer],
        }
    }
}

/// The optical depth of a forced collision for the uniform variate `u`,
/// with forcing probability `p` = 1 − e^(−τ_exit): the inverse of the
/// truncated exponential.
#[inline]
pub fn forced_distance(u: f64, p: f64) -> f64 {
    -(-u * p).ln_1p()
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geometry::ray::test_slant_ray as slant_ray;
    use crate::geometry::ray::*;
    use crate::geometry::shell::Geometry;

    use crate::job::options::MediumModel;
    use crate::sampling::sampler::Sampler;

    use crate::transport::medium::{Medium, test_medium as medium};
    use crate::transport::optical_depth::*;

    const R: f64 = 6378.0;

    /// Delta tracking of `m` by [`sample_t_maj`]: the next real collision.
    fn delta(m: &Medium, g: &Geometry, ray: &Ray, s: &mut Sampler) -> FlightEnd {
        sample_t_maj(
            |l| m.sigma_maj(l),
            g,
            m.levels_km(),
            ray,
            s,
            |c, s| {
                let z = g.altitude(ray.origin + c.t * ray.dir);
                s.next_f64() * c.sigma_maj >= m.at(c.layer, z).sigma_t
            },
        )
    }

    /// Ratio tracking of `m` by [`sample_t_maj`]: the transmittance to the
    /// top (0 into the ground).
    fn ratio(m: &Medium, g: &Geometry, ray: &Ray, s: &mut Sampler) -> f64 {
        let mut tr = 1.0;
        let end = sample_t_maj(
            |l| m.sigma_maj(l),
            g,
            m.levels_km(),
            ray,
            s,
            |c, _| {
                let z = g.altitude(ray.origin + c.t * ray.dir);
                tr *= 1.0 - m.at(c.layer, z).sigma_t / c.sigma_maj;
                tr > 0.0
            },
        );
        if matches!(end, FlightEnd::Top { .. }) { tr } else { 0.0 }
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
                let exact = (-optical_depth(&m, &g, &ray).0).exp();
                let n = 40_000u64;
                let (mr, ser, _) = mean_se((0..n).map(|k| {
                    let mut s = Sampler::new(&[11, k]);
                    ratio(&m, &g, &ray, &mut s)
                }));
                assert!(
                    (mr - exact).abs() < 4.0 * ser,
                    "ratio {model:?} ×{scale}: {mr} ± {ser} vs {exact}"
                );
                let (md, sed, _) = mean_se((0..n).map(|k| {
                    let mut s = Sampler::new(&[12, k]);
                    match delta(&m, &g, &ray, &mut s) {
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
    fn forced_distances_follow_the_truncated_exponential() {
        // The optical depth of a forced collision exceeds s with
        // probability (e^(−s) − e^(−τ))/(1 − e^(−τ)), and never exceeds τ.
        let tau_exit: f64 = 0.7;
        let p = -(-tau_exit).exp_m1();
        let n = 40_000u64;
        let depths: Vec<f64> = (0..n)
            .map(|k| forced_distance(Sampler::new(&[14, k]).next_f64(), p))
            .collect();
        assert!(depths.iter().all(|&d| (0.0..=tau_exit + 1e-12).contains(&d)));
        for s in [0.05f64, 0.3, 0.6] {
            let exact = ((-s).exp() - (-tau_exit).exp()) / p;
            let frac = depths.iter().filter(|&&d| d > s).count() as f64 / n as f64;
            let se = (exact * (1.0 - exact) / n as f64).sqrt();
            assert!((frac - exact).abs() < 4.0 * se, "{s}: {frac} vs {exact}");
        }
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
                match delta(&m, &g, &ray, &mut s) {
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
