//! Image sensors: how pixels map to viewing directions in the observer's
//! frame (z up, x toward the sun's azimuth, azimuth φ counter-clockwise
//! seen from above; CONVENTIONS.md).
//!
//! - `fisheye` (N × N): a circle of radius N/2 pixels holds a hemisphere.
//!   The radius ρ ∈ [0, 1] (in units of the circle's radius) of the angle
//!   θ' from the hemisphere's pole is θ'/(π/2) (equidistant),
//!   √2·sin(θ'/2) (equisolid, equal-area) or tan(θ'/2) (stereographic).
//!   Image up is the sun's azimuth. `up` looks at the zenith as a camera
//!   pointed up records it: image right is φ = +90°. `down` looks at the
//!   nadir as a camera pointed down records it: image right is φ = −90°.
//!   Pixels outside the circle are zero.
//! - `panorama` (w × h): the seed's 180° × 180° camera facing the sun's
//!   azimuth: x from φ = +90° (left) to −90° (right), y from elevation +90°
//!   (top, zenith) to −90° (bottom, nadir).
//! - `sphere` (w × h): equirectangular over every direction, the sun's
//!   azimuth at the centre, x from φ = +180° to −180°, y from +90° to −90°.
//!
//! Image coordinates are in pixels: x to the right from the left edge, y
//! down from the top edge; pixel (i, j) covers [i, i+1) × [j, j+1). The
//! Jacobian dΩ/dA (sr per pixel area) lets a pixel average radiance over its
//! solid angle from samples uniform in its area.
//!
//! (Over 600 lines with its unit tests, about 430 without: every projection
//! is tested beside it, pixel to direction and back.)

use std::f64::consts::{FRAC_PI_2, PI, SQRT_2};

use glam::DVec3;

/// Fisheye projection (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Projection {
    Equidistant,
    Equisolid,
    Stereographic,
}

impl Projection {
    /// ρ(θ') for θ' ∈ [0, π/2].
    pub fn radius(self, theta: f64) -> f64 {
        match self {
            Projection::Equidistant => theta / FRAC_PI_2,
            Projection::Equisolid => SQRT_2 * (0.5 * theta).sin(),
            Projection::Stereographic => (0.5 * theta).tan(),
        }
    }

    /// θ'(ρ) for ρ ∈ [0, 1].
    pub fn angle(self, rho: f64) -> f64 {
        match self {
            Projection::Equidistant => rho * FRAC_PI_2,
            Projection::Equisolid => 2.0 * (rho / SQRT_2).min(1.0).asin(),
            Projection::Stereographic => 2.0 * rho.atan(),
        }
    }

    /// dΩ/dA in sr per unit area of the unit circle: sin θ'/(ρ·dρ/dθ').
    pub fn jacobian(self, theta: f64) -> f64 {
        match self {
            Projection::Equidistant => {
                if theta < 1e-8 {
                    PI * PI / 4.0
                } else {
                    theta.sin() * PI * PI / (4.0 * theta)
                }
            }
            Projection::Equisolid => 2.0,
            Projection::Stereographic => (0.5 * theta).cos().powi(4) * 4.0,
        }
    }
}

/// Which hemisphere a fisheye looks at (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hemisphere {
    Up,
    Down,
}

/// How a pixel turns into radiance (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelFilter {
    /// The mean radiance over the pixel's solid angle (stratified jitter).
    Box,
    /// The radiance of the pixel centre's direction.
    Center,
}

/// An image camera (the `directions` sensor lives in `render`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Camera {
    Fisheye {
        resolution: usize,
        hemisphere: Hemisphere,
        projection: Projection,
    },
    Panorama {
        width: usize,
        height: usize,
    },
    Sphere {
        width: usize,
        height: usize,
    },
}

/// A viewing direction from a point of the image plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelRay {
    pub direction: DVec3,
    /// Azimuth φ (radians) of the direction, for its meridian frame.
    pub azimuth: f64,
    /// dΩ/dA at this point, sr per pixel area.
    pub jacobian: f64,
}

