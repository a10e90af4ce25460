//! The weighted low-rank approximation of a (γ, α) table: the rank-k
//! matrix L = Z·Sᵀ minimising Σ w·(A − L)² over the cells, solved by
//! alternating least squares (each row's Z from the fixed S, then each
//! column's S from the fixed Z, every solve exact), started from the plain
//! truncated SVD. Srebro & Jaakkola (2003), "Weighted low-rank
//! approximations", ICML, section 2, take the same objective; their EM
//! step (replace A by w·A + (1 − w)·L and decompose again) is the hard
//! imputation this replaces, whose convergence is as slow as a row's
//! share of weight is small: a row near the zenith, where the sky has a
//! handful of (γ, α) cells among 361, moves by that share of its error
//! per round and is left where the fill put it. An alternating solve fits
//! each row to its own cells at once, however few.
//!
//! The fit gives the filled cells a small weight rather than none: with
//! none, a row or column with fewer cells than the rank is free in the
//! cells no sky has, which the runtime reads between sun elevations (the
//! zenith row between two nodes' zeniths, the aureole at elevations
//! between the nodes), and such cells came out negative in a 1660 nm
//! table; a weight of 10⁻⁶ keeps them near the fill and costs the cells
//! with data nothing measurable.
//!
//! The result is returned in [`LowRank`]'s normal form (the SVD of L), so
//! that it reads like [`truncated_svd`]'s.

use super::decompose::{LowRank, truncated_svd};

/// A relative ridge on each k × k normal matrix (times its mean diagonal),
/// so that a row or column whose cells determine fewer than k of its
/// coefficients (weights 0, or a component that is all zeros) gets the
/// smallest solution instead of a failed solve.
const RIDGE: f64 = 1e-12;

/// The alternation stops when a sweep lowers the weighted squared error by
/// less than this fraction of it.
const TOLERANCE: f64 = 1e-7;

/// The rank-`rank` L = Σ_k zenith_k ⊗ sun_k minimising
/// Σ weights·(values − L)² over the row-major `rows` × `cols` table, by at
/// most `sweeps` alternating sweeps from the truncated SVD of `values`
/// (0 sweeps: that SVD). Weights are ≥ 0; every cell with weight 1 and
/// enough sweeps gives the truncated SVD again (which is then optimal).
/// `singular_values` are L's own (the first `rank`, the rest 0).
///
/// Non-finite values or weights give NaN components, as [`truncated_svd`]
/// does, so that the dataset writer rejects them by name.
///
/// # Panics
///
/// If `values` or `weights` does not hold `rows × cols` entries (a
/// caller's bug).
pub fn weighted_low_rank(
    values: &[f64],
    weights: &[f64],
    rows: usize,
    cols: usize,
    rank: usize,
    sweeps: usize,
) -> LowRank {
    assert_eq!(
        values.len(),
        rows * cols,
        "weighted_low_rank: values is not rows × cols"
    );
    assert_eq!(
        weights.len(),
        rows * cols,
        "weighted_low_rank: weights is not rows × cols"
    );
    let start = truncated_svd(values, rows, cols, rank);
    if sweeps == 0 || rank == 0 || rows == 0 || cols == 0 {
        return start;
    }
    if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
        return truncated_svd(&vec![f64::NAN; rows * cols], rows, cols, rank);
    }
    if start.sun.iter().flatten().any(|x| !x.is_finite()) {
        return start;
    }
    // Factors as rows of k coefficients: z[r·k + i], s[c·k + i].
    let k = rank;
    let mut z = vec![0.0; rows * k];
    let mut s = vec![0.0; cols * k];
    for i in 0..k {
        for r in 0..rows {
            z[r * k + i] = start.zenith[i][r];
        }
        for c in 0..cols {
            s[c * k + i] = start.sun[i][c];
        }
    }
    let transposed = |m: &[f64]| -> Vec<f64> {
        let mut t = vec![0.0; m.len()];
        for r in 0..rows {
            for c in 0..cols {
                t[c * rows + r] = m[r * cols + c];
            }
        }
        t
    };
    let (values_t, weights_t) = (transposed(values), transposed(weights));
    let mut last = weighted_error(values, weights, &z, &s, rows, cols, k);
    for _ in 0..sweeps {
        solve_factors(values, weights, &s, &mut z, rows, cols, k);
        solve_factors(&values_t, &weights_t, &z, &mut s, cols, rows, k);
        let error = weighted_error(values, weights, &z, &s, rows, cols, k);
        let done = last - error <= TOLERANCE * last;
        last = error;
        if done {
            break;
        }
    }
    let mut product = vec![0.0; rows * cols];
    for r in 0..rows {
        for c in 0..cols {
            product[r * cols + c] = (0..k).map(|i| z[r * k + i] * s[c * k + i]).sum();
        }
    }
    truncated_svd(&product, rows, cols, rank)
}

