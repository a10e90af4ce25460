//! The σ_s-weighted mixture of a point's phase matrices: Rayleigh,
//! Henyey–Greenstein and tabulated (Mie) matrices, evaluated at many angles
//! and sampled exactly (pick a part by its weight, then its own sampling).

use glam::DVec3;

use crate::polarization::phase::PhaseFunction;
use crate::polarization::phase_table_set::{Located, PhaseTableSet};
use crate::polarization::stokes::PhaseMatrix;

/// The most tabulated phase matrices one mixture holds: a point's aerosol
/// is its layer's combined tables at the two tabulated wavelengths around
/// the channel's (`transport::tracer::aerosol_phase`).
pub const MAX_TABULATED: usize = 2;

/// The σ_s-weighted mixture of Rayleigh (weight w_r, depolarisation ρ),
/// Henyey–Greenstein (weight w_hg, asymmetry g) and tabulated phase matrices
/// (tables of a [`PhaseTableSet`] with their weights), with every constant
/// that does not depend on the angle worked out once: for a point's (or a
/// layer's) coefficients, evaluated at many angles. The weights sum to 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseMixture {
    /// w_r and ρ, for sampling.
    rayleigh: f64,
    depolarization: f64,
    /// w_r·d·3/4, d the Rayleigh anisotropic weight (1 − ρ)/(1 + ρ/2).
    rayleigh_polarized: f64,
    /// w_r·(1 − d): the isotropic part of Rayleigh's P11.
    rayleigh_isotropic: f64,
    /// w_r·d·(1 − 2ρ)/(1 − ρ)·3/2 = w_r·(1 − 2ρ)/(1 + ρ/2)·3/2: the
    /// factor of cos Θ in P44.
    rayleigh_circular: f64,
    aerosol: f64,
    g: f64,
    /// (table, weight) of the tabulated part, the first `tabulated_len`.
    tabulated: [(u32, f64); MAX_TABULATED],
    tabulated_len: usize,
}

impl PhaseMixture {
    /// The mixture with weights `w_rayleigh` and `w_aerosol` (summing to 1)
    /// of Rayleigh and Henyey–Greenstein.
    pub fn new(w_rayleigh: f64, depolarization: f64, w_aerosol: f64, g: f64) -> PhaseMixture {
        let rho = depolarization;
        // One division for both factors (this runs per wavelength and
        // collision along shared spectral paths).
        let inv = 1.0 / (1.0 + 0.5 * rho);
        let d = (1.0 - rho) * inv;
        PhaseMixture {
            rayleigh: w_rayleigh,
            depolarization: rho,
            rayleigh_polarized: w_rayleigh * d * 0.75,
            rayleigh_isotropic: w_rayleigh * (1.0 - d),
            rayleigh_circular: w_rayleigh * (1.0 - 2.0 * rho) * inv * 1.5,
            aerosol: w_aerosol,
            g,
            tabulated: [(0, 0.0); MAX_TABULATED],
            tabulated_len: 0,
        }
    }

    /// Adds table `table` of the scene's [`PhaseTableSet`] with `weight`
    /// (the caller keeps the weights summing to 1 and within
    /// [`MAX_TABULATED`] tables, which the scene checks when it is built).
    #[inline]
    pub fn push_tabulated(&mut self, table: usize, weight: f64) {
        self.tabulated[self.tabulated_len] = (table as u32, weight);
        self.tabulated_len += 1;
    }

    /// The tabulated part: (table, weight).
    pub fn tabulated(&self) -> &[(u32, f64)] {
        &self.tabulated[..self.tabulated_len]
    }

