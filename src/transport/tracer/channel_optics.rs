//! The channels' optics on one path: each channel's term optics, its weights
//! on the extinction basis and its solar factor; σ_t, majorants and
//! coefficients per layer or point, and optical depths combined from the
//! basis (τ_λ = Σ_b W_λb·τ_b).

use glam::DVec3;

use crate::atmosphere::optics::PointOptics;
use crate::atmosphere::spectral_terms::{TermOptics, TermShape};
use crate::geometry::ray::Ray;
use crate::geometry::shell::Geometry;
use crate::sampling::sampler::Sampler;
use crate::transport::medium::shape_integrals;

use crate::polarization::phase_mixture::PhaseMixture;
use crate::polarization::phase_table_set::PhaseTableSet;

use super::scene::Scene;
use super::spectra::{Basis, ChannelSpectra};
use super::vertex::phase_mixture;

impl Scene {
    /// Fills the spectra's solar factors for the channels' wavelengths
    /// `lambda(channel)`.
    #[inline]
    pub(super) fn refresh_solar(&self, spectra: &mut ChannelSpectra, lambda: impl Fn(usize) -> f64) {
        spectra.solar.clear();
        spectra
            .solar
            .extend((0..self.channels.len()).map(|w| match &self.solar {
                Some(solar) => solar.irradiance(lambda(w)).unwrap_or(0.0),
                None => 1.0,
            }));
    }

    /// Fills the spectra's extinction weights on the basis from its
    /// responses.
    #[inline]
    pub(super) fn refresh_weights(&self, spectra: &mut ChannelSpectra) {
        let (n, t, b) = (self.channels.len(), self.terms.terms.len(), self.basis_len);
        match &self.basis {
            Basis::Terms(k) => {
                spectra.weights.resize(n * b, 0.0);
                for w in 0..n {
                    for (j, &k) in k.iter().enumerate() {
                        spectra.weights[w * b + j] = spectra.responses[w * t + k].ext;
                    }
                }
            }
            Basis::Channels => {
                spectra.weights.clear();
                spectra.weights.resize(n * n, 0.0);
                for w in 0..n {
                    spectra.weights[w * n + w] = 1.0;
                }
            }
        }
    }

    /// The spectra of one path: each band's wavelength drawn (stratified
    /// over the estimate's samples, one dimension per channel).
    #[inline]
    pub(super) fn draw_spectra(&self, spectra: &mut ChannelSpectra, sampler: &Sampler) {
        let t = self.terms.terms.len();
        spectra.responses.resize(self.channels.len() * t, TermOptics::default());
        let lambda = |w: usize| self.channels[w].wavelength(sampler.stratified(w as u64));
        for w in 0..self.channels.len() {
            self.terms.active_responses_into(
                lambda(w),
                &self.term_active[w * t..(w + 1) * t],
                &mut spectra.responses[w * t..(w + 1) * t],
            );
        }
        self.refresh_weights(spectra);
        self.refresh_phase_nodes(spectra, lambda);
        self.refresh_solar(spectra, lambda);
    }

    /// σ_t of channel `w` in `layer`.
    #[inline]
    pub(super) fn sigma_t(&self, spectra: &ChannelSpectra, layer: usize, w: usize) -> f64 {
        if let Some(&sigma) = spectra.sigma.get(w * self.track.layers() + layer) {
            return sigma;
        }
        self.basis_parts(spectra, layer, w)
            .map(|(x, _)| x)
            .sum::<f64>()
            .max(0.0)
    }