/// Σ w·(A − Z·Sᵀ)².
fn weighted_error(values: &[f64], weights: &[f64], z: &[f64], s: &[f64], rows: usize, cols: usize, k: usize) -> f64 {
    let mut sum = 0.0;
    for r in 0..rows {
        let zr = &z[r * k..(r + 1) * k];
        for c in 0..cols {
            let w = weights[r * cols + c];
            if w == 0.0 {
                continue;
            }
            let fit: f64 = zr.iter().zip(&s[c * k..(c + 1) * k]).map(|(a, b)| a * b).sum();
            let e = values[r * cols + c] - fit;
            sum += w * e * e;
        }
    }
    sum
}

/// For every row r of the `rows` × `cols` table, the k coefficients
/// `out[r]` minimising Σ_c w_rc·(A_rc − out[r]·fixed[c])²: the normal
/// equations (Σ_c w_rc f_c f_cᵀ)·x = Σ_c w_rc A_rc f_c, solved by Cholesky.
/// The normal matrix is the row's least weight times Σ_c f_c f_cᵀ (once
/// for all rows) plus the cells that weigh more, so that a row whose
/// filled cells weigh alike costs only its cells with data.
fn solve_factors(values: &[f64], weights: &[f64], fixed: &[f64], out: &mut [f64], rows: usize, cols: usize, k: usize) {
    let mut all = vec![0.0; k * k];
    for f in fixed.chunks_exact(k) {
        add_outer(&mut all, f, 1.0, k);
    }
    let mut gram = vec![0.0; k * k];
    let mut rhs = vec![0.0; k];
    for r in 0..rows {
        let w_row = &weights[r * cols..(r + 1) * cols];
        let base = w_row.iter().copied().fold(f64::INFINITY, f64::min);
        for (g, a) in gram.iter_mut().zip(&all) {
            *g = base * a;
        }
        rhs.fill(0.0);
        for (c, &w) in w_row.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            let f = &fixed[c * k..(c + 1) * k];
            let wa = w * values[r * cols + c];
            for (x, &fi) in rhs.iter_mut().zip(f) {
                *x += wa * fi;
            }
            if w > base {
                add_outer(&mut gram, f, w - base, k);
            }
        }
        solve_spd(&mut gram, &mut rhs, k);
        out[r * k..(r + 1) * k].copy_from_slice(&rhs);
    }
}

/// Adds w·f·fᵀ to the lower triangle of the k × k `gram`.
#[inline]
fn add_outer(gram: &mut [f64], f: &[f64], w: f64, k: usize) {
    for i in 0..k {
        let wf = w * f[i];
        for j in 0..=i {
            gram[i * k + j] += wf * f[j];
        }
    }
}