impl Camera {
    /// Image size (width, height) in pixels.
    pub fn size(&self) -> (usize, usize) {
        match *self {
            Camera::Fisheye { resolution, .. } => (resolution, resolution),
            Camera::Panorama { width, height } | Camera::Sphere { width, height } => (width, height),
        }
    }

    /// The same view at a width of at most `width` pixels (the height in
    /// proportion, at least 1).
    pub fn with_width_at_most(&self, width: usize) -> Camera {
        let (w, h) = self.size();
        if w <= width {
            return *self;
        }
        let height = (h * width / w).max(1);
        match *self {
            Camera::Fisheye {
                hemisphere, projection, ..
            } => Camera::Fisheye {
                resolution: width,
                hemisphere,
                projection,
            },
            Camera::Panorama { .. } => Camera::Panorama { width, height },
            Camera::Sphere { .. } => Camera::Sphere { width, height },
        }
    }

    /// The viewing direction at image point (x, y); `None` outside a
    /// fisheye's circle.
    pub fn ray_at(&self, x: f64, y: f64) -> Option<PixelRay> {
        match *self {
            Camera::Fisheye {
                resolution,
                hemisphere,
                projection,
            } => {
                let r = resolution as f64 / 2.0;
                let (dx, dy) = ((x - r) / r, (r - y) / r);
                let rho = (dx * dx + dy * dy).sqrt();
                if rho > 1.0 {
                    return None;
                }
                let pole_angle = projection.angle(rho);
                let (theta, phi) = match hemisphere {
                    Hemisphere::Up => (pole_angle, dx.atan2(dy)),
                    Hemisphere::Down => (PI - pole_angle, (-dx).atan2(dy)),
                };
                Some(PixelRay {
                    direction: direction(theta, phi),
                    azimuth: phi,
                    jacobian: projection.jacobian(pole_angle) / (r * r),
                })
            }
            Camera::Panorama { width, height } => {
                let phi = FRAC_PI_2 - PI * x / width as f64;
                let elevation = FRAC_PI_2 - PI * y / height as f64;
                Some(equirect_ray(phi, elevation, PI / width as f64 * PI / height as f64))
            }
            Camera::Sphere { width, height } => {
                let phi = PI - 2.0 * PI * x / width as f64;
                let elevation = FRAC_PI_2 - PI * y / height as f64;
                Some(equirect_ray(
                    phi,
                    elevation,
                    2.0 * PI / width as f64 * PI / height as f64,
                ))
            }
        }
    }

    /// The ray through the centre of pixel (i, j); for a fisheye pixel whose
    /// centre lies outside the circle, through the nearest point of the
    /// circle's rim (the pixel's frame is that of this direction).
    pub fn centre_ray(&self, i: usize, j: usize) -> Option<PixelRay> {
        let (x, y) = (i as f64 + 0.5, j as f64 + 0.5);
        match *self {
            Camera::Fisheye { resolution, .. } => {
                let r = resolution as f64 / 2.0;
                let (dx, dy) = (x - r, y - r);
                let rho = dx.hypot(dy) / r;
                if rho > 1.0 {
                    // Just inside the rim, so that rounding keeps it there.
                    let k = (1.0 - 1e-12) / rho;
                    self.ray_at(r + dx * k, r + dy * k)
                } else {
                    self.ray_at(x, y)
                }
            }
            Camera::Panorama { .. } | Camera::Sphere { .. } => self.ray_at(x, y),
        }
    }