    /// Channel `w`'s σ_t in `layer` by basis vector: each vector's share
    /// W·σ, and how it varies inside a smooth layer.
    #[inline]
    pub(super) fn basis_parts<'a>(
        &'a self,
        spectra: &'a ChannelSpectra,
        layer: usize,
        w: usize,
    ) -> impl Iterator<Item = (f64, TermShape)> + 'a {
        let b = self.basis_len;
        let weights = &spectra.weights[w * b..(w + 1) * b];
        let sigma = &self.track.sigma[layer * b..(layer + 1) * b];
        weights
            .iter()
            .zip(sigma)
            .zip(&self.basis_shapes)
            .map(|((a, s), shape)| (a * s, *shape))
    }

    /// Adds every basis vector's σ·`len` of `layer` to `tau`.
    #[inline]
    pub(super) fn accumulate(&self, tau: &mut [f64], layer: usize, len: f64) {
        let b = tau.len();
        for (t, s) in tau.iter_mut().zip(&self.track.sigma[layer * b..(layer + 1) * b]) {
            *t += s * len;
        }
    }

    /// Each channel's optical depth from the basis depths.
    #[inline]
    pub(super) fn combine(spectra: &ChannelSpectra, tau_basis: &[f64], tau: &mut [f64]) {
        let b = tau_basis.len();
        for (w, t) in tau.iter_mut().enumerate() {
            let weights = &spectra.weights[w * b..(w + 1) * b];
            *t = weights.iter().zip(tau_basis).map(|(a, s)| a * s).sum::<f64>().max(0.0);
        }
    }

    /// The coefficients of channel `w` at fraction `f` of the profile's
    /// layer `layer` (see [`Scene::fraction`]; the tracking layer unless
    /// layers are merged, `tracking`).
    #[inline]
    pub(super) fn coefficients(&self, spectra: &ChannelSpectra, layer: usize, w: usize, f: f64) -> PointOptics {
        if let Some(c) = spectra.coefficients.get(w * (self.levels_km.len() - 1) + layer) {
            return *c;
        }
        let t = self.terms.terms.len();
        let responses = &spectra.responses[w * t..(w + 1) * t];
        let sum = match &self.shapes {
            None => self.terms.layer_sum(layer, responses),
            Some(shapes) => self.terms.point_sum(layer, responses, |k| {
                self.term_shapes[k].factor(Some(&shapes[layer]), f)
            }),
        };
        let mut c = sum.coefficients();
        // The same sum on the basis: what flights see, or, through merged
        // layers, the profile layer's.
        c.sigma_t = if self.track.merged {
            let b = self.basis_len;
            spectra.weights[w * b..(w + 1) * b]
                .iter()
                .zip(&self.basis_sigma[layer * b..(layer + 1) * b])
                .map(|(a, s)| a * s)
                .sum::<f64>()
                .max(0.0)
        } else {
            self.sigma_t_point(spectra, layer, w, f)
        };
        c
    }

    /// Whether σ_t is constant in each layer and tracked against itself:
    /// optical depths in closed form, every tentative collision real.
    #[inline]
    pub(super) fn exact_majorant(&self) -> bool {
        self.shapes.is_none() && self.majorant_scale == 1.0
    }

    /// Whether flights that would end without contributing are forced to
    /// collide ([`Settings::forced_collisions`], with an exact majorant).
    #[inline]
    pub(super) fn forced(&self) -> bool {
        self.settings.forced_collisions && self.exact_majorant()
    }

    /// Where `x` lies in `layer` of `geometry`, 0 at its bottom and 1 at its
    /// top, for the smooth medium's shapes (0 in the layered medium, where
    /// nothing depends on it).
    #[inline]
    pub(super) fn fraction(&self, geometry: &Geometry, layer: usize, x: DVec3) -> f64 {
        if self.shapes.is_none() {
            return 0.0;
        }
        let (z0, z1) = (self.track.levels_km[layer], self.track.levels_km[layer + 1]);
        ((geometry.altitude(x) - z0) / (z1 - z0)).clamp(0.0, 1.0)
    }

    /// The profile's layer at `x` in tracking layer `layer`: itself unless
    /// layers are merged (`tracking`).
    #[inline]
    pub(super) fn profile_layer(&self, layer: usize, x: DVec3) -> usize {
        if !self.track.merged {
            return layer;
        }
        self.track
            .profile_layer(&self.levels_km, layer, self.geometry.altitude(x))
    }

    /// σ_t of channel `w` at fraction `f` of `layer`.
    #[inline]
    pub(super) fn sigma_t_point(&self, spectra: &ChannelSpectra, layer: usize, w: usize, f: f64) -> f64 {
        let Some(shapes) = &self.shapes else {
            return self.sigma_t(spectra, layer, w);
        };
        let shape = Some(&shapes[layer]);
        self.basis_parts(spectra, layer, w)
            .map(|(x, kind)| x * kind.factor(shape, f))
            .sum::<f64>()
            .max(0.0)
    }

    /// The majorant of channel `w` in `layer`: `majorant_scale` times a
    /// bound on its σ_t over the layer (σ_t itself in the layered medium;
    /// in the smooth one, each basis vector's largest factor).
    #[inline]
    pub(super) fn majorant(&self, spectra: &ChannelSpectra, layer: usize, w: usize) -> f64 {
        let bound = match &self.shapes {
            None => self.sigma_t(spectra, layer, w),
            Some(shapes) => {
                let shape = Some(&shapes[layer]);
                self.basis_parts(spectra, layer, w)
                    .map(|(x, kind)| x.abs() * kind.max_factor(shape))
                    .sum::<f64>()
            }
        };
        self.majorant_scale * bound
    }

    /// Adds every basis vector's optical depth over [t0, t1] of `ray` (in
    /// `layer` of `geometry`) to `tau`.
    #[inline]
    pub(super) fn accumulate_along(
        &self,
        tau: &mut [f64],
        geometry: &Geometry,
        ray: &Ray,
        layer: usize,
        t0: f64,
        t1: f64,
    ) {
        let Some(shapes) = &self.shapes else {
            return self.accumulate(tau, layer, t1 - t0);
        };
        let bounds = (self.track.levels_km[layer], self.track.levels_km[layer + 1]);
        let integrals = shape_integrals(&shapes[layer], bounds, geometry, ray.origin, ray.dir, t0, t1);
        let b = tau.len();
        let sigma = &self.track.sigma[layer * b..(layer + 1) * b];
        for ((t, s), shape) in tau.iter_mut().zip(sigma).zip(&self.basis_shapes) {
            *t += s * integrals[shape.index()];
        }
    }
}

