//! Harmonic infill of the unknown cells of an image (Matlab's `regionfill`,
//! which the supplement uses twice: below the horizon in section 1.5 and
//! outside the valid parallelogram of the (γ, α) plane in section 1.6).
//!
//! Every unknown cell gets the solution of the discrete Laplace equation,
//! its value the mean of its 4 neighbours', with the known cells as the
//! Dirichlet boundary. The left and right edges are periodic when asked
//! (an azimuth axis); otherwise, and at the top and bottom, a neighbour
//! outside the image is left out of the mean, the reflecting (Neumann)
//! boundary of a mirror image.
//!
//! The unknowns form the symmetric positive definite system A·u = b of a
//! weighted graph Laplacian, solved by conjugate gradients preconditioned
//! with one multigrid V-cycle: the coarse levels aggregate 2×2 cells and
//! take the Galerkin operator PᵀAP of the piecewise-constant prolongation
//! P, halved (the Galerkin operator of 2×2 aggregation is twice the
//! coarse grid's Laplacian, an under-correction the halving undoes), so
//! masks, periodic and reflecting edges coarsen by construction. Symmetric
//! Gauss–Seidel smoothing (forward before, backward after) keeps the
//! preconditioner symmetric, as conjugate gradients needs; the coarsest
//! level (at most [`COARSEST_CELLS`] unknowns) is solved exactly by a
//! dense Cholesky factorisation. The iteration stops at a relative
//! residual of [`TOLERANCE`]; a 2×10⁵-unknown fill takes about ten
//! iterations.

/// The solve stops once ‖b − A·u‖₂ ≤ `TOLERANCE`·‖b‖₂, b the known cells'
/// coupling into the unknowns: far below what a fill of rendered radiance
/// can resolve, and cheap because the preconditioned iteration gains
/// about a decimal digit per step.
pub const TOLERANCE: f64 = 1e-10;

/// The most unknowns of the coarsest level, which is solved directly.
pub const COARSEST_CELLS: usize = 200;

/// A bound on the iterations; the tolerance is reached long before.
const MAX_ITERATIONS: usize = 500;

/// What a fill did: for tests and reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillStats {
    /// The number of unknown cells that were filled.
    pub unknowns: usize,
    /// Conjugate-gradient iterations taken.
    pub iterations: usize,
    /// ‖b − A·u‖₂ / ‖b‖₂ at the end (0 when there was nothing to solve).
    pub relative_residual: f64,
}

