//! Where the dataset samples its one-variable functions (the supplement's
//! section 1.6, last paragraph): the fitted vectors come at 361 uniform
//! nodes (0.5°), and the dataset keeps them at fewer, non-uniform "breaks",
//! dense where the functions change fast and sparse where they are smooth.
//! The runtime evaluates them piecewise-linearly between breaks.
//!
//! Every set of breaks here is ascending over [0, π], its first break
//! exactly 0 and its last exactly π, written as x_k = π·g(t_k) with
//! t_k = k/(n − 1) and g an increasing map of [0, 1] onto itself, so the
//! spacing is π·g′(t)/(n − 1):
//!
//! - sun (γ): geometric grading away from the sun,
//!   g(t) = (ρ^t − 1)/(ρ − 1) with ρ = [`SUN_GRADING`] = 5, each spacing a
//!   constant factor larger than the one before, the last ρ times the
//!   first; with the seed's 275 breaks 0.26° at the sun to 1.32° at the
//!   anti-solar point;
//! - zenith/shadow (α): a cosine density about the horizon,
//!   g(t) = t + b·sin(2πt)/(2π) with b = [`ZENITH_GRADING`] = 0.68, spacing
//!   ∝ 1 − b·cos(2π(t − ½)); with the seed's 205 breaks 0.28° at the horizon
//!   (a break exactly at π/2 for odd n) to 1.48° at zenith and nadir;
//! - emphasis (θ′): a break exactly on the horizon (for n ≥ 3), and
//!   geometric grading away from it on both sides: of the n − 1 intervals
//!   m_a = ⌈(n − 1)/2⌉ lie above the horizon (θ′ < π/2) and m_b the rest
//!   below, the break d intervals from the horizon on a side of m at
//!   π/2 ∓ (π/2)·(ρ^(d/m) − 1)/(ρ − 1), ρ = [`EMPH_GRADING`] = 16; with the
//!   seed's 118 breaks 0.29° next to the horizon to 4.5° at zenith and
//!   nadir. 118 breaks over 180° average 1.54°, so no emphasis set of that
//!   size can keep every spacing under 1.5°: the sparse ends are where the
//!   de-emphasis is smooth (exactly 1 in the sky, a slow ground ratio
//!   below), and the dense middle holds the step at the horizon, which
//!   [`super::emphasis`] puts just below the break at π/2.
//!
//! Spacings scale with 1/(n − 1) for other counts.

use std::f64::consts::PI;

/// ρ of the sun breaks: the last spacing over the first.
pub const SUN_GRADING: f64 = 5.0;
/// b of the zenith breaks: the spacing at the horizon is (1 − b) times
/// the mean spacing, at zenith and nadir (1 + b) times.
pub const ZENITH_GRADING: f64 = 0.68;
/// ρ of the emphasis breaks: the spacing at zenith or nadir over the one
/// at the horizon.
pub const EMPH_GRADING: f64 = 16.0;

/// `n` breaks of γ, dense at the sun (γ = 0). Fewer than 2 give [0, π].
pub fn sun_breaks(n: usize) -> Vec<f64> {
    graded(n, |t| (SUN_GRADING.powf(t) - 1.0) / (SUN_GRADING - 1.0))
}

/// `n` breaks of α, dense at the horizon (π/2), sparse at 0 and π.
/// Fewer than 2 give [0, π].
pub fn zenith_breaks(n: usize) -> Vec<f64> {
    let mut out = graded(n, |t| t + ZENITH_GRADING * (2.0 * PI * t).sin() / (2.0 * PI));
    if out.len() % 2 == 1 {
        // sin(π) rounds to 1.2e-16, not 0: the horizon exactly.
        let middle = out.len() / 2;
        out[middle] = PI / 2.0;
    }
    out
}

/// `n` breaks of θ′ for the de-emphasis, dense at the horizon (π/2) and
/// with a break exactly there when n ≥ 3. Fewer than 2 give [0, π].
pub fn emph_breaks(n: usize) -> Vec<f64> {
    if n < 3 {
        return vec![0.0, PI];
    }
    let above = (n - 1).div_ceil(2);
    let below = n - 1 - above;
    let offset = |d: usize, m: usize| PI / 2.0 * (EMPH_GRADING.powf(d as f64 / m as f64) - 1.0) / (EMPH_GRADING - 1.0);
    let mut out: Vec<f64> = (0..=above).rev().map(|d| PI / 2.0 - offset(d, above)).collect();
    out.extend((1..=below).map(|d| PI / 2.0 + offset(d, below)));
    out[0] = 0.0;
    out[n - 1] = PI;
    out
}

