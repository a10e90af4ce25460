//! The comparison statistics of a validation case: the seed's ratio and
//! correlation figures over the intensities, and the z test over every
//! compared value (z = difference over the combined standard error, Šidák
//! threshold for a 1 % family-wise false alarm).

use crate::compat::significance::sidak_threshold;

/// Family-wise false-alarm rate of a case's z test.
pub const ALPHA: f64 = 0.01;

/// One compared value: atmosim's estimate and the reference's, with their
/// standard errors and the reference's stated accuracy floor (absolute).
#[derive(Debug, Clone, PartialEq)]
pub struct Value {
    /// What it is, for the report (level, direction, component).
    pub label: String,
    /// The set of values it belongs to (an output level, a sun angle):
    /// inverse-variance mean ratios are taken per group.
    pub group: String,
    pub view_zenith_deg: f64,
    pub azimuth_deg: f64,
    /// Stokes component: 0 = I, 1 = Q, 2 = U, 3 = V.
    pub component: usize,
    pub atmosim: f64,
    pub atmosim_se: f64,
    pub reference: f64,
    /// The reference's own standard error (Monte Carlo references), else 0.
    pub reference_se: f64,
    /// The reference's accuracy floor (deterministic truncation, printed
    /// digits), absolute, combined with the errors in quadrature.
    pub floor: f64,
    /// Whether the value enters the statistics (e.g. false for directions
    /// near the sun in a case restricted away from it).
    pub in_stats: bool,
}

impl Value {
    /// √(se² + se_ref² + floor²).
    pub fn combined_se(&self) -> f64 {
        (self.atmosim_se.powi(2) + self.reference_se.powi(2) + self.floor.powi(2)).sqrt()
    }

    /// (atmosim − reference)/combined standard error (±∞ for a difference
    /// with no error at all, 0 for equality).
    pub fn z(&self) -> f64 {
        let d = self.atmosim - self.reference;
        let se = self.combined_se();
        if se > 0.0 {
            d / se
        } else if d == 0.0 {
            0.0
        } else {
            d.signum() * f64::INFINITY
        }
    }

    /// atmosim/reference (NaN for a zero reference).
    pub fn ratio(&self) -> f64 {
        if self.reference == 0.0 {
            f64::NAN
        } else {
            self.atmosim / self.reference
        }
    }
}

/// The statistics of one case.
#[derive(Debug, Clone, PartialEq)]
pub struct Statistics {
    /// Values in the z test (every component).
    pub values: usize,
    /// Intensities in the ratio and correlation statistics.
    pub intensities: usize,
    pub mean_ratio: f64,
    pub median_ratio: f64,
    pub mean_abs_rel_diff: f64,
    pub median_abs_rel_diff: f64,
    pub max_abs_rel_diff: f64,
    /// Pearson correlation of atmosim's and the reference's intensities.
    pub correlation: f64,
    pub max_abs_z: f64,
    /// The value with the largest |z|.
    pub worst: String,
    /// Šidák threshold for `values` comparisons at [`ALPHA`].
    pub threshold: f64,
    /// Fraction of |z| < 1 (≈ 0.68 when the errors are honest).
    pub within_one_sigma: f64,
    /// Per group, the inverse-variance mean ratio of the intensities.
    pub group_ratios: Vec<GroupRatio>,
}

/// The inverse-variance weighted mean of atmosim/reference over the
/// intensities of one group: a bias common to a group's directions shows
/// here long before any single value's z does.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupRatio {
    pub group: String,
    pub intensities: usize,
    /// Σ (r_i/σ_i²) / Σ (1/σ_i²), r_i = atmosim/reference, σ_i = the
    /// combined standard error over the reference.
    pub ratio: f64,
    /// 1/√Σ (1/σ_i²).
    pub se: f64,
}