/// Replaces every cell of `values` (row-major, `width` × `height`) whose
/// `known` flag is false by the harmonic interpolant of the known cells:
/// the solution of Laplace's equation on the 4-neighbour stencil with the
/// known cells as Dirichlet boundary, periodic in x when `wrap_x`, and
/// reflecting at the image's other edges. With no known cell at all every
/// cell becomes 0. Known cells are left untouched.
///
/// # Panics
///
/// If `values` or `known` does not hold `width × height` cells: a
/// programming error of the caller, not something a user can cause.
pub fn fill(values: &mut [f64], known: &[bool], width: usize, height: usize, wrap_x: bool) -> FillStats {
    let cells = width * height;
    assert_eq!(values.len(), cells, "laplace::fill: values is not width × height");
    assert_eq!(known.len(), cells, "laplace::fill: known is not width × height");
    let unknowns = known.iter().filter(|&&k| !k).count();
    let mut stats = FillStats {
        unknowns,
        iterations: 0,
        relative_residual: 0.0,
    };
    if unknowns == 0 {
        return stats;
    }
    if unknowns == cells {
        values.fill(0.0);
        return stats;
    }

    // The fine level: the unknowns, their couplings, and b.
    let grid = GridOp::fine(known, width, height, wrap_x);
    let (fine, fine_cells) = Level::from_grid(&grid);
    let mut b = vec![0.0; fine.n];
    let mut boundary_weight = 0.0;
    for (k, &c) in fine_cells.iter().enumerate() {
        for q in grid.neighbours(c).into_iter().flatten() {
            if known[q] {
                b[k] += values[q];
                boundary_weight += 1.0;
            }
        }
    }

    // The hierarchy: aggregate until the coarsest level is small.
    let mut levels = vec![fine];
    let mut op = grid;
    let mut cells_of = fine_cells;
    while levels[levels.len() - 1].n > COARSEST_CELLS {
        let (coarse_op, aggregate) = op.coarsen();
        let (coarse, coarse_cells) = Level::from_grid(&coarse_op);
        let index = compact_index(&coarse_op.free);
        let last = levels.len() - 1;
        levels[last].to_coarse = cells_of.iter().map(|&c| index[aggregate[c]]).collect();
        levels.push(coarse);
        op = coarse_op;
        cells_of = coarse_cells;
    }
    let coarsest = Cholesky::of(&levels[levels.len() - 1]);

    // Preconditioned conjugate gradients from the mean boundary value.
    let n = levels[0].n;
    let start = if boundary_weight > 0.0 {
        b.iter().sum::<f64>() / boundary_weight
    } else {
        0.0
    };
    let mut x = vec![start; n];
    let mut p = vec![0.0; n + 1];
    let mut q = vec![0.0; n];
    let mut r = vec![0.0; n];
    x.push(0.0);
    levels[0].apply(&x, &mut q);
    for k in 0..n {
        r[k] = b[k] - q[k];
    }
    x.pop();
    let b_norm = norm(&b);
    let target = TOLERANCE * b_norm;
    let mut r_norm = norm(&r);
    if b_norm > 0.0 && r_norm > target {
        let mut z = precondition(&mut levels, &coarsest, &r);
        p[..n].copy_from_slice(&z);
        let mut rz = dot(&r, &z);
        while stats.iterations < MAX_ITERATIONS {
            stats.iterations += 1;
            levels[0].apply(&p, &mut q);
            let pq = dot(&p[..n], &q);
            if pq <= 0.0 {
                break;
            }
            let step = rz / pq;
            for k in 0..n {
                x[k] += step * p[k];
                r[k] -= step * q[k];
            }
            r_norm = norm(&r);
            if r_norm <= target {
                break;
            }
            z = precondition(&mut levels, &coarsest, &r);
            let rz_next = dot(&r, &z);
            let beta = rz_next / rz;
            rz = rz_next;
            for k in 0..n {
                p[k] = z[k] + beta * p[k];
            }
        }
    }
    stats.relative_residual = if b_norm > 0.0 { r_norm / b_norm } else { 0.0 };
    if b_norm == 0.0 {
        // Every known neighbour is 0: so is the harmonic interpolant.
        x.fill(0.0);
    }

    let mut k = 0;
    for (value, &is_known) in values.iter_mut().zip(known) {
        if !is_known {
            *value = x[k];
            k += 1;
        }
    }
    stats
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// One V-cycle applied to `r`: the preconditioner's z = M⁻¹·r.
fn precondition(levels: &mut [Level], coarsest: &Cholesky, r: &[f64]) -> Vec<f64> {
    levels[0].rhs.copy_from_slice(r);
    v_cycle(levels, coarsest);
    levels[0].x[..r.len()].to_vec()
}

/// Approximately solves the first level's A·x = rhs into its `x`, from 0.
fn v_cycle(levels: &mut [Level], coarsest: &Cholesky) {
    let Some((this, rest)) = levels.split_first_mut() else {
        return;
    };
    let Some(next) = rest.first_mut() else {
        coarsest.solve(&this.rhs, &mut this.x);
        return;
    };
    this.x.fill(0.0);
    this.sweep_forward();
    // The residual, summed into the aggregates (R = Pᵀ).
    let n = this.n;
    let mut t = std::mem::take(&mut this.t);
    this.apply(&this.x, &mut t);
    next.rhs.fill(0.0);
    for k in 0..n {
        next.rhs[this.to_coarse[k] as usize] += this.rhs[k] - t[k];
    }
    this.t = t;
    v_cycle(rest, coarsest);
    let next = &rest[0];
    for k in 0..n {
        this.x[k] += next.x[this.to_coarse[k] as usize];
    }
    this.sweep_backward();
}

/// The grid index → compact index of the free cells (u32::MAX elsewhere
/// is never read: only free cells are looked up).
fn compact_index(free: &[bool]) -> Vec<u32> {
    let mut next = 0u32;
    free.iter()
        .map(|&f| {
            if f {
                next += 1;
                next - 1
            } else {
                u32::MAX
            }
        })
        .collect()
}

/// A level's operator on its grid: edge weights between free cells (east
/// and south of each cell) and the diagonal, which also holds the free
/// cells' couplings to fixed ones.
struct GridOp {
    width: usize,
    height: usize,
    wrap: bool,
    free: Vec<bool>,
    east: Vec<f64>,
    south: Vec<f64>,
    diag: Vec<f64>,
}

impl GridOp {
    /// The image's own operator: unit weights, the known cells fixed.
    fn fine(known: &[bool], width: usize, height: usize, wrap: bool) -> GridOp {
        let cells = width * height;
        let mut op = GridOp {
            width,
            height,
            wrap,
            free: known.iter().map(|&k| !k).collect(),
            east: vec![0.0; cells],
            south: vec![0.0; cells],
            diag: vec![0.0; cells],
        };
        for c in 0..cells {
            if !op.free[c] {
                continue;
            }
            let [e, w, n, s] = op.neighbours(c);
            op.diag[c] = [e, w, n, s].iter().filter(|q| q.is_some()).count() as f64;
            if let Some(q) = e
                && op.free[q]
            {
                op.east[c] = 1.0;
            }
            if let Some(q) = s
                && op.free[q]
            {
                op.south[c] = 1.0;
            }
        }
        op
    }

    /// Cell `c`'s neighbours east, west, north, south (grid indices).
    fn neighbours(&self, c: usize) -> [Option<usize>; 4] {
        let (i, j) = (c % self.width, c / self.width);
        let around = self.wrap && self.width > 1;
        let east = if i + 1 < self.width {
            Some(c + 1)
        } else if around {
            Some(c + 1 - self.width)
        } else {
            None
        };
        let west = if i > 0 {
            Some(c - 1)
        } else if around {
            Some(c + self.width - 1)
        } else {
            None
        };
        let north = (j > 0).then(|| c - self.width);
        let south = (j + 1 < self.height).then_some(c + self.width);
        [east, west, north, south]
    }

    /// The next coarser level (2×2 aggregates, halved Galerkin operator)
    /// and each cell's aggregate.
    fn coarsen(&self) -> (GridOp, Vec<usize>) {
        let (wc, hc) = (self.width.div_ceil(2), self.height.div_ceil(2));
        let cells = wc * hc;
        let aggregate: Vec<usize> = (0..self.width * self.height)
            .map(|c| (c / self.width / 2) * wc + (c % self.width) / 2)
            .collect();
        let mut op = GridOp {
            width: wc,
            height: hc,
            wrap: self.wrap,
            free: vec![false; cells],
            east: vec![0.0; cells],
            south: vec![0.0; cells],
            diag: vec![0.0; cells],
        };
        for c in 0..self.width * self.height {
            if !self.free[c] {
                continue;
            }
            let a = aggregate[c];
            op.free[a] = true;
            op.diag[a] += self.diag[c];
            let [e, _, _, s] = self.neighbours(c);
            for (q, weight, coarse) in [(e, self.east[c], &mut op.east), (s, self.south[c], &mut op.south)] {
                if let Some(q) = q
                    && weight > 0.0
                {
                    if aggregate[q] == a {
                        op.diag[a] -= 2.0 * weight;
                    } else {
                        // East (south) of a fine cell in another aggregate
                        // is the aggregate east (south) of this one, also
                        // across the periodic seam.
                        coarse[a] += weight;
                    }
                }
            }
        }
        for v in op.east.iter_mut().chain(&mut op.south).chain(&mut op.diag) {
            *v *= 0.5;
        }
        (op, aggregate)
    }
}

/// A level in compact form: its free cells in row-major order, each with
/// 4 neighbours (index `n`, a ghost that is always 0, where there is none)
/// and weights, plus the work vectors of the V-cycle.
struct Level {
    n: usize,
    neighbour: Vec<[u32; 4]>,
    weight: Vec<[f64; 4]>,
    diag: Vec<f64>,
    inv_diag: Vec<f64>,
    /// Each free cell's aggregate on the next level (compact index).
    to_coarse: Vec<u32>,
    rhs: Vec<f64>,
    /// The level's iterate, with the ghost at index `n`.
    x: Vec<f64>,
    t: Vec<f64>,
}

impl Level {
    /// The compact level of `op`, and the grid index of each free cell.
    fn from_grid(op: &GridOp) -> (Level, Vec<usize>) {
        let index = compact_index(&op.free);
        let cells: Vec<usize> = (0..op.free.len()).filter(|&c| op.free[c]).collect();
        let n = cells.len();
        let ghost = n as u32;
        let mut neighbour = Vec::with_capacity(n);
        let mut weight = Vec::with_capacity(n);
        for &c in &cells {
            let [e, w, no, s] = op.neighbours(c);
            let links = [
                (e, e.map(|_| op.east[c])),
                (w, w.map(|q| op.east[q])),
                (no, no.map(|q| op.south[q])),
                (s, s.map(|_| op.south[c])),
            ];
            let mut nb = [ghost; 4];
            let mut wt = [0.0; 4];
            for (m, (q, link)) in links.into_iter().enumerate() {
                if let (Some(q), Some(link)) = (q, link)
                    && link > 0.0
                    && op.free[q]
                {
                    nb[m] = index[q];
                    wt[m] = link;
                }
            }
            neighbour.push(nb);
            weight.push(wt);
        }
        let diag: Vec<f64> = cells.iter().map(|&c| op.diag[c]).collect();
        let inv_diag = diag.iter().map(|&d| if d > 0.0 { 1.0 / d } else { 0.0 }).collect();
        let level = Level {
            n,
            neighbour,
            weight,
            diag,
            inv_diag,
            to_coarse: Vec::new(),
            rhs: vec![0.0; n],
            x: vec![0.0; n + 1],
            t: vec![0.0; n],
        };
        (level, cells)
    }

    /// y = A·x (`x` with the ghost entry, `y` without).
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        for k in 0..self.n {
            let nb = self.neighbour[k];
            let wt = self.weight[k];
            let off = wt[0] * x[nb[0] as usize]
                + wt[1] * x[nb[1] as usize]
                + wt[2] * x[nb[2] as usize]
                + wt[3] * x[nb[3] as usize];
            y[k] = self.diag[k] * x[k] - off;
        }
    }

    /// One Gauss–Seidel update of cell `k` toward A·x = rhs.
    #[inline]
    fn relax(&mut self, k: usize) {
        let nb = self.neighbour[k];
        let wt = self.weight[k];
        let x = &self.x;
        let off = wt[0] * x[nb[0] as usize]
            + wt[1] * x[nb[1] as usize]
            + wt[2] * x[nb[2] as usize]
            + wt[3] * x[nb[3] as usize];
        self.x[k] = (self.rhs[k] + off) * self.inv_diag[k];
    }

    fn sweep_forward(&mut self) {
        for k in 0..self.n {
            self.relax(k);
        }
    }

    fn sweep_backward(&mut self) {
        for k in (0..self.n).rev() {
            self.relax(k);
        }
    }
}

