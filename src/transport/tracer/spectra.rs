//! What the channels' optics are on one path, and the basis its optical
//! depths are computed on.

use crate::atmosphere::optics::PointOptics;
use crate::atmosphere::spectral_terms::TermOptics;

use super::aerosol_phase::PhaseNode;

/// What the channels' optics are on one path: each channel's term
/// responses (`[channel·terms + term]`), extinction weights on the
/// basis (`[channel·basis + b]`) and solar factors (E0 at the channel's
/// wavelength, or 1 without a solar spectrum).
#[derive(Debug, Clone, Default)]
pub(super) struct ChannelSpectra {
    pub(super) responses: Vec<TermOptics>,
    pub(super) weights: Vec<f64>,
    pub(super) solar: Vec<f64>,
    /// Where each channel's wavelength lies in the aerosol's tabulated
    /// wavelengths (empty without phase tables).
    pub(super) phase_nodes: Vec<PhaseNode>,
    /// Where every path shares them (monochromatic channels): each
    /// channel's σ_t per layer (`[channel·layers + layer]`; the layer mean in
    /// the smooth medium) and, in the layered medium, its coefficients per
    /// layer likewise; empty otherwise.
    pub(super) sigma: Vec<f64>,
    pub(super) coefficients: Vec<PointOptics>,
}

/// The basis optical depths are computed on.
#[derive(Debug, Clone)]
pub(super) enum Basis {
    /// The extinction terms (their indices among the atmosphere's terms).
    Terms(Vec<usize>),
    /// One σ_t profile per (monochromatic) channel.
    Channels,
}
