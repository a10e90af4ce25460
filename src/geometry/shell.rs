//! The planet's geometry (concentric spherical shells around the planet
//! centre at the origin, or plane-parallel slabs; lengths in km) and the
//! step of the general ray walk: [`next_boundary`], the distance from a
//! point inside one layer to the next layer boundary, including rays that
//! dip towards a lower shell, miss it and leave through the upper shell of
//! the same layer. The stepwise walk (`geometry::ray`) uses it in slabs,
//! and the closed-form walk through shells is tested against it.
//!
//! Rays in a 6378 km planet are often nearly tangent to a shell, where the
//! textbook quadratic `t² + 2bt + c = 0` loses most of its digits. Following
//! Haines et al. 2019, "Precision Improvements for Ray/Sphere Intersection"
//! (Ray Tracing Gems, ch. 7), the entry and exit distances take
//! - the discriminant as `r² − |o − (o·d)d|²`, factored as
//!   `(r − h)(r + h)` with `h` the distance of the line from the centre,
//!   instead of `b² − c` (two nearly equal numbers);
//! - `c = |o|² − r²` as `(|o| − r)(|o| + r)`;
//! - the smaller root through the stable form `t = c/q`, `q = −b − sgn(b)√Δ`.

use glam::DVec3;

/// Which geometry the atmosphere has.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Geometry {
    /// Concentric shells around a sphere of radius `radius_km` centred at
    /// the origin.
    Spherical { radius_km: f64 },
    /// Horizontally infinite slabs; the ground is `z = 0`, up is `+z`.
    PlaneParallel,
}

impl Geometry {
    /// Altitude (km) above the ground of the point `p`.
    pub fn altitude(&self, p: DVec3) -> f64 {
        match *self {
            Geometry::Spherical { radius_km } => p.length() - radius_km,
            Geometry::PlaneParallel => p.z,
        }
    }

    /// Position of an observer at `altitude_km` (on the z axis).
    pub fn observer_position(&self, altitude_km: f64) -> DVec3 {
        match *self {
            Geometry::Spherical { radius_km } => DVec3::new(0.0, 0.0, radius_km + altitude_km),
            Geometry::PlaneParallel => DVec3::new(0.0, 0.0, altitude_km),
        }
    }

    /// Local vertical (unit vector, up) at `p`. At the planet centre, where it
    /// is undefined, `+z` is returned.
    pub fn up(&self, p: DVec3) -> DVec3 {
        match *self {
            Geometry::Spherical { .. } => p.try_normalize().unwrap_or(DVec3::Z),
            Geometry::PlaneParallel => DVec3::Z,
        }
    }
}

/// The next layer boundary along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellCrossing {
    /// Distance (km) along the ray, `t ≥ 0`.
    pub t: f64,
    /// Index into `levels_km` of the boundary crossed.
    pub boundary: usize,
}

/// Roots of `|origin + t·dir| = radius` for a unit `dir`: `(t_near, t_far)`
/// with `t_near ≤ t_far` (either may be negative), or `None` when the line
/// misses the sphere. A tangent line gives `t_near == t_far` up to rounding.
/// (The tests' check of the root forms.)
#[cfg(test)]
fn ray_sphere(origin: DVec3, dir: DVec3, radius: f64) -> Option<(f64, f64)> {
    let (b, c, disc) = quadratic_terms(origin, dir, radius);
    if disc < 0.0 {
        return None;
    }
    Some(stable_roots(b, c, disc))
}

/// `b = o·d`, `c = |o|² − r²` and the discriminant `Δ = b² − c`, the latter
/// two in the cancellation-free forms of the module docs.
fn quadratic_terms(origin: DVec3, dir: DVec3, radius: f64) -> (f64, f64, f64) {
    let b = origin.dot(dir);
    let dist = origin.length();
    let c = (dist - radius) * (dist + radius);
    let h = (origin - b * dir).length();
    let disc = (radius - h) * (radius + h);
    (b, c, disc)
}

