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
//! masks, periodic and reflecting edges coarsen by construction.
//! Red–black Gauss–Seidel smoothing, forward before the coarse correction
//! and its exact reverse after, keeps the preconditioner symmetric, as
//! conjugate gradients needs; the coarsest
//! level (at most [`COARSEST_CELLS`] unknowns) is solved exactly by a
//! dense Cholesky factorisation. The iteration stops at a relative
//! residual of [`TOLERANCE`], in 13 to 20 iterations whatever the size.
//!
//! Every level is kept on its grid, its fixed cells held at 0 (the
//! correction there is 0), so that the sweeps read neighbours by index
//! arithmetic from contiguous rows.
//!
//! (Over 600 lines, about 620 without its unit tests: the levels, their
//! sweeps, the coarsening and the coarsest solve are one solver, and its
//! doc comments are long.)

/// The solve stops once ‖b − A·u‖₂ ≤ `TOLERANCE`·‖b‖₂, b the known cells'
/// coupling into the unknowns: far below the noise of rendered radiance,
/// and cheap because each preconditioned iteration gains about half a
/// decimal digit (1e-8 would save two of about 13 iterations).
pub const TOLERANCE: f64 = 1e-10;

/// The most unknowns of the coarsest level, which is solved directly.
pub const COARSEST_CELLS: usize = 200;

/// A bound on the iterations; the tolerance is reached long before.
const MAX_ITERATIONS: usize = 500;

