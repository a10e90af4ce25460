//! The aerosol's tabulated phase matrices in a scene, and how a point's
//! phase mixture gets them.
//!
//! An aerosol term t (an OPAC component at one humidity) with amount A_t in
//! a layer scatters A_t·k_sca,t(λ)·P_t(λ, Θ). Between the tabulated
//! wavelengths λ_i < λ < λ_{i+1} (fraction f), k_sca and k_sca·P are
//! interpolated linearly, as k_ext, k_sca and g·k_sca are
//! ([`crate::physics::aerosol`]): so the term is the sum of two tables,
//! A_t·(1 − f)·k_sca,t(λ_i)·P_t(λ_i) and A_t·f·k_sca,t(λ_{i+1})·P_t(λ_{i+1}),
//! and the point's aerosol phase matrix is the σ_s-weighted sum of at most
//! two tables per component with mass there. Sampling picks one table with
//! its weight and inverts its CDF, so the density is exactly the mixture's
//! P11/(4π).

use crate::atmosphere::optics::PointOptics;
use crate::atmosphere::spectral_terms::{SpectralTerms, Spectrum};
use crate::physics::data::bracket;
use crate::polarization::phase::{MAX_TABULATED, PhaseMixture};
use crate::polarization::phase_table_set::PhaseTableSet;
use crate::polarization::tabulated_phase::TabulatedPhaseMatrix;

use super::scene::Scene;
use super::spectra::ChannelSpectra;
use super::vertex::phase_mixture;

/// One aerosol term with phase tables.
#[derive(Debug, Clone)]
struct PhaseTerm {
    /// Its tabulated wavelengths (nm), ascending.
    wavelengths_nm: Vec<f64>,
    /// The index in the set of its table at `wavelengths_nm[0]` (the
    /// others follow).
    first: usize,
    /// k_sca per unit amount at each tabulated wavelength.
    k_sca: Vec<f64>,
}

/// A scene's aerosol phase tables: every term's tables, and which terms
/// have amount in each layer.
#[derive(Debug, Clone)]
pub(super) struct AerosolPhases {
    pub(super) tables: PhaseTableSet,
    terms: Vec<PhaseTerm>,
    /// Per layer: (phase term, amount) of the terms with amount there.
    layers: Vec<Vec<(usize, f64)>>,
}

/// Where a channel's wavelength lies in one phase term's tables: the
/// lower table and the weight of the upper one.
pub(super) type PhaseNode = (usize, f64);

