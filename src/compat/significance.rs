//! The significance of a difference between a Monte Carlo estimate and a
//! reference: the standard normal tail, its quantile, and the
//! Šidák-corrected threshold for |z| over a family of comparisons.

/// Complementary error function, erfc(x), from the Chebyshev fit of
/// Press et al. (Numerical Recipes, 2nd ed., §6.2), fractional error below
/// 1.2e-7 everywhere.
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// Two-sided tail probability P(|Z| > z) of a standard normal variable.
pub fn two_sided_tail(z: f64) -> f64 {
    erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// The |z| threshold whose two-sided tail is `p` (bisection on the tail).
pub fn two_sided_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if two_sided_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The Šidák-corrected |z| threshold for `n` independent comparisons at a
/// family-wise false-alarm rate `alpha`: each comparison at
/// 1 − (1 − alpha)^(1/n).
pub fn sidak_threshold(n: usize, alpha: f64) -> f64 {
    let per = 1.0 - (1.0 - alpha).powf(1.0 / n.max(1) as f64);
    two_sided_quantile(per)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_tail_matches_tabulated_values() {
        // Abramowitz & Stegun Table 26.1: P(|Z| > 1.959964) = 0.05, P(|Z| > 2.575829) = 0.01.
        assert!((two_sided_tail(1.959964) - 0.05).abs() < 1e-7);
        assert!((two_sided_quantile(0.01) - 2.575829).abs() < 1e-5);
        assert!((erfc(0.0) - 1.0).abs() < 1e-7);
    }

    #[test]
    fn sidak_thresholds_are_those_of_the_issue() {
        // ≈ 4.4 for 1,000 values and ≈ 5.2 for 50,000 at 1 % family-wise.
        assert!(
            (sidak_threshold(1000, 0.01) - 4.42).abs() < 0.02,
            "{}",
            sidak_threshold(1000, 0.01)
        );
        assert!(
            (sidak_threshold(50_000, 0.01) - 5.16).abs() < 0.05,
            "{}",
            sidak_threshold(50_000, 0.01)
        );
        assert!((sidak_threshold(1, 0.01) - 2.5758).abs() < 1e-3);
    }
}
