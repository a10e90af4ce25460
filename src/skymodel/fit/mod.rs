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

    /// Bilinear value at the unit direction `v`: periodic in azimuth,
    /// clamped to the first and last rows' centres in θ.
    pub fn sample(&self, v: DVec3) -> f64 {
        let (w, h) = (self.width as f64, self.height as f64);
        let theta = v.z.clamp(-1.0, 1.0).acos();
        let phi = v.y.atan2(v.x);
        let x = (PI - phi) / (2.0 * PI) * w - 0.5;
        let y = (theta / PI * h - 0.5).clamp(0.0, h - 1.0);
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
}
