//! Image sensors: how pixels map to viewing directions in the observer's
//! frame (z up, x toward the sun's azimuth, azimuth φ counter-clockwise
//! seen from above; shared/CONVENTIONS.md).
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

    /// Mean dΩ/dA over pixel (i, j) (16 × 16 midpoint quadrature, zero
    /// outside a fisheye's circle): the pixel's solid angle per pixel area.
    pub fn mean_jacobian(&self, i: usize, j: usize) -> f64 {
        const N: usize = 16;
        let mut sum = 0.0;
        for a in 0..N {
            for b in 0..N {
                let x = i as f64 + (a as f64 + 0.5) / N as f64;
                let y = j as f64 + (b as f64 + 0.5) / N as f64;
                sum += self.ray_at(x, y).map_or(0.0, |r| r.jacobian);
            }
        }
        sum / (N * N) as f64
    }
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
    use crate::sampler::Sampler;

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
                .map(|(i, j)| cam.mean_jacobian(i, j))
                .sum();
            assert!((total / expect - 1.0).abs() < 2e-3, "{cam:?}: {total} vs {expect}");
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
}
