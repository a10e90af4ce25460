//! A tabulated phase matrix of spheres (a Mie table) with exact importance
//! sampling of its phase function.
//!
//! The table holds P11, P12, P33 and P34 at scattering angles Θ from 0 to
//! 180°; for spheres P22 = P11 and P44 = P33, so the matrix has the block
//! form of [`PhaseMatrix`] in the scattering-plane frame (CONVENTIONS.md §6,
//! §11).
//!
//! **Interpolation.** Every element is interpolated linearly in μ = cos Θ
//! between the nodes. Why μ and not Θ: the sampling density of μ is ½·P11(μ),
//! so with P11 linear in μ its CDF is a quadratic on each segment, inverted in
//! closed form by one square root, and the pdf that sampling draws from is
//! exactly the P11 that [`TabulatedPhaseMatrix::p11`] and
//! [`TabulatedPhaseMatrix::matrix`] evaluate (linear in Θ would need a root
//! of `a·(cos Θ₀ − cos Θ) + b·(sin Θ − …)`, a transcendental equation, per
//! sample). Log-linear interpolation in μ would also invert in closed form and
//! follows an exponential forward peak more closely, but costs an exp and a
//! log per sample; on the Mie side's default grid (0.01° steps in the
//! forward peak, i.e. μ steps of 1.5e-8 to 3e-6 there) the forward peak is
//! resolved well enough that the linear form changes the normalisation by
//! about as much as the Mie side's own quadrature (1e-5 to 1e-4), which
//! [`TabulatedPhaseMatrix::renormalization`] reports. P11 linear between
//! positive nodes stays positive.
//!
//! **Normalisation.** The constructor integrates the interpolated P11
//! exactly (the trapezoidal rule in μ, exact for a piecewise-linear
//! function) and scales all four elements by the factor that makes
//! (1/4π)∫P11 dΩ = ½∫₋₁¹P11 dμ = 1; the sampling pdf per steradian is then
//! P11/(4π), as for [`crate::polarization::phase::PhaseFunction`].
//!
//! **Signs.** The elements are taken as the Mie side stores them
//! (`physics::mie::phase_matrix`): P12 < 0 for light polarised perpendicular
//! to the scattering plane (Rayleigh's sign, §6), and P34 in libRadtran's
//! sign (§11), which is the sign atmosim adopts for the (3, 4) element of
//! [`PhaseMatrix`] (its (4, 3) element is −P34). No sign is changed; the
//! Rayleigh limit of a tiny sphere (P34 → 0, P12 → −¾ sin²Θ) and the
//! identity of the P34 element with the Mie table's are pinned by tests.

use std::f64::consts::PI;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::physics::mie::phase_matrix::PhaseMatrix as MieTable;
use crate::polarization::phase::PhaseSample;
use crate::polarization::stokes::PhaseMatrix;

/// A sphere ensemble's phase matrix tabulated in μ = cos Θ, interpolated
/// linearly in μ, normalised so that (1/4π)∫P11 dΩ = 1.
#[derive(Debug, Clone, PartialEq)]
pub struct TabulatedPhaseMatrix {
    /// μ = cos Θ at the nodes, strictly ascending from −1 to 1 (the input
    /// angles in reverse order).
    mu: Vec<f64>,
    /// 1/(μ_{i+1} − μ_i) for each segment i.
    inv_dmu: Vec<f64>,
    /// Normalised P11 at the nodes.
    p11: Vec<f64>,
    /// P12 at the nodes (same scale as P11).
    p12: Vec<f64>,
    /// P33 at the nodes.
    p33: Vec<f64>,
    /// P34 at the nodes (libRadtran's sign, CONVENTIONS.md §11).
    p34: Vec<f64>,
    /// CDF of μ at the nodes, ½∫₋₁^{μ_i} P11 dμ: 0 at the first, 1 at the last.
    cdf: Vec<f64>,
    /// ⟨cos Θ⟩ of the interpolated P11.
    mean_cosine: f64,
    /// The factor the input elements were multiplied by.
    renormalization: f64,
}