impl Scene {
    /// The aerosol's phase tables (none without tabulated aerosol).
    #[inline]
    pub(super) fn phase_tables(&self) -> &PhaseTableSet {
        static NONE: PhaseTableSet = PhaseTableSet::EMPTY;
        self.aerosol_phases.as_ref().map_or(&NONE, |p| &p.tables)
    }

    /// The σ_s-weighted phase mixture of channel `w` at a point of `layer`
    /// with coefficients `c`: Rayleigh and the aerosol's tables, or
    /// Henyey–Greenstein with the aerosol's g where it has none.
    #[inline]
    pub(super) fn phase_mixture(
        &self,
        spectra: &ChannelSpectra,
        layer: usize,
        w: usize,
        c: &PointOptics,
    ) -> PhaseMixture {
        let Some(phases) = &self.aerosol_phases else {
            return phase_mixture(c);
        };
        let sigma_s = c.sigma_s();
        if sigma_s <= 0.0 || c.sigma_aerosol_sca <= 0.0 {
            return phase_mixture(c);
        }
        let inv = 1.0 / sigma_s;
        let mut m = PhaseMixture::new(c.sigma_rayleigh * inv, c.rayleigh_depolarization, 0.0, c.aerosol_g);
        phases.add_to(&mut m, layer, spectra.phase_nodes[w], c.sigma_aerosol_sca * inv);
        m
    }

    /// Fills the spectra's phase nodes for the channels' wavelengths
    /// `lambda(channel)`.
    #[inline]
    pub(super) fn refresh_phase_nodes(&self, spectra: &mut ChannelSpectra, lambda: impl Fn(usize) -> f64) {
        let Some(phases) = &self.aerosol_phases else {
            return;
        };
        spectra.phase_nodes.clear();
        spectra
            .phase_nodes
            .extend((0..self.channels.len()).map(|w| phases.node(lambda(w))));
    }
}
