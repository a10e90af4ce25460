//! The reference frame an output Stokes vector is given in, and how an
//! image pixel keeps one frame over its whole area.
//!
//! A Stokes vector of the light arriving from viewing direction `v` needs a
//! reference axis `e1 ⟂ v` (with `e2 = k × e1`, `k = −v`; see
//! [`crate::polarization::stokes`]). Two frames are offered (closed set):
//!
//! - **meridian** (the default): `e1 = ∂v/∂θ`, in the plane of `v` and the
//!   zenith ([`crate::polarization::stokes::meridian_frame`]); at exactly the zenith or the
//!   nadir, the meridian plane of the requested azimuth (a pixel centred on
//!   the pole: the pixel centre's azimuth as the camera gives it, 0 for a
//!   fisheye, i.e. `e1` toward the sun's azimuth looking up and away from it
//!   looking down). IPRT's and libRadtran/MYSTIC's frame.
//! - **sun–view**: `e1` perpendicular to the plane of `v` and the sun, along
//!   `s × v` (its sign does not change Q or U). Single Rayleigh scattering
//!   then gives `Q = +DoLP·I`, `U = 0`; this is the frame of the sky model's
//!   signed degree of polarisation. Where `v` is along the sun or away from
//!   it the plane is undefined and the meridian axis is used.
//!
//! A pixel averages the light of many directions, and a frame that turns
//! inside the pixel (the meridian frame at the zenith turns through a full
//! circle around it) would cancel the polarisation of the average. So a
//! pixel's frame is the frame of its centre direction `c`, carried to each
//! sample direction `d` by the rotation about `c × d` that takes `c` to `d`
//! (the shortest one): a frame continuous over the pixel, equal to the
//! chosen frame at the centre. The pixel's Stokes vector is then the mean
//! over its solid angle of the Stokes vectors in these carried frames.

use glam::DVec3;

use crate::polarization::stokes::meridian_frame;

/// Below this |v × s| (sin of the angle between the view and the sun) the
/// sun–view plane is taken as undefined.
const SUN_VIEW_MIN_SIN: f64 = 1e-9;

/// The frame of output Stokes vectors (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StokesFrame {
    /// `e1` in the plane of the view and the zenith.
    #[default]
    Meridian,
    /// `e1` perpendicular to the plane of the view and the sun.
    SunView,
}

impl StokesFrame {
    /// The name used in job files and output metadata.
    pub fn name(self) -> &'static str {
        match self {
            StokesFrame::Meridian => "meridian",
            StokesFrame::SunView => "sun_view",
        }
    }

    /// The reference axis `e1` (unit, ⟂ `v`) for viewing direction `v`
    /// (unit); `phi_fallback` (radians) is the azimuth of the meridian plane
    /// at the exact zenith or nadir; `sun` is the unit vector toward the sun.
    pub fn axis(self, v: DVec3, phi_fallback: f64, sun: DVec3) -> DVec3 {
        match self {
            StokesFrame::Meridian => meridian_frame(v, phi_fallback).0,
            StokesFrame::SunView => {
                let n = sun.cross(v);
                let len = n.length();
                if len > SUN_VIEW_MIN_SIN {
                    n / len
                } else {
                    meridian_frame(v, phi_fallback).0
                }
            }
        }
    }

    /// A one-line description for output metadata.
    pub fn describe(self) -> &'static str {
        match self {
            StokesFrame::Meridian => {
                "meridian: e1 = dv/dtheta (in the plane of the view direction v and the zenith), e2 = k x e1 with k = -v \
                 the propagation direction; at the exact zenith or nadir the meridian plane of azimuth phi (0 for a \
                 pixel centred there)"
            }
            StokesFrame::SunView => {
                "sun_view: e1 perpendicular to the plane of the view direction v and the sun (along s x v), \
                 e2 = k x e1 with k = -v; single Rayleigh scattering gives Q = +DoLP I, U = 0"
            }
        }
    }
}

