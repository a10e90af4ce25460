//! The sky's symmetries, and the image columns they pair.
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
//! ([`crate::film::tally::Tally::mirrored`]). With the sun at the zenith
//! the sky is also symmetric under every rotation about the vertical, in
//! which the meridian frame (and the sun–view frame) turn along: an
//! equirectangular image's columns (sphere, panorama) are then rotations of
//! one another, so with [`Symmetry::Rotation`] its first column alone is
//! traced and every column holds its Stokes vectors unchanged. A copied
//! pixel's estimate is its source's: unbiased, with its source's error.

use crate::sensor::camera::Camera;

/// What a job lets an image use (`sensor.symmetry`, closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SymmetryChoice {
    /// Every symmetry of the sky that maps the image's pixels onto one
    /// another: the mirror, and the rotation for a sun at the zenith seen
    /// by an equirectangular image.
    Auto,
    /// The mirror alone.
    Mirror,
    /// None: every column traced.
    None,
}

/// Whether a sun at the zenith makes the columns of `camera`'s images
/// rotations of one another (an equirectangular image: sphere, panorama).
pub fn rotates(camera: &Camera) -> bool {
    matches!(camera, Camera::Sphere { .. } | Camera::Panorama { .. })
}

impl SymmetryChoice {
    /// The symmetry an image of `camera` uses with the sun `sun_zenith_deg`
    /// from the zenith.
    pub fn resolve(self, camera: &Camera, sun_zenith_deg: f64) -> Symmetry {
        match self {
            SymmetryChoice::Auto if rotates(camera) && sun_zenith_deg == 0.0 => Symmetry::Rotation,
            SymmetryChoice::Auto | SymmetryChoice::Mirror => Symmetry::Mirror,
            SymmetryChoice::None => Symmetry::None,
        }
    }

    /// The job file's value.
    pub fn key_value(self) -> &'static str {
        match self {
            SymmetryChoice::Auto => "auto",
            SymmetryChoice::Mirror => "mirror",
            SymmetryChoice::None => "none",
        }
    }
}

/// Which columns of an image are traced, and which copy them (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// Trace columns `0 .. ⌈width/2⌉`; the rest are their mirror images.
    Mirror,
    /// Trace column 0; every other column is a rotation of it.
    Rotation,
    /// Trace every column.
    None,
}

impl Symmetry {
    /// The columns of an image `width` wide that are traced: `0 .. n`.
    pub fn traced_columns(self, width: usize) -> usize {
        match self {
            Symmetry::Mirror => width.div_ceil(2),
            Symmetry::Rotation => width.min(1),
            Symmetry::None => width,
        }
    }

    /// The traced column that column `i` of an image `width` wide copies,
    /// or `None` when column `i` is traced itself.
    pub fn source_column(self, width: usize, i: usize) -> Option<usize> {
        if i < self.traced_columns(width) || i >= width {
            return None;
        }
        match self {
            Symmetry::Mirror => Some(width - 1 - i),
            Symmetry::Rotation => Some(0),
            Symmetry::None => None,
        }
    }

    /// The column that column `i` of an image `width` wide shows the same
    /// radiance as: itself where it is traced, else its source.
    pub fn traced_column(self, width: usize, i: usize) -> usize {
        self.source_column(width, i).unwrap_or(i)
    }

    /// True when a copied column's U and V are its source's negated (the
    /// mirror); a rotation keeps all four.
    pub fn negates_u_v(self) -> bool {
        self == Symmetry::Mirror
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
            Symmetry::Rotation if width > 1 => "rotation: column 0 is traced; every other column holds its Stokes \
                 vectors (the sun at the zenith: the sky is symmetric about the vertical, and the frames turn with \
                 the azimuth)"
                .into(),
            Symmetry::Mirror | Symmetry::Rotation | Symmetry::None => "none: every column traced".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::camera::{Camera, Hemisphere, Projection};

    #[test]
    fn the_rotation_needs_the_sun_at_the_zenith_and_an_equirectangular_image() {
        let sphere = Camera::Sphere { width: 8, height: 4 };
        let panorama = Camera::Panorama { width: 8, height: 4 };
        let fisheye = Camera::Fisheye {
            resolution: 8,
            hemisphere: Hemisphere::Up,
            projection: Projection::Equidistant,
        };
        assert_eq!(SymmetryChoice::Auto.resolve(&sphere, 0.0), Symmetry::Rotation);
        assert_eq!(SymmetryChoice::Auto.resolve(&panorama, 0.0), Symmetry::Rotation);
        assert_eq!(SymmetryChoice::Auto.resolve(&fisheye, 0.0), Symmetry::Mirror);
        assert_eq!(SymmetryChoice::Auto.resolve(&sphere, 1e-9), Symmetry::Mirror);
        assert_eq!(SymmetryChoice::Mirror.resolve(&sphere, 0.0), Symmetry::Mirror);
        assert_eq!(SymmetryChoice::None.resolve(&sphere, 0.0), Symmetry::None);
        for i in 0..8 {
            assert_eq!(Symmetry::Rotation.traced_column(8, i), 0);
        }
        assert_eq!(Symmetry::Rotation.source_column(8, 0), None);
        assert!(Symmetry::Mirror.negates_u_v() && !Symmetry::Rotation.negates_u_v());
    }

    /// An equirectangular image's column i + k looks along column i's
    /// directions turned about the vertical by k columns' azimuth.
    #[test]
    fn equirectangular_columns_are_turned_copies_of_one_another() {
        for (camera, d_phi) in [
            (Camera::Sphere { width: 16, height: 8 }, -std::f64::consts::TAU / 16.0),
            (Camera::Panorama { width: 9, height: 6 }, -std::f64::consts::PI / 9.0),
        ] {
            let (w, h) = camera.size();
            for j in 0..h {
                let (x, y) = (0.3, j as f64 + 0.6);
                let a = camera.ray_at(x, y).unwrap();
                for k in 1..w {
                    let b = camera.ray_at(x + k as f64, y).unwrap();
                    let (s, c) = (k as f64 * d_phi).sin_cos();
                    let turned = glam::DVec3::new(
                        c * a.direction.x - s * a.direction.y,
                        s * a.direction.x + c * a.direction.y,
                        a.direction.z,
                    );
                    assert!((turned - b.direction).length() < 1e-12, "{camera:?} ({k}, {j})");
                    let (pa, pb) = (camera.pixel_solid_angle(0, j), camera.pixel_solid_angle(k, j));
                    assert!((pa - pb).abs() <= 1e-12 * pa);
                }
            }
        }
    }

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
