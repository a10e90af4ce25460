//! Weighted sums over many spheres of the scattering-matrix elements at many
//! angles, Σᵢ wᵢ·(S11, S12, S33, S34)(Θⱼ), the inner loop of an ensemble's
//! phase matrix ([`super::lognormal`]).
//!
//! The amplitude functions of Bohren & Huffman (1983) Eq. 4.74,
//!
//!   S1(μ) = Σₙ cₙ (aₙπₙ(μ) + bₙτₙ(μ)),  S2(μ) = Σₙ cₙ (aₙτₙ(μ) + bₙπₙ(μ)),
//!   cₙ = (2n+1)/(n(n+1)),
//!
//! are linear in the Mie coefficients with angular functions πₙ, τₙ that do
//! not depend on the sphere. So πₙ(μⱼ) and τₙ(μⱼ) are computed once, for
//! every angle and every order up to the largest sphere's N, as one real
//! matrix M (angles × 2N, columns π₁ τ₁ π₂ τ₂ …), and the amplitudes of a
//! chunk of K spheres are one real matrix product M·C, where C has four
//! columns per sphere, [Re S1, Im S1, Re S2, Im S2]:
//!
//!   row of πₙ: cₙ·[Re aₙ, Im aₙ, Re bₙ, Im bₙ],
//!   row of τₙ: cₙ·[Re bₙ, Im bₙ, Re aₙ, Im aₙ].
//!
//! The product runs at the speed of a blocked, vectorised matrix
//! multiplication (faer) instead of a recurrence per sphere and angle;
//! πₙ and τₙ come from the same recurrence (BH Eq. 4.47) as in
//! [`Sphere::amplitudes`], so the two differ only in the order the series
//! is summed: a few units of the last place of the largest term.
//!
//! Spheres are grouped in chunks of similar term counts (consecutive radii
//! of an ascending quadrature), and each chunk multiplies only the first
//! 2N columns of M, N its largest term count, so that small spheres do not
//! pay for the orders of the largest.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use num_complex::Complex64;

use crate::physics::mie::sphere::{Amplitudes, Sphere};

/// Spheres per matrix product: 4·64 = 256 right-hand columns, enough for
/// the product to run near the machine's peak while the amplitude matrix
/// of a chunk (angles × 256) stays small.
const CHUNK: usize = 64;

/// The angular functions πₙ(μⱼ), τₙ(μⱼ) for n = 1..=N at every angle.
#[derive(Debug, Clone)]
pub struct AngularFunctions {
    /// Angles × 2N: column 2(n−1) holds πₙ, column 2(n−1)+1 holds τₙ.
    m: Mat<f64>,
}

impl AngularFunctions {
    /// πₙ and τₙ at cos Θ = `mu` for n = 1..=`n_max`, by the upward
    /// recurrence of [`Sphere::amplitudes`] (BH Eq. 4.47).
    pub fn new(mu: &[f64], n_max: usize) -> AngularFunctions {
        let mut m = Mat::<f64>::zeros(mu.len(), 2 * n_max);
        // πₙ₋₁ and πₙ per angle, starting from π₀ = 0, π₁ = 1.
        let mut pi_prev = vec![0.0; mu.len()];
        let mut pi = vec![1.0; mu.len()];
        for i in 0..n_max {
            let k = (i + 1) as f64;
            for (j, &mu_j) in mu.iter().enumerate() {
                let tau = k * mu_j * pi[j] - (k + 1.0) * pi_prev[j];
                m[(j, 2 * i)] = pi[j];
                m[(j, 2 * i + 1)] = tau;
                let pi_next = ((2.0 * k + 1.0) * mu_j * pi[j] - (k + 1.0) * pi_prev[j]) / k;
                (pi_prev[j], pi[j]) = (pi[j], pi_next);
            }
        }
        AngularFunctions { m }
    }

    /// The number of angles.
    pub fn angles(&self) -> usize {
        self.m.nrows()
    }