    /// The image point (x, y) that looks along unit `v`; `None` when no
    /// pixel does (the other hemisphere of a fisheye, behind a panorama).
    pub fn point_of(&self, v: DVec3) -> Option<(f64, f64)> {
        let theta = v.z.clamp(-1.0, 1.0).acos();
        let phi = v.y.atan2(v.x);
        match *self {
            Camera::Fisheye {
                resolution,
                hemisphere,
                projection,
            } => {
                let r = resolution as f64 / 2.0;
                let (pole_angle, sign) = match hemisphere {
                    Hemisphere::Up => (theta, 1.0),
                    Hemisphere::Down => (PI - theta, -1.0),
                };
                if pole_angle > FRAC_PI_2 {
                    return None;
                }
                let rho = projection.radius(pole_angle);
                let (dx, dy) = (sign * rho * phi.sin(), rho * phi.cos());
                Some((r + dx * r, r - dy * r))
            }
            Camera::Panorama { width, height } => {
                if phi.abs() > FRAC_PI_2 {
                    return None;
                }
                Some(((FRAC_PI_2 - phi) / PI * width as f64, theta / PI * height as f64))
            }
            Camera::Sphere { width, height } => {
                Some(((PI - phi) / (2.0 * PI) * width as f64, theta / PI * height as f64))
            }
        }
    }

    /// The solid angle (sr) of pixel (i, j), which is its mean dΩ/dA (sr
    /// per pixel area): in closed form for the equirectangular cameras;
    /// for a fisheye, Gauss–Legendre over a pixel inside the circle and, for
    /// a pixel the rim crosses, the exact flux of a field whose divergence
    /// is dΩ/dA through the boundary of the part inside (see
    /// [`fisheye_rim_solid_angle`]). Zero for a pixel outside the circle.
    pub fn pixel_solid_angle(&self, i: usize, j: usize) -> f64 {
        match *self {
            Camera::Fisheye {
                resolution, projection, ..
            } => {
                let r = resolution as f64 / 2.0;
                // The pixel in units of the circle's radius, y up.
                let (x0, x1) = ((i as f64 - r) / r, (i as f64 + 1.0 - r) / r);
                let (y0, y1) = ((r - j as f64 - 1.0) / r, (r - j as f64) / r);
                let far = x0.abs().max(x1.abs()).hypot(y0.abs().max(y1.abs()));
                let near = nearest(x0, x1).hypot(nearest(y0, y1));
                if near >= 1.0 {
                    0.0
                } else if far <= 1.0 {
                    gauss_legendre_2d(projection, [x0, x1], [y0, y1], resolution)
                } else {
                    fisheye_rim_solid_angle(projection, [x0, x1], [y0, y1])
                }
            }
            Camera::Panorama { width, height } => equirect_solid_angle(PI / width as f64, j, height),
            Camera::Sphere { width, height } => equirect_solid_angle(2.0 * PI / width as f64, j, height),
        }
    }

    /// The rows whose every direction lies below the horizon (elevation
    /// ≤ 0): the lower half of an equirectangular image (rows j with
    /// 2j ≥ height, whose top edge is at or below the horizon), every row
    /// of a downward fisheye, none of an upward one. An observer standing
    /// on the ground sees one radiance in all of them (`run::layout`).
    pub fn rows_below_horizon(&self) -> std::ops::Range<usize> {
        match *self {
            Camera::Fisheye {
                resolution, hemisphere, ..
            } => match hemisphere {
                Hemisphere::Down => 0..resolution,
                Hemisphere::Up => resolution..resolution,
            },
            Camera::Panorama { height, .. } | Camera::Sphere { height, .. } => height.div_ceil(2)..height,
        }
    }

