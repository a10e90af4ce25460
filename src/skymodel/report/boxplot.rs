//! Box plots as PNG: per group the minimum-to-maximum whisker, the box from
//! the first to the third quartile and the median as a red line (the
//! supplement's figures 11–15), the groups' labels below (digits only: the
//! raster's font) and the y range at the left.

use std::path::Path;

use crate::error::Result;
use crate::io::canvas::Canvas;
use crate::io::preview::write_png;

const WIDTH: usize = 760;
const HEIGHT: usize = 360;
const MARGIN_LEFT: i64 = 90;
const MARGIN_RIGHT: i64 = 20;
const MARGIN_TOP: i64 = 20;
const MARGIN_BOTTOM: i64 = 40;

/// The five numbers of a box plot: minimum, first quartile, median, third
/// quartile, maximum (quartiles by linear interpolation between order
/// statistics); `None` for no values.
pub fn five_numbers(values: &[f64]) -> Option<[f64; 5]> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| {
        let x = p * (v.len() - 1) as f64;
        let (i, f) = (x.floor() as usize, x - x.floor());
        if i + 1 < v.len() {
            v[i] * (1.0 - f) + v[i + 1] * f
        } else {
            v[i]
        }
    };
    Some([v[0], q(0.25), q(0.5), q(0.75), v[v.len() - 1]])
}

/// Writes a box plot of `groups` (label, values) to `path`; `title` goes
/// into the PNG's text.
pub fn write_box_plot(path: &Path, title: &str, groups: &[(String, Vec<f64>)]) -> Result<()> {
    let stats: Vec<Option<[f64; 5]>> = groups.iter().map(|(_, v)| five_numbers(v)).collect();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in stats.iter().flatten() {
        lo = lo.min(s[0]);
        hi = hi.max(s[4]);
    }
    if !lo.is_finite() {
        (lo, hi) = (0.0, 1.0);
    }
    let pad = 0.05 * (hi - lo).max(1e-12 * hi.abs().max(1.0));
    let (lo, hi) = (lo - pad, hi + pad);
    let mut c = Canvas::new(WIDTH, HEIGHT);
    let (x0, x1) = (MARGIN_LEFT, WIDTH as i64 - MARGIN_RIGHT);
    let (y0, y1) = (MARGIN_TOP, HEIGHT as i64 - MARGIN_BOTTOM);
    let y_of = |v: f64| y1 - ((v - lo) / (hi - lo) * (y1 - y0) as f64).round() as i64;
    let black = [0, 0, 0];
    c.hline(x0, x1, y0, black);
    c.hline(x0, x1, y1, black);
    c.vline(x0, y0, y1, black);
    c.vline(x1, y0, y1, black);
    c.text(4, y0, &format!("{hi:.4}"), black);
    c.text(4, y1 - 10, &format!("{lo:.4}"), black);
    let n = groups.len().max(1) as f64;
    let slot = (x1 - x0) as f64 / n;
    for (k, ((label, _), s)) in groups.iter().zip(&stats).enumerate() {
        let centre = x0 + ((k as f64 + 0.5) * slot).round() as i64;
        let half = ((slot * 0.3).round() as i64).max(2);
        let chars = label.chars().count() as i64;
        c.text(centre - 4 * chars, y1 + 12, label, black);
        let Some([min, q1, med, q3, max]) = *s else { continue };
        let blue = [70, 110, 220];
        c.vline(centre, y_of(min), y_of(q1), black);
        c.vline(centre, y_of(q3), y_of(max), black);
        c.hline(centre - half / 2, centre + half / 2, y_of(min), black);
        c.hline(centre - half / 2, centre + half / 2, y_of(max), black);
        c.hline(centre - half, centre + half, y_of(q1), blue);
        c.hline(centre - half, centre + half, y_of(q3), blue);
        c.vline(centre - half, y_of(q1), y_of(q3), blue);
        c.vline(centre + half, y_of(q1), y_of(q3), blue);
        for dy in 0..2 {
            c.hline(centre - half, centre + half, y_of(med) + dy, [220, 0, 0]);
        }
    }
    let labels: Vec<&str> = groups.iter().map(|(l, _)| l.as_str()).collect();
    write_png(
        path,
        WIDTH,
        HEIGHT,
        3,
        &c.pixels,
        &[
            ("Title", title.to_string()),
            ("groups", labels.join(", ")),
            ("y_range", format!("{lo} to {hi}")),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn five_numbers_of_known_samples() {
        assert_eq!(five_numbers(&[]), None);
        assert_eq!(five_numbers(&[3.0]), Some([3.0; 5]));
        assert_eq!(
            five_numbers(&[4.0, 1.0, 3.0, 2.0, 5.0]),
            Some([1.0, 2.0, 3.0, 4.0, 5.0])
        );
        // Quartiles between order statistics: 1..=4 → 1.75, 2.5, 3.25.
        assert_eq!(five_numbers(&[1.0, 2.0, 3.0, 4.0]), Some([1.0, 1.75, 2.5, 3.25, 4.0]));
        assert_eq!(five_numbers(&[f64::NAN, 1.0]), Some([1.0; 5]));
    }

    #[test]
    fn a_plot_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b.png");
        write_box_plot(&p, "t", &[("340".into(), vec![1.0, 2.0, 3.0]), ("380".into(), vec![])]).unwrap();
        assert!(std::fs::metadata(&p).unwrap().len() > 100);
    }
}