/// Both roots of `t² + 2bt + c = 0` with `Δ = b² − c ≥ 0`, ordered.
fn stable_roots(b: f64, c: f64, disc: f64) -> (f64, f64) {
    let q = -b - disc.sqrt().copysign(b);
    if q == 0.0 {
        // b = 0 and Δ = 0: the origin is the tangent point.
        return (0.0, 0.0);
    }
    let (t0, t1) = (q, c / q);
    if t0 <= t1 { (t0, t1) } else { (t1, t0) }
}

/// Distance to the far intersection with a sphere the origin lies inside of
/// (or on). Rounding can push a nearly tangent ray from a point on the
/// sphere to a slightly negative discriminant, which is clamped to 0 (the
/// exact value for the origin inside is `Δ ≥ r² − |o|² ≥ 0`).
fn exit_distance(origin: DVec3, dir: DVec3, radius: f64) -> f64 {
    let (b, c, disc) = quadratic_terms(origin, dir, radius);
    let (_, t_far) = stable_roots(b, c, disc.max(0.0));
    t_far.max(0.0)
}

/// Relative resolution of the discriminant: `h` and `|o|` carry a few ulps of
/// `max(|o|, r)`, so `Δ = (r − h)(r + h)` is uncertain by about
/// `2r·3ε·max(|o|, r)`; this bound adds a safety factor of about 3.
const DISC_RESOLUTION: f64 = 16.0 * f64::EPSILON;

/// Distance to where the ray enters a sphere the origin lies outside of,
/// or `None` if it does not enter it ahead of the origin.
///
/// A ray can only enter the sphere ahead while it descends (`o·d < 0`). A
/// ray whose chord through the sphere is below the resolution of the
/// discriminant (`Δ ≤ 16ε·r·max(|o|, r)`, a chord under about 0.8 m for the
/// Earth) is taken to miss it: whether it grazes or misses is decided by
/// rounding, and counting it as a miss is what keeps a ray that starts on
/// the sphere and leaves it horizontally (the caller said it is in the layer
/// above) from returning the sphere it starts on. A clearly descending ray
/// from an origin that rounding put inside the sphere gets `t = 0`.
fn entry_distance(origin: DVec3, dir: DVec3, radius: f64) -> Option<f64> {
    let (b, c, disc) = quadratic_terms(origin, dir, radius);
    let disc_resolution = DISC_RESOLUTION * radius * origin.length().max(radius);
    if b >= 0.0 || disc <= disc_resolution {
        return None;
    }
    let (t_near, _) = stable_roots(b, c, disc);
    Some(t_near.max(0.0))
}