    /// The columns of row `j` whose pixels see part of the sky (all but
    /// those of a fisheye outside its circle): the pixels that are traced.
    pub fn active_columns(&self, j: usize) -> std::ops::Range<usize> {
        match *self {
            Camera::Fisheye { resolution, .. } => {
                let r = resolution as f64 / 2.0;
                let (y0, y1) = (j as f64 - r, j as f64 + 1.0 - r);
                let dy = nearest(y0, y1);
                if dy >= r {
                    return 0..0;
                }
                // Columns [i, i + 1) meeting the open chord |x − r| < half.
                let half = (r * r - dy * dy).sqrt();
                let lo = ((r - half).floor() as usize).min(resolution);
                let hi = ((r + half).ceil() as usize).min(resolution);
                // A column whose edge only touches the chord's end holds none of it.
                let lo = if lo as f64 + 1.0 <= r - half { lo + 1 } else { lo };
                let hi = if hi as f64 - 1.0 >= r + half { hi - 1 } else { hi };
                lo..hi.max(lo)
            }
            Camera::Panorama { width, .. } | Camera::Sphere { width, .. } => 0..width,
        }
    }
}

/// The distance from 0 to the nearest point of [a, b].
fn nearest(a: f64, b: f64) -> f64 {
    if a <= 0.0 && b >= 0.0 {
        0.0
    } else {
        a.abs().min(b.abs())
    }
}

/// A row of an equirectangular image: Δφ × (sin of its top elevation − sin
/// of its bottom one).
fn equirect_solid_angle(d_phi: f64, j: usize, height: usize) -> f64 {
    let elevation = |k: usize| FRAC_PI_2 - PI * k as f64 / height as f64;
    d_phi * (elevation(j).sin() - elevation(j + 1).sin())
}

/// Gauss–Legendre nodes and weights on [−1, 1]: 2 and 4 points.
const GL2: [(f64, f64); 2] = [(-0.577_350_269_189_625_8, 1.0), (0.577_350_269_189_625_8, 1.0)];
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];
/// 8 points, for the line integrals of rim pixels.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_2, 0.101_228_536_290_376_3),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_2, 0.101_228_536_290_376_3),
];

/// ∫∫ dΩ/dA over a rectangle inside the unit circle (units of the circle's
/// radius) by Gauss–Legendre: dΩ/dA is analytic there, and 8 × 8 points
/// (4 × 4 from 32 pixels across, 2 × 2 from 512, as pixels get smaller)
/// are exact to ~1e-11 relative
/// (`tests::interior_pixels_match_a_fine_quadrature`).
fn gauss_legendre_2d(projection: Projection, x: [f64; 2], y: [f64; 2], resolution: usize) -> f64 {
    let rule: &[(f64, f64)] = match resolution {
        0..32 => &GL8,
        32..512 => &GL4,
        _ => &GL2,
    };
    let (cx, hx) = (0.5 * (x[0] + x[1]), 0.5 * (x[1] - x[0]));
    let (cy, hy) = (0.5 * (y[0] + y[1]), 0.5 * (y[1] - y[0]));
    let mut sum = 0.0;
    for &(u, wu) in rule {
        for &(v, wv) in rule {
            let rho = (cx + hx * u).hypot(cy + hy * v);
            sum += wu * wv * projection.jacobian(projection.angle(rho));
        }
    }
    sum * hx * hy
}