/// The dense Cholesky factor of the coarsest level's operator.
struct Cholesky {
    n: usize,
    /// Lower triangle, row-major n × n.
    l: Vec<f64>,
}

impl Cholesky {
    fn of(level: &Level) -> Cholesky {
        let n = level.n;
        let mut a = vec![0.0; n * n];
        for k in 0..n {
            a[k * n + k] += level.diag[k];
            for m in 0..4 {
                let q = level.neighbour[k][m] as usize;
                if q < n {
                    a[k * n + q] -= level.weight[k][m];
                }
            }
        }
        for j in 0..n {
            let mut d = a[j * n + j];
            for m in 0..j {
                d -= a[j * n + m] * a[j * n + m];
            }
            // The operator is positive definite; a rounding-level pivot
            // would only come from a free component without boundary,
            // which a grid with a known cell cannot have.
            let d = if d > 0.0 { d.sqrt() } else { 1.0 };
            a[j * n + j] = d;
            for i in j + 1..n {
                let mut s = a[i * n + j];
                for m in 0..j {
                    s -= a[i * n + m] * a[j * n + m];
                }
                a[i * n + j] = s / d;
            }
        }
        Cholesky { n, l: a }
    }

    /// x = A⁻¹·rhs (`x` keeps its ghost entry at 0).
    fn solve(&self, rhs: &[f64], x: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let mut s = rhs[i];
            for m in 0..i {
                s -= self.l[i * n + m] * x[m];
            }
            x[i] = s / self.l[i * n + i];
        }
        for i in (0..n).rev() {
            let mut s = x[i];
            for m in i + 1..n {
                s -= self.l[m * n + i] * x[m];
            }
            x[i] = s / self.l[i * n + i];
        }
        x[n] = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    /// Fills the cells where `hole` holds and returns the largest error
    /// against `f`.
    fn fill_error(
        w: usize,
        h: usize,
        wrap: bool,
        f: impl Fn(f64, f64) -> f64,
        hole: impl Fn(usize, usize) -> bool,
    ) -> (f64, FillStats) {
        let mut values = vec![0.0; w * h];
        let mut known = vec![true; w * h];
        for j in 0..h {
            for i in 0..w {
                let c = j * w + i;
                if hole(i, j) {
                    known[c] = false;
                    values[c] = 1e3;
                } else {
                    values[c] = f(i as f64, j as f64);
                }
            }
        }
        let stats = fill(&mut values, &known, w, h, wrap);
        let mut worst: f64 = 0.0;
        for j in 0..h {
            for i in 0..w {
                worst = worst.max((values[j * w + i] - f(i as f64, j as f64)).abs());
            }
        }
        (worst, stats)
    }