/// Distance along the ray `origin + t·dir` (unit `dir`) to the next boundary
/// of the layer it is in.
///
/// `levels_km` holds the ascending altitudes of the layer boundaries, with
/// `levels_km[0] = 0` the ground; layer `i` lies between `levels_km[i]` and
/// `levels_km[i + 1]` and the origin is in layer `layer`. The crossing is
/// either the lower boundary (`boundary = layer`, which for `layer = 0` is
/// the ground) or the upper one (`boundary = layer + 1`, which for the top
/// layer is `levels_km.len() − 1`, the top of the atmosphere).
///
/// An origin exactly on a boundary belongs to the layer the ray is moving
/// into, and that is the layer the caller passes; the boundary it starts on
/// is then never returned with `t ≈ 0` (only a ray exactly tangent to it can
/// legitimately return `t = 0` for it).
///
/// In spherical geometry a layer is a closed shell, so there is always a
/// crossing and the result is `Some`. In plane-parallel geometry a
/// horizontal ray (`dir.z = 0`) never reaches a boundary: `None`.
///
/// Panics if `layer + 1 >= levels_km.len()` (a caller bug, not user input).
pub fn next_boundary(
    geometry: &Geometry,
    levels_km: &[f64],
    origin: DVec3,
    dir: DVec3,
    layer: usize,
) -> Option<ShellCrossing> {
    let (z_lo, z_hi) = (levels_km[layer], levels_km[layer + 1]);
    match *geometry {
        Geometry::Spherical { radius_km } => {
            // A descending ray hits the lower shell first if it hits it at
            // all; otherwise (also when it grazes past it) it leaves through
            // the upper shell.
            if let Some(t) = entry_distance(origin, dir, radius_km + z_lo) {
                return Some(ShellCrossing { t, boundary: layer });
            }
            let t = exit_distance(origin, dir, radius_km + z_hi);
            Some(ShellCrossing { t, boundary: layer + 1 })
        }
        Geometry::PlaneParallel => {
            let (z_target, boundary) = if dir.z > 0.0 {
                (z_hi, layer + 1)
            } else if dir.z < 0.0 {
                (z_lo, layer)
            } else {
                return None;
            };
            let t = ((z_target - origin.z) / dir.z).max(0.0);
            Some(ShellCrossing { t, boundary })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;
    use std::f64::consts::PI;

    const R: f64 = 6378.0;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(1.0)
    }

    fn random_unit(rng: &mut Pcg64Mcg) -> DVec3 {
        let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
        let phi = 2.0 * PI * rng.random::<f64>();
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// A unit vector perpendicular to `n`, at angle `alpha` about it.
    fn horizontal(n: DVec3, alpha: f64) -> DVec3 {
        let a = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let t1 = n.cross(a).normalize();
        let t2 = n.cross(t1);
        alpha.cos() * t1 + alpha.sin() * t2
    }

    #[test]
    fn ray_sphere_outside_inside_miss_tangent() {
        // From 1000 km above the north pole, straight down.
        let (t0, t1) = ray_sphere(DVec3::new(0.0, 0.0, R + 1000.0), -DVec3::Z, R).unwrap();
        assert_eq!((t0, t1), (1000.0, 1000.0 + 2.0 * R));
        // Pointing away: both roots behind.
        let (t0, t1) = ray_sphere(DVec3::new(0.0, 0.0, R + 1000.0), DVec3::Z, R).unwrap();
        assert_eq!((t0, t1), (-1000.0 - 2.0 * R, -1000.0));
        // From the centre.
        assert_eq!(ray_sphere(DVec3::ZERO, DVec3::X, R), Some((-R, R)));
        // Passing 10 km outside.
        assert_eq!(ray_sphere(DVec3::new(0.0, R + 10.0, -5000.0), DVec3::Z, R), None);
        // Exactly tangent at (0, R, 0).
        let (t0, t1) = ray_sphere(DVec3::new(0.0, R, -5000.0), DVec3::Z, R).unwrap();
        assert!(close(t0, 5000.0, 1e-15) && close(t1, 5000.0, 1e-15), "{t0} {t1}");
        // Passing 1 mm inside: chord 2√((R − h)(R + h)).
        // (R − h is exact in f64 by Sterbenz's lemma, h being the rounded R − 1e-6.)
        let h = R - 1e-6;
        let (t0, t1) = ray_sphere(DVec3::new(0.0, h, -5000.0), DVec3::Z, R).unwrap();
        let half_chord = ((R - h) * (R + h)).sqrt();
        assert!(
            close(t1 - t0, 2.0 * half_chord, 1e-9),
            "{} vs {}",
            t1 - t0,
            2.0 * half_chord
        );
        assert!(close(0.5 * (t0 + t1), 5000.0, 1e-15));
    }

    #[test]
    fn horizontal_ray_hits_outer_sphere_at_exact_distance() {
        // From altitude h horizontally: t = √((R + H)² − (R + h)²) = √((H − h)(2R + H + h)).
        let cases = [(0.0, 100.0), (0.0, 0.001), (5.0, 5.000001), (12.5, 60.0), (99.0, 100.0)];
        // Axis-aligned origin and direction: the inputs are exactly the f64
        // values `r_in = R + h` and `r_out = R + H`, and for them
        // t = √((r_out − r_in)(r_out + r_in)) with an exact difference
        // (Sterbenz), so only the formula's own rounding remains: the result
        // must be good to ~1e-14 even for a 1 m thin shell.
        for &(h, big_h) in &cases {
            let (r_in, r_out): (f64, f64) = (R + h, R + big_h);
            let exact = ((r_out - r_in) * (r_out + r_in)).sqrt();
            let (t0, t1) = ray_sphere(DVec3::new(r_in, 0.0, 0.0), DVec3::Y, r_out).unwrap();
            assert!(
                close(t1, exact, 1e-14) && close(-t0, exact, 1e-14),
                "h {h} H {big_h}: {t1} vs {exact}"
            );
        }
        // Random orientations: the origin (R + h)·n itself is rounded by
        // δ ≈ ε(R + h) per component, which moves t by about (R + H)·δ/t
        // (dt = r dr/t); the tolerance is 8 such units plus 1e-12 relative.
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        for &(h, big_h) in &cases {
            let exact = ((big_h - h) * (2.0 * R + big_h + h)).sqrt();
            let tol = 1e-12 * exact + 8.0 * f64::EPSILON * (R + big_h) * (R + h) / exact;
            for _ in 0..20 {
                let n = random_unit(&mut rng);
                let origin = (R + h) * n;
                let dir = horizontal(n, 2.0 * PI * rng.random::<f64>());
                let (t0, t1) = ray_sphere(origin, dir, R + big_h).unwrap();
                assert!((t1 - exact).abs() < tol, "h {h} H {big_h}: {t1} vs {exact}");
                assert!((-t0 - exact).abs() < tol);
            }
        }
    }

    #[test]
    fn ground_to_horizon_leaves_top_at_1134_km() {
        let levels = [0.0, 50.0, 100.0];
        let geometry = Geometry::Spherical { radius_km: R };
        let origin = DVec3::new(0.0, 0.0, R);
        let dir = DVec3::X;
        let c0 = next_boundary(&geometry, &levels, origin, dir, 0).unwrap();
        assert_eq!(c0.boundary, 1);
        assert!(close(c0.t, (50.0 * (2.0 * R + 50.0f64)).sqrt(), 1e-12));
        let c1 = next_boundary(&geometry, &levels, origin + c0.t * dir, dir, 1).unwrap();
        assert_eq!(c1.boundary, 2);
        let total = c0.t + c1.t;
        let exact = (100.0 * (2.0 * R + 100.0f64)).sqrt();
        assert!(close(total, exact, 1e-12), "{total} vs {exact}");
        assert!((total - 1133.84).abs() < 0.01);
    }

    #[test]
    fn downward_ray_hits_the_ground() {
        let levels = [0.0, 2.0, 10.0];
        let geometry = Geometry::Spherical { radius_km: R };
        // Straight down from 1.5 km.
        let c = next_boundary(&geometry, &levels, DVec3::new(0.0, 0.0, R + 1.5), -DVec3::Z, 0).unwrap();
        assert_eq!(c.boundary, 0);
        assert!(close(c.t, 1.5, 1e-12));
        // Slanted: origin at altitude h, direction at depression angle δ below
        // the local horizontal; law of cosines: t = −(R+h)(−sin δ) − √(R² − (R+h)²cos²δ).
        let (h, delta) = (1.5f64, 0.2f64);
        let origin = DVec3::new(R + h, 0.0, 0.0);
        let dir = DVec3::new(-delta.sin(), delta.cos(), 0.0);
        let exact = (R + h) * delta.sin() - (R * R - ((R + h) * delta.cos()).powi(2)).sqrt();
        let c = next_boundary(&geometry, &levels, origin, dir, 0).unwrap();
        assert_eq!(c.boundary, 0);
        assert!(close(c.t, exact, 1e-10), "{} vs {exact}", c.t);
    }

    #[test]
    fn grazing_ray_misses_lower_shell_and_leaves_through_upper() {
        // In the layer 5–10 km at 7 km, descending so that its lowest point is
        // at 6 km: it never reaches 5 km and leaves through 10 km.
        let levels = [0.0, 5.0, 10.0, 20.0];
        let geometry = Geometry::Spherical { radius_km: R };
        let (h, h_tan, h_top) = (7.0, 6.0, 10.0);
        let to_tangent = ((h - h_tan) * (2.0 * R + h + h_tan)).sqrt();
        let from_tangent = ((h_top - h_tan) * (2.0 * R + h_top + h_tan)).sqrt();
        // Build the ray from its tangent point (R + 6, 0, 0) moving along +y.
        let origin = DVec3::new(R + h_tan, -to_tangent, 0.0);
        let dir = DVec3::Y;
        assert!(close(geometry.altitude(origin), h, 1e-12));
        assert!(dir.dot(geometry.up(origin)) < 0.0);
        let c = next_boundary(&geometry, &levels, origin, dir, 1).unwrap();
        assert_eq!(c.boundary, 2);
        assert!(close(c.t, to_tangent + from_tangent, 1e-12));
        // Dipping to 4.9 km instead, it enters the layer below.
        let to_tangent = ((h - 4.9) * (2.0 * R + h + 4.9)).sqrt();
        let origin = DVec3::new(R + 4.9, -to_tangent, 0.0);
        let c = next_boundary(&geometry, &levels, origin, dir, 1).unwrap();
        assert_eq!(c.boundary, 1);
        let in_lower = ((5.0 - 4.9) * (2.0 * R + 5.0 + 4.9f64)).sqrt();
        assert!(close(c.t, to_tangent - in_lower, 1e-9));
    }

    #[test]
    fn ray_starting_on_a_boundary_does_not_return_it() {
        let levels = [0.0, 5.0, 10.0, 20.0];
        let geometry = Geometry::Spherical { radius_km: R };
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        for _ in 0..200 {
            let n = random_unit(&mut rng);
            let on_10km = (R + 10.0) * n;
            // Radially up from 10 km (layer 2) and down (layer 1).
            let up = next_boundary(&geometry, &levels, on_10km, n, 2).unwrap();
            assert_eq!(up.boundary, 3);
            assert!(close(up.t, 10.0, 1e-10));
            let down = next_boundary(&geometry, &levels, on_10km, -n, 1).unwrap();
            assert_eq!(down.boundary, 1);
            assert!(close(down.t, 5.0, 1e-10));
            // Slanted up at elevation ε: t = √((R+20)² − (R+10)²cos²ε) − (R+10) sin ε.
            let eps: f64 = 0.05 + 1.4 * rng.random::<f64>();
            let dir = eps.cos() * horizontal(n, rng.random::<f64>() * 2.0 * PI) + eps.sin() * n;
            let exact = ((R + 20.0f64).powi(2) - ((R + 10.0) * eps.cos()).powi(2)).sqrt() - (R + 10.0) * eps.sin();
            let c = next_boundary(&geometry, &levels, on_10km, dir, 2).unwrap();
            assert_eq!(c.boundary, 3);
            assert!(close(c.t, exact, 1e-9), "{} vs {exact}", c.t);
            // Horizontal from a boundary rises into the layer above.
            let flat = horizontal(n, 1.0);
            let c = next_boundary(&geometry, &levels, on_10km, flat, 2).unwrap();
            assert_eq!(c.boundary, 3);
            assert!(close(c.t, (10.0 * (2.0 * R + 30.0f64)).sqrt(), 1e-9));
            // Slanted down from 10 km into layer 1, hitting 5 km.
            let dir = eps.cos() * flat - eps.sin() * n;
            let c = next_boundary(&geometry, &levels, on_10km, dir, 1).unwrap();
            assert_eq!(c.boundary, 1);
            assert!(c.t > 4.9);
            // A caller that puts a clearly descending ray in the layer above
            // while rounding left it just inside the lower sphere gets t = 0
            // for that boundary, not a path through the planet.
            let inside = on_10km * (1.0 - 4.0 * f64::EPSILON);
            let c = next_boundary(&geometry, &levels, inside, -n, 2).unwrap();
            assert_eq!(c, ShellCrossing { t: 0.0, boundary: 2 });
        }
    }

    #[test]
    fn plane_parallel_boundaries() {
        let levels = [0.0, 1.0, 3.0, 10.0];
        let geometry = Geometry::PlaneParallel;
        assert_eq!(geometry.altitude(DVec3::new(5.0, -3.0, 2.5)), 2.5);
        assert_eq!(geometry.up(DVec3::new(5.0, -3.0, 2.5)), DVec3::Z);
        let mu: f64 = 0.6;
        let up = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let c = next_boundary(&geometry, &levels, DVec3::new(0.0, 0.0, 2.0), up, 1).unwrap();
        assert_eq!(
            c,
            ShellCrossing {
                t: 1.0 / mu,
                boundary: 2
            }
        );
        let down = DVec3::new(up.x, 0.0, -mu);
        let c = next_boundary(&geometry, &levels, DVec3::new(0.0, 0.0, 2.0), down, 1).unwrap();
        assert_eq!(c.boundary, 1);
        assert!(close(c.t, 1.0 / mu, 1e-15));
        // Starting on the 3 km boundary, up into layer 2 and down into layer 1.
        let c = next_boundary(&geometry, &levels, DVec3::new(0.0, 0.0, 3.0), up, 2).unwrap();
        assert_eq!(c.boundary, 3);
        assert!(close(c.t, 7.0 / mu, 1e-15));
        let c = next_boundary(&geometry, &levels, DVec3::new(0.0, 0.0, 3.0), down, 1).unwrap();
        assert_eq!(c.boundary, 1);
        assert!(close(c.t, 2.0 / mu, 1e-15));
        // A slanted ray through 50 levels travels H/μ in total.
        let levels: Vec<f64> = (0..50).map(|i| 100.0 * (i as f64 / 49.0).powi(2)).collect();
        let walk_up = walk(&geometry, &levels, DVec3::new(3.0, 4.0, 0.0), up, 0);
        assert_eq!((walk_up.exit, walk_up.steps), (49, 49));
        assert!(close(walk_up.total, 100.0 / mu, 1e-13));
        let walk_down = walk(&geometry, &levels, DVec3::new(0.0, 0.0, 100.0), down, 48);
        assert_eq!((walk_down.exit, walk_down.steps), (0, 49));
        assert!(close(walk_down.total, 100.0 / mu, 1e-13));
        // Horizontal rays never cross a plane.
        assert_eq!(
            next_boundary(&geometry, &levels, DVec3::new(0.0, 0.0, 2.0), DVec3::X, 1),
            None
        );
    }

    #[test]
    fn spherical_geometry_altitude_and_up() {
        let geometry = Geometry::Spherical { radius_km: R };
        let p = DVec3::new(3.0, -4.0, 12.0).normalize() * (R + 42.0);
        assert!(close(geometry.altitude(p), 42.0, 1e-12));
        assert!((geometry.up(p) - DVec3::new(3.0, -4.0, 12.0) / 13.0).length() < 1e-15);
        assert_eq!(geometry.up(DVec3::ZERO), DVec3::Z);
    }

    /// Result of walking a ray through the layers with [`next_boundary`].
    struct Walk {
        /// Sum of the segment lengths.
        total: f64,
        /// The boundary the ray left through (ground or top).
        exit: usize,
        /// The lowest layer visited.
        lowest: usize,
        /// Number of segments.
        steps: usize,
    }

    fn walk(geometry: &Geometry, levels: &[f64], origin: DVec3, dir: DVec3, mut layer: usize) -> Walk {
        let top = levels.len() - 1;
        let (mut p, mut total, mut steps, mut lowest) = (origin, 0.0, 0, layer);
        loop {
            lowest = lowest.min(layer);
            let c = next_boundary(geometry, levels, p, dir, layer).unwrap();
            assert!(c.t >= 0.0);
            assert!(c.boundary == layer || c.boundary == layer + 1);
            total += c.t;
            p += c.t * dir;
            steps += 1;
            assert!(steps < 10 * levels.len(), "walk does not terminate");
            if c.boundary == 0 || c.boundary == top {
                return Walk {
                    total,
                    exit: c.boundary,
                    lowest,
                    steps,
                };
            }
            layer = if c.boundary == layer + 1 { layer + 1 } else { layer - 1 };
        }
    }

    #[test]
    fn walk_through_fifty_levels_sums_to_the_chord() {
        // 50 levels, finer near the ground, 0 to 100 km.
        let levels: Vec<f64> = (0..50).map(|i| 100.0 * (i as f64 / 49.0).powf(1.5)).collect();
        let geometry = Geometry::Spherical { radius_km: R };
        let top = R + 100.0;
        let mut rng = Pcg64Mcg::seed_from_u64(77);
        for _ in 0..300 {
            let n = random_unit(&mut rng);
            let flat = horizontal(n, 2.0 * PI * rng.random::<f64>());
            // Up from the ground at an elevation in (0°, 90°]: crosses all 49 layers.
            let elev = 0.5 * PI * (1.0 - rng.random::<f64>());
            let dir = elev.cos() * flat + elev.sin() * n;
            let Walk { total, exit, steps, .. } = walk(&geometry, &levels, R * n, dir, 0);
            let (_, chord) = ray_sphere(R * n, dir, top).unwrap();
            assert_eq!((exit, steps), (49, 49));
            assert!(close(total, chord, 1e-10), "{total} vs {chord}");

            // From 60 km at a random direction: down to the ground or out of
            // the top, possibly after dipping and rising again.
            let start_alt = 60.0;
            let layer = levels.iter().rposition(|&z| z <= start_alt).unwrap();
            let origin = (R + start_alt) * n;
            let dir = random_unit(&mut rng);
            let Walk { total, exit, .. } = walk(&geometry, &levels, origin, dir, layer);
            let ground = ray_sphere(origin, dir, R).filter(|&(t0, _)| t0 > 0.0);
            match ground {
                Some((t_ground, _)) => {
                    assert_eq!(exit, 0);
                    assert!(close(total, t_ground, 1e-10), "{total} vs {t_ground}");
                }
                None => {
                    let (_, t_top) = ray_sphere(origin, dir, top).unwrap();
                    assert_eq!(exit, 49);
                    assert!(close(total, t_top, 1e-10), "{total} vs {t_top}");
                }
            }
        }
    }

    #[test]
    fn walk_with_limb_rays_near_tangent_to_a_level() {
        // Rays whose lowest point lies just above or below a level: they
        // descend, graze or enter the shell below, and rise out of the top.
        let levels: Vec<f64> = (0..50).map(|i| 100.0 * (i as f64 / 49.0).powf(1.5)).collect();
        let geometry = Geometry::Spherical { radius_km: R };
        let mut rng = Pcg64Mcg::seed_from_u64(8);
        for k in 1..49 {
            for offset in [-1e-3, -1e-7, -1e-11, -1e-13, 0.0, 1e-13, 1e-11, 1e-7, 1e-3] {
                let h_tan = levels[k] + offset;
                let n = random_unit(&mut rng);
                let dir = horizontal(n, 2.0 * PI * rng.random::<f64>());
                // Start at the top of the atmosphere, moving down towards the tangent point.
                let back = ((100.0 - h_tan) * (2.0 * R + 100.0 + h_tan)).sqrt();
                let origin = (R + h_tan) * n - back * dir;
                let Walk {
                    total, exit, lowest, ..
                } = walk(&geometry, &levels, origin, dir, 48);
                assert_eq!(exit, 49);
                // Resolved dips reach the layer below the level, clear
                // misses stay above it.
                if offset <= -1e-7 {
                    assert_eq!(lowest, k - 1, "level {k} offset {offset}");
                } else if offset >= 1e-7 {
                    assert_eq!(lowest, k, "level {k} offset {offset}");
                }
                assert!(
                    close(total, 2.0 * back, 1e-9),
                    "level {k} offset {offset}: {total} vs {}",
                    2.0 * back
                );
            }
        }
    }
}
