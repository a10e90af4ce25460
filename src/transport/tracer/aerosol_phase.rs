//! The aerosol's tabulated phase matrices in a scene, and how a point's
//! phase mixture gets them.
//!
//! An aerosol term t (an OPAC component at one humidity) with amount A_t in
//! a layer scatters A_t·k_sca,t(λ)·P_t(λ, Θ). Between the tabulated
//! wavelengths λ_i < λ < λ_{i+1} (fraction f), k_sca and k_sca·P are
//! interpolated linearly, as k_ext, k_sca and g·k_sca are
//! ([`crate::physics::aerosol`]). So with the layer's scattering at each
//! tabulated wavelength, S_i = Σ_t A_t·k_sca,t(λ_i), and its combined table
//! there, C_i = Σ_t A_t·k_sca,t(λ_i)·P_t(λ_i)/S_i (built once per scene:
//! piecewise linear in μ like its parts, so exactly their sum), the
//! aerosol's phase matrix at λ is
//!
//! P(λ) = [(1 − f)·S_i·C_i + f·S_{i+1}·C_{i+1}] / [(1 − f)·S_i + f·S_{i+1}],
//!
//! two tables whatever the number of components. Sampling picks one with
//! its weight and inverts its CDF, so the density is exactly the mixture's
//! P11/(4π).

use crate::atmosphere::spectral_terms::{SpectralTerms, Spectrum};
use crate::physics::data::bracket;
use crate::polarization::phase_mixture::PhaseMixture;
use crate::polarization::phase_table_set::PhaseTableSet;
use crate::polarization::tabulated_phase::TabulatedPhaseMatrix;

/// A scene's aerosol phase tables: each layer's combined table at every
/// tabulated wavelength, and its scattering there.
#[derive(Debug, Clone)]
pub(super) struct AerosolPhases {
    pub(super) tables: PhaseTableSet,
    /// The tabulated wavelengths (nm), ascending, the same for every term.
    wavelengths_nm: Vec<f64>,
    /// The tabulated wavelengths tables are built for: `nodes.0..=nodes.1`
    /// (those the channels' wavelengths lie between).
    nodes: (usize, usize),
    /// Per layer: the index of its table at `wavelengths_nm[nodes.0]` (the
    /// others follow), `None` without aerosol.
    layer_first: Vec<Option<usize>>,
    /// S_i per layer and tabulated wavelength (`[layer·wavelengths + i]`).
    layer_sca: Vec<f64>,
}

/// Where a channel's wavelength lies in the tables: the lower tabulated
/// wavelength and the weight f of the upper one.
pub(super) type PhaseNode = (usize, f64);

impl AerosolPhases {
    /// The tables of the terms that have them (`None` if none has: the
    /// aerosol then scatters by Henyey–Greenstein). The atmosphere checked
    /// the tables when it was built (`atmosphere::check_phase_tables`:
    /// valid samplers on one angle grid, one wavelength grid).
    /// Tables are built for the tabulated wavelengths around
    /// `range_nm` (the channels' wavelengths, bands included) only.
    pub(super) fn of_terms(terms: &SpectralTerms, layers: usize, range_nm: (f64, f64)) -> Option<AerosolPhases> {
        // Per term with tables: its amount, its tables and k_sca at each
        // tabulated wavelength.
        let mut parts: Vec<(&[f64], Vec<TabulatedPhaseMatrix>, Vec<f64>)> = Vec::new();
        let mut wavelengths_nm: Option<&[f64]> = None;
        for term in &terms.terms {
            let Spectrum::Aerosol {
                component,
                rh,
                phase: Some(phase),
            } = &term.spectrum
            else {
                continue;
            };
            assert!(
                wavelengths_nm.is_none_or(|w| w == phase.wavelengths_nm),
                "the atmosphere checked that every phase table has the same wavelengths"
            );
            wavelengths_nm = Some(&phase.wavelengths_nm);
            let tables = phase
                .wavelengths_nm
                .iter()
                .zip(&phase.matrices)
                .map(|(lambda, m)| {
                    TabulatedPhaseMatrix::from_mie(&format!("{} at {lambda} nm", phase.component), m)
                        .expect("the atmosphere checked every phase table when it was built")
                })
                .collect();
            let k_sca = phase
                .wavelengths_nm
                .iter()
                .map(|&l| component.optics(l, *rh).map_or(0.0, |o| o.k_sca))
                .collect();
            parts.push((&term.amount, tables, k_sca));
        }
        let wavelengths_nm = wavelengths_nm?.to_vec();
        let nw = wavelengths_nm.len();
        let at =
            |l: f64| bracket(&wavelengths_nm, l.clamp(wavelengths_nm[0], wavelengths_nm[nw - 1])).map_or(0, |b| b.0);
        let nodes = (at(range_nm.0), (at(range_nm.1) + 1).min(nw - 1));
        let mut tables = Vec::new();
        let mut layer_first = Vec::with_capacity(layers);
        let mut layer_sca = vec![0.0; layers * nw];
        for l in 0..layers {
            let present: Vec<_> = parts.iter().filter(|p| p.0[l] > 0.0).collect();
            if present.is_empty() {
                layer_first.push(None);
                continue;
            }
            layer_first.push(Some(tables.len()));
            for i in 0..nw {
                let weighted: Vec<(&TabulatedPhaseMatrix, f64)> =
                    present.iter().map(|p| (&p.1[i], p.0[l] * p.2[i])).collect();
                let sca: f64 = weighted.iter().map(|w| w.1).sum();
                layer_sca[l * nw + i] = sca;
                if i < nodes.0 || i > nodes.1 {
                    continue;
                }
                let normalised: Vec<_> = weighted
                    .iter()
                    .filter(|w| w.1 > 0.0)
                    .map(|&(t, w)| (t, w / sca))
                    .collect();
                tables.push(if normalised.is_empty() {
                    weighted[0].0.clone()
                } else {
                    TabulatedPhaseMatrix::mixture(&normalised)
                });
            }
        }
        Some(AerosolPhases {
            tables: PhaseTableSet::new(tables).expect("the atmosphere checked that the tables share one angle grid"),
            wavelengths_nm,
            nodes,
            layer_first,
            layer_sca,
        })
    }

