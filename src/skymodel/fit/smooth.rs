//! The Gaussian blur of the (γ, α) table before its decomposition (the
//! supplement's section 1.6: σ = 1 node of 0.5° along both axes, after
//! the infill). The decomposition keeps the input's noise and turns the
//! renders' grain into ringing along the axes; the blur removes it.
//!
//! Separable, a sampled Gaussian truncated at [`TRUNCATION`]·σ and
//! normalised to sum 1. Beyond the table's edges the values are mirrored
//! about the end nodes (x₋ₖ = xₖ, x_{n−1+k} = x_{n−1−k}): both axes are
//! angles on [0, π] whose ends are the poles of their own coordinate (the
//! sun and the anti-solar point for γ; zenith and nadir, or the shadow
//! point and its antipode, for α), where a function of the direction is
//! even in the angle. Mirroring keeps constants exactly and every
//! cos(m·x), m an integer, up to its own factor.

use super::AngleTable;

/// The kernel's half-width in standard deviations: the weight left out
/// is below 10⁻⁴ of the total.
pub const TRUNCATION: f64 = 4.0;

/// Blurs every cell of `table` (valid or not: run it after the infill)
/// by a Gaussian of standard deviation `sigma_nodes` nodes along both
/// axes. A σ that is not positive and finite leaves the table as it is.
pub fn gaussian(table: &mut AngleTable, sigma_nodes: f64) {
    let n = table.n;
    blur(&mut table.values, n, n, sigma_nodes);
}

/// The separable blur of a row-major `width` × `height` grid, mirrored at
/// all four edges; σ in cells.
///
/// # Panics
///
/// If `values` does not hold `width × height` cells (a caller's bug).
pub fn blur(values: &mut [f64], width: usize, height: usize, sigma_nodes: f64) {
    assert_eq!(
        values.len(),
        width * height,
        "smooth::blur: values is not width × height"
    );
    if !(sigma_nodes > 0.0 && sigma_nodes.is_finite()) || width == 0 {
        return;
    }
    let kernel = kernel(sigma_nodes);
    let mut line = Vec::new();
    let mut out = Vec::new();
    // Along rows (x), then along columns (y).
    for row in values.chunks_exact_mut(width) {
        line.clear();
        line.extend_from_slice(row);
        convolve(&line, &kernel, &mut out);
        row.copy_from_slice(&out);
    }
    for i in 0..width {
        line.clear();
        line.extend((0..height).map(|j| values[j * width + i]));
        convolve(&line, &kernel, &mut out);
        for (j, &v) in out.iter().enumerate() {
            values[j * width + i] = v;
        }
    }
}

/// The normalised weights w₋ᵣ … wᵣ, r = ⌈TRUNCATION·σ⌉.
fn kernel(sigma: f64) -> Vec<f64> {
    let r = (TRUNCATION * sigma).ceil() as i64;
    let mut w: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = w.iter().sum();
    for x in &mut w {
        *x /= total;
    }
    w
}

/// The index of `k` (any integer) on `n` nodes mirrored about both ends.
fn mirrored(k: i64, n: usize) -> usize {
    if n < 2 {
        return 0;
    }
    let period = 2 * (n as i64 - 1);
    let m = k.rem_euclid(period);
    (if m > n as i64 - 1 { period - m } else { m }) as usize
}

/// out = line ∗ kernel with the mirrored extension.
fn convolve(line: &[f64], kernel: &[f64], out: &mut Vec<f64>) {
    let n = line.len();
    let r = (kernel.len() / 2) as i64;
    // The line with r mirrored values on each side.
    let padded: Vec<f64> = (-r..n as i64 + r).map(|k| line[mirrored(k, n)]).collect();
    out.clear();
    out.extend((0..n).map(|i| kernel.iter().zip(&padded[i..]).map(|(w, x)| w * x).sum::<f64>()));
}

