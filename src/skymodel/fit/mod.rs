//! From rendered skies to a sky-model dataset: the method of the Prague
//! sky model's supplement (sections 1 and 2), one tested function per step.
//!
//! The images a step works on are [`SphereImage`]s (every direction, in the
//! sphere camera's layout) and [`AngleTable`]s (the (γ, α) plane).

pub mod breaks;
pub mod decompose;
pub mod emphasis;
pub mod grid;
pub mod image_fit;
pub mod laplace;
pub mod neighbours;
pub mod render_layers;
pub mod renders;
pub mod reproject;
pub mod settings;
pub mod smooth;
pub mod transmittance;
pub mod weighted;

use std::f64::consts::PI;

use glam::DVec3;

use crate::sensor::camera::direction;

/// An equirectangular image over every direction of the observer's frame
/// (z up, x toward the sun's azimuth), in the `sphere` camera's layout:
/// column i is centred on azimuth φ = π − 2π(i + ½)/w (the sun's azimuth
/// in the middle), row j on zenith angle θ = π(j + ½)/h (the zenith at the
/// top). `values` is row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereImage {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f64>,
}

impl SphereImage {
    /// An image of zeros.
    pub fn zeros(width: usize, height: usize) -> SphereImage {
        SphereImage {
            width,
            height,
            values: vec![0.0; width * height],
        }
    }

    /// The zenith angle θ of row `j`'s centre.
    pub fn theta(&self, j: usize) -> f64 {
        PI * (j as f64 + 0.5) / self.height as f64
    }

    /// The azimuth φ of column `i`'s centre.
    pub fn phi(&self, i: usize) -> f64 {
        PI - 2.0 * PI * (i as f64 + 0.5) / self.width as f64
    }

    /// The unit direction of pixel (i, j)'s centre.
    pub fn direction(&self, i: usize, j: usize) -> DVec3 {
        direction(self.theta(j), self.phi(i))
    }

    /// The solid angle of a pixel of row `j` (sr).
    pub fn solid_angle(&self, j: usize) -> f64 {
        let h = self.height as f64;
        let (t0, t1) = (PI * j as f64 / h, PI * (j + 1) as f64 / h);
        2.0 * PI / self.width as f64 * (t0.cos() - t1.cos())
    }

    /// Bilinear value at the unit direction `v`, periodic in azimuth.
    /// Between a pole and the centres of the row next to it, linear in θ
    /// from the pole's value, the mean of that row (the pole's own value
    /// for a field linear in the direction), to the row's value at
    /// the view's azimuth: a view 0.5° from the zenith reads what lies
    /// 0.5° from it, not the row 2.8° away (64 × 32 pixels), whose values
    /// toward and away from the sun differ most.
    pub fn sample(&self, v: DVec3) -> f64 {
        let (w, h) = (self.width as f64, self.height as f64);
        let theta = v.z.clamp(-1.0, 1.0).acos();
        let phi = v.y.atan2(v.x);
        let x = (PI - phi) / (2.0 * PI) * w - 0.5;
        let y = theta / PI * h - 0.5;
        let pole = |row: usize| {
            let values = &self.values[row * self.width..(row + 1) * self.width];
            values.iter().sum::<f64>() / w
        };
        if y < 0.0 {
            // y + 0.5 is θ over the row centre's θ, in [0, 1).
            let on_row = self.bilinear(x, 0.0);
            return pole(0) + (y + 0.5) * 2.0 * (on_row - pole(0));
        }
        if y > h - 1.0 {
            let on_row = self.bilinear(x, h - 1.0);
            return pole(self.height - 1) + (h - 0.5 - y) * 2.0 * (on_row - pole(self.height - 1));
        }
        self.bilinear(x, y)
    }

