//! The low-rank decomposition of a (γ, α) table into outer products of
//! one-variable functions (the supplement's section 1.4, eq. 4):
//! F(γ, α) ≈ Σ_k F_zenith⁽ᵏ⁾(α)·F_solar⁽ᵏ⁾(γ).
//!
//! The supplement uses CPD; for a matrix (a 2-way tensor) the best rank-k
//! approximation in the least-squares sense is the truncated singular
//! value decomposition (Eckart–Young), which CPD of a matrix converges to,
//! so the SVD is used: faer's thin SVD, on the calling thread (faer is
//! built without its rayon feature; callers parallelise over tables).
//!
//! The split of each singular value between the two vectors: every sun
//! vector (a row function, one value per column) has a largest magnitude
//! of exactly 1, and that entry is positive (which also fixes the SVD's
//! sign ambiguity deterministically); its zenith vector carries the scale
//! σ_k·‖v_k‖_∞. Sun values then lie in [−1, 1], safe for half floats, and
//! the dataset writer scales each zenith vector on its own.

use faer::Mat;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::svd::{ComputeSvdVectors, svd, svd_scratch};
use faer::{Par, Spec};

/// A rank-`rank` approximation: `values[r·cols + c] ≈ Σ_k zenith[k][r]·sun[k][c]`.
#[derive(Debug, Clone, PartialEq)]
pub struct LowRank {
    pub rows: usize,
    pub cols: usize,
    pub rank: usize,
    /// The column functions (γ for a (γ, α) table): `rank` vectors of
    /// `cols` values, each of largest magnitude 1 with that entry positive
    /// (all zeros for a zero component).
    pub sun: Vec<Vec<f64>>,
    /// The row functions (α): `rank` vectors of `rows` values, each the
    /// left singular vector times σ_k·‖v_k‖_∞.
    pub zenith: Vec<Vec<f64>>,
    /// Every singular value of the table, nonincreasing (min(rows, cols)
    /// of them), kept or not.
    pub singular_values: Vec<f64>,
}

impl LowRank {
    /// The approximation at (row, col).
    pub fn value(&self, row: usize, col: usize) -> f64 {
        (0..self.rank).map(|k| self.zenith[k][row] * self.sun[k][col]).sum()
    }

    /// The whole approximation, row-major.
    pub fn reconstruct(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.rows * self.cols];
        for k in 0..self.rank {
            for (r, row) in out.chunks_exact_mut(self.cols).enumerate() {
                let z = self.zenith[k][r];
                for (x, &s) in row.iter_mut().zip(&self.sun[k]) {
                    *x += z * s;
                }
            }
        }
        out
    }

    /// The fraction of the table's variance (Σ of squares, ‖·‖_F²) that the
    /// first `k` components explain: Σ_{i<k} σ_i² / Σ_i σ_i² (1 for a zero
    /// table).
    pub fn explained_variance_by(&self, k: usize) -> f64 {
        let total: f64 = self.singular_values.iter().map(|s| s * s).sum();
        if total <= 0.0 {
            return 1.0;
        }
        self.singular_values.iter().take(k).map(|s| s * s).sum::<f64>() / total
    }

    /// The explained variance by rank 1, 2, …, `rank`: element k − 1 is
    /// [`explained_variance_by`](Self::explained_variance_by)(k); the last
    /// is what the kept components explain.
    pub fn explained_variance(&self) -> Vec<f64> {
        (1..=self.rank).map(|k| self.explained_variance_by(k)).collect()
    }

    /// The share of the sum of squares of `values` (row-major, of this
    /// table's size) over the cells where `counts` is true that the first
    /// k components reproduce, 1 − Σ (v − Σ_{i<k} zenith_i·sun_i)² / Σ v²,
    /// for k = 1, …, `rank` (1 where those cells are all zero). For the
    /// truncated SVD over every cell it is
    /// [`explained_variance`](Self::explained_variance) (Eckart–Young);
    /// for a weighted decomposition over the cells with data it is what
    /// the components reproduce of the data alone, whatever they put in
    /// the other cells. Then it need not grow with k: the components are
    /// ordered by their size over every cell (in 39 of 308 images of the
    /// mini grid it dips from one rank to the next, by up to 0.005).
    pub fn explained_over(&self, values: &[f64], counts: &[bool]) -> Vec<f64> {
        let cells: Vec<usize> = (0..values.len()).filter(|&k| counts[k]).collect();
        let total: f64 = cells.iter().map(|&k| values[k] * values[k]).sum();
        let mut approx = vec![0.0; cells.len()];
        (0..self.rank)
            .map(|i| {
                let mut error = 0.0;
                for (a, &k) in approx.iter_mut().zip(&cells) {
                    *a += self.zenith[i][k / self.cols] * self.sun[i][k % self.cols];
                    error += (values[k] - *a) * (values[k] - *a);
                }
                if total > 0.0 { 1.0 - error / total } else { 1.0 }
            })
            .collect()
    }
}