    #[test]
    fn a_discrete_harmonic_function_is_recovered_in_a_hole() {
        // x·y and x² − y² are exactly harmonic on the 5-point stencil; the
        // image edges are known, so no reflecting edge is involved.
        let (w, h) = (97, 64);
        let inside = |i: usize, j: usize| i > 0 && j > 0 && i + 1 < w && j + 1 < h;
        let xy = |x: f64, y: f64| 0.01 * (x - 40.0) * (y - 20.0);
        let (err, stats) = fill_error(w, h, false, xy, inside);
        assert!(err < 1e-8, "x·y: error {err}, {stats:?}");
        assert!(stats.relative_residual <= TOLERANCE);
        let saddle = |x: f64, y: f64| 1e-3 * ((x - 30.0).powi(2) - (y - 10.0).powi(2));
        // A hole that is not a rectangle: a disc and a ring of known cells.
        let disc = |i: usize, j: usize| {
            let r2 = (i as f64 - 48.0).powi(2) + (j as f64 - 32.0).powi(2);
            r2 < 900.0 && !(100.0..130.0).contains(&r2)
        };
        let (err, stats) = fill_error(w, h, false, saddle, disc);
        assert!(err < 1e-8, "saddle: error {err}, {stats:?}");
    }

    #[test]
    fn a_linear_ramp_with_reflecting_edges() {
        // u = a + b·x is harmonic and, along y, satisfies the reflecting
        // edges: the known first and last columns fix it everywhere else.
        let (w, h) = (50, 33);
        let ramp = |x: f64, _: f64| 2.0 - 0.03 * x;
        let (err, stats) = fill_error(w, h, false, ramp, |i, _| i > 0 && i + 1 < w);
        assert!(err < 1e-9, "error {err}, {stats:?}");
    }

