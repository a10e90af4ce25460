//! A subset of libRadtran's uvspec input language (Mayer & Kylling 2005;
//! Emde et al. 2016, the libRadtran 2 user guide): enough to describe
//! single-wavelength radiance runs over an AFGL atmosphere with ozone, OPAC or
//! explicit Henyey–Greenstein aerosol and a Lambertian ground, mapped onto an
//! atmosim [`Job`](crate::job::Job). `run` renders it; `format` prints uvspec-style output.
//!
//! Directions: uvspec's `umu` is the cosine of the zenith angle of the
//! direction the light PROPAGATES (umu < 0: downwelling radiance, the sensor
//! looks up), so atmosim's view zenith is θ = acos(−umu). uvspec's `phi` and
//! `phi0` share one azimuth origin; phi − phi0 = 0 is a sensor looking toward
//! the sun's azimuth. atmosim computes φ = (phi − phi0) mod 360 and reports
//! Q and U in its own meridian frame, the pair IPRT's MYSTIC results satisfy
//! (validation/README.md): libRadtran counts azimuths clockwise, so the
//! geometric mirror image φ = phi0 − phi differs only by the sign of U, and
//! a horizontally homogeneous atmosphere is mirror-symmetric.

mod input;
mod job_map;
mod output;

pub use input::*;
pub use output::{UvspecResult, ZoutResult, format_csv, format_uvspec, run};

#[cfg(test)]
mod tests;