    /// The bilinear value at pixel coordinates (x, y), y within the rows'
    /// centres [0, h − 1], periodic in x.
    fn bilinear(&self, x: f64, y: f64) -> f64 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let col = |k: f64| (k as i64).rem_euclid(self.width as i64) as usize;
        let (c0, c1) = (col(x0), col(x0 + 1.0));
        let r0 = y0 as usize;
        let r1 = (r0 + 1).min(self.height - 1);
        let at = |r: usize, c: usize| self.values[r * self.width + c];
        (1.0 - fy) * ((1.0 - fx) * at(r0, c0) + fx * at(r0, c1)) + fy * ((1.0 - fx) * at(r1, c0) + fx * at(r1, c1))
    }
}

/// A table over the (γ, α) plane, [0, π]² with `n` nodes per axis at a
/// step of π/(n − 1) (361 nodes: 0.5°). Row-major: α is the row, γ the
/// column. `valid[k]` is false where no view direction has those angles.
#[derive(Debug, Clone, PartialEq)]
pub struct AngleTable {
    pub n: usize,
    pub values: Vec<f64>,
    pub valid: Vec<bool>,
}

impl AngleTable {
    /// The angle of node `k` on either axis.
    pub fn angle(&self, k: usize) -> f64 {
        PI * k as f64 / (self.n - 1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_pixels_cover_the_sphere_and_sample_back() {
        let mut img = SphereImage::zeros(64, 32);
        let total: f64 = (0..32).map(|j| img.solid_angle(j) * 64.0).sum();
        assert!((total - 4.0 * PI).abs() < 1e-12);
        for j in 0..32 {
            for i in 0..64 {
                img.values[j * 64 + i] = (i * 100 + j) as f64;
            }
        }
        for (i, j) in [(0, 0), (5, 7), (63, 31), (32, 16)] {
            assert!((img.sample(img.direction(i, j)) - img.values[j * 64 + i]).abs() < 1e-9);
        }
        // The sun's azimuth (φ = 0) lies between the two middle columns.
        assert!((img.phi(31) + img.phi(32)).abs() < 1e-12);
    }

    #[test]
    fn views_closer_to_a_pole_than_the_first_row_read_across_it() {
        // A field linear in the direction, 1 + 0.3·x − 0.2·y + 0.1·z, at the
        // pixel centres of 64 × 32 (the first row 2.8° from the zenith).
        let mut img = SphereImage::zeros(64, 32);
        let f = |v: DVec3| 1.0 + 0.3 * v.x - 0.2 * v.y + 0.1 * v.z;
        for j in 0..32 {
            for i in 0..64 {
                img.values[j * 64 + i] = f(img.direction(i, j));
            }
        }
        // At the poles: the field there (the row's mean is the pole's value
        // plus z's part, cos 2.8°·0.1, short of 0.1 by 1.2e-4).
        let theta0 = img.theta(0);
        let pole = 1.0 + 0.1 * theta0.cos();
        assert!((img.sample(DVec3::Z) - pole).abs() < 1e-12);
        assert!((img.sample(-DVec3::Z) - (1.0 - 0.1 * theta0.cos())).abs() < 1e-12);
        // 0.5° and 2° from the zenith, toward +x and toward −y: the field
        // there to 4e-4 (the azimuthal interpolation of a 5.6° row and the
        // chord), where reading the row itself is off by 0.3·(sin 2.8° −
        // sin θ), up to 1.2e-2.
        for deg in [0.5f64, 2.0] {
            let t = deg.to_radians();
            for v in [DVec3::new(t.sin(), 0.0, t.cos()), DVec3::new(0.0, -t.sin(), t.cos())] {
                let e = (img.sample(v) - f(v)).abs();
                assert!(e < 4e-4, "{deg}° {v}: {e}");
                let nadir = DVec3::new(v.x, v.y, -v.z);
                assert!((img.sample(nadir) - f(nadir)).abs() < 4e-4, "{deg}° below");
            }
        }
        // At the row's centres the value is the row's, as before.
        let on_row = DVec3::new(theta0.sin(), 0.0, theta0.cos());
        let x = (PI - 0.0) / (2.0 * PI) * 64.0 - 0.5;
        assert!((img.sample(on_row) - img.bilinear(x, 0.0)).abs() < 1e-12);
    }
}