/// π·g(k/(n − 1)) for k = 0 … n − 1, the ends exactly 0 and π.
fn graded(n: usize, g: impl Fn(f64) -> f64) -> Vec<f64> {
    let n = n.max(2);
    let mut out: Vec<f64> = (0..n).map(|k| PI * g(k as f64 / (n - 1) as f64)).collect();
    out[0] = 0.0;
    out[n - 1] = PI;
    out
}

/// The values at `breaks` of the function given at `uniform.len()` evenly
/// spaced nodes over [0, π] (node k at kπ/(m − 1)), interpolated linearly;
/// breaks outside [0, π] take the end values. A single node is a constant;
/// no node at all gives zeros.
pub fn resample(uniform: &[f64], breaks: &[f64]) -> Vec<f64> {
    let m = uniform.len();
    if m < 2 {
        let value = uniform.first().copied().unwrap_or(0.0);
        return vec![value; breaks.len()];
    }
    let step = PI / (m - 1) as f64;
    breaks
        .iter()
        .map(|&x| {
            let s = (x / step).clamp(0.0, (m - 1) as f64);
            let k = (s.floor() as usize).min(m - 2);
            let f = s - k as f64;
            (1.0 - f) * uniform[k] + f * uniform[k + 1]
        })
        .collect()
}