/// The best rank-`rank` approximation of the row-major `rows` × `cols`
/// matrix `values`, by the thin SVD. A rank above min(rows, cols) is padded
/// with zero components, so the result always has `rank` of them.
///
/// Non-finite input (a NaN from a broken render) makes every component and
/// singular value NaN, as does the SVD's failure to converge (which faer
/// reports only for such input): the dataset writer rejects non-finite
/// values with the table's name, so nothing here panics on data.
///
/// # Panics
///
/// If `values` does not hold `rows × cols` values (a caller's bug).
pub fn truncated_svd(values: &[f64], rows: usize, cols: usize, rank: usize) -> LowRank {
    assert_eq!(values.len(), rows * cols, "truncated_svd: values is not rows × cols");
    let size = rows.min(cols);
    let mut low = LowRank {
        rows,
        cols,
        rank,
        sun: vec![vec![0.0; cols]; rank],
        zenith: vec![vec![0.0; rows]; rank],
        singular_values: vec![0.0; size],
    };
    if size == 0 {
        return low;
    }
    let Some(factors) = thin_svd(values, rows, cols) else {
        for v in low.sun.iter_mut().chain(&mut low.zenith) {
            v.fill(f64::NAN);
        }
        low.singular_values.fill(f64::NAN);
        return low;
    };
    low.singular_values.copy_from_slice(&factors.s);
    for k in 0..rank.min(size) {
        let sigma = factors.s[k];
        let v = |c: usize| factors.v[c * size + k];
        // The largest-magnitude entry of v_k (the first of equals).
        let mut peak = 0.0f64;
        for c in 0..cols {
            if v(c).abs() > peak.abs() {
                peak = v(c);
            }
        }
        if sigma == 0.0 || peak == 0.0 {
            continue;
        }
        for c in 0..cols {
            low.sun[k][c] = v(c) / peak;
        }
        for r in 0..rows {
            low.zenith[k][r] = factors.u[r * size + k] * sigma * peak;
        }
    }
    low
}

/// A thin SVD A = U·diag(s)·Vᵀ, row-major U (rows × size) and V (cols ×
/// size), or None for non-finite input or no convergence.
struct ThinSvd {
    u: Vec<f64>,
    s: Vec<f64>,
    v: Vec<f64>,
}

fn thin_svd(values: &[f64], rows: usize, cols: usize) -> Option<ThinSvd> {
    if values.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let size = rows.min(cols);
    let a = Mat::from_fn(rows, cols, |r, c| values[r * cols + c]);
    let mut u = Mat::<f64>::zeros(rows, size);
    let mut v = Mat::<f64>::zeros(cols, size);
    let mut s = faer::diag::Diag::<f64>::zeros(size);
    let thin = ComputeSvdVectors::Thin;
    let par = Par::Seq;
    let mut buffer = MemBuffer::new(svd_scratch::<f64>(rows, cols, thin, thin, par, Spec::default()));
    svd(
        a.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        Some(v.as_mut()),
        par,
        MemStack::new(&mut buffer),
        Spec::default(),
    )
    .ok()?;
    let s: Vec<f64> = (0..size).map(|k| s.column_vector()[k]).collect();
    let mut u_rows = vec![0.0; rows * size];
    let mut v_rows = vec![0.0; cols * size];
    for k in 0..size {
        for r in 0..rows {
            u_rows[r * size + k] = u[(r, k)];
        }
        for c in 0..cols {
            v_rows[c * size + k] = v[(c, k)];
        }
    }
    Some(ThinSvd {
        u: u_rows,
        s,
        v: v_rows,
    })
}

#[cfg(test)]
mod tests {
    use super::super::laplace::thread_cpu_seconds;
    use super::*;
    use std::time::Instant;

    /// A deterministic table with a decaying spectrum: smooth sky-like
    /// structure plus a little hash noise.
    fn table(rows: usize, cols: usize) -> Vec<f64> {
        let mut out = vec![0.0; rows * cols];
        for r in 0..rows {
            for c in 0..cols {
                let (a, g) = (r as f64 / rows as f64, c as f64 / cols as f64);
                let hash = ((r * 7919 + c * 104_729) % 1009) as f64 / 1009.0 - 0.5;
                out[r * cols + c] = (-g / 0.03).exp() * (1.0 + a)
                    + (3.0 * a).cos() * (1.0 + g * g)
                    + 0.2 * (7.0 * a * g).sin()
                    + 1e-3 * hash;
            }
        }
        out
    }