#[cfg(test)]
mod tests {
    use super::super::laplace::thread_cpu_seconds;
    use super::*;
    use std::f64::consts::PI;
    use std::time::Instant;

    fn table(n: usize, f: impl Fn(usize, usize) -> f64) -> AngleTable {
        let mut values = vec![0.0; n * n];
        for a in 0..n {
            for g in 0..n {
                values[a * n + g] = f(g, a);
            }
        }
        AngleTable {
            n,
            values,
            valid: vec![true; n * n],
        }
    }

    #[test]
    fn a_constant_stays_and_a_ramp_stays_away_from_the_edges() {
        let mut t = table(61, |_, _| 2.5);
        gaussian(&mut t, 1.0);
        assert!(t.values.iter().all(|v| (v - 2.5).abs() < 1e-14));
        let ramp = |g: usize, a: usize| 0.3 * g as f64 - 0.1 * a as f64 + 1.0;
        let mut t = table(61, ramp);
        gaussian(&mut t, 1.5);
        let r = (TRUNCATION * 1.5).ceil() as usize;
        for a in r..61 - r {
            for g in r..61 - r {
                assert!((t.values[a * 61 + g] - ramp(g, a)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_delta_spreads_with_variance_sigma_squared() {
        for sigma in [1.0, 2.5] {
            let n = 101;
            let mut t = table(n, |g, a| if (g, a) == (50, 50) { 1.0 } else { 0.0 });
            gaussian(&mut t, sigma);
            let (mut mass, mut var_g, mut var_a, mut cov) = (0.0, 0.0, 0.0, 0.0);
            for a in 0..n {
                for g in 0..n {
                    let v = t.values[a * n + g];
                    let (dg, da) = (g as f64 - 50.0, a as f64 - 50.0);
                    mass += v;
                    var_g += v * dg * dg;
                    var_a += v * da * da;
                    cov += v * dg * da;
                }
            }
            assert!((mass - 1.0).abs() < 1e-14);
            // The sampled Gaussian's variance is σ² to 1e-8 (Poisson
            // summation); the truncation at 4σ takes < 1e-3 of it.
            for var in [var_g, var_a] {
                assert!((var / (sigma * sigma) - 1.0).abs() < 1e-3, "σ {sigma}: variance {var}");
            }
            assert!(cov.abs() < 1e-14);
        }
    }

    #[test]
    fn even_functions_of_the_angles_keep_their_shape_up_to_the_edges() {
        // cos(m·x) continues evenly past 0 and π, so the mirrored blur is
        // cos(m·x)·Σₖ wₖ cos(m·k·h) at every node, edge nodes included.
        let n = 91;
        let h = PI / (n - 1) as f64;
        let (m_g, m_a) = (3.0, 7.0);
        let f = |g: usize, a: usize| (m_g * g as f64 * h).cos() * (m_a * a as f64 * h).cos();
        let mut t = table(n, f);
        let sigma = 1.7;
        gaussian(&mut t, sigma);
        let w = kernel(sigma);
        let r = (w.len() / 2) as i64;
        let factor = |m: f64| (-r..=r).zip(&w).map(|(k, w)| w * (m * k as f64 * h).cos()).sum::<f64>();
        let (fg, fa) = (factor(m_g), factor(m_a));
        for a in 0..n {
            for g in 0..n {
                assert!((t.values[a * n + g] - fg * fa * f(g, a)).abs() < 1e-13);
            }
        }
        // σ = 0 leaves the table alone.
        let before = t.clone();
        gaussian(&mut t, 0.0);
        assert_eq!(t, before);
    }

    #[test]
    fn a_361_table_blurs_quickly() {
        let mut t = table(361, |g, a| ((g * 31 + a * 17) % 13) as f64);
        let (start, cpu) = (Instant::now(), thread_cpu_seconds());
        gaussian(&mut t, 1.0);
        let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
        println!("smooth::gaussian 361×361, σ = 1 node: {cpu:.4} s CPU ({wall:.4} s wall)");
    }
}
