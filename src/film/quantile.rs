//! Quantiles of a film's per-pixel (or per-point) figures, one definition
//! for every report that quotes a percentile.

/// The `q`-quantile of `values` by the nearest rank: after sorting them in
/// place, the value at index round((n − 1)·q). `values` must not be empty.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    values[((values.len() - 1) as f64 * q).round() as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_on_a_short_list() {
        // Five values: index round(4q).
        let mut v = [5.0, 1.0, 4.0, 2.0, 3.0];
        assert_eq!(quantile(&mut v, 0.5), 3.0);
        assert_eq!(quantile(&mut v, 0.99), 5.0);
        assert_eq!(quantile(&mut v, 0.1), 1.0);
        assert_eq!(quantile(&mut [3.0], 0.99), 3.0);
    }
}
