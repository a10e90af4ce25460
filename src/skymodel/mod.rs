//! Fitted sky models: the dataset format of the Prague sky model's public
//! runtime, that runtime's evaluation in Rust, and the fitter that makes a
//! dataset from rendered skies and transmittance tables.
//!
//! - `angles`: the runtime's view angles (γ, θ, θ′, σ, α), shared by the
//!   fitter and the evaluation;
//! - `dataset`: the file format, written and read field by field;
//! - `runtime`: evaluation with the runtime's semantics (radiance,
//!   polarisation, transmittance, the sun);
//! - `fit/`: from renders to a dataset, one tested function per step;
//! - `fit_files`: the names of a fit's sidecars and shards, and `combine`,
//!   the shards joined.

pub mod angles;
pub mod combine;
pub mod dataset;
pub mod eval_image;
pub mod fit;
pub mod fit_files;
pub mod queries;
pub mod report;
pub mod runtime;