/// [`GroupRatio`] per group of the intensities in the statistics, in order
/// of first appearance (values without noise are left out).
pub fn group_ratios(values: &[Value]) -> Vec<GroupRatio> {
    let mut out: Vec<(GroupRatio, f64, f64)> = Vec::new();
    for v in values
        .iter()
        .filter(|v| v.in_stats && v.component == 0 && v.reference != 0.0)
    {
        let sigma = v.combined_se() / v.reference.abs();
        if !(sigma > 0.0 && sigma.is_finite()) {
            continue;
        }
        let w = 1.0 / (sigma * sigma);
        let i = match out.iter().position(|(g, ..)| g.group == v.group) {
            Some(i) => i,
            None => {
                let g = GroupRatio {
                    group: v.group.clone(),
                    intensities: 0,
                    ratio: f64::NAN,
                    se: f64::NAN,
                };
                out.push((g, 0.0, 0.0));
                out.len() - 1
            }
        };
        let (g, sum_w, sum_wr) = &mut out[i];
        g.intensities += 1;
        *sum_w += w;
        *sum_wr += w * v.ratio();
    }
    out.into_iter()
        .map(|(g, sum_w, sum_wr)| GroupRatio {
            ratio: sum_wr / sum_w,
            se: 1.0 / sum_w.sqrt(),
            ..g
        })
        .collect()
}

impl GroupRatio {
    /// "zout 0: 0.99912 ± 0.00061 (38 I)".
    pub fn describe(&self) -> String {
        format!(
            "{}: {:.5} ± {:.5} ({} I)",
            self.group, self.ratio, self.se, self.intensities
        )
    }
}