impl TabulatedPhaseMatrix {
    /// Builds the table from scattering angles `angles_deg` (degrees,
    /// strictly ascending, exactly 0 first and 180 last, at least 2) and the
    /// elements at those angles (`p11` > 0, all finite, same lengths).
    /// `name` names the table in errors. The elements are rescaled together
    /// so that the interpolated P11 is normalised; the factor is
    /// [`TabulatedPhaseMatrix::renormalization`].
    pub fn new(
        name: &str,
        angles_deg: &[f64],
        p11: &[f64],
        p12: &[f64],
        p33: &[f64],
        p34: &[f64],
    ) -> Result<TabulatedPhaseMatrix> {
        let n = angles_deg.len();
        let err = |msg: String| Error::data(name, msg);
        if n < 2 {
            return Err(err(format!("phase matrix needs at least 2 angles, got {n}")));
        }
        for (element, values) in [("P11", p11), ("P12", p12), ("P33", p33), ("P34", p34)] {
            if values.len() != n {
                return Err(err(format!(
                    "{element} has {} values for {n} scattering angles",
                    values.len()
                )));
            }
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(err(format!(
                    "{element} at {}° is not finite ({})",
                    angles_deg[i], values[i]
                )));
            }
        }
        if let Some(i) = angles_deg.iter().position(|a| !a.is_finite()) {
            return Err(err(format!("scattering angle {i} is not finite ({})", angles_deg[i])));
        }
        if angles_deg[0] != 0.0 || angles_deg[n - 1] != 180.0 {
            return Err(err(format!(
                "scattering angles must run from 0 to 180°, got {}° to {}°",
                angles_deg[0],
                angles_deg[n - 1]
            )));
        }
        if let Some(i) = angles_deg.windows(2).position(|w| w[1] <= w[0]) {
            return Err(err(format!(
                "scattering angles must be strictly ascending: {}° is followed by {}°",
                angles_deg[i],
                angles_deg[i + 1]
            )));
        }
        if let Some(i) = p11.iter().position(|&p| p <= 0.0) {
            return Err(err(format!(
                "P11 at {}° is {}, must be positive",
                angles_deg[i], p11[i]
            )));
        }

        // Nodes in ascending μ; the end points exactly ±1.
        let mu: Vec<f64> = angles_deg
            .iter()
            .rev()
            .map(|&a| {
                if a == 0.0 {
                    1.0
                } else if a == 180.0 {
                    -1.0
                } else {
                    a.to_radians().cos()
                }
            })
            .collect();
        if let Some(i) = mu.windows(2).position(|w| w[1] <= w[0]) {
            return Err(err(format!(
                "scattering angles {}° and {}° are too close: their cosines are equal in f64",
                angles_deg[n - 2 - i],
                angles_deg[n - 1 - i]
            )));
        }
        let inv_dmu: Vec<f64> = mu.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect();
        let reversed = |v: &[f64]| v.iter().rev().copied().collect::<Vec<f64>>();
        let (mut p11, mut p12, mut p33, mut p34) = (reversed(p11), reversed(p12), reversed(p33), reversed(p34));

        // Exact integral of the piecewise-linear P11: ½∫P11 dμ per segment is
        // ¼(p_i + p_{i+1})(μ_{i+1} − μ_i).
        let mut cdf = Vec::with_capacity(n);
        cdf.push(0.0);
        for i in 0..n - 1 {
            let mass = 0.25 * (p11[i] + p11[i + 1]) * (mu[i + 1] - mu[i]);
            cdf.push(cdf[i] + mass);
        }
        let total = cdf[n - 1];
        let renormalization = 1.0 / total;
        for v in [&mut p11, &mut p12, &mut p33, &mut p34] {
            v.iter_mut().for_each(|p| *p *= renormalization);
        }
        cdf.iter_mut().for_each(|c| *c /= total);
        cdf[n - 1] = 1.0;

        // ½∫μ·P11 dμ, exact for P11 linear on [a, b]:
        // (b − a)/6·[p_a(2a + b) + p_b(a + 2b)].
        let mean_cosine = 0.5
            * (0..n - 1)
                .map(|i| {
                    let (a, b) = (mu[i], mu[i + 1]);
                    (b - a) / 6.0 * (p11[i] * (2.0 * a + b) + p11[i + 1] * (a + 2.0 * b))
                })
                .sum::<f64>();

