//! A ratio plot per validation case, drawn into an RGB raster and written as
//! PNG: atmosim/reference for each intensity (x: the values in case order,
//! grouped by output level), with ±2 combined standard errors as vertical
//! bars, the line ratio = 1, and the y-axis range printed at the top left
//! and bottom left in a 3×5 pixel digit font. Values outside the statistics
//! are grey.

use std::path::Path;

use super::case::CaseResult;
use crate::error::Result;
use crate::io::canvas::Canvas;
use crate::io::preview::write_png;

const WIDTH: usize = 900;
const HEIGHT: usize = 420;
const MARGIN_LEFT: usize = 70;
const MARGIN_RIGHT: usize = 20;
const MARGIN_Y: usize = 25;

/// The plot's points: ratio, half-width of the ±2σ bar (as a ratio) and
/// whether the value is in the statistics; intensities only.
fn points(r: &CaseResult) -> Vec<(f64, f64, bool)> {
    r.values
        .iter()
        .filter(|v| v.component == 0 && v.reference != 0.0)
        .map(|v| (v.ratio(), 2.0 * v.combined_se() / v.reference.abs(), v.in_stats))
        .collect()
}

/// The y range: the in-statistics points with their bars (all points when
/// none is in), padded, always including 1.
fn y_range(points: &[(f64, f64, bool)]) -> (f64, f64) {
    let any_in = points.iter().any(|p| p.2);
    let (mut lo, mut hi) = (1.0f64, 1.0f64);
    for &(ratio, bar, in_stats) in points {
        if (in_stats || !any_in) && ratio.is_finite() {
            lo = lo.min(ratio - bar);
            hi = hi.max(ratio + bar);
        }
    }
    let pad = 0.05 * (hi - lo).max(1e-6);
    (lo - pad, hi + pad)
}

/// Writes the ratio plot of a case result.
pub fn write_ratio_plot(path: &Path, r: &CaseResult) -> Result<()> {
    let pts = points(r);
    let (lo, hi) = y_range(&pts);
    let mut c = Canvas::new(WIDTH, HEIGHT);
    let (x0, x1) = (MARGIN_LEFT as i64, (WIDTH - MARGIN_RIGHT) as i64);
    let (y0, y1) = (MARGIN_Y as i64, (HEIGHT - MARGIN_Y) as i64);
    let y_of = |v: f64| y1 - ((v - lo) / (hi - lo) * (y1 - y0) as f64).round() as i64;
    // Frame and the line ratio = 1.
    let frame = [0, 0, 0];
    c.hline(x0, x1, y0, frame);
    c.hline(x0, x1, y1, frame);
    c.vline(x0, y0, y1, frame);
    c.vline(x1, y0, y1, frame);
    c.hline(x0, x1, y_of(1.0), [160, 160, 160]);
    c.text(4, y_of(1.0) - 5, "1", [0, 0, 0]);
    c.text(4, y0, &format!("{hi:.4}"), [0, 0, 0]);
    c.text(4, y1 - 10, &format!("{lo:.4}"), [0, 0, 0]);
    let n = pts.len().max(1);
    for (k, &(ratio, bar, in_stats)) in pts.iter().enumerate() {
        if !ratio.is_finite() {
            continue;
        }
        let x = x0 + ((k as f64 + 0.5) / n as f64 * (x1 - x0) as f64).round() as i64;
        let (bar_rgb, dot_rgb) = if in_stats {
            ([70, 110, 220], [0, 0, 0])
        } else {
            ([200, 200, 200], [150, 150, 150])
        };
        let clamp = |y: i64| y.clamp(y0, y1);
        c.vline(x, clamp(y_of(ratio - bar)), clamp(y_of(ratio + bar)), bar_rgb);
        let y = y_of(ratio);
        if (y0..=y1).contains(&y) {
            for dx in -1..=1 {
                for dy in -1..=1 {
                    c.set(x + dx, y + dy, dot_rgb);
                }
            }
        } else {
            // Off the scale: a mark on the frame.
            c.hline(x - 2, x + 2, clamp(y), [220, 0, 0]);
        }
    }
    write_png(
        path,
        WIDTH,
        HEIGHT,
        3,
        &c.pixels,
        &[
            (
                "Title",
                format!("{}: atmosim/reference per intensity, ±2 combined SE", r.case.name),
            ),
            ("y_range", format!("{lo} to {hi}")),
            (
                "statistics",
                format!(
                    "mean ratio {:.5}, correlation {:.6}, max |z| {:.2} (threshold {:.2})",
                    r.stats.mean_ratio, r.stats.correlation, r.stats.max_abs_z, r.stats.threshold
                ),
            ),
        ],
    )
}