/// Mean of a slice (NaN when empty).
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Median of a slice (NaN when empty): the middle value, or the mean of the
/// two middle values.
pub fn median(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Pearson's correlation coefficient (NaN for fewer than two points or a
/// constant series).
pub fn pearson(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    if n < 2 {
        return f64::NAN;
    }
    let (mx, my) = (mean(&x[..n]), mean(&y[..n]));
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (dx, dy) = (x[i] - mx, y[i] - my);
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    sxy / (sxx * syy).sqrt()
}

/// The statistics over the values with `in_stats`: ratios, relative
/// differences and correlation over the intensities with a non-zero
/// reference; z over every component.
pub fn statistics(values: &[Value]) -> Statistics {
    let used: Vec<&Value> = values.iter().filter(|v| v.in_stats).collect();
    let intensities: Vec<&Value> = used
        .iter()
        .copied()
        .filter(|v| v.component == 0 && v.reference != 0.0)
        .collect();
    let ratios: Vec<f64> = intensities.iter().map(|v| v.ratio()).collect();
    let rel: Vec<f64> = ratios.iter().map(|r| (r - 1.0).abs()).collect();
    let a: Vec<f64> = intensities.iter().map(|v| v.atmosim).collect();
    let b: Vec<f64> = intensities.iter().map(|v| v.reference).collect();
    let mut max_abs_z = 0.0;
    let mut worst = String::new();
    for v in &used {
        let z = v.z().abs();
        if z > max_abs_z || (z.is_nan() && !max_abs_z.is_nan()) {
            max_abs_z = z;
            worst = format!(
                "{}: atmosim {:.6e} ± {:.2e}, reference {:.6e} (± {:.2e}, floor {:.2e}), z = {:.2}",
                v.label,
                v.atmosim,
                v.atmosim_se,
                v.reference,
                v.reference_se,
                v.floor,
                v.z()
            );
        }
    }
    Statistics {
        values: used.len(),
        intensities: intensities.len(),
        mean_ratio: mean(&ratios),
        median_ratio: median(&ratios),
        mean_abs_rel_diff: mean(&rel),
        median_abs_rel_diff: median(&rel),
        max_abs_rel_diff: rel.iter().copied().fold(f64::NAN, f64::max),
        correlation: pearson(&a, &b),
        max_abs_z,
        worst,
        threshold: sidak_threshold(used.len(), ALPHA),
        within_one_sigma: used.iter().filter(|v| v.z().abs() < 1.0).count() as f64 / used.len().max(1) as f64,
        group_ratios: group_ratios(values),
    }
}

impl Statistics {
    /// No |z| above the threshold (and at least one value).
    pub fn passes(&self) -> bool {
        self.values > 0 && self.max_abs_z <= self.threshold
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(atmosim: f64, se: f64, reference: f64, component: usize) -> Value {
        Value {
            label: String::new(),
            group: String::new(),
            view_zenith_deg: 0.0,
            azimuth_deg: 0.0,
            component,
            atmosim,
            atmosim_se: se,
            reference,
            reference_se: 0.0,
            floor: 0.0,
            in_stats: true,
        }
    }

    #[test]
    fn median_mean_and_pearson_by_hand() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(mean(&[1.0, 2.0, 6.0]), 3.0);
        // x = 1,2,3; y = 2,4,7: mean 2, 13/3; Sxy = 5, Sxx = 2, Syy = 38/3.
        let r = pearson(&[1.0, 2.0, 3.0], &[2.0, 4.0, 7.0]);
        assert!((r - 5.0 / (2.0f64 * 38.0 / 3.0).sqrt()).abs() < 1e-15, "{r}");
        assert!((pearson(&[1.0, 2.0], &[-3.0, -5.0]) + 1.0).abs() < 1e-15);
    }

    #[test]
    fn z_combines_the_errors_in_quadrature() {
        let mut v = value(1.05, 0.03, 1.0, 0);
        v.reference_se = 0.04;
        assert!((v.combined_se() - 0.05).abs() < 1e-15);
        assert!((v.z() - 1.0).abs() < 1e-12);
        v.floor = 0.12;
        // √(0.03² + 0.04² + 0.12²) = 0.13.
        assert!((v.z() - 0.05 / 0.13).abs() < 1e-12);
        assert_eq!(value(1.0, 0.0, 1.0, 0).z(), 0.0);
        assert_eq!(value(2.0, 0.0, 1.0, 0).z(), f64::INFINITY);
    }

    #[test]
    fn statistics_of_a_small_case_by_hand() {
        // Ratios 1.1, 0.9, 1.2 over the intensities; the Q value only in z.
        let values = vec![
            value(1.1, 0.05, 1.0, 0),
            value(1.8, 0.1, 2.0, 0),
            value(3.6, 0.3, 3.0, 0),
            value(0.5, 0.1, 0.0, 1),
        ];
        let s = statistics(&values);
        assert_eq!((s.values, s.intensities), (4, 3));
        assert!((s.mean_ratio - 3.2 / 3.0).abs() < 1e-12);
        assert!((s.median_ratio - 1.1).abs() < 1e-12);
        assert!((s.mean_abs_rel_diff - 0.4 / 3.0).abs() < 1e-12);
        assert!((s.median_abs_rel_diff - 0.1).abs() < 1e-12);
        assert!((s.max_abs_rel_diff - 0.2).abs() < 1e-12);
        // z: 2, -2, 2, 5 → max 5 (the Q value).
        assert!((s.max_abs_z - 5.0).abs() < 1e-12, "{}", s.max_abs_z);
        assert_eq!(s.within_one_sigma, 0.0);
        assert!((s.threshold - sidak_threshold(4, 0.01)).abs() < 1e-12);
        assert!(!s.passes());
        let r = pearson(&[1.1, 1.8, 3.6], &[1.0, 2.0, 3.0]);
        assert!((s.correlation - r).abs() < 1e-15);
    }

    #[test]
    fn values_outside_the_statistics_are_left_out() {
        let mut far = value(10.0, 0.1, 1.0, 0);
        far.in_stats = false;
        let s = statistics(&[value(1.0, 0.1, 1.0, 0), far]);
        assert_eq!(s.values, 1);
        assert_eq!(s.max_abs_z, 0.0);
        assert!(s.passes());
    }

    #[test]
    fn group_ratios_by_hand() {
        // Group a: ratios 1.1 (σ 0.1) and 0.95 (σ 0.05): weights 100, 400;
        // mean (110 + 380)/500 = 0.98, se 1/√500. Group b: one value.
        let mut values = vec![
            value(1.1, 0.1, 1.0, 0),
            value(1.9, 0.1, 2.0, 0),
            value(3.0, 0.3, 3.0, 0),
        ];
        values[0].group = "a".into();
        values[1].group = "a".into();
        values[2].group = "b".into();
        let g = group_ratios(&values);
        assert_eq!(g.len(), 2);
        assert_eq!((g[0].group.as_str(), g[0].intensities), ("a", 2));
        assert!((g[0].ratio - 0.98).abs() < 1e-12, "{}", g[0].ratio);
        assert!((g[0].se - 1.0 / 500f64.sqrt()).abs() < 1e-12);
        assert!((g[1].ratio - 1.0).abs() < 1e-15 && (g[1].se - 0.1).abs() < 1e-15);
    }
}