    /// The largest order N held.
    pub fn n_max(&self) -> usize {
        self.m.ncols() / 2
    }
}

/// Accumulates Σ w·[S11, S12, S33, S34] at every angle of an
/// [`AngularFunctions`], sphere by sphere (see the module docs).
#[derive(Debug)]
pub struct ElementSums<'a> {
    functions: &'a AngularFunctions,
    /// 2N × 4·CHUNK: the pending spheres' coefficient columns.
    coefficients: Mat<f64>,
    /// Angles × 4·CHUNK: the pending spheres' amplitudes after a product.
    amplitudes: Mat<f64>,
    /// Weight and term count of each pending sphere.
    pending: Vec<(f64, usize)>,
    /// The sums per angle, [S11, S12, S33, S34].
    sums: Vec<[f64; 4]>,
}

impl<'a> ElementSums<'a> {
    /// Empty sums at the angles of `functions`.
    pub fn new(functions: &'a AngularFunctions) -> ElementSums<'a> {
        ElementSums {
            functions,
            coefficients: Mat::zeros(2 * functions.n_max(), 4 * CHUNK),
            amplitudes: Mat::zeros(functions.angles(), 4 * CHUNK),
            pending: Vec::with_capacity(CHUNK),
            sums: vec![[0.0; 4]; functions.angles()],
        }
    }

    /// Adds w·[S11, S12, S33, S34] of `sphere`, whose term count must not
    /// exceed the functions' N (a programming error otherwise: panics).
    pub fn add(&mut self, sphere: &Sphere, w: f64) {
        let (a, b) = sphere.coefficients();
        let n = a.len();
        assert!(
            n <= self.functions.n_max(),
            "sphere with {n} terms, angular functions up to {}",
            self.functions.n_max()
        );
        // A chunk spans term counts within 25 % (+8) of each other, so
        // padding the smaller spheres to the chunk's N costs little.
        if let (Some(lo), Some(hi)) = (
            self.pending.iter().map(|p| p.1).min(),
            self.pending.iter().map(|p| p.1).max(),
        ) && (self.pending.len() == CHUNK || n.max(hi) > n.min(lo) * 5 / 4 + 8)
        {
            self.flush();
        }
        let col = 4 * self.pending.len();
        for (i, (an, bn)) in a.iter().zip(b).enumerate() {
            let k = (i + 1) as f64;
            let c = (2.0 * k + 1.0) / (k * (k + 1.0));
            let (ca, cb) = (c * an, c * bn);
            for (r, v) in [
                (2 * i, [ca.re, ca.im, cb.re, cb.im]),
                (2 * i + 1, [cb.re, cb.im, ca.re, ca.im]),
            ] {
                for (q, v) in v.into_iter().enumerate() {
                    self.coefficients[(r, col + q)] = v;
                }
            }
        }
        self.pending.push((w, n));
    }

    /// Multiplies out the pending chunk and adds it to the sums.
    fn flush(&mut self) {
        let Some(n) = self.pending.iter().map(|p| p.1).max() else {
            return;
        };
        let cols = 4 * self.pending.len();
        // Zero the rows of the orders a smaller sphere of the chunk lacks.
        for (s, &(_, n_s)) in self.pending.iter().enumerate() {
            for q in 4 * s..4 * s + 4 {
                for r in 2 * n_s..2 * n {
                    self.coefficients[(r, q)] = 0.0;
                }
            }
        }
        matmul(
            self.amplitudes.as_mut().subcols_mut(0, cols),
            Accum::Replace,
            self.functions.m.as_ref().subcols(0, 2 * n),
            self.coefficients.as_ref().submatrix(0, 0, 2 * n, cols),
            1.0,
            Par::Seq,
        );
        for (s, &(w, _)) in self.pending.iter().enumerate() {
            let col = |q: usize| self.amplitudes.col_as_slice(4 * s + q);
            let (s1_re, s1_im, s2_re, s2_im) = (col(0), col(1), col(2), col(3));
            for (j, acc) in self.sums.iter_mut().enumerate() {
                let el = Amplitudes {
                    s1: Complex64::new(s1_re[j], s1_im[j]),
                    s2: Complex64::new(s2_re[j], s2_im[j]),
                }
                .matrix_elements();
                for (a, v) in acc.iter_mut().zip(el) {
                    *a += w * v;
                }
            }
        }
        self.pending.clear();
    }

    /// The sums per angle, [S11, S12, S33, S34].
    pub fn finish(mut self) -> Vec<[f64; 4]> {
        self.flush();
        self.sums
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same sums the slow way: a recurrence per sphere and angle.
    fn direct(spheres: &[(Sphere, f64)], mu: &[f64]) -> Vec<[f64; 4]> {
        let mut s = vec![[0.0; 4]; mu.len()];
        for (sphere, w) in spheres {
            for (acc, &mu_j) in s.iter_mut().zip(mu) {
                for (a, v) in acc.iter_mut().zip(sphere.amplitudes(mu_j).matrix_elements()) {
                    *a += w * v;
                }
            }
        }
        s
    }

    /// The matrix-product sums equal the direct ones to rounding, for one
    /// sphere and for a set of spheres of very different sizes (several
    /// chunks, padded orders), absorbing or not, at angles that include
    /// 0°, 180° and the fine forward grid. Tolerance: both sum the same
    /// series in a different order, so they differ by a few units in the
    /// last place of the largest term, Σ|terms| ≈ N·|S(0)|; relative to
    /// S11 at that angle the difference is that times the dynamic range
    /// S11(0)/S11(Θ), about 10⁴ for x = 60, so 1e-10 relative to S11
    /// leaves a margin of 10² over 1e-16·N·10⁴. Measured: below 1e-12.
    #[test]
    fn matrix_product_sums_equal_the_direct_sums() {
        let angles = [0.0, 0.01, 0.3, 1.0, 7.25, 45.0, 90.0, 133.5, 179.5, 180.0];
        let mu: Vec<f64> = angles.iter().map(|a: &f64| a.to_radians().cos()).collect();
        let m = [
            Complex64::new(1.53, 0.008),
            Complex64::new(1.33, 0.0),
            Complex64::new(1.75, 0.44),
        ];
        let mut sets: Vec<Vec<(Sphere, f64)>> = vec![vec![(Sphere::new(12.5, m[0]).unwrap(), 1.0)]];
        let xs: Vec<f64> = (0..150).map(|i| 0.05 * 1.04f64.powi(i)).collect();
        for mi in m {
            sets.push(
                xs.iter()
                    .filter(|&&x| x < 60.0)
                    .map(|&x| (Sphere::new(x, mi).unwrap(), 1.0 / (1.0 + x)))
                    .collect(),
            );
        }
        let mut worst = 0.0f64;
        for spheres in &sets {
            let n_max = spheres.iter().map(|(s, _)| s.terms()).max().unwrap();
            let f = AngularFunctions::new(&mu, n_max + 3);
            let mut sums = ElementSums::new(&f);
            for (s, w) in spheres {
                sums.add(s, *w);
            }
            let fast = sums.finish();
            let slow = direct(spheres, &mu);
            for (j, (a, b)) in fast.iter().zip(&slow).enumerate() {
                for e in 0..4 {
                    let d = (a[e] - b[e]).abs() / b[0];
                    worst = worst.max(d);
                    assert!(d < 1e-10, "angle {}: element {e}: {} vs {}", angles[j], a[e], b[e]);
                }
            }
        }
        println!("largest difference relative to S11: {worst:.1e}");
    }

    #[test]
    fn no_spheres_no_sums() {
        let f = AngularFunctions::new(&[1.0, 0.0], 4);
        assert_eq!(ElementSums::new(&f).finish(), vec![[0.0; 4]; 2]);
    }
}
