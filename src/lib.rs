//! # atmosim
//!
//! A spectral, polarised Monte Carlo path tracer for the Earth's atmosphere,
//! producing the reference skies that fitted sky models are built from.
//!
//! Conventions (shared/CONVENTIONS.md, pinned by tests): wavelengths in nm,
//! lengths in km (f64), coefficients in km⁻¹; angles in degrees at the edges
//! and radians inside; radiance per unit extraterrestrial solar irradiance
//! (E0 = 1, sr⁻¹); Stokes vectors (I, Q, U, V) in the meridian frame of the
//! viewing direction, as IPRT and libRadtran/MYSTIC define them, or on
//! request in the sun–view frame; an image pixel's in the frame of its
//! centre carried over the pixel ([`stokes_frame`]).
//!
//! Data flow: job file → [`job::Job`] → [`atmosphere::Atmosphere`] (optical
//! properties per layer and wavelength) → sensor → integrator → film → output.

pub mod aerosol;
pub mod atmosphere;
pub mod bench;
pub mod camera;
pub mod checkpoint;
pub mod color;
pub mod constants;
pub mod data;
pub mod error;
pub mod film;
pub mod flight_density;
pub mod input;
pub mod integrator;
pub mod job;
pub mod medium;
pub mod merge;
pub mod openexr;
pub mod out_dir;
pub mod output;
pub mod ozone;
pub mod phase;
pub mod plan;
pub mod profile;
pub mod rayleigh;
pub mod render;
pub mod report;
pub mod sampler;
pub mod shard;
pub mod shell;
pub mod sky_image;
pub mod solar;
pub mod spectral;
pub mod spectral_terms;
pub mod stats;
pub mod stokes;
pub mod stokes_frame;
pub mod sun;
pub mod sun_depth;
pub mod sun_table;
pub mod task_output;
pub mod tracking;
pub mod transmittance;
pub mod unit;
pub mod uvspec;
pub mod validate;
pub mod visibility;

pub use error::{Error, Result};