    #[test]
    fn an_exact_rank_two_matrix_is_recovered() {
        let (rows, cols) = (37, 23);
        let mut m = vec![0.0; rows * cols];
        for r in 0..rows {
            for c in 0..cols {
                let (x, y) = (r as f64 * 0.1, c as f64 * 0.2);
                m[r * cols + c] = 3.0 * x.cos() * (1.0 + y) - 0.5 * (x * x) * y.sin();
            }
        }
        let low = truncated_svd(&m, rows, cols, 2);
        let back = low.reconstruct();
        let worst = m.iter().zip(&back).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-12, "worst {worst}");
        assert!(low.singular_values[2] < 1e-12 * low.singular_values[0]);
        assert!((low.explained_variance()[1] - 1.0).abs() < 1e-14);
        // The split and the sign: every sun vector's largest entry is +1.
        for s in &low.sun {
            let peak = s.iter().cloned().fold(f64::MIN, f64::max);
            assert_eq!(peak, 1.0);
            assert!(s.iter().all(|x| x.abs() <= 1.0));
        }
        assert_eq!(low.value(5, 7), back[5 * cols + 7]);
    }

    #[test]
    fn explained_variance_accumulates_to_one() {
        let (rows, cols) = (40, 60);
        let low = truncated_svd(&table(rows, cols), rows, cols, 5);
        assert_eq!(low.singular_values.len(), 40);
        let mut last = 0.0;
        for k in 0..=40 {
            let e = low.explained_variance_by(k);
            assert!(e >= last - 1e-15 && e <= 1.0 + 1e-15);
            last = e;
        }
        assert!((low.explained_variance_by(40) - 1.0).abs() < 1e-13);
        // Σ σ² is the squared Frobenius norm.
        let frob: f64 = table(rows, cols).iter().map(|x| x * x).sum();
        let total: f64 = low.singular_values.iter().map(|s| s * s).sum();
        assert!((frob - total).abs() < 1e-10 * frob);
    }

    /// Over every cell of a truncated SVD, what the first k components
    /// reproduce is the share of the first k squared singular values
    /// (Eckart–Young); over a part of the cells it is that part's own
    /// share, 1 on cells all zero.
    #[test]
    fn explained_over_every_cell_is_the_explained_variance() {
        let (rows, cols) = (40, 60);
        let m = table(rows, cols);
        let low = truncated_svd(&m, rows, cols, 5);
        let over = low.explained_over(&m, &vec![true; rows * cols]);
        for (k, (a, b)) in over.iter().zip(low.explained_variance()).enumerate() {
            assert!((a - b).abs() < 1e-12, "rank {}: {a} against {b}", k + 1);
        }
        // The first row alone, by hand.
        let first: Vec<bool> = (0..rows * cols).map(|k| k < cols).collect();
        let total: f64 = m[..cols].iter().map(|v| v * v).sum();
        let error: f64 = (0..cols)
            .map(|c| (m[c] - low.zenith[0][0] * low.sun[0][c]).powi(2))
            .sum();
        assert!((low.explained_over(&m, &first)[0] - (1.0 - error / total)).abs() < 1e-15);
        assert_eq!(low.explained_over(&vec![0.0; rows * cols], &first), vec![1.0; 5]);
    }

    #[test]
    fn rank_nine_error_is_the_eckart_young_tail() {
        let n = 361;
        let m = table(n, n);
        let (start, cpu) = (Instant::now(), thread_cpu_seconds());
        let low = truncated_svd(&m, n, n, 9);
        let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
        println!("decompose::truncated_svd 361×361 rank 9: {cpu:.3} s CPU ({wall:.3} s wall)");
        let back = low.reconstruct();
        let error = m.iter().zip(&back).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        let tail = low.singular_values[9..].iter().map(|s| s * s).sum::<f64>().sqrt();
        assert!(
            (error - tail).abs() < 1e-9 * low.singular_values[0],
            "‖A − A₉‖ {error}, tail {tail}"
        );
        assert!(low.explained_variance()[8] > 0.999);
    }

    #[test]
    fn a_rank_above_the_size_pads_and_zeros_stay_zero() {
        let m = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let low = truncated_svd(&m, 2, 3, 4);
        assert_eq!((low.sun.len(), low.zenith.len(), low.singular_values.len()), (4, 4, 2));
        assert!(
            low.sun[2]
                .iter()
                .chain(&low.sun[3])
                .chain(&low.zenith[3])
                .all(|&x| x == 0.0)
        );
        let back = low.reconstruct();
        assert!(m.iter().zip(&back).all(|(a, b)| (a - b).abs() < 1e-13));
        let zero = truncated_svd(&[0.0; 6], 3, 2, 2);
        assert!(zero.reconstruct().iter().all(|&x| x == 0.0));
        assert_eq!(zero.explained_variance(), vec![1.0, 1.0]);
    }

    #[test]
    fn non_finite_input_gives_nan_components_not_a_panic() {
        let low = truncated_svd(&[1.0, f64::NAN, 0.0, 2.0], 2, 2, 1);
        assert!(low.sun[0][0].is_nan() && low.zenith[0][0].is_nan());
    }
}