    #[test]
    fn a_single_known_value_fills_a_constant_and_none_fills_zero() {
        let (w, h) = (40, 25);
        let mut values = vec![f64::NAN; w * h];
        let mut known = vec![false; w * h];
        values[7 * w + 13] = 3.25;
        known[7 * w + 13] = true;
        fill(&mut values, &known, w, h, false);
        assert!(values.iter().all(|v| (v - 3.25).abs() < 1e-8), "{:?}", &values[..5]);
        let mut values = vec![5.0; w * h];
        let stats = fill(&mut values, &vec![false; w * h], w, h, true);
        assert!(values.iter().all(|&v| v == 0.0));
        assert_eq!(stats.unknowns, w * h);
        // Nothing unknown: nothing changes.
        let mut values = vec![1.5; 6];
        fill(&mut values, &[true; 6], 3, 2, false);
        assert_eq!(values, vec![1.5; 6]);
    }

    #[test]
    fn wrap_joins_the_left_and_right_edges() {
        // The bottom half unknown, the top half cos(2πx/w) (+ const): with
        // the periodic seam the fill is the separable harmonic cos(kx)·
        // cosh-like decay whose discrete form is exact: cos(k x)·g(y) with
        // g(y+1) + g(y−1) = (4 − 2cos k)·g(y) and g reflected at the
        // bottom. Without the seam the fill would differ at the columns
        // next to it.
        let (w, h) = (64, 40);
        let k = 2.0 * std::f64::consts::PI / w as f64;
        let top = 20;
        let c = 2.0 - k.cos();
        // Reflecting bottom row: g(h) = g(h−1), i.e. the mirrored cell.
        // Solve the recurrence downward from g(top − 1) = 1 with a shooting
        // parameter: g = A·λ^y + B·λ^−y; reflecting: g(h) = g(h − 1).
        let lambda = c + (c * c - 1.0).sqrt();
        let y0 = (top - 1) as f64;
        let yh = h as f64 - 0.5;
        // g(y) ∝ cosh(μ (y − yh)), μ = ln λ, symmetric about the mirror line.
        let mu = lambda.ln();
        let g = |y: f64| (mu * (y - yh)).cosh() / (mu * (y0 - yh)).cosh();
        let f = |x: f64, y: f64| 1.0 + 0.5 * (k * x).cos() * if y >= y0 { g(y) } else { 1.0 };
        let (err, stats) = fill_error(w, h, true, f, |_, j| j >= top);
        assert!(err < 1e-8, "error {err}, {stats:?}");
    }