/// Solves G·x = b in place (`b` becomes x) for the symmetric positive
/// semi-definite k × k `gram` given by its lower triangle, with the
/// relative [`RIDGE`] on the diagonal; a matrix that is all zeros gives 0.
fn solve_spd(gram: &mut [f64], b: &mut [f64], k: usize) {
    let mean_diagonal = (0..k).map(|i| gram[i * k + i]).sum::<f64>() / k as f64;
    if mean_diagonal <= 0.0 || !mean_diagonal.is_finite() {
        b.fill(if mean_diagonal.is_finite() { 0.0 } else { f64::NAN });
        return;
    }
    let ridge = RIDGE * mean_diagonal;
    // Cholesky G + ridge·I = L·Lᵀ, L in the lower triangle.
    for j in 0..k {
        let mut d = gram[j * k + j] + ridge - (0..j).map(|p| gram[j * k + p] * gram[j * k + p]).sum::<f64>();
        // A pivot lost to rounding (a direction no cell weighs) counts as
        // the ridge alone.
        if d <= ridge {
            d = ridge;
        }
        let d = d.sqrt();
        gram[j * k + j] = d;
        for i in j + 1..k {
            let dot: f64 = (0..j).map(|p| gram[i * k + p] * gram[j * k + p]).sum();
            gram[i * k + j] = (gram[i * k + j] - dot) / d;
        }
    }
    // L·y = b, then Lᵀ·x = y.
    for i in 0..k {
        let dot: f64 = (0..i).map(|p| gram[i * k + p] * b[p]).sum();
        b[i] = (b[i] - dot) / gram[i * k + i];
    }
    for i in (0..k).rev() {
        let dot: f64 = (i + 1..k).map(|p| gram[p * k + i] * b[p]).sum();
        b[i] = (b[i] - dot) / gram[i * k + i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth rank-3 table plus a little deterministic hash noise.
    fn table(rows: usize, cols: usize, noise: f64) -> Vec<f64> {
        let mut out = vec![0.0; rows * cols];
        for r in 0..rows {
            for c in 0..cols {
                let (a, g) = (r as f64 / rows as f64, c as f64 / cols as f64);
                let hash = ((r * 7919 + c * 104_729) % 1009) as f64 / 1009.0 - 0.5;
                out[r * cols + c] =
                    (-g / 0.1).exp() * (1.0 + a) + (3.0 * a).cos() * (1.0 + g * g) + a * a * g + noise * hash;
            }
        }
        out
    }

    #[test]
    fn unit_weights_give_the_truncated_svd() {
        let (rows, cols) = (30, 40);
        let m = table(rows, cols, 1e-2);
        let plain = truncated_svd(&m, rows, cols, 2).reconstruct();
        let weighted = weighted_low_rank(&m, &vec![1.0; rows * cols], rows, cols, 2, 50).reconstruct();
        let worst = plain
            .iter()
            .zip(&weighted)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "worst {worst}");
    }

    #[test]
    fn a_row_with_few_cells_is_fitted_to_them() {
        // The zenith's geometry: a rank-3 table whose first row has data in
        // 4 cells of 40, the other rows in all but a wedge next to the first
        // column (c < 12 − r/2), every other cell filled with its row's mean
        // of the data and weighing 10⁻⁴. The truncated SVD of the filled
        // table fits the first row's data to 0.061 (measured), the weighted
        // fit after 200 sweeps to 0.00096 and every cell with data to
        // 0.0072; required: a tenth of the SVD's error on both.
        let (rows, cols) = (30, 40);
        let m = table(rows, cols, 0.0);
        let data = |r: usize, c: usize| if r == 0 { c % 10 == 3 } else { c + r / 2 >= 12 };
        let mut filled = m.clone();
        let mut weights = vec![1.0; rows * cols];
        for r in 0..rows {
            let row = &m[r * cols..(r + 1) * cols];
            let kept: Vec<f64> = (0..cols).filter(|&c| data(r, c)).map(|c| row[c]).collect();
            let mean = kept.iter().sum::<f64>() / kept.len() as f64;
            for c in (0..cols).filter(|&c| !data(r, c)) {
                filled[r * cols + c] = mean;
                weights[r * cols + c] = 1e-4;
            }
        }
        // The largest error over the data cells, over those of row 0.
        let errors = |low: &LowRank| -> (f64, f64) {
            let back = low.reconstruct();
            let (mut all, mut first) = (0.0f64, 0.0f64);
            for r in 0..rows {
                for c in (0..cols).filter(|&c| data(r, c)) {
                    let e = (back[r * cols + c] - m[r * cols + c]).abs();
                    assert!(e.is_finite());
                    all = all.max(e);
                    if r == 0 {
                        first = first.max(e);
                    }
                }
            }
            (all, first)
        };
        let (plain_all, plain_first) = errors(&truncated_svd(&filled, rows, cols, 3));
        let (all, first) = errors(&weighted_low_rank(&filled, &weights, rows, cols, 3, 200));
        assert!(plain_first > 0.05, "the SVD's first row {plain_first}");
        assert!(
            first < plain_first / 10.0,
            "first row {first} vs the SVD's {plain_first}"
        );
        assert!(all < plain_all / 10.0, "data cells {all} vs the SVD's {plain_all}");
    }

    #[test]
    fn weighted_error_never_exceeds_the_start() {
        let (rows, cols) = (25, 35);
        let m = table(rows, cols, 0.1);
        let weights: Vec<f64> = (0..rows * cols)
            .map(|i| if i % 7 == 0 { 1e-3 } else { 1.0 + (i % 5) as f64 })
            .collect();
        let error = |low: &LowRank| -> f64 {
            let back = low.reconstruct();
            (0..rows * cols).map(|i| weights[i] * (m[i] - back[i]).powi(2)).sum()
        };
        let start = error(&weighted_low_rank(&m, &weights, rows, cols, 2, 0));
        let fitted = error(&weighted_low_rank(&m, &weights, rows, cols, 2, 100));
        assert!(fitted < start, "{fitted} vs {start}");
    }

    #[test]
    fn a_zero_table_and_bad_weights() {
        let low = weighted_low_rank(&[0.0; 6], &[1.0; 6], 2, 3, 2, 10);
        assert!(low.reconstruct().iter().all(|&x| x == 0.0));
        let low = weighted_low_rank(&[1.0; 6], &[1.0, f64::NAN, 1.0, 1.0, 1.0, 1.0], 2, 3, 1, 10);
        assert!(low.sun[0][0].is_nan());
    }

    #[test]
    fn the_spd_solve() {
        // G = [[4, 2], [2, 3]] (lower triangle given), b = [2, 1]: x = [0.5, 0].
        let mut g = [4.0, 0.0, 2.0, 3.0];
        let mut b = [2.0, 1.0];
        solve_spd(&mut g, &mut b, 2);
        assert!((b[0] - 0.5).abs() < 1e-9 && b[1].abs() < 1e-9, "{b:?}");
        // A singular G (one direction unweighed) gives the weighed one.
        let mut g = [2.0, 0.0, 0.0, 0.0];
        let mut b = [4.0, 0.0];
        solve_spd(&mut g, &mut b, 2);
        assert!((b[0] - 2.0).abs() < 1e-9 && b[1] == 0.0, "{b:?}");
    }
}