/// The solid angle of the part inside the unit circle of a rectangle that
/// the circle crosses, exactly: with F(ρ) = 1 − cos θ(ρ) (the cap of radius
/// ρ holds 2πF), the field G = F(ρ)/ρ² · (x, y) has divergence dΩ/dA, so
/// the solid angle is the outward flux of G through the region's boundary
/// (Gauss): ∫ G·n along the rectangle's edges inside the circle (smooth
/// integrands, 8-point Gauss–Legendre), plus F(1) = 1 times the angle of
/// the circle's arcs inside the rectangle.
pub fn fisheye_rim_solid_angle(projection: Projection, x: [f64; 2], y: [f64; 2]) -> f64 {
    // F(ρ)/ρ², from 2 sin²(θ/2) without cancellation near the centre.
    let f_over_rho2 = |rho2: f64| -> f64 {
        if rho2 < 1e-300 {
            return 0.5 * projection.jacobian(0.0);
        }
        let half = 0.5 * projection.angle(rho2.sqrt());
        2.0 * half.sin().powi(2) / rho2
    };
    // ∫ G·n along the segment of the line {fixed = c} for the free
    // coordinate in [a, b], clipped to the circle; n = ±1 along the fixed axis.
    let edge = |c: f64, a: f64, b: f64, sign: f64| -> f64 {
        if c.abs() >= 1.0 {
            return 0.0;
        }
        let limit = (1.0 - c * c).sqrt();
        let (a, b) = (a.max(-limit), b.min(limit));
        if a >= b {
            return 0.0;
        }
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        let sum: f64 = GL8
            .iter()
            .map(|&(u, w)| {
                let t = mid + half * u;
                w * f_over_rho2(c * c + t * t) * c
            })
            .sum();
        sign * sum * half
    };
    let flux = edge(x[1], y[0], y[1], 1.0) - edge(x[0], y[0], y[1], 1.0) + edge(y[1], x[0], x[1], 1.0)
        - edge(y[0], x[0], x[1], 1.0);
    // The circle's arcs inside the rectangle: cut it where it crosses the
    // rectangle's lines and keep the pieces whose middle is inside.
    let mut cuts = Vec::with_capacity(8);
    for c in [x[0], x[1]] {
        if c.abs() < 1.0 {
            let s = (1.0 - c * c).sqrt();
            cuts.extend([s.atan2(c), (-s).atan2(c)]);
        }
    }
    for c in [y[0], y[1]] {
        if c.abs() < 1.0 {
            let s = (1.0 - c * c).sqrt();
            cuts.extend([c.atan2(s), c.atan2(-s)]);
        }
    }
    let inside = |a: f64| {
        let (px, py) = (a.cos(), a.sin());
        // Closed: an arc may touch an edge (a tangent) at its middle.
        px >= x[0] && px <= x[1] && py >= y[0] && py <= y[1]
    };
    let arc = if cuts.is_empty() {
        // The whole circle is inside the rectangle, or none of it.
        if inside(0.25 * PI) { 2.0 * PI } else { 0.0 }
    } else {
        cuts.sort_by(f64::total_cmp);
        let n = cuts.len();
        (0..n)
            .map(|k| {
                let (a, b) = (cuts[k], if k + 1 < n { cuts[k + 1] } else { cuts[0] + 2.0 * PI });
                if b > a && inside(0.5 * (a + b)) { b - a } else { 0.0 }
            })
            .sum()
    };
    // F(1) = 1 − cos 90° = 1 for every projection.
    flux + arc
}