        Ok(TabulatedPhaseMatrix {
            mu,
            inv_dmu,
            p11,
            p12,
            p33,
            p34,
            cdf,
            mean_cosine,
            renormalization,
        })
    }

    /// The table of a Mie computation ([`crate::physics::mie`]), whose grid
    /// must run from 0 to 180° (as the default grid does).
    pub fn from_mie(name: &str, table: &MieTable) -> Result<TabulatedPhaseMatrix> {
        TabulatedPhaseMatrix::new(name, &table.angles_deg, &table.p11, &table.p12, &table.p33, &table.p34)
    }

    /// The factor the input elements were multiplied by so that
    /// (1/4π)∫P11 dΩ = 1 under linear interpolation in μ: 1 for a table that
    /// was already normalised that way; for a Mie table on the default grid,
    /// 1 to within about 1e-4.
    pub fn renormalization(&self) -> f64 {
        self.renormalization
    }

    /// The number of tabulated angles.
    pub fn len(&self) -> usize {
        self.mu.len()
    }

    /// Always false: a table has at least two angles.
    pub fn is_empty(&self) -> bool {
        self.mu.is_empty()
    }

    /// The segment `i` with μ_i ≤ μ ≤ μ_{i+1} (clamped to the table), by
    /// binary search.
    #[inline]
    fn segment(&self, cos_theta: f64) -> usize {
        let n = self.mu.len();
        self.mu.partition_point(|&m| m <= cos_theta).clamp(1, n - 1) - 1
    }

    /// P11 at `cos_theta` on segment `i`: the one formula both evaluation
    /// and sampling use.
    #[inline]
    fn p11_on(&self, i: usize, cos_theta: f64) -> f64 {
        let w = (cos_theta - self.mu[i]) * self.inv_dmu[i];
        self.p11[i] + w * (self.p11[i + 1] - self.p11[i])
    }

    /// The phase function P11(cos Θ), normalised so that
    /// (1/4π)∫P11 dΩ = 1. `cos_theta` is clamped to [−1, 1].
    #[inline]
    pub fn p11(&self, cos_theta: f64) -> f64 {
        let mu = cos_theta.clamp(-1.0, 1.0);
        self.p11_on(self.segment(mu), mu)
    }

    /// Probability density per steradian of scattering by Θ: P11/(4π).
    #[inline]
    pub fn pdf(&self, cos_theta: f64) -> f64 {
        self.p11(cos_theta) / (4.0 * PI)
    }

    /// The phase matrix at `cos_theta` in the scattering-plane frame, with
    /// P22 = P11 and P44 = P33 (spheres).
    pub fn matrix(&self, cos_theta: f64) -> PhaseMatrix {
        let mu = cos_theta.clamp(-1.0, 1.0);
        let i = self.segment(mu);
        let w = (mu - self.mu[i]) * self.inv_dmu[i];
        let lerp = |v: &[f64]| v[i] + w * (v[i + 1] - v[i]);
        let p11 = self.p11_on(i, mu);
        let p33 = lerp(&self.p33);
        PhaseMatrix {
            p11,
            p12: lerp(&self.p12),
            p22: p11,
            p33,
            p34: lerp(&self.p34),
            p44: p33,
        }
    }

    /// Mean cosine ⟨cos Θ⟩ of the interpolated P11 (exact for it).
    pub fn mean_cosine(&self) -> f64 {
        self.mean_cosine
    }

    /// Samples cos Θ ∝ P11 from `u[0]` by inverting the CDF exactly and the
    /// azimuth φ = 2π·u[1].
    ///
    /// The segment i with CDF_i ≤ u < CDF_{i+1} is found by binary search.
    /// On it P11 = p_i + s·t with t = μ − μ_i, so the mass r = u − CDF_i
    /// satisfies ½(p_i·t + s·t²/2) = r; its root in the segment is
    /// t = 4r/(p_i + √(p_i² + 4s·r)), free of cancellation for either sign
    /// of s (the square root is P11 at the sampled μ, which is positive).
    #[inline]
    pub fn sample(&self, u: [f64; 2]) -> PhaseSample {
        let n = self.cdf.len();
        let i = self.cdf.partition_point(|&c| c <= u[0]).clamp(1, n - 1) - 1;
        let r = (u[0] - self.cdf[i]).max(0.0);
        let p0 = self.p11[i];
        let s = (self.p11[i + 1] - p0) * self.inv_dmu[i];
        let root = (p0 * p0 + 4.0 * s * r).max(0.0).sqrt();
        let t = 4.0 * r / (p0 + root);
        let cos_theta = (self.mu[i] + t).min(self.mu[i + 1]);
        PhaseSample {
            cos_theta,
            phi: 2.0 * PI * u[1],
            pdf: self.p11_on(i, cos_theta) / (4.0 * PI),
        }
    }

    /// Samples the outgoing propagation direction for a photon travelling
    /// along the unit vector `k_in`, with the azimuth reference of
    /// [`crate::polarization::phase::PhaseFunction::sample_direction`]
    /// ([`PhaseSample::direction`]).
    pub fn sample_direction(&self, k_in: DVec3, u: [f64; 2]) -> (DVec3, PhaseSample) {
        let sample = self.sample(u);
        (sample.direction(k_in), sample)
    }
}
