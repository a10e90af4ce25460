//! What a finished `directions` render holds: per wavelength, albedo and
//! direction the radiance sums, and per wavelength and albedo the fluxes.

use crate::film::fluxes::Fluxes;
use crate::film::tally::Tally;
use crate::sensor::direction::Direction;

/// The radiance of one direction at one wavelength and albedo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadianceRow {
    pub wavelength_nm: f64,
    pub albedo: f64,
    pub direction: Direction,
    pub tally: Tally,
}

/// The fluxes at one wavelength and albedo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FluxRow {
    pub wavelength_nm: f64,
    pub albedo: f64,
    pub altitude_km: f64,
    pub fluxes: Fluxes,
}

/// Everything a `directions` render produces.
#[derive(Debug, Clone, Default)]
pub struct RenderResult {
    pub radiance: Vec<RadianceRow>,
    pub fluxes: Vec<FluxRow>,
}