impl AerosolPhases {
    /// The tables of the terms that have them (`None` if none has): the
    /// aerosol then scatters by Henyey–Greenstein. The atmosphere checked
    /// the tables when it was built (`atmosphere::check_phase_tables`).
    pub(super) fn of_terms(terms: &SpectralTerms, layers: usize) -> Option<AerosolPhases> {
        let mut tables = Vec::new();
        let mut phase_terms = Vec::new();
        let mut term_index = Vec::new();
        for (k, term) in terms.terms.iter().enumerate() {
            let Spectrum::Aerosol {
                component,
                rh,
                phase: Some(phase),
            } = &term.spectrum
            else {
                continue;
            };
            let first = tables.len();
            for (lambda, m) in phase.wavelengths_nm.iter().zip(&phase.matrices) {
                let name = format!("{} at {lambda} nm", phase.component);
                tables.push(
                    TabulatedPhaseMatrix::from_mie(&name, m)
                        .expect("the atmosphere checked every phase table when it was built"),
                );
            }
            let k_sca = phase
                .wavelengths_nm
                .iter()
                .map(|&l| component.optics(l, *rh).map_or(0.0, |o| o.k_sca))
                .collect();
            phase_terms.push(PhaseTerm {
                wavelengths_nm: phase.wavelengths_nm.clone(),
                first,
                k_sca,
            });
            term_index.push(k);
        }
        if phase_terms.is_empty() {
            return None;
        }
        let per_layer = (0..layers)
            .map(|l| {
                term_index
                    .iter()
                    .enumerate()
                    .filter_map(|(p, &k)| {
                        let a = terms.terms[k].amount[l];
                        (a != 0.0).then_some((p, a))
                    })
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<_>>();
        assert!(
            per_layer.iter().all(|l| 2 * l.len() <= MAX_TABULATED),
            "one humidity per component and layer: at most {} tables",
            MAX_TABULATED
        );
        Some(AerosolPhases {
            tables: PhaseTableSet::new(tables).expect("the atmosphere checked that the tables share one angle grid"),
            terms: phase_terms,
            layers: per_layer,
        })
    }

    /// The number of terms with tables.
    pub(super) fn term_count(&self) -> usize {
        self.terms.len()
    }

    /// Each phase term's place at wavelength `lambda_nm`, into `out`
    /// (clamped to its tables' range; the atmosphere checks the channels'
    /// wavelengths against the components' data).
    pub(super) fn nodes_into(&self, lambda_nm: f64, out: &mut [PhaseNode]) {
        for (o, t) in out.iter_mut().zip(&self.terms) {
            let wl = &t.wavelengths_nm;
            let l = lambda_nm.clamp(wl[0], wl[wl.len() - 1]);
            *o = bracket(wl, l).unwrap_or((0, 0.0));
        }
    }

    /// Adds the tables of `layer` to `mixture` for a channel at `nodes`
    /// (its [`AerosolPhases::nodes_into`]), their weights summing to
    /// `aerosol_weight` (the aerosol's σ_s share at the point).
    pub(super) fn add_to(&self, mixture: &mut PhaseMixture, layer: usize, nodes: &[PhaseNode], aerosol_weight: f64) {
        let mut parts = [(0usize, 0.0f64); MAX_TABULATED];
        let mut len = 0;
        let mut total = 0.0;
        for &(p, amount) in &self.layers[layer] {
            let t = &self.terms[p];
            let (i, f) = nodes[p];
            for (j, w) in [(i, 1.0 - f), (i + 1, f)] {
                if w > 0.0 && j < t.k_sca.len() {
                    let x = amount * w * t.k_sca[j];
                    parts[len] = (t.first + j, x);
                    len += 1;
                    total += x;
                }
            }
        }
        if total <= 0.0 {
            return;
        }
        let scale = aerosol_weight / total;
        for &(k, x) in &parts[..len] {
            mixture.push_tabulated(k, x * scale);
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
        let n = phases.term_count();
        phases.add_to(
            &mut m,
            layer,
            &spectra.phase_nodes[w * n..(w + 1) * n],
            c.sigma_aerosol_sca * inv,
        );
        m
    }

    /// Fills the spectra's phase nodes for the channels' wavelengths
    /// `lambda(channel)`.
    #[inline]
    pub(super) fn refresh_phase_nodes(&self, spectra: &mut ChannelSpectra, lambda: impl Fn(usize) -> f64) {
        let Some(phases) = &self.aerosol_phases else {
            return;
        };
        let n = phases.term_count();
        spectra.phase_nodes.resize(self.channels.len() * n, (0, 0.0));
        for w in 0..self.channels.len() {
            phases.nodes_into(lambda(w), &mut spectra.phase_nodes[w * n..(w + 1) * n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::atmosphere::spectral_terms::Term;
    use crate::physics::aerosol::Component;

    /// waso at 50 % in one layer and inso in two: the tables of a channel
    /// between two tabulated wavelengths are the two nodes' tables weighted
    /// by amount·(1 − f)·k_sca(λ_i) and amount·f·k_sca(λ_{i+1}), so that the
    /// mixture's P11 is the k_sca-weighted interpolation the module states.
    #[test]
    fn a_wavelength_between_tables_mixes_them_by_scattering() {
        let term = |name: &str, rh: usize, amount: Vec<f64>| {
            let component = Component::builtin(name).unwrap().unwrap();
            let phase = Some(Arc::new(component.phase_tables(rh).unwrap()));
            Term {
                amount,
                spectrum: Spectrum::Aerosol {
                    component: Arc::new(component),
                    rh,
                    phase,
                },
            }
        };
        let terms = SpectralTerms {
            terms: vec![term("waso", 1, vec![2e-5, 0.0]), term("inso", 0, vec![1e-5, 3e-6])],
        };
        let phases = AerosolPhases::of_terms(&terms, 2).unwrap();
        assert_eq!(phases.term_count(), 2);
        let mut nodes = [(0, 0.0); 2];
        // 520 nm: halfway between the 500 and 540 nm tables.
        phases.nodes_into(520.0, &mut nodes);
        let (i, f) = nodes[0];
        assert_eq!((phases.terms[0].wavelengths_nm[i], f), (500.0, 0.5));
        let mut m = PhaseMixture::new(0.4, 0.03, 0.0, 0.0);
        phases.add_to(&mut m, 0, &nodes, 0.6);
        assert_eq!(m.tabulated().len(), 4);
        let sum: f64 = m.tabulated().iter().map(|t| t.1).sum();
        assert!((sum - 0.6).abs() < 1e-15);
        let waso = Component::builtin("waso").unwrap().unwrap();
        let inso = Component::builtin("inso").unwrap().unwrap();
        let k = |c: &Component, rh, l| c.optics(l, rh).unwrap().k_sca;
        let parts = [
            2e-5 * 0.5 * k(&waso, 1, 500.0),
            2e-5 * 0.5 * k(&waso, 1, 540.0),
            1e-5 * 0.5 * k(&inso, 0, 500.0),
            1e-5 * 0.5 * k(&inso, 0, 540.0),
        ];
        let total: f64 = parts.iter().sum();
        for ((_, w), p) in m.tabulated().iter().zip(parts) {
            assert!((w - 0.6 * p / total).abs() < 1e-15, "{w} vs {}", 0.6 * p / total);
        }
        // The layer's σ_sca at 520 nm is the same sum: k_sca is linear
        // between the tabulated wavelengths.
        let sigma = 2e-5 * k(&waso, 1, 520.0) + 1e-5 * k(&inso, 0, 520.0);
        assert!((sigma - total).abs() < 1e-12 * total);
        // The second layer holds inso alone.
        let mut m = PhaseMixture::new(0.0, 0.0, 0.0, 0.0);
        phases.add_to(&mut m, 1, &nodes, 1.0);
        assert_eq!(m.tabulated().len(), 2);
        // At a tabulated wavelength one table per component.
        phases.nodes_into(540.0, &mut nodes);
        let mut m = PhaseMixture::new(0.0, 0.0, 0.0, 0.0);
        phases.add_to(&mut m, 0, &nodes, 1.0);
        assert_eq!(m.tabulated().len(), 2);
    }
}
