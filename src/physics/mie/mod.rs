//! Mie scattering from first principles: one homogeneous sphere
//! (Lorenz–Mie, [`sphere`]), truncated log-normal ensembles of spheres
//! ([`lognormal`]) with their phase matrices ([`phase_matrix`], summed over
//! the sizes by matrix products in [`ensemble_sums`]), and the
//! OPAC components' optics from their size distributions and refractive
//! indices ([`refractive`], [`opac`]), tabulated for every component,
//! humidity and table wavelength by `atmosim opac-tables` ([`generate`]) in
//! the format of [`tables`].
//!
//! Refractive indices are m = n + i·k with k ≥ 0 for absorption; phase
//! matrices are in the scattering-plane frame and normalised so that
//! ½∫₋₁¹ P11 dμ = 1 (CONVENTIONS.md §6, §11).

pub mod ensemble_sums;
pub mod generate;
pub mod lognormal;
pub mod opac;
pub mod phase_matrix;
pub mod refractive;
pub mod sphere;
pub mod tables;
