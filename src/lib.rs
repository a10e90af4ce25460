//! # atmosim
//!
//! A spectral, polarised Monte Carlo path tracer for the Earth's atmosphere,
//! producing the reference skies that fitted sky models are built from.
//!
//! Conventions (CONVENTIONS.md, pinned by tests): wavelengths in nm,
//! lengths in km (f64), coefficients in km⁻¹; angles in degrees at the edges
//! and radians inside; radiance per unit extraterrestrial solar irradiance
//! (E0 = 1, sr⁻¹); Stokes vectors (I, Q, U, V) in the meridian frame of the
//! viewing direction, as IPRT and libRadtran/MYSTIC define them, or on
//! request in the sun–view frame; an image pixel's in the frame of its
//! centre carried over the pixel ([`stokes_frame`]).
//!
//! Data flow: job file → [`job::Job`] → [`atmosphere::Atmosphere`] (optical
//! properties per layer and wavelength) → sensor → integrator → film → output.

pub mod atmosphere;
pub mod compat;
pub mod error;
pub mod film;
pub mod fnv;
pub mod geometry;
pub mod io;
pub mod job;
pub mod physics;
pub mod polarization;
pub mod run;
pub mod sampling;
pub mod sensor;
pub mod transport;

pub use error::{Error, Result};
