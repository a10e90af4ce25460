//! The sky's mirror symmetry, and the image columns it pairs.
//!
//! The atmosphere is a set of concentric shells (or plane layers) over a
//! uniform Lambertian ground, and the sun lies in the observer's x–z plane
//! (its azimuth is 0 by construction, CONVENTIONS.md §3), so the sky is
//! symmetric under the reflection y → −y, φ → −φ: I and Q are even in φ, U
//! and V odd (§4). Every image sensor maps that reflection onto its
//! columns, column `i` onto column `width − 1 − i` (the sphere and the
//! panorama have the sun's azimuth at their middle, a fisheye has it
//! straight up), so with [`Symmetry::Mirror`] only the first ⌈width/2⌉
//! columns are traced and the others are their mirror images
//! ([`crate::film::tally::Tally::mirrored`]). A mirrored pixel's estimate is
//! its partner's: unbiased, with its partner's error, at half the paths.

/// Whether an image traces every column or the half the sky's mirror
/// symmetry does not give (closed set; `sensor.symmetry`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// Trace columns `0 .. ⌈width/2⌉`; the rest are their mirror images.
    Mirror,
    /// Trace every column.
    None,
}

impl Symmetry {
    /// The columns of an image `width` wide that are traced: `0 .. n`.
    pub fn traced_columns(self, width: usize) -> usize {
        match self {
            Symmetry::Mirror => width.div_ceil(2),
            Symmetry::None => width,
        }
    }

    /// The traced column that column `i` of an image `width` wide mirrors,
    /// or `None` when column `i` is traced itself.
    pub fn source_column(self, width: usize, i: usize) -> Option<usize> {
        (i >= self.traced_columns(width) && i < width).then(|| width - 1 - i)
    }

    /// The column that column `i` of an image `width` wide shows the same
    /// radiance as: itself where it is traced, else its mirror image.
    pub fn traced_column(self, width: usize, i: usize) -> usize {
        self.source_column(width, i).unwrap_or(i)
    }

    /// A one-line description for output metadata.
    pub fn describe(self, width: usize) -> String {
        match self {
            Symmetry::Mirror if width > 1 => format!(
                "mirror: columns 0 to {} are traced; column i >= {} is the mirror image of column {} - i (the sky \
                 is symmetric about the sun's vertical plane: I and Q the same, U and V negated)",
                self.traced_columns(width) - 1,
                self.traced_columns(width),
                width - 1
            ),
            Symmetry::Mirror | Symmetry::None => "none: every column traced".into(),
        }
    }

    /// The job file's value.
    pub fn key_value(self) -> &'static str {
        match self {
            Symmetry::Mirror => "mirror",
            Symmetry::None => "none",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::camera::{Camera, Hemisphere, Projection};

    #[test]
    fn mirror_pairs_the_columns_of_both_halves() {
        for width in [1, 2, 7, 64] {
            let n = Symmetry::Mirror.traced_columns(width);
            assert_eq!(n, width.div_ceil(2));
            for i in 0..width {
                let src = Symmetry::Mirror.source_column(width, i);
                match src {
                    None => assert!(i < n),
                    Some(s) => {
                        assert!(s < n && i >= n);
                        assert_eq!(s + i, width - 1);
                    }
                }
                assert_eq!(Symmetry::None.source_column(width, i), None);
            }
        }
        assert_eq!(Symmetry::None.traced_columns(9), 9);
    }

    /// Every camera maps the reflection φ → −φ onto x → width − x, and its
    /// traced columns of each row are symmetric, so column i's mirror image
    /// is column width − 1 − i.
    #[test]
    fn every_camera_mirrors_its_columns_about_the_sun_azimuth() {
        let mut cameras = vec![
            Camera::Sphere { width: 64, height: 32 },
            Camera::Sphere { width: 7, height: 5 },
            Camera::Panorama { width: 10, height: 6 },
        ];
        for resolution in [8, 9, 33] {
            for hemisphere in [Hemisphere::Up, Hemisphere::Down] {
                for projection in [
                    Projection::Equidistant,
                    Projection::Equisolid,
                    Projection::Stereographic,
                ] {
                    cameras.push(Camera::Fisheye {
                        resolution,
                        hemisphere,
                        projection,
                    });
                }
            }
        }
        for camera in cameras {
            let (w, h) = camera.size();
            for j in 0..h {
                let cols = camera.active_columns(j);
                assert!(cols.is_empty() || cols.start + cols.end == w, "{camera:?} row {j}");
                for k in 0..5 {
                    let (x, y) = ((0.05 + 0.19 * k as f64) * w as f64, j as f64 + 0.37);
                    let (Some(a), Some(b)) = (camera.ray_at(x, y), camera.ray_at(w as f64 - x, y)) else {
                        assert!(camera.ray_at(x, y).is_none() && camera.ray_at(w as f64 - x, y).is_none());
                        continue;
                    };
                    let mirrored = glam::DVec3::new(a.direction.x, -a.direction.y, a.direction.z);
                    assert!((mirrored - b.direction).length() < 1e-12, "{camera:?} at ({x}, {y})");
                    assert!((a.jacobian - b.jacobian).abs() <= 1e-12 * a.jacobian.abs());
                }
                for i in 0..w {
                    let (a, b) = (camera.pixel_solid_angle(i, j), camera.pixel_solid_angle(w - 1 - i, j));
                    assert!((a - b).abs() <= 1e-9 * a.max(b), "{camera:?} pixel ({i}, {j})");
                }
            }
        }
    }
}
