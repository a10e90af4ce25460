//! A viewing direction of a `directions` sensor: view zenith and azimuth
//! relative to the sun's, its unit vector and the Stokes axis it is reported
//! in.

use glam::DVec3;

use crate::polarization::stokes::meridian_frame;
use crate::polarization::stokes_frame::StokesFrame;

/// A viewing direction: view zenith (0 = zenith, 180 = nadir) and azimuth
/// relative to the sun's, counter-clockwise from above, in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Direction {
    pub view_zenith_deg: f64,
    pub azimuth_deg: f64,
}

impl Direction {
    /// The unit vector v = (sin θ cos φ, sin θ sin φ, cos θ).
    pub fn vector(&self) -> DVec3 {
        let (st, ct) = self.view_zenith_deg.to_radians().sin_cos();
        let (sp, cp) = self.azimuth_deg.to_radians().sin_cos();
        DVec3::new(st * cp, st * sp, ct)
    }

    /// The Stokes reference axis e1 of this direction in `frame`
    /// ([`crate::polarization::stokes_frame`]); `sun` is the unit vector toward the sun.
    pub fn axis(&self, frame: StokesFrame, sun: DVec3) -> DVec3 {
        frame.axis(self.vector(), self.azimuth_deg.to_radians(), sun)
    }

    /// The meridian axis e1 = ∂v/∂θ of this direction (at the zenith or
    /// nadir, that of its azimuth).
    pub fn meridian_axis(&self) -> DVec3 {
        meridian_frame(self.vector(), self.azimuth_deg.to_radians()).0
    }
}