    /// The mixture's phase matrix at the located angle (the weighted sum
    /// of [`PhaseFunction::matrix`] and the tables' matrices).
    #[inline]
    pub fn matrix(&self, at: &Located) -> PhaseMatrix {
        let cos_theta = at.cos_theta;
        let mu2 = cos_theta * cos_theta;
        let p22 = self.rayleigh_polarized * (1.0 + mu2);
        let hg = if self.aerosol > 0.0 {
            self.aerosol * PhaseFunction::HenyeyGreenstein { g: self.g }.p11(cos_theta)
        } else {
            0.0
        };
        let mut m = PhaseMatrix {
            p11: p22 + self.rayleigh_isotropic + hg,
            p12: -self.rayleigh_polarized * (1.0 - mu2),
            p22,
            p33: 2.0 * self.rayleigh_polarized * cos_theta,
            p34: 0.0,
            p44: self.rayleigh_circular * cos_theta,
        };
        for &(k, w) in self.tabulated() {
            let t = at.matrix(k as usize);
            m.p11 += w * t.p11;
            m.p12 += w * t.p12;
            m.p22 += w * t.p22;
            m.p33 += w * t.p33;
            m.p34 += w * t.p34;
            m.p44 += w * t.p44;
        }
        m
    }

    /// Samples a direction for light along `k_in` from the mixture: a
    /// component picked with its weight by `u_pick`, then its own exact
    /// sampling with `u` ([`crate::polarization::phase::PhaseSample::direction`]). The density is the
    /// mixture's P11/(4π), which [`PhaseMixture::matrix`] evaluates.
    #[inline]
    pub fn sample_direction(&self, k_in: DVec3, u_pick: f64, u: [f64; 2], tables: &PhaseTableSet) -> DVec3 {
        let total = self.rayleigh + self.aerosol + self.tabulated().iter().map(|t| t.1).sum::<f64>();
        let mut x = u_pick * total;
        let sample = if x < self.rayleigh {
            PhaseFunction::Rayleigh {
                depolarization: self.depolarization,
            }
            .sample(u)
        } else {
            x -= self.rayleigh;
            let mut pick = None;
            if x >= self.aerosol {
                x -= self.aerosol;
                for &(k, w) in self.tabulated() {
                    pick = Some(k as usize);
                    if x < w {
                        break;
                    }
                    x -= w;
                }
            }
            match pick {
                Some(k) => tables.sample(k, u),
                None => PhaseFunction::HenyeyGreenstein { g: self.g }.sample(u),
            }
        };
        sample.direction(k_in)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// χ² critical value for 49 degrees of freedom at p = 0.001.
    const CHI2_CRIT_49_DOF_P001: f64 = 85.3506;

    const RHO_AIR: f64 = 0.02837;

    #[test]
    fn the_precomputed_mixture_is_the_weighted_sum_of_its_components() {
        for (wr, rho, g) in [
            (1.0, 0.0, 0.0),
            (1.0, 0.0279, 0.7),
            (0.3, 0.1, 0.75),
            (0.0, 0.03, -0.4),
            (0.55, 0.0, 0.9),
        ] {
            let mix = PhaseMixture::new(wr, rho, 1.0 - wr, g);
            for k in 0..=40 {
                let mu = -1.0 + k as f64 / 20.0;
                let r = PhaseFunction::Rayleigh { depolarization: rho }.mueller(mu);
                let h = PhaseFunction::HenyeyGreenstein { g }.mueller(mu);
                let m = mix.matrix(&PhaseTableSet::default().locate(mu)).mueller();
                for i in 0..4 {
                    for j in 0..4 {
                        let want = wr * r.0[i][j] + (1.0 - wr) * h.0[i][j];
                        assert!((m.0[i][j] - want).abs() < 1e-12 * want.abs().max(1.0), "{i}{j} μ {mu}");
                    }
                }
            }
        }
    }

    /// Two tabulated tables on one grid (a forward-peaked one and one with
    /// a backward lobe) with their own P12, P33, P34.
    fn two_tables() -> PhaseTableSet {
        use crate::polarization::tabulated_phase::TabulatedPhaseMatrix;
        let angles: Vec<f64> = (0..=360).map(|i| i as f64 * 0.5).collect();
        let table = |f: &dyn Fn(f64) -> f64, pol: f64| {
            let p11: Vec<f64> = angles.iter().map(|a| f(a.to_radians().cos())).collect();
            let s2 = |a: &f64| a.to_radians().sin().powi(2);
            let p12: Vec<f64> = angles.iter().zip(&p11).map(|(a, p)| -pol * p * s2(a)).collect();
            let p33: Vec<f64> = angles.iter().zip(&p11).map(|(a, p)| p * a.to_radians().cos()).collect();
            let p34: Vec<f64> = angles.iter().zip(&p11).map(|(a, p)| 0.1 * pol * p * s2(a)).collect();
            TabulatedPhaseMatrix::new("t", &angles, &p11, &p12, &p33, &p34).unwrap()
        };
        let hg = |g: f64| move |mu: f64| (1.0 - g * g) / (1.0 + g * g - 2.0 * g * mu).powf(1.5);
        PhaseTableSet::new(vec![table(&hg(0.8), 0.3), table(&|mu| 1.0 + 0.5 * hg(-0.6)(mu), 0.6)]).unwrap()
    }

    fn mixed(tables: &PhaseTableSet) -> PhaseMixture {
        let _ = tables;
        let mut m = PhaseMixture::new(0.3, RHO_AIR, 0.2, 0.7);
        m.push_tabulated(0, 0.35);
        m.push_tabulated(1, 0.15);
        assert_eq!(MAX_TABULATED, 2);
        m
    }

    #[test]
    fn a_mixture_with_tables_is_the_weighted_sum_of_its_parts() {
        let tables = two_tables();
        let m = mixed(&tables);
        for k in 0..=200 {
            let mu = -1.0 + k as f64 / 100.0;
            let got = m.matrix(&tables.locate(mu)).mueller();
            let r = PhaseFunction::Rayleigh {
                depolarization: RHO_AIR,
            }
            .mueller(mu);
            let h = PhaseFunction::HenyeyGreenstein { g: 0.7 }.mueller(mu);
            let (t0, t1) = (
                tables.table(0).matrix(mu).mueller(),
                tables.table(1).matrix(mu).mueller(),
            );
            for i in 0..4 {
                for j in 0..4 {
                    let want = 0.3 * r.0[i][j] + 0.2 * h.0[i][j] + 0.35 * t0.0[i][j] + 0.15 * t1.0[i][j];
                    assert!(
                        (got.0[i][j] - want).abs() < 1e-12 * want.abs().max(1.0),
                        "{i}{j} μ {mu}"
                    );
                }
            }
        }
    }

    #[test]
    fn sampling_a_mixture_with_tables_follows_its_p11() {
        // χ² of the sampled cos Θ against the CDF of the mixture's own P11,
        // integrated by Simpson's rule on 2·10⁴ intervals per bin (the
        // tables' kinks make it accurate to 1e-7, far below the bins' noise).
        const BINS: usize = 50;
        const SAMPLES: usize = 200_000;
        let tables = two_tables();
        let m = mixed(&tables);
        let p11 = |mu: f64| m.matrix(&tables.locate(mu)).p11;
        let h = 2.0 / BINS as f64;
        let expected: Vec<f64> = (0..BINS)
            .map(|i| {
                let a = -1.0 + i as f64 * h;
                let n = 20_000;
                let step = h / n as f64;
                let inner: f64 = (1..n)
                    .map(|k| if k % 2 == 1 { 4.0 } else { 2.0 } * p11(a + k as f64 * step))
                    .sum();
                0.5 * (p11(a) + p11(a + h) + inner) * step / 3.0
            })
            .collect();
        let total: f64 = expected.iter().sum();
        assert!((total - 1.0).abs() < 1e-6, "the mixture is normalised: {total}");
        let mut rng = Pcg64Mcg::seed_from_u64(77);
        let mut counts = [0usize; BINS];
        let k_in = DVec3::new(0.2, 0.3, -0.9).normalize();
        for _ in 0..SAMPLES {
            let k = m.sample_direction(k_in, rng.random(), [rng.random(), rng.random()], &tables);
            let mu = k.dot(k_in);
            counts[(((mu + 1.0) / h) as usize).min(BINS - 1)] += 1;
        }
        let chi2: f64 = (0..BINS)
            .map(|i| {
                let e = SAMPLES as f64 * expected[i];
                (counts[i] as f64 - e).powi(2) / e
            })
            .sum();
        assert!(chi2 < CHI2_CRIT_49_DOF_P001, "χ² = {chi2}");
    }
}
