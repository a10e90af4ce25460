//! Optical depths of one wavelength's medium along a ray: to where it leaves,
//! or over a given length (exact for the layered medium, by quadrature for
//! the smooth one).

use std::ops::ControlFlow;

use crate::geometry::ray::{Ray, WalkEnd, walk};
use crate::geometry::shell::Geometry;
use crate::transport::medium::Medium;

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

#[cfg(test)]
mod tests {
    use super::*;

    use glam::DVec3;

    use crate::geometry::ray::test_slant_ray as slant_ray;
    use crate::geometry::ray::*;
    use crate::geometry::shell::Geometry;

    use crate::job::options::MediumModel;

    use crate::transport::medium::test_medium as medium;

    const R: f64 = 6378.0;

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
        let (_, end) = optical_depth(&m, &Geometry::Spherical { radius_km: R }, &down);
        assert!(matches!(end, WalkEnd::Ground { .. }));
    }
}