const SWEEPS: usize = 1;

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

    // The fine level and b: each unknown's known neighbours.
    let fine = Level::fine(known, width, height, wrap_x);
    let mut b = vec![0.0; cells];
    let mut boundary_weight = 0.0;
    for j in 0..height {
        for i in 0..width {
            let c = j * width + i;
            if known[c] {
                continue;
            }
            for q in fine.neighbours(c, i, j).into_iter().flatten() {
                if known[q] {
                    b[c] += values[q];
                    boundary_weight += 1.0;
                }
            }
        }
    }

    // The hierarchy: aggregate until the coarsest level is small.
    let mut levels = vec![fine];
    while levels[levels.len() - 1].free_count > COARSEST_CELLS {
        let coarse = levels[levels.len() - 1].coarsen();
        levels.push(coarse);
    }
    let coarsest = Cholesky::of(&levels[levels.len() - 1]);

    // Preconditioned conjugate gradients from the mean boundary value.
    let start = if boundary_weight > 0.0 {
        b.iter().sum::<f64>() / boundary_weight
    } else {
        0.0
    };
    let free = levels[0].free.clone();
    let mut x: Vec<f64> = free.iter().map(|&f| if f { start } else { 0.0 }).collect();
    let mut q = vec![0.0; cells];
    levels[0].apply(&x, &mut q);
    let mut r: Vec<f64> = b.iter().zip(&q).map(|(b, q)| b - q).collect();
    let b_norm = norm(&b);
    let target = TOLERANCE * b_norm;
    let mut r_norm = norm(&r);
    if b_norm > 0.0 && r_norm > target {
        let mut z = vec![0.0; cells];
        precondition(&mut levels, &coarsest, &r, &mut z);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        while stats.iterations < MAX_ITERATIONS {
            stats.iterations += 1;
            levels[0].apply(&p, &mut q);
            let pq = dot(&p, &q);
            if pq <= 0.0 {
                break;
            }
            let step = rz / pq;
            for (((x, r), p), q) in x.iter_mut().zip(&mut r).zip(&p).zip(&q) {
                *x += step * p;
                *r -= step * q;
            }
            r_norm = norm(&r);
            if r_norm <= target {
                break;
            }
            precondition(&mut levels, &coarsest, &r, &mut z);
            let rz_next = dot(&r, &z);
            let beta = rz_next / rz;
            rz = rz_next;
            for (p, z) in p.iter_mut().zip(&z) {
                *p = z + beta * *p;
            }
        }
    }
    stats.relative_residual = if b_norm > 0.0 { r_norm / b_norm } else { 0.0 };
    for ((value, &f), x) in values.iter_mut().zip(&free).zip(&x) {
        if f {
            // With every known neighbour 0 (b = 0) the interpolant is 0.
            *value = if b_norm > 0.0 { *x } else { 0.0 };
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
fn precondition(levels: &mut [Level], coarsest: &Cholesky, r: &[f64], z: &mut [f64]) {
    levels[0].rhs.copy_from_slice(r);
    v_cycle(levels, coarsest);
    z.copy_from_slice(&levels[0].x);
}

/// Approximately solves the first level's A·x = rhs into its `x`, from 0.
fn v_cycle(levels: &mut [Level], coarsest: &Cholesky) {
    let Some((this, rest)) = levels.split_first_mut() else {
        return;
    };
    let Some(next) = rest.first_mut() else {
        coarsest.solve(this);
        return;
    };
    this.x.fill(0.0);
    for _ in 0..SWEEPS {
        this.sweep(false);
    }
    this.restrict_residual(next);
    v_cycle(rest, coarsest);
    this.prolong(&rest[0]);
    for _ in 0..SWEEPS {
        this.sweep(true);
    }
}

/// A level of the hierarchy on its grid: which cells are free, the link
/// weights between free cells (east and south of each cell; all 1 on the
/// image's own level, which stores none), the diagonal (which also holds
/// the couplings to fixed cells), and the V-cycle's work vectors. Fixed
/// cells hold 0 in `x`, so a link to one adds nothing.
struct Level {
    width: usize,
    height: usize,
    wrap: bool,
    unit: bool,
    free: Vec<bool>,
    free_count: usize,
    east: Vec<f64>,
    south: Vec<f64>,
    diag: Vec<f64>,
    inv_diag: Vec<f64>,
    rhs: Vec<f64>,
    x: Vec<f64>,
}

impl Level {
    /// The image's own level: unit weights, the known cells fixed, a
    /// neighbour outside a non-periodic edge left out.
    fn fine(known: &[bool], width: usize, height: usize, wrap: bool) -> Level {
        let cells = width * height;
        let mut level = Level {
            width,
            height,
            wrap,
            unit: true,
            free: known.iter().map(|&k| !k).collect(),
            free_count: 0,
            east: Vec::new(),
            south: Vec::new(),
            diag: vec![0.0; cells],
            inv_diag: vec![0.0; cells],
            rhs: vec![0.0; cells],
            x: vec![0.0; cells],
        };
        for j in 0..height {
            for i in 0..width {
                let c = j * width + i;
                if level.free[c] {
                    let links = level.neighbours(c, i, j).iter().filter(|q| q.is_some()).count();
                    level.diag[c] = links as f64;
                }
            }
        }
        level.finish();
        level
    }

    /// The free count and the inverse diagonal.
    fn finish(&mut self) {
        self.free_count = self.free.iter().filter(|&&f| f).count();
        for ((inv, &d), &f) in self.inv_diag.iter_mut().zip(&self.diag).zip(&self.free) {
            *inv = if f && d > 0.0 { 1.0 / d } else { 0.0 };
        }
    }

    /// Cell `c` = (i, j)'s neighbours east, west, north, south.
    #[inline]
    fn neighbours(&self, c: usize, i: usize, j: usize) -> [Option<usize>; 4] {
        let w = self.width;
        let around = self.wrap && w > 1;
        let east = if i + 1 < w {
            Some(c + 1)
        } else if around {
            Some(c + 1 - w)
        } else {
            None
        };
        let west = if i > 0 {
            Some(c - 1)
        } else if around {
            Some(c + w - 1)
        } else {
            None
        };
        let north = (j > 0).then(|| c - w);
        let south = (j + 1 < self.height).then_some(c + w);
        [east, west, north, south]
    }

    /// The weight of the link from `c` east to `q` (a neighbour): 0 unless
    /// both are free.
    #[inline]
    fn east_link(&self, c: usize, q: usize) -> f64 {
        match self.unit {
            true if self.free[c] && self.free[q] => 1.0,
            true => 0.0,
            false => self.east[c],
        }
    }

    /// The weight of the link from `c` south to `q`.
    #[inline]
    fn south_link(&self, c: usize, q: usize) -> f64 {
        match self.unit {
            true if self.free[c] && self.free[q] => 1.0,
            true => 0.0,
            false => self.south[c],
        }
    }

    /// Σ over the links of an interior cell `c` (not on an image edge) of
    /// weight × x at the other end.
    #[inline(always)]
    fn interior_off<const UNIT: bool>(&self, x: &[f64], c: usize) -> f64 {
        let w = self.width;
        if UNIT {
            // Fixed neighbours hold 0 in x: no weight needed.
            x[c - 1] + x[c + 1] + x[c - w] + x[c + w]
        } else {
            self.east[c] * x[c + 1]
                + self.east[c - 1] * x[c - 1]
                + self.south[c] * x[c + w]
                + self.south[c - w] * x[c - w]
        }
    }

    /// Σ over `c` = (i, j)'s links of weight × x at the other end, for any
    /// cell.
    #[inline(never)]
    fn edge_off(&self, x: &[f64], c: usize, i: usize, j: usize) -> f64 {
        let [e, west, n, s] = self.neighbours(c, i, j);
        let mut sum = 0.0;
        if let Some(q) = e {
            sum += self.east_link(c, q) * x[q];
        }
        if let Some(q) = west {
            sum += self.east_link(q, c) * x[q];
        }
        if let Some(q) = n {
            sum += self.south_link(q, c) * x[q];
        }
        if let Some(q) = s {
            sum += self.south_link(c, q) * x[q];
        }
        sum
    }

    /// Calls `visit(c, i, j, off)` for every free cell in row-major order
    /// (or its reverse), `off` the cell's off-diagonal sum over `x` read
    /// just before the call.
    #[inline(always)]
    fn for_free<const UNIT: bool>(
        &self,
        backward: bool,
        x: &mut [f64],
        mut visit: impl FnMut(&mut [f64], usize, usize, usize, f64),
    ) {
        let (w, h) = (self.width, self.height);
        for jj in 0..h {
            let j = if backward { h - 1 - jj } else { jj };
            let inner_row = j > 0 && j + 1 < h;
            for ii in 0..w {
                let i = if backward { w - 1 - ii } else { ii };
                let c = j * w + i;
                if !self.free[c] {
                    continue;
                }
                let off = if inner_row && i > 0 && i + 1 < w {
                    self.interior_off::<UNIT>(x, c)
                } else {
                    self.edge_off(x, c, i, j)
                };
                visit(x, c, i, j, off);
            }
        }
    }

    /// y = A·x on the free cells, 0 on the fixed ones.
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        if self.unit {
            self.apply_with::<true>(x, y);
        } else {
            self.apply_with::<false>(x, y);
        }
    }

    fn apply_with<const UNIT: bool>(&self, x: &[f64], y: &mut [f64]) {
        let (w, h) = (self.width, self.height);
        for j in 0..h {
            let inner_row = j > 0 && j + 1 < h;
            for i in 0..w {
                let c = j * w + i;
                y[c] = if !self.free[c] {
                    0.0
                } else if inner_row && i > 0 && i + 1 < w {
                    self.diag[c] * x[c] - self.interior_off::<UNIT>(x, c)
                } else {
                    self.diag[c] * x[c] - self.edge_off(x, c, i, j)
                };
            }
        }
    }

    /// One red–black Gauss–Seidel sweep toward A·x = rhs: the cells with
    /// i + j even, then the odd ones, each in row-major order; `backward`
    /// runs the exact reverse (the adjoint sweep). Within a colour no cell
    /// waits for another's update (except across an odd-width periodic
    /// seam, where the order still makes it a Gauss–Seidel sweep), so the
    /// updates do not form one long chain of dependent additions.
    fn sweep(&mut self, backward: bool) {
        let colours = if backward { [1, 0] } else { [0, 1] };
        for colour in colours {
            if self.unit {
                self.sweep_colour::<true>(colour, backward);
            } else {
                self.sweep_colour::<false>(colour, backward);
            }
        }
    }

    fn sweep_colour<const UNIT: bool>(&mut self, colour: usize, backward: bool) {
        let (w, h) = (self.width, self.height);
        let mut x = std::mem::take(&mut self.x);
        for jj in 0..h {
            let j = if backward { h - 1 - jj } else { jj };
            let first = (j + colour) % 2;
            if first >= w {
                continue;
            }
            let count = (w - first).div_ceil(2);
            let inner_row = j > 0 && j + 1 < h;
            for kk in 0..count {
                let k = if backward { count - 1 - kk } else { kk };
                let i = first + 2 * k;
                let c = j * w + i;
                if !self.free[c] {
                    continue;
                }
                let off = if inner_row && i > 0 && i + 1 < w {
                    self.interior_off::<UNIT>(&x, c)
                } else {
                    self.edge_off(&x, c, i, j)
                };
                x[c] = (self.rhs[c] + off) * self.inv_diag[c];
            }
        }
        self.x = x;
    }

    /// The aggregate (on the next level) of cell (i, j).
    #[inline]
    fn aggregate(&self, i: usize, j: usize) -> usize {
        (j / 2) * self.width.div_ceil(2) + i / 2
    }

    /// next.rhs = Pᵀ(rhs − A·x): the residual summed into the aggregates.
    fn restrict_residual(&mut self, next: &mut Level) {
        next.rhs.fill(0.0);
        let mut x = std::mem::take(&mut self.x);
        let (rhs, diag, wc) = (&self.rhs, &self.diag, self.width.div_ceil(2));
        let coarse = &mut next.rhs;
        let add = |x: &mut [f64], c: usize, i: usize, j: usize, off: f64| {
            coarse[(j / 2) * wc + i / 2] += rhs[c] - diag[c] * x[c] + off
        };
        if self.unit {
            self.for_free::<true>(false, &mut x, add);
        } else {
            self.for_free::<false>(false, &mut x, add);
        }
        self.x = x;
    }

    /// x += P·next.x: each free cell gets its aggregate's correction.
    fn prolong(&mut self, next: &Level) {
        for j in 0..self.height {
            for i in 0..self.width {
                let c = j * self.width + i;
                if self.free[c] {
                    self.x[c] += next.x[self.aggregate(i, j)];
                }
            }
        }
    }

    /// The next coarser level: 2×2 aggregates, the halved Galerkin
    /// operator.
    fn coarsen(&self) -> Level {
        let (wc, hc) = (self.width.div_ceil(2), self.height.div_ceil(2));
        let cells = wc * hc;
        let mut next = Level {
            width: wc,
            height: hc,
            wrap: self.wrap,
            unit: false,
            free: vec![false; cells],
            free_count: 0,
            east: vec![0.0; cells],
            south: vec![0.0; cells],
            diag: vec![0.0; cells],
            inv_diag: vec![0.0; cells],
            rhs: vec![0.0; cells],
            x: vec![0.0; cells],
        };
        for j in 0..self.height {
            for i in 0..self.width {
                let c = j * self.width + i;
                if !self.free[c] {
                    continue;
                }
                let a = self.aggregate(i, j);
                next.free[a] = true;
                next.diag[a] += self.diag[c];
                let [e, _, _, s] = self.neighbours(c, i, j);
                if let Some(q) = e {
                    let weight = self.east_link(c, q);
                    let iq = if i + 1 < self.width { i + 1 } else { 0 };
                    if self.aggregate(iq, j) == a {
                        next.diag[a] -= 2.0 * weight;
                    } else {
                        // The aggregate east of this one, also across the
                        // periodic seam.
                        next.east[a] += weight;
                    }
                }
                if let Some(q) = s {
                    let weight = self.south_link(c, q);
                    if self.aggregate(i, j + 1) == a {
                        next.diag[a] -= 2.0 * weight;
                    } else {
                        next.south[a] += weight;
                    }
                }
            }
        }
        for v in next.east.iter_mut().chain(&mut next.south).chain(&mut next.diag) {
            *v *= 0.5;
        }
        next.finish();
        next
    }
}

/// The dense Cholesky factor of the coarsest level's operator over its
/// free cells.
struct Cholesky {
    /// The grid index of each free cell.
    cells: Vec<usize>,
    /// Lower triangle, row-major n × n.
    l: Vec<f64>,
}

impl Cholesky {
    fn of(level: &Level) -> Cholesky {
        let cells: Vec<usize> = (0..level.free.len()).filter(|&c| level.free[c]).collect();
        let n = cells.len();
        let mut index = vec![usize::MAX; level.free.len()];
        for (k, &c) in cells.iter().enumerate() {
            index[c] = k;
        }
        // Column k of A from A·e_k, read back at the free cells.
        let mut a = vec![0.0; n * n];
        let mut unit = vec![0.0; level.free.len()];
        let mut column = vec![0.0; level.free.len()];
        for (k, &c) in cells.iter().enumerate() {
            unit[c] = 1.0;
            level.apply(&unit, &mut column);
            unit[c] = 0.0;
            for (m, &q) in cells.iter().enumerate() {
                a[m * n + k] = column[q];
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
        Cholesky { cells, l: a }
    }

    /// level.x = A⁻¹·level.rhs on the free cells (0 on the fixed ones).
    fn solve(&self, level: &mut Level) {
        let n = self.cells.len();
        let mut y: Vec<f64> = self.cells.iter().map(|&c| level.rhs[c]).collect();
        // L·y = rhs, then Lᵀ·x = y.
        for i in 0..n {
            let row = &self.l[i * n..i * n + i];
            let s = y[i] - row.iter().zip(&y[..i]).map(|(l, y)| l * y).sum::<f64>();
            y[i] = s / self.l[i * n + i];
        }
        for i in (0..n).rev() {
            let s = y[i]
                - (i + 1..n)
                    .map(|m| self.l[m * n + i])
                    .zip(&y[i + 1..])
                    .map(|(l, y)| l * y)
                    .sum::<f64>();
            y[i] = s / self.l[i * n + i];
        }
        level.x.fill(0.0);
        for (&c, &v) in self.cells.iter().zip(&y) {
            level.x[c] = v;
        }
    }
}

/// The calling thread's CPU time (s) from /proc/thread-self/schedstat,
/// for the tests' timing prints: on a shared machine wall-clock time also
/// counts the neighbours' work. NaN where the file is not there.
#[cfg(test)]
pub(super) fn thread_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|t| t.parse::<f64>().ok()))
        .map_or(f64::NAN, |ns| ns * 1e-9)
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
        let (start, cpu) = (Instant::now(), thread_cpu_seconds());
        let stats = fill(&mut values, &known, w, h, true);
        let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
        println!("laplace::fill 1024×512, lower half unknown: {cpu:.3} s CPU ({wall:.3} s wall), {stats:?}");
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
        let (start, cpu) = (Instant::now(), thread_cpu_seconds());
        let stats = fill(&mut values, &known, n, n, false);
        let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
        println!("laplace::fill 361×361, outside the parallelogram: {cpu:.3} s CPU ({wall:.3} s wall), {stats:?}");
        assert!(stats.relative_residual <= TOLERANCE, "{stats:?}");
    }
}