/// v = (sin θ cos φ, sin θ sin φ, cos θ).
pub fn direction(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

fn equirect_ray(phi: f64, elevation: f64, d_phi_d_elev: f64) -> PixelRay {
    PixelRay {
        direction: direction(FRAC_PI_2 - elevation, phi),
        azimuth: phi,
        jacobian: elevation.cos().max(0.0) * d_phi_d_elev,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::sampler::Sampler;

    fn cameras() -> Vec<Camera> {
        let mut v = Vec::new();
        for hemisphere in [Hemisphere::Up, Hemisphere::Down] {
            for projection in [
                Projection::Equidistant,
                Projection::Equisolid,
                Projection::Stereographic,
            ] {
                v.push(Camera::Fisheye {
                    resolution: 64,
                    hemisphere,
                    projection,
                });
            }
        }
        v.push(Camera::Panorama { width: 90, height: 60 });
        v.push(Camera::Sphere { width: 120, height: 60 });
        v
    }

    #[test]
    fn pixel_direction_round_trips_for_every_projection() {
        let mut s = Sampler::new(&[5]);
        for cam in cameras() {
            let (w, h) = cam.size();
            let mut checked = 0;
            for _ in 0..5000 {
                let (x, y) = (s.next_f64() * w as f64, s.next_f64() * h as f64);
                let Some(ray) = cam.ray_at(x, y) else { continue };
                assert!((ray.direction.length() - 1.0).abs() < 1e-12);
                let (x2, y2) = cam.point_of(ray.direction).unwrap();
                // The sphere's left and right edges are the same azimuth.
                let dx = if matches!(cam, Camera::Sphere { .. }) {
                    ((x - x2 + w as f64 / 2.0).rem_euclid(w as f64)) - w as f64 / 2.0
                } else {
                    x - x2
                };
                assert!(
                    dx.abs() < 1e-7 && (y - y2).abs() < 1e-7,
                    "{cam:?}: ({x}, {y}) → ({x2}, {y2})"
                );
                checked += 1;
            }
            assert!(checked > 3000);
        }
    }

    #[test]
    fn pixels_cover_their_solid_angle() {
        // Σ over pixels of mean dΩ/dA × pixel area: 2π for a hemisphere,
        // π·π (180° × 180° half sphere: 2π) for the panorama, 4π for the sphere.
        for (cam, expect) in [
            (
                Camera::Fisheye {
                    resolution: 128,
                    hemisphere: Hemisphere::Up,
                    projection: Projection::Equidistant,
                },
                2.0 * PI,
            ),
            (
                Camera::Fisheye {
                    resolution: 128,
                    hemisphere: Hemisphere::Down,
                    projection: Projection::Stereographic,
                },
                2.0 * PI,
            ),
            (
                Camera::Fisheye {
                    resolution: 128,
                    hemisphere: Hemisphere::Up,
                    projection: Projection::Equisolid,
                },
                2.0 * PI,
            ),
            (Camera::Panorama { width: 64, height: 64 }, 2.0 * PI),
            (Camera::Sphere { width: 128, height: 64 }, 4.0 * PI),
        ] {
            let (w, h) = cam.size();
            let total: f64 = (0..w)
                .flat_map(|i| (0..h).map(move |j| (i, j)))
                .map(|(i, j)| cam.pixel_solid_angle(i, j))
                .sum();
            assert!((total / expect - 1.0).abs() < 1e-10, "{cam:?}: {total} vs {expect}");
        }
    }

    #[test]
    fn orientation_conventions() {
        let up = Camera::Fisheye {
            resolution: 100,
            hemisphere: Hemisphere::Up,
            projection: Projection::Equidistant,
        };
        // Centre: the zenith; top edge: the horizon toward the sun; right edge: φ = +90°.
        assert!((up.ray_at(50.0, 50.0).unwrap().direction - DVec3::Z).length() < 1e-12);
        assert!((up.ray_at(50.0, 0.0).unwrap().direction - DVec3::X).length() < 1e-12);
        assert!((up.ray_at(100.0, 50.0).unwrap().direction - DVec3::Y).length() < 1e-12);
        assert!(up.ray_at(1.0, 1.0).is_none());
        let down = Camera::Fisheye {
            resolution: 100,
            hemisphere: Hemisphere::Down,
            projection: Projection::Equidistant,
        };
        assert!((down.ray_at(50.0, 50.0).unwrap().direction + DVec3::Z).length() < 1e-12);
        assert!((down.ray_at(100.0, 50.0).unwrap().direction + DVec3::Y).length() < 1e-12);
        let pano = Camera::Panorama {
            width: 180,
            height: 180,
        };
        assert!((pano.ray_at(90.0, 90.0).unwrap().direction - DVec3::X).length() < 1e-12);
        assert!((pano.ray_at(0.0, 90.0).unwrap().direction - DVec3::Y).length() < 1e-12);
        assert!((pano.ray_at(90.0, 0.0).unwrap().direction - DVec3::Z).length() < 1e-12);
        let sphere = Camera::Sphere {
            width: 360,
            height: 180,
        };
        assert!((sphere.ray_at(180.0, 90.0).unwrap().direction - DVec3::X).length() < 1e-12);
        assert!((sphere.ray_at(0.0, 90.0).unwrap().direction + DVec3::X).length() < 1e-12);
    }

    #[test]
    fn projections_invert() {
        for p in [
            Projection::Equidistant,
            Projection::Equisolid,
            Projection::Stereographic,
        ] {
            for k in 0..=90 {
                let t = (k as f64).to_radians();
                assert!((p.angle(p.radius(t)) - t).abs() < 1e-12, "{p:?} {k}");
            }
            assert!((p.radius(FRAC_PI_2) - 1.0).abs() < 1e-12);
        }
    }

    fn fisheyes(resolution: usize) -> Vec<Camera> {
        [
            Projection::Equidistant,
            Projection::Equisolid,
            Projection::Stereographic,
        ]
        .into_iter()
        .map(|projection| Camera::Fisheye {
            resolution,
            hemisphere: Hemisphere::Up,
            projection,
        })
        .collect()
    }

    #[test]
    fn small_fisheyes_have_exact_pixel_solid_angles() {
        // One pixel holds the hemisphere; two by two, a quarter each; every
        // pixel of these is a rim pixel (the arc and clipped edges).
        for cam in fisheyes(1) {
            assert!((cam.pixel_solid_angle(0, 0) - 2.0 * PI).abs() < 1e-12, "{cam:?}");
        }
        for cam in fisheyes(2) {
            for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                assert!((cam.pixel_solid_angle(i, j) - PI / 2.0).abs() < 1e-12, "{cam:?}");
            }
        }
        // Equisolid is equal-area: dΩ/dA = 2 (unit circle), so a pixel's solid
        // angle is twice its area inside the circle; the centre pixel of a
        // 3 × 3 image is inside, the corner one holds a known circular segment.
        let Camera::Fisheye { .. } = fisheyes(3)[1] else {
            unreachable!()
        };
        let cam = fisheyes(3)[1];
        let side = 2.0 / 3.0;
        assert!((cam.pixel_solid_angle(1, 1) - 2.0 * side * side).abs() < 1e-12);
        // Corner pixel [1/3, 1] × [1/3, 1]: the area of {x, y > 1/3, x² + y² < 1}.
        let a = 1.0 / 3.0;
        let b = (1.0f64 - a * a).sqrt();
        let area = 0.5 * ((b * (1.0 - b * b).sqrt() + b.asin()) - (a * (1.0 - a * a).sqrt() + a.asin())) - a * (b - a);
        assert!(
            (cam.pixel_solid_angle(2, 0) - 2.0 * area).abs() < 1e-12,
            "{} vs {}",
            cam.pixel_solid_angle(2, 0),
            2.0 * area
        );
    }

    #[test]
    fn interior_pixels_match_a_fine_quadrature() {
        for n in [8usize, 64, 127, 128, 1000] {
            for cam in fisheyes(n) {
                let Camera::Fisheye { projection, .. } = cam else {
                    unreachable!()
                };
                for (i, j) in [
                    (n / 2, n / 2),
                    (n / 2 - 1, n / 4),
                    (n / 3, n / 2 + 1),
                    (n / 8 + 1, n / 2),
                ] {
                    let r = n as f64 / 2.0;
                    let x = [(i as f64 - r) / r, (i as f64 + 1.0 - r) / r];
                    let y = [(r - j as f64 - 1.0) / r, (r - j as f64) / r];
                    if x[0].abs().max(x[1].abs()).hypot(y[0].abs().max(y[1].abs())) > 1.0 {
                        continue;
                    }
                    // 16 × 16 cells of 4 × 4 Gauss–Legendre points.
                    let mut fine = 0.0;
                    let m = 16;
                    for a in 0..m {
                        for b in 0..m {
                            let cx = [
                                x[0] + (x[1] - x[0]) * a as f64 / m as f64,
                                x[0] + (x[1] - x[0]) * (a + 1) as f64 / m as f64,
                            ];
                            let cy = [
                                y[0] + (y[1] - y[0]) * b as f64 / m as f64,
                                y[0] + (y[1] - y[0]) * (b + 1) as f64 / m as f64,
                            ];
                            fine += gauss_legendre_2d(projection, cx, cy, 64);
                        }
                    }
                    let got = cam.pixel_solid_angle(i, j);
                    assert!((got / fine - 1.0).abs() < 1e-11, "{cam:?} ({i}, {j}): {got} vs {fine}");
                }
            }
        }
    }

    #[test]
    fn rim_pixels_match_a_fine_midpoint_quadrature() {
        for cam in fisheyes(10) {
            let mut checked = 0;
            for j in 0..10 {
                for i in 0..10 {
                    let exact = cam.pixel_solid_angle(i, j);
                    let (mut sum, m) = (0.0, 400);
                    for a in 0..m {
                        for b in 0..m {
                            let (x, y) = (
                                i as f64 + (a as f64 + 0.5) / m as f64,
                                j as f64 + (b as f64 + 0.5) / m as f64,
                            );
                            sum += cam.ray_at(x, y).map_or(0.0, |r| r.jacobian);
                        }
                    }
                    let midpoint = sum / (m * m) as f64;
                    // The midpoint rule's error at the rim: O(1/m) of the pixel.
                    assert!(
                        (exact - midpoint).abs() < 2e-3 * cam.pixel_solid_angle(5, 5),
                        "{cam:?} ({i}, {j}): {exact} vs {midpoint}"
                    );
                    checked += (exact > 0.0) as usize;
                }
            }
            assert!(checked > 70);
        }
    }

    #[test]
    fn rows_below_the_horizon_see_only_directions_below_it() {
        // Every corner, edge midpoint and interior point of those rows'
        // pixels looks at or below the horizon; each row above holds a
        // point above it.
        let cameras = [
            Camera::Sphere { width: 8, height: 5 },
            Camera::Sphere { width: 64, height: 32 },
            Camera::Panorama { width: 9, height: 7 },
            Camera::Panorama { width: 10, height: 2 },
        ]
        .into_iter()
        .chain(fisheyes(7))
        .chain(fisheyes(8))
        .chain(fisheyes(7).into_iter().map(|c| match c {
            Camera::Fisheye {
                resolution, projection, ..
            } => Camera::Fisheye {
                resolution,
                hemisphere: Hemisphere::Down,
                projection,
            },
            other => other,
        }));
        for cam in cameras {
            let (w, h) = cam.size();
            let below = cam.rows_below_horizon();
            for j in 0..h {
                let mut highest = f64::NEG_INFINITY;
                for i in 0..w {
                    for (dx, dy) in [
                        (0.0, 0.0),
                        (0.5, 0.0),
                        (1.0, 0.0),
                        (0.0, 0.5),
                        (0.5, 0.5),
                        (0.5, 0.9),
                        (1.0, 1.0),
                        (0.3, 0.9),
                    ] {
                        if let Some(ray) = cam.ray_at(i as f64 + dx, j as f64 + dy) {
                            highest = highest.max(ray.direction.z);
                        }
                    }
                }
                if below.contains(&j) {
                    assert!(highest <= 1e-12, "{cam:?} row {j}: {highest}");
                } else {
                    assert!(highest > 0.0, "{cam:?} row {j}: {highest}");
                }
            }
        }
    }

    #[test]
    fn active_columns_are_the_pixels_with_a_solid_angle() {
        for n in [1usize, 2, 3, 7, 10, 33, 64] {
            for cam in fisheyes(n).into_iter().chain([Camera::Sphere { width: n, height: n }]) {
                let (w, h) = cam.size();
                for j in 0..h {
                    let cols = cam.active_columns(j);
                    for i in 0..w {
                        assert_eq!(
                            cols.contains(&i),
                            cam.pixel_solid_angle(i, j) > 0.0,
                            "{cam:?} ({i}, {j}) {cols:?}"
                        );
                    }
                }
            }
        }
    }
}