    #[test]
    fn a_large_fill_is_fast() {
        // The emphasis step's case: the lower half of a 1024 × 512 sphere.
        let (w, h) = (1024, 512);
        let mut values = vec![0.0; w * h];
        let mut known = vec![false; w * h];
        for j in 0..256 {
            for i in 0..w {
                let phi = 2.0 * std::f64::consts::PI * i as f64 / w as f64;
                values[j * w + i] = 1.0 + 0.3 * phi.cos() + 0.1 * (5.0 * phi).sin() + 0.01 * j as f64;
                known[j * w + i] = true;
            }
        }
        let start = Instant::now();
        let stats = fill(&mut values, &known, w, h, true);
        let seconds = start.elapsed().as_secs_f64();
        println!("laplace::fill 1024×512, lower half unknown: {seconds:.3} s, {stats:?}");
        assert!(stats.relative_residual <= TOLERANCE, "{stats:?}");
        // The (γ, α) case: a 361 × 361 table with a parallelogram missing.
        let n = 361;
        let mut values = vec![0.0; n * n];
        let mut known = vec![false; n * n];
        for a in 0..n {
            for g in 0..n {
                if (a as i64 - 180).abs() <= g as i64 && g + a <= 540 {
                    values[a * n + g] = (-(g as f64) / 30.0).exp() + 0.01 * a as f64;
                    known[a * n + g] = true;
                }
            }
        }
        let start = Instant::now();
        let stats = fill(&mut values, &known, n, n, false);
        let seconds = start.elapsed().as_secs_f64();
        println!("laplace::fill 361×361, outside the parallelogram: {seconds:.3} s, {stats:?}");
        assert!(stats.relative_residual <= TOLERANCE, "{stats:?}");
    }
}