    /// Where `lambda_nm` lies in the tabulated wavelengths (clamped to
    /// their range; the atmosphere checks the channels' wavelengths
    /// against the components' data).
    pub(super) fn node(&self, lambda_nm: f64) -> PhaseNode {
        let wl = &self.wavelengths_nm;
        let (lo, hi) = self.nodes;
        let (i, f) = bracket(wl, lambda_nm.clamp(wl[lo], wl[hi])).unwrap_or((lo, 0.0));
        // Only the built tables: λ at the top node is its lower end.
        if i >= hi && hi > lo { (hi - 1, 1.0) } else { (i, f) }
    }

    /// Adds the tables of `layer` to `mixture` for a channel at `node`
    /// (its [`AerosolPhases::node`]), their weights summing to
    /// `aerosol_weight` (the aerosol's σ_s share at the point).
    #[inline]
    pub(super) fn add_to(&self, mixture: &mut PhaseMixture, layer: usize, (i, f): PhaseNode, aerosol_weight: f64) {
        let Some(first) = self.layer_first[layer] else {
            return;
        };
        let nw = self.wavelengths_nm.len();
        let sca = &self.layer_sca[layer * nw..(layer + 1) * nw];
        let lower = (1.0 - f) * sca[i];
        let upper = if f > 0.0 && i + 1 < nw { f * sca[i + 1] } else { 0.0 };
        let total = lower + upper;
        if total <= 0.0 {
            return;
        }
        let scale = aerosol_weight / total;
        let k = first + i - self.nodes.0;
        if lower > 0.0 {
            mixture.push_tabulated(k, lower * scale);
        }
        if upper > 0.0 {
            mixture.push_tabulated(k + 1, upper * scale);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::atmosphere::spectral_terms::Term;
    use crate::physics::aerosol::Component;

    /// waso at 50 % and inso in layer 0, inso alone in layer 1, none in
    /// layer 2: at 520 nm, halfway between the 500 and 540 nm tables, the
    /// aerosol's phase matrix is Σ_t A_t·[½k_t(500)·P_t(500) + ½k_t(540)·P_t(540)]
    /// over Σ_t A_t·[½k_t(500) + ½k_t(540)], computed here from the
    /// components' own tables.
    #[test]
    fn the_layer_tables_give_the_k_sca_weighted_interpolation() {
        let load = |name: &str, rh: usize| {
            let component = Component::builtin(name).unwrap().unwrap();
            let phase = component.phase_tables(rh).unwrap();
            (component, phase)
        };
        let ((waso, waso_p), (inso, inso_p)) = (load("waso", 1), load("inso", 0));
        let term = |c: &Component, p: &crate::physics::mie::tables::PhaseTables, rh, amount| Term {
            amount,
            spectrum: Spectrum::Aerosol {
                component: Arc::new(c.clone()),
                rh,
                phase: Some(Arc::new(p.clone())),
            },
        };
        let terms = SpectralTerms {
            terms: vec![
                term(&waso, &waso_p, 1, vec![2e-5, 0.0, 0.0]),
                term(&inso, &inso_p, 0, vec![1e-5, 3e-6, 0.0]),
            ],
        };
        let phases = AerosolPhases::of_terms(&terms, 3, (300.0, 800.0)).unwrap();
        let node = phases.node(520.0);
        assert_eq!((phases.wavelengths_nm[node.0], node.1), (500.0, 0.5));
        let mut m = PhaseMixture::new(0.4, 0.03, 0.0, 0.0);
        phases.add_to(&mut m, 0, node, 0.6);
        assert_eq!(m.tabulated().len(), 2);
        assert!((m.tabulated().iter().map(|t| t.1).sum::<f64>() - 0.6).abs() < 1e-15);
        let table = |p: &crate::physics::mie::tables::PhaseTables, l: f64| {
            let i = p.wavelengths_nm.iter().position(|&w| w == l).unwrap();
            TabulatedPhaseMatrix::from_mie("t", &p.matrices[i]).unwrap()
        };
        let k = |c: &Component, rh, l| c.optics(l, rh).unwrap().k_sca;
        let direct = [
            (table(&waso_p, 500.0), 2e-5 * 0.5 * k(&waso, 1, 500.0)),
            (table(&waso_p, 540.0), 2e-5 * 0.5 * k(&waso, 1, 540.0)),
            (table(&inso_p, 500.0), 1e-5 * 0.5 * k(&inso, 0, 500.0)),
            (table(&inso_p, 540.0), 1e-5 * 0.5 * k(&inso, 0, 540.0)),
        ];
        let total: f64 = direct.iter().map(|d| d.1).sum();
        let rayleigh = PhaseMixture::new(0.4, 0.03, 0.0, 0.0);
        for j in 0..=100 {
            let mu = -1.0 + j as f64 / 50.0;
            let got = m.matrix(&phases.tables.locate(mu));
            let r = rayleigh.matrix(&phases.tables.locate(mu));
            let want = |e: fn(&crate::polarization::stokes::PhaseMatrix) -> f64| {
                e(&r) + 0.6 * direct.iter().map(|(t, w)| w * e(&t.matrix(mu))).sum::<f64>() / total
            };
            for (g, w) in [
                (got.p11, want(|p| p.p11)),
                (got.p12, want(|p| p.p12)),
                (got.p33, want(|p| p.p33)),
                (got.p34, want(|p| p.p34)),
            ] {
                assert!((g - w).abs() <= 1e-10 * w.abs().max(1e-3), "μ {mu}: {g} vs {w}");
            }
        }
        // σ_sca at 520 nm is the same sum: k_sca is linear between the
        // tabulated wavelengths.
        let sigma = 2e-5 * k(&waso, 1, 520.0) + 1e-5 * k(&inso, 0, 520.0);
        assert!((sigma - total).abs() < 1e-12 * total);
        // At a tabulated wavelength one table; none where there is no aerosol.
        let mut m = PhaseMixture::new(0.0, 0.0, 0.0, 0.0);
        phases.add_to(&mut m, 1, phases.node(540.0), 1.0);
        assert_eq!(m.tabulated().len(), 1);
        let mut m = PhaseMixture::new(1.0, 0.0, 0.0, 0.0);
        phases.add_to(&mut m, 2, node, 0.0);
        assert!(m.tabulated().is_empty());
        // Tables only around the channels' wavelengths, with the same
        // mixtures: 510 to 530 nm needs the 500 and 540 nm tables.
        let few = AerosolPhases::of_terms(&terms, 3, (510.0, 530.0)).unwrap();
        assert_eq!(few.tables.len(), 2 * 2);
        let mut m2 = PhaseMixture::new(0.4, 0.03, 0.0, 0.0);
        few.add_to(&mut m2, 0, few.node(520.0), 0.6);
        let mut m = PhaseMixture::new(0.4, 0.03, 0.0, 0.0);
        phases.add_to(&mut m, 0, phases.node(520.0), 0.6);
        for j in 0..=20 {
            let mu = -1.0 + j as f64 / 10.0;
            assert_eq!(m2.matrix(&few.tables.locate(mu)), m.matrix(&phases.tables.locate(mu)));
        }
        // One wavelength on a node, and the top of the tables.
        let one = AerosolPhases::of_terms(&terms, 3, (540.0, 540.0)).unwrap();
        assert_eq!(one.node(540.0), (one.nodes.0, 0.0));
        let top = AerosolPhases::of_terms(&terms, 3, (2500.0, 2500.0)).unwrap();
        assert_eq!(top.node(2500.0), (top.wavelengths_nm.len() - 2, 1.0));
        let mut m = PhaseMixture::new(0.0, 0.0, 0.0, 0.0);
        top.add_to(&mut m, 1, top.node(2500.0), 1.0);
        assert_eq!(m.tabulated(), &[(3, 1.0)]);
    }
}
