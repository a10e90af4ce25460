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
//!
//! (About 300 lines without its unit tests, which check sampling by χ²,
//! the normalisation and mean cosine by exact quadrature, Henyey–Greenstein
//! tables against analytic error bounds, and the Rayleigh limit of the Mie
//! solver.)

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
    /// Per cell of sin(Θ/2) ([`GUIDE`] cells): the segment at its smallest μ.
    guide_mu: Vec<u32>,
    /// Per cell of the CDF: the segment at its lowest value.
    guide_cdf: Vec<u32>,
}

/// Cells of the guide tables that replace binary searches (a few nodes per
/// cell on the default 561-angle grid).
const GUIDE: usize = 1024;

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
        let reversed = |v: &[f64]| v.iter().rev().copied().collect::<Vec<f64>>();
        Ok(Self::on_nodes(
            mu,
            reversed(p11),
            reversed(p12),
            reversed(p33),
            reversed(p34),
        ))
    }

    /// The σ-weighted mixture Σ w_k·T_k of tables on the same μ nodes
    /// (weights positive, at least one table): linear in μ between the
    /// nodes like its parts, so it is exactly their weighted sum
    /// everywhere (renormalised, by a factor 1 to rounding when the
    /// weights sum to 1).
    pub fn mixture(parts: &[(&TabulatedPhaseMatrix, f64)]) -> TabulatedPhaseMatrix {
        let first = parts[0].0;
        assert!(parts.iter().all(|(t, _)| t.mu == first.mu), "tables on different nodes");
        let n = first.mu.len();
        let sum = |get: fn(&TabulatedPhaseMatrix) -> &[f64]| {
            (0..n)
                .map(|i| parts.iter().map(|(t, w)| w * get(t)[i]).sum::<f64>())
                .collect::<Vec<f64>>()
        };
        Self::on_nodes(
            first.mu.clone(),
            sum(|t| &t.p11),
            sum(|t| &t.p12),
            sum(|t| &t.p33),
            sum(|t| &t.p34),
        )
    }

    /// The table of checked nodes (μ strictly ascending from −1 to 1, P11
    /// positive): normalisation, CDF, mean cosine and guide tables.
    fn on_nodes(
        mu: Vec<f64>,
        mut p11: Vec<f64>,
        mut p12: Vec<f64>,
        mut p33: Vec<f64>,
        mut p34: Vec<f64>,
    ) -> TabulatedPhaseMatrix {
        let n = mu.len();
        let inv_dmu: Vec<f64> = mu.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect();

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

        // Guide tables: the segment where each cell of s = sin(Θ/2) =
        // √((1 − μ)/2) (about Θ/2, so the fine forward nodes spread over
        // cells) starts, at the cell's smallest μ; and where each cell of
        // the CDF starts.
        let segment_of_mu = |m: f64| mu.partition_point(|&x| x <= m).clamp(1, n - 1) - 1;
        let guide_mu = (0..GUIDE)
            .map(|c| {
                let s = (c + 1) as f64 / GUIDE as f64;
                segment_of_mu(1.0 - 2.0 * s * s) as u32
            })
            .collect();
        let guide_cdf = (0..GUIDE)
            .map(|c| {
                let u = c as f64 / GUIDE as f64;
                (cdf.partition_point(|&x| x <= u).clamp(1, n - 1) - 1) as u32
            })
            .collect();
        TabulatedPhaseMatrix {
            mu,
            inv_dmu,
            p11,
            p12,
            p33,
            p34,
            cdf,
            mean_cosine,
            renormalization,
            guide_mu,
            guide_cdf,
        }
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
        let s = ((1.0 - cos_theta) * 0.5).max(0.0).sqrt();
        let cell = ((s * GUIDE as f64) as usize).min(GUIDE - 1);
        let mut i = self.guide_mu[cell] as usize;
        // The cell's smallest μ is at most cos Θ, up to rounding of s.
        while i > 0 && self.mu[i] > cos_theta {
            i -= 1;
        }
        while i + 2 < n && self.mu[i + 1] <= cos_theta {
            i += 1;
        }
        i
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
        let (i, w) = self.locate(cos_theta);
        self.matrix_on(i, w)
    }

    /// Where `cos_theta` (clamped to [−1, 1]) lies in the table: its segment
    /// i and the weight w ∈ [0, 1] of node i + 1. Tables on the same μ
    /// nodes share it ([`crate::polarization::phase_table_set`]).
    #[inline]
    pub fn locate(&self, cos_theta: f64) -> (usize, f64) {
        let mu = cos_theta.clamp(-1.0, 1.0);
        let i = self.segment(mu);
        (i, (mu - self.mu[i]) * self.inv_dmu[i])
    }

    /// The μ nodes, ascending from −1 to 1.
    pub fn mu_nodes(&self) -> &[f64] {
        &self.mu
    }

    /// The phase matrix at the place `(i, w)` of [`TabulatedPhaseMatrix::locate`].
    #[inline]
    pub fn matrix_on(&self, i: usize, w: f64) -> PhaseMatrix {
        let lerp = |v: &[f64]| v[i] + w * (v[i + 1] - v[i]);
        let p11 = lerp(&self.p11);
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
    /// azimuth φ = 2π·`u[1]`.
    ///
    /// The segment i with CDF_i ≤ u < CDF_{i+1} is found by binary search.
    /// On it P11 = p_i + s·t with t = μ − μ_i, so the mass r = u − CDF_i
    /// satisfies ½(p_i·t + s·t²/2) = r; its root in the segment is
    /// t = 4r/(p_i + √(p_i² + 4s·r)), free of cancellation for either sign
    /// of s (the square root is P11 at the sampled μ, which is positive).
    #[inline]
    pub fn sample(&self, u: [f64; 2]) -> PhaseSample {
        let n = self.cdf.len();
        let cell = ((u[0] * GUIDE as f64) as usize).min(GUIDE - 1);
        let mut i = self.guide_cdf[cell] as usize;
        while i + 2 < n && self.cdf[i + 1] <= u[0] {
            i += 1;
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::mie::lognormal::Quadrature;
    use crate::physics::mie::opac::component_optics;
    use crate::physics::mie::phase_matrix::default_angles_deg;
    use crate::physics::mie::sphere::Sphere;
    use crate::polarization::phase::PhaseFunction;
    use num_complex::Complex64;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// χ² critical value for 49 degrees of freedom (50 bins, no fitted
    /// parameter) at p = 0.001.
    const CHI2_CRIT_49_DOF_P001: f64 = 85.3506;

    /// Henyey–Greenstein P11 (normalised), an independent closed form.
    fn hg(g: f64, mu: f64) -> f64 {
        (1.0 - g * g) / (1.0 + g * g - 2.0 * g * mu).powf(1.5)
    }

    /// A table with only P11 given (P12 = P33 = P34 = 0).
    fn p11_table(name: &str, angles_deg: &[f64], f: impl Fn(f64) -> f64) -> TabulatedPhaseMatrix {
        let p11: Vec<f64> = angles_deg.iter().map(|a| f(a.to_radians().cos())).collect();
        let zero = vec![0.0; angles_deg.len()];
        TabulatedPhaseMatrix::new(name, angles_deg, &p11, &zero, &zero, &zero).unwrap()
    }

    /// The phase matrix of one sphere from the Mie solver, normalised as
    /// the Mie side normalises ensembles: P = 4·S/(x²·Q_sca).
    fn sphere_table(x: f64, m: Complex64, angles_deg: &[f64]) -> MieTable {
        let sphere = Sphere::new(x, m).unwrap();
        let norm = 4.0 / (x * x * sphere.efficiencies().q_sca);
        let el: Vec<[f64; 4]> = angles_deg
            .iter()
            .map(|a| {
                sphere
                    .amplitudes(a.to_radians().cos())
                    .matrix_elements()
                    .map(|v| v * norm)
            })
            .collect();
        let col = |j: usize| el.iter().map(|e| e[j]).collect::<Vec<f64>>();
        MieTable {
            angles_deg: angles_deg.to_vec(),
            p11: col(0),
            p12: col(1),
            p33: col(2),
            p34: col(3),
        }
    }

    /// OPAC water-soluble aerosol at 50 % humidity and 550 nm on the default grid.
    fn waso_table() -> MieTable {
        component_optics("waso", 50.0, 550.0, &default_angles_deg(), Quadrature::default())
            .unwrap()
            .phase
    }

    /// The tables the sampling tests run on: forward-peaked (a real Mie
    /// table, HG g = 0.9), backward-structured (a water sphere of x = 15 with
    /// its glory and rainbow ripples; HG g = −0.7), with their names.
    /// Computed once (the waso table takes seconds) and shared by the tests.
    fn test_tables() -> &'static [(String, TabulatedPhaseMatrix)] {
        static TABLES: std::sync::OnceLock<Vec<(String, TabulatedPhaseMatrix)>> = std::sync::OnceLock::new();
        TABLES.get_or_init(build_test_tables)
    }

    fn build_test_tables() -> Vec<(String, TabulatedPhaseMatrix)> {
        let grid = default_angles_deg();
        let waso = TabulatedPhaseMatrix::from_mie("waso 50 % 550 nm", &waso_table()).unwrap();
        let water = sphere_table(15.0, Complex64::new(1.33, 0.0), &grid);
        let water = TabulatedPhaseMatrix::from_mie("water sphere x = 15", &water).unwrap();
        vec![
            ("waso 50 % 550 nm".to_string(), waso),
            ("HG g = 0.9".to_string(), p11_table("hg", &grid, |mu| hg(0.9, mu))),
            ("water sphere x = 15".to_string(), water),
            ("HG g = −0.7".to_string(), p11_table("hg", &grid, |mu| hg(-0.7, mu))),
        ]
    }

    #[test]
    fn guide_tables_find_the_segments_binary_search_finds() {
        // Every node, its neighbours in f64, and random μ and u, on the
        // test tables: the guided searches return what a binary search does.
        let mut rng = Pcg64Mcg::seed_from_u64(91);
        for (name, t) in test_tables() {
            let n = t.mu.len();
            let binary_mu = |m: f64| t.mu.partition_point(|&x| x <= m).clamp(1, n - 1) - 1;
            let binary_u = |u: f64| t.cdf.partition_point(|&x| x <= u).clamp(1, n - 1) - 1;
            let mut mus: Vec<f64> = t.mu.iter().flat_map(|&m| [m, m.next_up(), m.next_down()]).collect();
            mus.extend((0..20_000).map(|_| 2.0 * rng.random::<f64>() - 1.0));
            mus.extend((0..20_000).map(|_| 1.0 - 1e-4 * rng.random::<f64>()));
            for m in mus.into_iter().map(|m| m.clamp(-1.0, 1.0)) {
                assert_eq!(t.segment(m), binary_mu(m), "{name}: μ {m}");
            }
            for k in 0..50_000 {
                let u = if k < t.cdf.len() {
                    t.cdf[k].min(0.999_999_999)
                } else {
                    rng.random::<f64>()
                };
                let s = t.sample([u, 0.0]);
                let i = binary_u(u);
                assert!(s.cos_theta >= t.mu[i] && s.cos_theta <= t.mu[i + 1], "{name}: u {u}");
            }
        }
    }

    #[test]
    fn a_mixture_of_tables_is_their_weighted_sum() {
        let tables = test_tables();
        let (a, b) = (&tables[0].1, &tables[1].1);
        let m = TabulatedPhaseMatrix::mixture(&[(a, 0.3), (b, 0.7)]);
        assert!((m.renormalization() - 1.0).abs() < 1e-12);
        for k in 0..=400 {
            let mu = -1.0 + k as f64 / 200.0;
            let (x, y, z) = (m.matrix(mu), a.matrix(mu), b.matrix(mu));
            for (got, want) in [
                (x.p11, 0.3 * y.p11 + 0.7 * z.p11),
                (x.p12, 0.3 * y.p12 + 0.7 * z.p12),
                (x.p33, 0.3 * y.p33 + 0.7 * z.p33),
                (x.p34, 0.3 * y.p34 + 0.7 * z.p34),
            ] {
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "μ {mu}: {got} vs {want}"
                );
            }
        }
    }

    /// Two-point Gauss–Legendre nodes on [a, b] (exact for cubics).
    fn gauss2(a: f64, b: f64) -> [f64; 2] {
        let (m, d) = (0.5 * (a + b), 0.5 * (b - a) / 3f64.sqrt());
        [m - d, m + d]
    }

    /// The CDF of μ of the interpolated P11, written independently of the
    /// sampler: ½∫₋₁^μ p11 by two-point Gauss–Legendre per segment, which is
    /// exact for the piecewise-linear P11, evaluating only `p11()`.
    struct TestCdf {
        mu: Vec<f64>,
        cum: Vec<f64>,
    }

    impl TestCdf {
        fn new(t: &TabulatedPhaseMatrix) -> TestCdf {
            let mu = t.mu.clone();
            let mut cum = vec![0.0];
            for w in mu.windows(2) {
                let [x0, x1] = gauss2(w[0], w[1]);
                cum.push(cum.last().unwrap() + 0.25 * (w[1] - w[0]) * (t.p11(x0) + t.p11(x1)));
            }
            TestCdf { mu, cum }
        }

        fn at(&self, t: &TabulatedPhaseMatrix, mu: f64) -> f64 {
            let i = self.mu.partition_point(|&m| m <= mu).clamp(1, self.mu.len() - 1) - 1;
            let [x0, x1] = gauss2(self.mu[i], mu);
            self.cum[i] + 0.25 * (mu - self.mu[i]) * (t.p11(x0) + t.p11(x1))
        }
    }

    #[test]
    fn normalisation_and_mean_cosine_by_exact_quadrature() {
        for (name, t) in test_tables() {
            // ½∫P11 dμ by two-point Gauss–Legendre per segment (exact for
            // linear P11), and ½∫μ·P11 dμ likewise (exact for quadratics).
            let (mut norm, mut mean) = (0.0, 0.0);
            for w in t.mu.windows(2) {
                for x in gauss2(w[0], w[1]) {
                    norm += 0.25 * (w[1] - w[0]) * t.p11(x);
                    mean += 0.25 * (w[1] - w[0]) * x * t.p11(x);
                }
            }
            assert!((norm - 1.0).abs() < 1e-12, "{name}: ½∫P11 dμ = {norm}");
            assert!(
                (mean - t.mean_cosine()).abs() < 1e-12,
                "{name}: {mean} vs {}",
                t.mean_cosine()
            );
            println!(
                "{name}: renormalisation {:.3e} − 1, ⟨cos Θ⟩ {mean:.6}",
                t.renormalization() - 1.0
            );
        }
    }

    #[test]
    fn real_mie_tables_need_little_renormalisation() {
        // The Mie side's tables are normalised by its own quadrature to
        // 1e-4 on the default grid (physics::mie::phase_matrix); linear
        // interpolation in μ must agree to that order, or the grid does not
        // resolve the table.
        let waso = TabulatedPhaseMatrix::from_mie("waso", &waso_table()).unwrap();
        assert!(
            (waso.renormalization() - 1.0).abs() < 1e-4,
            "{}",
            waso.renormalization()
        );
        // The Mie side's asymmetry parameter comes from the Mie series, not
        // the table: the table's mean cosine agrees to the grid's accuracy.
        let o = component_optics("waso", 50.0, 550.0, &[], Quadrature::default()).unwrap();
        assert!(
            (waso.mean_cosine() - o.g).abs() < 1e-4,
            "{} vs g {}",
            waso.mean_cosine(),
            o.g
        );
        println!(
            "waso: renormalisation − 1 = {:.3e}, ⟨cos Θ⟩ − g = {:.3e}",
            waso.renormalization() - 1.0,
            waso.mean_cosine() - o.g
        );
    }

    #[test]
    fn a_phase_function_linear_in_mu_is_reproduced_exactly() {
        // P11 = 1 + 0.6μ is normalised, has ⟨μ⟩ = 0.2 and the CDF
        // F(μ) = ½(μ + 1) + 0.15(μ² − 1); linear interpolation is exact for it.
        let t = p11_table("linear", &default_angles_deg(), |mu| 1.0 + 0.6 * mu);
        assert!((t.renormalization() - 1.0).abs() < 1e-14);
        assert!((t.mean_cosine() - 0.2).abs() < 1e-14);
        for k in 0..=10_000 {
            let u = k as f64 / 10_000.0;
            let mu = t.sample([u, 0.0]).cos_theta;
            let f = 0.5 * (mu + 1.0) + 0.15 * (mu * mu - 1.0);
            assert!((f - u).abs() < 1e-14, "F(F⁻¹({u})) = {f}");
            assert!((t.p11(mu) - (1.0 + 0.6 * mu)).abs() < 1e-14);
        }
    }

    #[test]
    fn chi_squared_of_sampled_cos_theta() {
        // 50 bins of equal expected count: sampled μ is mapped through the
        // independently written CDF, under which it is uniform on [0, 1).
        const BINS: usize = 50;
        const SAMPLES: usize = 200_000;
        for (n, (name, t)) in test_tables().iter().enumerate() {
            let cdf = TestCdf::new(t);
            let mut rng = Pcg64Mcg::seed_from_u64(2000 + n as u64);
            let mut counts = [0usize; BINS];
            for _ in 0..SAMPLES {
                let mu = t.sample([rng.random(), rng.random()]).cos_theta;
                let v = cdf.at(t, mu);
                counts[((v * BINS as f64) as usize).min(BINS - 1)] += 1;
            }
            let expected = SAMPLES as f64 / BINS as f64;
            let chi2: f64 = counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum();
            println!("{name}: χ² = {chi2:.3} (49 dof, critical {CHI2_CRIT_49_DOF_P001} at p = 0.001)");
            assert!(chi2 < CHI2_CRIT_49_DOF_P001, "{name}: χ² = {chi2}");
        }
    }

    #[test]
    fn inverse_cdf_roundtrip() {
        // The sampler inverts the independently written CDF to rounding.
        for (name, t) in test_tables() {
            let cdf = TestCdf::new(t);
            let mut worst = 0.0f64;
            for k in 0..=20_000 {
                let u = k as f64 / 20_000.0;
                let mu = t.sample([u, 0.5]).cos_theta;
                assert!((-1.0..=1.0).contains(&mu), "{name}: {mu}");
                worst = worst.max((cdf.at(t, mu) - u).abs());
            }
            assert!(worst < 1e-12, "{name}: F(F⁻¹(u)) off by {worst}");
        }
    }

    #[test]
    fn sample_pdf_matches_pdf() {
        let mut worst = 0.0f64;
        for (n, (name, t)) in test_tables().iter().enumerate() {
            let mut rng = Pcg64Mcg::seed_from_u64(50 + n as u64);
            for _ in 0..100_000 {
                let s = t.sample([rng.random(), rng.random()]);
                let pdf = t.pdf(s.cos_theta);
                let rel = (s.pdf - pdf).abs() / pdf;
                assert!(rel <= 1e-12, "{name}: μ {} pdf {} vs {pdf}", s.cos_theta, s.pdf);
                assert!((0.0..2.0 * PI).contains(&s.phi));
                assert_eq!(pdf, t.p11(s.cos_theta) / (4.0 * PI));
                worst = worst.max(rel);
            }
        }
        println!("worst relative pdf mismatch {worst:.2e}");
    }

    #[test]
    fn sampled_directions_are_unit_and_at_the_sampled_angle() {
        let mut rng = Pcg64Mcg::seed_from_u64(71);
        for (name, t) in test_tables() {
            for _ in 0..5_000 {
                let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
                let phi = 2.0 * PI * rng.random::<f64>();
                let s = (1.0 - z * z).sqrt();
                let k_in = DVec3::new(s * phi.cos(), s * phi.sin(), z);
                let u = [rng.random(), rng.random()];
                let (k_out, sample) = t.sample_direction(k_in, u);
                assert_eq!(sample, t.sample(u));
                assert!((k_out.length() - 1.0).abs() < 1e-12, "{name}");
                assert!((k_out.dot(k_in) - sample.cos_theta).abs() < 1e-12, "{name}");
            }
        }
    }

    #[test]
    fn mean_cosine_by_monte_carlo() {
        for (n, (name, t)) in test_tables().iter().enumerate() {
            let mut rng = Pcg64Mcg::seed_from_u64(400 + n as u64);
            let count = 200_000;
            let (mut sum, mut sum2) = (0.0, 0.0);
            for _ in 0..count {
                let mu = t.sample([rng.random(), rng.random()]).cos_theta;
                sum += mu;
                sum2 += mu * mu;
            }
            let mean = sum / count as f64;
            let var = (sum2 / count as f64 - mean * mean) * count as f64 / (count as f64 - 1.0);
            let sigma = (var / count as f64).sqrt();
            let diff = (mean - t.mean_cosine()).abs();
            assert!(diff < 4.0 * sigma, "{name}: {mean} vs {} (σ {sigma})", t.mean_cosine());
        }
    }

    #[test]
    fn henyey_greenstein_tables_reproduce_the_closed_form() {
        // Linear interpolation of a convex P (HG: P'' = 15g²(1 − g²)D^{−7/2},
        // D = 1 + g² − 2gμ, monotone in μ, so its maximum on a segment is at
        // an end) lies above P by at most h²/8·max P'' on a segment of width
        // h, and its integral exceeds P's by at most h³/12·max P''. So
        // 0 ≤ ½∫L dμ − 1 ≤ B = ½Σh³/12·max P'', the table's factor
        // c = 1/(½∫L dμ) is 1 − O(B), P11 = c·L is within
        // c·h²/8·max P'' + (1 − c)·P of P, and ⟨μ⟩ is within
        // ½∫|cL − P| dμ ≤ c(1/c − 1) + (1 − c) = 2(1 − c) of g.
        let uniform: Vec<f64> = (0..=1800).map(|i| i as f64 * 0.1).collect();
        for (grid_name, grid) in [("default grid", default_angles_deg()), ("0.1° grid", uniform)] {
            for g in [0.9, 0.7, -0.5] {
                let t = p11_table("hg", &grid, |mu| hg(g, mu));
                let d2 = |mu: f64| 15.0 * g * g * (1.0 - g * g) * (1.0 + g * g - 2.0 * g * mu).powf(-3.5);
                let mut bound_norm = 0.0;
                let mut worst_rel = 0.0f64;
                let c = t.renormalization();
                for w in t.mu.windows(2) {
                    let h = w[1] - w[0];
                    let d2_max = d2(w[0]).max(d2(w[1]));
                    bound_norm += 0.5 * h * h * h / 12.0 * d2_max;
                    for f in [0.1, 0.37, 0.5, 0.81] {
                        let mu = w[0] + f * h;
                        let (p, exact) = (t.p11(mu), hg(g, mu));
                        let bound = c * h * h / 8.0 * d2_max + (1.0 - c) * exact;
                        assert!(
                            (p - exact).abs() <= bound * (1.0 + 1e-9) + 1e-14 * exact,
                            "g {g} μ {mu}"
                        );
                        worst_rel = worst_rel.max((p - exact).abs() / exact);
                    }
                }
                let excess = 1.0 / c - 1.0;
                assert!(
                    excess >= -1e-15 && excess <= bound_norm,
                    "g {g}: ½∫L − 1 = {excess}, bound {bound_norm}"
                );
                let mean_err = (t.mean_cosine() - g).abs();
                assert!(mean_err <= 2.0 * (1.0 - c) + 1e-14, "g {g}: {mean_err}");
                println!(
                    "HG g = {g} on the {grid_name}: c − 1 = {:.2e} (bound {bound_norm:.2e}), \
                     worst relative P11 error {worst_rel:.2e}, |⟨μ⟩ − g| = {mean_err:.2e}",
                    c - 1.0
                );
            }
        }
    }

    #[test]
    fn a_tiny_sphere_is_rayleigh_with_libradtran_signs() {
        // Rayleigh limit of the Mie solver (x ≪ 1): the table must match
        // PhaseFunction::Rayleigh { depolarization: 0 } element by element,
        // with P34 → 0. Let δ be the largest difference between the Mie
        // values at the nodes (the table divided by its factor c) and
        // Rayleigh's: the Mie series' first correction, O(x²). Then
        // - 1/c − 1 is the trapezoid error of Rayleigh's exactly quadratic
        //   P11 = ¾(1 + μ²), ½Σh³/12·3/2, plus ½∫ of the node differences
        //   interpolated, at most δ;
        // - between nodes, c·L_Mie − R differs from R by at most
        //   c·δ + c·h²/8·3/2 (linear interpolation of ¾(1 + μ²) and
        //   −¾(1 − μ²); P33 = 3/2·μ is linear and exact) + |1 − c|·|R|.
        let grid = default_angles_deg();
        let rayleigh = PhaseFunction::Rayleigh { depolarization: 0.0 };
        let mut delta_at = Vec::new();
        for x in [1e-2, 1e-3] {
            let mie = sphere_table(x, Complex64::new(1.5, 0.01), &grid);
            let t = TabulatedPhaseMatrix::from_mie("tiny sphere", &mie).unwrap();
            let c = t.renormalization();
            let mut delta = 0.0f64;
            for (j, &mu) in t.mu.iter().enumerate() {
                let (m, r) = (t.matrix(mu).scaled(1.0 / c), rayleigh.matrix(mu));
                let d = [
                    m.p11 - r.p11,
                    m.p12 - r.p12,
                    m.p22 - r.p22,
                    m.p33 - r.p33,
                    m.p34,
                    m.p44 - r.p44,
                ];
                delta = d.iter().fold(delta, |a, v| a.max(v.abs()));
                // The table's elements are the Mie side's, signs unchanged.
                let k = t.mu.len() - 1 - j;
                let raw = t.matrix(mu);
                assert_eq!(
                    (raw.p12, raw.p33, raw.p34),
                    (c * mie.p12[k], c * mie.p33[k], c * mie.p34[k])
                );
            }
            let trapezoid: f64 = t.mu.windows(2).map(|w| 0.5 * (w[1] - w[0]).powi(3) / 12.0 * 1.5).sum();
            let excess = 1.0 / c - 1.0;
            assert!(
                (excess - trapezoid).abs() <= delta,
                "x {x}: {excess} vs {trapezoid} ± {delta}"
            );
            let mut worst_between = 0.0f64;
            for w in t.mu.windows(2) {
                let mu = 0.5 * (w[0] + w[1]);
                let (m, r) = (t.matrix(mu), rayleigh.matrix(mu));
                let interpolation = c * (delta + (w[1] - w[0]).powi(2) / 8.0 * 1.5);
                for (d, r) in [
                    (m.p11 - r.p11, r.p11),
                    (m.p12 - r.p12, r.p12),
                    (m.p33 - r.p33, r.p33),
                    (m.p34, 0.0),
                ] {
                    let bound = interpolation + (1.0 - c).abs() * r.abs();
                    assert!(d.abs() <= bound * (1.0 + 1e-9) + 1e-15, "x {x} μ {mu}: {d} vs {bound}");
                    worst_between = worst_between.max(d.abs());
                }
            }
            println!(
                "x = {x}: δ (Mie vs Rayleigh at the nodes) {delta:.2e}, c − 1 = {:.2e}, \
                 worst |table − Rayleigh| between nodes {worst_between:.2e}",
                c - 1.0
            );
            delta_at.push(delta);
        }
        // δ is the O(x²) Mie correction: a tenth of x gives a hundredth of
        // it (a factor 2 allowed for the next order).
        assert!(delta_at[1] < delta_at[0] / 50.0, "{delta_at:?}");
    }

    #[test]
    fn the_matrix_has_the_sphere_block_form() {
        let mie = sphere_table(5.0, Complex64::new(1.5, 0.01), &default_angles_deg());
        let t = TabulatedPhaseMatrix::from_mie("sphere", &mie).unwrap();
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        for _ in 0..1000 {
            let mu = 2.0 * rng.random::<f64>() - 1.0;
            let m = t.matrix(mu);
            assert_eq!((m.p11, m.p22, m.p44), (t.p11(mu), m.p11, m.p33));
            // One sphere's matrix is pure: P12² + P33² + P34² = P11² at the
            // nodes. That set's convex hull, P12² + P33² + P34² ≤ P11² with
            // P11 > 0, is a convex cone, so linear interpolation stays in it
            // (to rounding).
            let lhs = (m.p12 * m.p12 + m.p33 * m.p33 + m.p34 * m.p34).sqrt();
            assert!(lhs <= m.p11 * (1.0 + 1e-12), "μ {mu}: {lhs} > {}", m.p11);
        }
        assert!(
            mie.p34.iter().any(|&v| v.abs() > 1e-3),
            "an absorbing x = 5 sphere has P34 ≠ 0"
        );
    }

    #[test]
    fn invalid_tables_are_refused_with_the_reason() {
        let a = [0.0, 90.0, 180.0];
        let p = [1.0, 1.0, 1.0];
        let z = [0.0; 3];
        /// Angles, P11, P12 and the text the error must contain.
        type Case = (Vec<f64>, Vec<f64>, Vec<f64>, &'static str);
        let cases: Vec<Case> = vec![
            (vec![0.0], vec![1.0], vec![0.0], "at least 2"),
            (a.to_vec(), vec![1.0, 1.0], z.to_vec(), "P11 has 2 values for 3"),
            (a.to_vec(), p.to_vec(), vec![0.0, 0.0], "P12 has 2 values"),
            (vec![1.0, 90.0, 180.0], p.to_vec(), z.to_vec(), "from 0 to 180"),
            (vec![0.0, 90.0, 179.0], p.to_vec(), z.to_vec(), "from 0 to 180"),
            (
                vec![0.0, 90.0, 80.0, 180.0],
                vec![1.0; 4],
                vec![0.0; 4],
                "strictly ascending: 90° is followed by 80°",
            ),
            (
                vec![0.0, 90.0, 90.0, 180.0],
                vec![1.0; 4],
                vec![0.0; 4],
                "strictly ascending",
            ),
            (
                vec![0.0, f64::NAN, 180.0],
                p.to_vec(),
                z.to_vec(),
                "angle 1 is not finite",
            ),
            (
                a.to_vec(),
                vec![1.0, f64::INFINITY, 1.0],
                z.to_vec(),
                "P11 at 90° is not finite",
            ),
            (
                a.to_vec(),
                p.to_vec(),
                vec![0.0, f64::NAN, 0.0],
                "P12 at 90° is not finite",
            ),
            (
                a.to_vec(),
                vec![1.0, 0.0, 1.0],
                z.to_vec(),
                "P11 at 90° is 0, must be positive",
            ),
            (a.to_vec(), vec![1.0, 1.0, -2.0], z.to_vec(), "P11 at 180° is -2"),
            (vec![0.0, 1e-10, 180.0], p.to_vec(), z.to_vec(), "too close"),
        ];
        for (angles, p11, p12, want) in cases {
            let zeros = vec![0.0; angles.len()];
            let e = TabulatedPhaseMatrix::new("my.table", &angles, &p11, &p12, &zeros, &zeros).unwrap_err();
            let msg = e.to_string();
            assert!(
                msg.starts_with("my.table: ") && msg.contains(want),
                "{msg} (wanted {want})"
            );
        }
    }
}