/// `e1` (⟂ `from`) carried to `to` by the rotation about `from × to` that
/// takes unit `from` to unit `to`: `R a = (c·a) + w × a + w (w·a)/(1 + c)`
/// with `w = from × to` and `c = from · to` (Rodrigues' formula without
/// square roots). The result is re-orthogonalised to `to` and normalised.
/// `from` and `to` must not be opposite (a pixel never spans 180°).
pub fn carry(e1: DVec3, from: DVec3, to: DVec3) -> DVec3 {
    let w = from.cross(to);
    let c = from.dot(to);
    let carried = c * e1 + w.cross(e1) + w * (w.dot(e1) / (1.0 + c));
    (carried - carried.dot(to) * to).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polarization::stokes::{Stokes, StokesRotation};
    use crate::sensor::camera::direction;

    /// The sun at elevation 30°, azimuth 0.
    fn sun() -> DVec3 {
        direction(60f64.to_radians(), 0.0)
    }

    #[test]
    fn axes_are_unit_and_perpendicular_to_the_view() {
        for frame in [StokesFrame::Meridian, StokesFrame::SunView] {
            for (t, p) in [
                (0.0, 0.3),
                (10.0, 40.0),
                (60.0, 0.0),
                (90.0, 180.0),
                (135.0, -70.0),
                (180.0, 1.0),
            ] {
                let v = direction(f64::to_radians(t), f64::to_radians(p));
                let e1 = frame.axis(v, 0.3, sun());
                assert!((e1.length() - 1.0).abs() < 1e-12, "{frame:?} {t} {p}");
                assert!(e1.dot(v).abs() < 1e-12, "{frame:?} {t} {p}");
            }
        }
    }

    #[test]
    fn sun_view_axis_is_perpendicular_to_the_sun_and_falls_back_at_the_sun() {
        let v = direction(30f64.to_radians(), 100f64.to_radians());
        let e1 = StokesFrame::SunView.axis(v, 0.0, sun());
        assert!(e1.dot(sun()).abs() < 1e-12);
        // Along the sun (and away from it) the meridian axis.
        for v in [sun(), -sun()] {
            let e1 = StokesFrame::SunView.axis(v, 0.0, sun());
            assert!((e1 - meridian_frame(v, 0.0).0).length() < 1e-12);
        }
    }

    #[test]
    fn meridian_axis_at_the_zenith_follows_the_fallback_azimuth() {
        let e1 = StokesFrame::Meridian.axis(DVec3::Z, 0.0, sun());
        assert!((e1 - DVec3::X).length() < 1e-12);
        let e1 = StokesFrame::Meridian.axis(DVec3::Z, std::f64::consts::FRAC_PI_2, sun());
        assert!((e1 - DVec3::Y).length() < 1e-12);
        let e1 = StokesFrame::Meridian.axis(-DVec3::Z, 0.0, sun());
        assert!((e1 + DVec3::X).length() < 1e-12);
    }

    #[test]
    fn carrying_is_the_identity_at_the_start_and_keeps_the_frame_rigid() {
        let c = direction(0.2, 1.0);
        let e1 = meridian_frame(c, 0.0).0;
        assert!((carry(e1, c, c) - e1).length() < 1e-15);
        // The rotation preserves angles: two axes a quarter turn apart stay so.
        let e2 = (-c).cross(e1);
        for d in [direction(0.25, 1.1), direction(0.01, 3.0), direction(0.6, -2.0)] {
            let (a, b) = (carry(e1, c, d), carry(e2, c, d));
            assert!(a.dot(d).abs() < 1e-14 && b.dot(d).abs() < 1e-14);
            assert!(a.dot(b).abs() < 1e-12, "{d}");
            // Handedness: b = k × a at d, as e2 = k × e1 at c.
            assert!(((-d).cross(a) - b).length() < 1e-12, "{d}");
        }
    }

    #[test]
    fn carried_frames_are_continuous_across_the_zenith_where_the_meridian_frame_is_not() {
        // A ring of directions 0.5° from the zenith: the meridian frame turns
        // through a full circle around it, the carried zenith frame stays put.
        let c = DVec3::Z;
        let e1c = StokesFrame::Meridian.axis(c, 0.0, sun());
        let light = Stokes::new(1.0, 0.4, 0.0, 0.0); // polarised along e1c
        let mut mean_carried = Stokes::zero();
        let mut mean_meridian = Stokes::zero();
        let n = 360;
        for k in 0..n {
            let d = direction(0.5f64.to_radians(), 2.0 * std::f64::consts::PI * k as f64 / n as f64);
            let e1d = carry(e1c, c, d);
            // The same light (nearly uniform around the pole: polarised along
            // the carried axis), referred to the carried and the meridian axes.
            mean_carried += light * (1.0 / n as f64);
            let to_meridian = StokesRotation::between(e1d, meridian_frame(d, 0.0).0, -d);
            mean_meridian += to_meridian.apply(light) * (1.0 / n as f64);
            assert!((e1d - e1c).length() < 0.01);
        }
        assert!((mean_carried.degree_of_linear_polarization() - 0.4).abs() < 1e-12);
        assert!(mean_meridian.degree_of_linear_polarization() < 1e-3);
    }
}