/// The runtime's piecewise-linear evaluation at `x` of the function with
/// `values` at the ascending `breaks`: `x` clamped to the first and last
/// break, the interval the one whose lower break is the last not above
/// `x`, and a linear blend across it. Empty breaks give 0.
///
/// # Panics
///
/// If `values` is shorter than `breaks` (a caller's bug).
pub fn eval_piecewise(breaks: &[f64], values: &[f64], x: f64) -> f64 {
    let Some(&last_break) = breaks.last() else {
        return 0.0;
    };
    let last = breaks.len() - 1;
    let x = x.clamp(breaks[0], last_break);
    // The first break above x, searched from the second.
    let above = 1 + breaks[1..].partition_point(|&b| b <= x);
    if above > last {
        return values[last];
    }
    let below = above - 1;
    let f = (x - breaks[below]) / (breaks[above] - breaks[below]);
    (1.0 - f) * values[below] + f * values[above]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn spacings_deg(b: &[f64]) -> (f64, f64) {
        let d: Vec<f64> = b.windows(2).map(|w| (w[1] - w[0]).to_degrees()).collect();
        (
            d.iter().cloned().fold(f64::MAX, f64::min),
            d.iter().cloned().fold(0.0, f64::max),
        )
    }

    #[test]
    fn counts_ends_order_and_spacing() {
        for (b, n) in [
            (sun_breaks(275), 275),
            (zenith_breaks(205), 205),
            (emph_breaks(118), 118),
        ] {
            assert_eq!(b.len(), n);
            assert_eq!((b[0], b[n - 1]), (0.0, PI));
            assert!(b.windows(2).all(|w| w[1] > w[0]));
        }
        let (lo, hi) = spacings_deg(&sun_breaks(275));
        assert!(lo >= 0.25 && hi <= 1.5, "sun {lo}° … {hi}°");
        // Densest at the sun, sparsest at the anti-solar point.
        let s = sun_breaks(275);
        assert!((s[1] - s[0] - lo.to_radians()).abs() < 1e-12);
        assert!((s[274] - s[273] - hi.to_radians()).abs() < 1e-12);
        let (lo, hi) = spacings_deg(&zenith_breaks(205));
        assert!(lo >= 0.25 && hi <= 1.5, "zenith {lo}° … {hi}°");
        // An odd count puts a break on the horizon, where spacing is least.
        let z = zenith_breaks(205);
        assert_eq!(z[102], FRAC_PI_2);
        assert!((z[103] - z[102]).to_degrees() < 0.29);
        let (lo, hi) = spacings_deg(&emph_breaks(118));
        assert!(lo >= 0.25 && hi <= 4.6, "emph {lo}° … {hi}°");
        // The horizon is a break, with the finest spacing either side.
        for n in [118, 119, 4, 3] {
            let e = emph_breaks(n);
            assert_eq!(e.len(), n);
            let mid = e.partition_point(|&x| x < FRAC_PI_2);
            assert_eq!(e[mid], FRAC_PI_2, "n {n}");
            assert!(e.windows(2).all(|w| w[1] > w[0]));
        }
        let e = emph_breaks(118);
        let mid = e.partition_point(|&x| x < FRAC_PI_2);
        assert!((e[mid] - e[mid - 1]).to_degrees() < 0.3 && (e[mid + 1] - e[mid]).to_degrees() < 0.3);
        // Symmetric about the horizon for odd n.
        let e = emph_breaks(119);
        for k in 0..119 {
            assert!((e[k] + e[118 - k] - PI).abs() < 1e-12);
        }
        // Degenerate counts still span [0, π].
        assert_eq!(sun_breaks(0), vec![0.0, PI]);
        assert_eq!(zenith_breaks(2), vec![0.0, PI]);
        assert_eq!(emph_breaks(3), vec![0.0, FRAC_PI_2, PI]);
        assert_eq!(emph_breaks(1), vec![0.0, PI]);
    }

    #[test]
    fn a_linear_function_resamples_and_evaluates_exactly() {
        let uniform: Vec<f64> = (0..361).map(|k| 2.0 - 0.7 * k as f64 * PI / 360.0).collect();
        let line = |x: f64| 2.0 - 0.7 * x;
        for breaks in [sun_breaks(275), zenith_breaks(205), emph_breaks(118)] {
            let values = resample(&uniform, &breaks);
            for (x, v) in breaks.iter().zip(&values) {
                assert!((v - line(*x)).abs() < 1e-13);
            }
            for k in 0..=1000 {
                let x = PI * k as f64 / 1000.0;
                assert!((eval_piecewise(&breaks, &values, x) - line(x)).abs() < 1e-13);
            }
            // Clamped outside [0, π].
            assert_eq!(eval_piecewise(&breaks, &values, -1.0), values[0]);
            assert_eq!(eval_piecewise(&breaks, &values, 4.0), values[values.len() - 1]);
        }
        assert_eq!(resample(&[3.0], &[0.0, 1.0]), vec![3.0, 3.0]);
        assert_eq!(resample(&[], &[0.0]), vec![0.0]);
        assert_eq!(eval_piecewise(&[], &[], 1.0), 0.0);
        assert_eq!(eval_piecewise(&[0.5], &[7.0], 1.0), 7.0);
    }

    /// The largest error, at the 361 uniform nodes, of the dataset's
    /// piecewise-linear function through the resampled values.
    fn resampling_error(f: impl Fn(f64) -> f64, breaks: &[f64]) -> f64 {
        let uniform: Vec<f64> = (0..361).map(|k| f(PI * k as f64 / 360.0)).collect();
        let values = resample(&uniform, breaks);
        (0..361)
            .map(|k| (eval_piecewise(breaks, &values, PI * k as f64 / 360.0) - uniform[k]).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn features_survive_the_resampling() {
        // The solar peak exp(−γ/0.05) (e-folding 2.9°): below 0.3 % of the
        // peak, where 275 uniform breaks lose 0.7 %.
        let peak = |g: f64| (-g / 0.05).exp();
        let graded = resampling_error(peak, &sun_breaks(275));
        let uniform: Vec<f64> = (0..275).map(|k| PI * k as f64 / 274.0).collect();
        assert!(graded < 3e-3, "sun {graded}");
        assert!(resampling_error(peak, &uniform) > 2.0 * graded);
        // A horizon step of unit height smoothed over ±1° (logistic, scale
        // 1°): within 0.4 % on the zenith and emphasis breaks.
        let step = |a: f64| 1.0 / (1.0 + ((a - FRAC_PI_2) / 1f64.to_radians()).exp());
        let zenith = resampling_error(step, &zenith_breaks(205));
        let emph = resampling_error(step, &emph_breaks(118));
        assert!(zenith < 4e-3 && emph < 4e-3, "zenith {zenith}, emphasis {emph}");
        // A smooth sky profile: far below that.
        let sky = |a: f64| 1.0 + 0.5 * a.cos() + 0.3 * (-(a - FRAC_PI_2).abs() / 0.1).exp();
        assert!(resampling_error(sky, &zenith_breaks(205)) < 5e-4);
    }
}
