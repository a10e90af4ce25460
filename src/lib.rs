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
//! centre carried over the pixel ([`polarization::stokes_frame`]).
//!
//! The folders are the data flow: each imports only from those above it in
//! this list (`tests/layering.rs` reads the imports and checks; `error` and
//! `fnv` sit at the root, below everything):
//!
//! ```text
//! physics/       constants, Rayleigh, ozone, OPAC aerosol, Mie, visibility, gas profiles,
//!                the solar spectrum, and the embedded data tables they read
//! geometry/      shells and slabs, rays and their walk, half chords, the sun,
//!                orthonormal bases
//! polarization/  Stokes vectors, Mueller and phase matrices, Stokes frames
//! sampling/      random streams and their typed keys
//! atmosphere/    levels and one optics record per layer and wavelength; reports
//! sensor/        viewing directions and cameras
//! job/           job file → resolved, validated Job and its task grid
//! transport/     medium, free flight, the path tracer, sun connections,
//!                transmittance, and scenes built from a job
//! film/          sums of samples: directions, fluxes, images, their results
//! io/            CSV, OpenEXR, PNG previews, task files; atomic writes
//! run/           work units, shards, checkpoints, merges, plans (no physics)
//! compat/        uvspec input and output, validation against references
//! skymodel/      the Prague sky model's dataset format, its runtime in Rust, the fitter
//! ```
//!
//! The binary (`src/main.rs`, `src/cli/`) parses the command line, calls
//! the library and maps errors to exit codes.

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
pub mod skymodel;
pub mod transport;

pub use error::{Error, Result};
