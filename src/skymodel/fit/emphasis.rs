//! Pre-emphasis: the sharp horizon taken out of a rendered sky before it
//! is fitted, and the de-emphasis function E(θ′) that puts it back (the
//! supplement's section 1.5, eqs. 5–8). The runtime multiplies the fitted
//! radiance by E at the view's corrected zenith angle θ′ (section 1.7),
//! the angle whose 90° is the horizon at every altitude (section 1.3), so
//! the image here is cut, binned and divided by θ′ too.
//!
//! For an image I_orig with per-pixel θ′:
//!
//! 1. the pixels more than [`CUT_ZERO`] (89.5°, 30′ above the horizon)
//!    from the corrected zenith are deleted and filled harmonically from
//!    the rest (periodic in azimuth, [`laplace::fill`]): I_infill, a
//!    featureless continuation of the sky just above the horizon;
//! 2. κ is the mean of I_orig over the pixels below the horizon (θ′ > 90°)
//!    over the mean of I_infill there, both weighted by solid angle (1
//!    where the infill's mean is 0);
//! 3. I_guide = lerp(I_orig, I_infill, V_c) with V_c = sat(sat((θ′ −
//!    π/2)/(π/2)) + sat((κ − 0.5)/(−0.2))): the original where the ground
//!    is bright enough (κ ≥ 0.5) near the horizon, the infill toward the
//!    nadir and wherever the ground is dark (fully for κ ≤ 0.3);
//! 4. I_ratio = I_orig / I_guide;
//! 5. E(z) is the solid-angle weighted mean of I_ratio over the pixels
//!    with θ′ = z, tabulated at [`EMPHASIS_NODES`] nodes z_k = kπ/360: each
//!    row of pixels (θ′ is constant along a row, the correction being
//!    vertical) is split between its two nearest nodes in proportion to
//!    its nearness, and a node no row reaches is interpolated linearly
//!    from its neighbours. The horizon splits the bins: a row below it
//!    gives nothing to the node at 90°, so E(90°) is the sky's (≈ 1) and
//!    the step of E lies just below the horizon;
//! 6. I_preemph = I_orig / E(θ′) with E as the runtime will evaluate it:
//!    piecewise linear between the dataset's emphasis breaks, at which the
//!    table is resampled ([`pre_emphasis_at`]; [`pre_emphasis`] takes the
//!    361 nodes themselves as the breaks). So I_preemph·E(θ′) = I_orig for
//!    the runtime's E exactly, and the only trace of the horizon left in
//!    I_preemph is between the break at 90° and the next one below it
//!    (0.29° with 118 breaks): there the ground is divided by an E between
//!    the sky's and the ground's, a dip no deeper than the ground's own
//!    value and never an overshoot above the sky's.

use std::f64::consts::{FRAC_PI_2, PI};

use super::SphereImage;
use super::breaks::eval_piecewise;
use super::laplace;
use crate::skymodel::angles::corrected_view;

/// The number of nodes of the tabulated E, z_k = kπ/(n − 1): 0.5°.
pub const EMPHASIS_NODES: usize = 361;

/// θ′ beyond which the image is cut and filled: 30′ above the horizon.
pub const CUT_ZERO: f64 = FRAC_PI_2 - 0.5 * PI / 180.0;

/// A guide with a magnitude at or below this fraction of the image's
/// largest magnitude gives a ratio of 1 (0/0 = 1): where both the image
/// and its guide vanish there is nothing to emphasise.
pub const GUIDE_FLOOR: f64 = 1e-12;

/// Where E(θ′) is at or below this, I_preemph is the guide (the smooth
/// continuation) instead of I_orig/E: E is 0 there only because I_orig is,
/// so I_preemph·E still gives I_orig back (to E_FLOOR·guide), and the fit
/// sees no 0/0.
pub const E_FLOOR: f64 = 1e-12;

/// The result of [`pre_emphasis`].
#[derive(Debug, Clone, PartialEq)]
pub struct Emphasis {
    /// I_preemph, the image to re-project and fit.
    pub image: SphereImage,
    /// E at z_k = kπ/(n − 1), k = 0 … [`EMPHASIS_NODES`] − 1.
    pub table: Vec<f64>,
    /// The breaks (θ′, ascending over [0, π]) the image was divided at.
    pub breaks: Vec<f64>,
    /// E at the breaks: the table resampled, what the dataset stores.
    pub values: Vec<f64>,
    /// κ: how bright the ground was relative to its infill.
    pub kappa: f64,
}

impl Emphasis {
    /// E(θ′) as the runtime evaluates it: piecewise linear between the
    /// breaks.
    pub fn factor(&self, zero: f64) -> f64 {
        eval_piecewise(&self.breaks, &self.values, zero)
    }
}

/// E(θ′) from a table at uniform nodes over [0, π], linear between them
/// and clamped to the ends.
pub fn de_emphasis(table: &[f64], zero: f64) -> f64 {
    let m = table.len();
    if m < 2 {
        return table.first().copied().unwrap_or(1.0);
    }
    let s = (zero / PI * (m - 1) as f64).clamp(0.0, (m - 1) as f64);
    let k = (s.floor() as usize).min(m - 2);
    let f = s - k as f64;
    (1.0 - f) * table[k] + f * table[k + 1]
}

/// θ′ of row `j` of `image` for an observer at `altitude_m` (the same for
/// every pixel of the row).
pub fn zero_of_row(image: &SphereImage, j: usize, altitude_m: f64) -> f64 {
    corrected_view(image.direction(0, j), altitude_m)
        .z
        .clamp(-1.0, 1.0)
        .acos()
}

/// The pre-emphasis of `image` for an observer at `altitude_m` (the
/// runtime's altitude, as [`corrected_view`] takes it), E taken at its
/// 361 nodes.
pub fn pre_emphasis(image: &SphereImage, altitude_m: f64) -> Emphasis {
    let nodes: Vec<f64> = (0..EMPHASIS_NODES)
        .map(|k| PI * k as f64 / (EMPHASIS_NODES - 1) as f64)
        .collect();
    pre_emphasis_at(image, altitude_m, &nodes)
}

/// The pre-emphasis of `image` for an observer at `altitude_m`, the image
/// divided by E resampled at `breaks` (the dataset's emphasis breaks,
/// ascending over [0, π]) and evaluated as the runtime does.
pub fn pre_emphasis_at(image: &SphereImage, altitude_m: f64, breaks: &[f64]) -> Emphasis {
    let (w, h) = (image.width, image.height);
    let orig = &image.values;
    let zero: Vec<f64> = (0..h).map(|j| zero_of_row(image, j, altitude_m)).collect();
    let weight: Vec<f64> = (0..h).map(|j| image.solid_angle(j)).collect();

    // (a) The cut and the harmonic infill.
    let known: Vec<bool> = (0..w * h).map(|c| zero[c / w.max(1)] <= CUT_ZERO).collect();
    let mut infill = orig.clone();
    laplace::fill(&mut infill, &known, w, h, true);

    // (b) κ over the pixels below the horizon.
    let (mut sum_orig, mut sum_infill) = (0.0, 0.0);
    for j in (0..h).filter(|&j| zero[j] > FRAC_PI_2) {
        let row = j * w..(j + 1) * w;
        sum_orig += weight[j] * orig[row.clone()].iter().sum::<f64>();
        sum_infill += weight[j] * infill[row].iter().sum::<f64>();
    }
    let kappa = if sum_infill != 0.0 && (sum_orig / sum_infill).is_finite() {
        sum_orig / sum_infill
    } else {
        1.0
    };

    // (c, d) The guide and the ratio, summed per row.
    let sat = |x: f64| x.clamp(0.0, 1.0);
    let dark = sat((kappa - 0.5) / -0.2);
    let floor = GUIDE_FLOOR * orig.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut guide = vec![0.0; w * h];
    let mut rows = Vec::with_capacity(h);
    for j in 0..h {
        let control = sat(sat((zero[j] - FRAC_PI_2) / FRAC_PI_2) + dark);
        let mut ratio_sum = 0.0;
        for c in j * w..(j + 1) * w {
            let g = orig[c] + control * (infill[c] - orig[c]);
            guide[c] = g;
            ratio_sum += if g.abs() > floor { orig[c] / g } else { 1.0 };
        }
        rows.push(RowRatio {
            zero: zero[j],
            sum: weight[j] * ratio_sum,
            mass: weight[j] * w as f64,
        });
    }

    // (e) E at the 361 nodes and at the breaks, each binned from the rows.
    let nodes: Vec<f64> = (0..EMPHASIS_NODES)
        .map(|k| PI * k as f64 / (EMPHASIS_NODES - 1) as f64)
        .collect();
    let table = bin(&rows, &nodes);
    let values = bin(&rows, breaks);

    // (f) The pre-emphasised image.
    let mut out = SphereImage::zeros(w, h);
    for (j, &z) in zero.iter().enumerate() {
        let e = eval_piecewise(breaks, &values, z);
        for c in j * w..(j + 1) * w {
            out.values[c] = if e > E_FLOOR { orig[c] / e } else { guide[c] };
        }
    }
    Emphasis {
        image: out,
        table,
        breaks: breaks.to_vec(),
        values,
        kappa,
    }
}

/// One row of pixels: its θ′ and its solid-angle weighted sums of
/// I_ratio and of 1.
struct RowRatio {
    zero: f64,
    sum: f64,
    mass: f64,
}

/// E at the ascending `nodes`: the weighted mean of the rows' ratios, each
/// row split between the two nodes around its θ′ in proportion to its
/// nearness (hat functions), except that a row gives nothing to a node on
/// the other side of the horizon (a node at π/2 counts as the sky's). A
/// node no row reaches is interpolated linearly (in θ′) between the
/// nearest nodes that have rows, or takes the nearest one's value beyond
/// the last; with no rows at all E is 1.
fn bin(rows: &[RowRatio], nodes: &[f64]) -> Vec<f64> {
    let n = nodes.len();
    let mut sum = vec![0.0; n];
    let mut mass = vec![0.0; n];
    if n == 0 {
        return sum;
    }
    let sky = |z: f64| z <= FRAC_PI_2;
    for row in rows {
        let z = row.zero.clamp(nodes[0], nodes[n - 1]);
        let above = 1 + nodes[1..].partition_point(|&b| b <= z);
        if above >= n {
            sum[n - 1] += row.sum;
            mass[n - 1] += row.mass;
            continue;
        }
        let below = above - 1;
        let f = (z - nodes[below]) / (nodes[above] - nodes[below]);
        for (k, share) in [(below, 1.0 - f), (above, f)] {
            if sky(nodes[k]) == sky(row.zero) {
                sum[k] += share * row.sum;
                mass[k] += share * row.mass;
            }
        }
    }
    let filled: Vec<usize> = (0..n).filter(|&k| mass[k] > 0.0).collect();
    let mean = |k: usize| sum[k] / mass[k];
    (0..n)
        .map(|k| {
            let next = filled.partition_point(|&m| m < k);
            match (next.checked_sub(1).map(|p| filled[p]), filled.get(next).copied()) {
                (_, Some(hi)) if hi == k => mean(k),
                (Some(lo), Some(hi)) => {
                    let f = (nodes[k] - nodes[lo]) / (nodes[hi] - nodes[lo]);
                    (1.0 - f) * mean(lo) + f * mean(hi)
                }
                (Some(lo), None) => mean(lo),
                (None, Some(hi)) => mean(hi),
                (None, None) => 1.0,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::laplace::thread_cpu_seconds;
    use super::*;
    use std::time::Instant;

    /// A 1024 × 512 image with f(θ′, φ) in every pixel.
    fn image_of(altitude_m: f64, f: impl Fn(f64, f64) -> f64) -> SphereImage {
        let mut img = SphereImage::zeros(1024, 512);
        for j in 0..img.height {
            let zero = zero_of_row(&img, j, altitude_m);
            for i in 0..img.width {
                img.values[j * img.width + i] = f(zero, img.phi(i));
            }
        }
        img
    }

    /// The largest |I_preemph·E(θ′) − I_orig| relative to |I_orig|.
    fn round_trip_error(img: &SphereImage, em: &Emphasis, altitude_m: f64) -> f64 {
        let mut worst: f64 = 0.0;
        for j in 0..img.height {
            let e = em.factor(zero_of_row(img, j, altitude_m));
            for c in j * img.width..(j + 1) * img.width {
                let back = em.image.values[c] * e;
                worst = worst.max((back - img.values[c]).abs() / img.values[c].abs().max(1e-300));
            }
        }
        worst
    }

    #[test]
    fn a_sky_smooth_across_the_horizon_is_left_alone() {
        // Brighter toward the zenith, constant 1 below the horizon: the
        // infill is the constant of the last row above the cut (1.005), so
        // E stays within 1 % of 1.
        for altitude_m in [0.0, 15_000.0] {
            let img = image_of(altitude_m, |z, _| 1.0 + 0.5 * z.cos().max(0.0));
            let em = pre_emphasis(&img, altitude_m);
            assert!(em.kappa > 0.99 && em.kappa < 1.0, "κ {}", em.kappa);
            assert!(
                em.table.iter().all(|e| (e - 1.0).abs() < 0.01),
                "{:?}",
                &em.table[170..200]
            );
            // Exactly 1 where only uncut rows reach.
            assert!(em.table[..=178].iter().all(|&e| e == 1.0));
            assert!(round_trip_error(&img, &em, altitude_m) < 1e-14);
        }
    }

    /// The row index of the first row with θ′ above `zero`.
    fn first_row_past(img: &SphereImage, altitude_m: f64, zero: f64) -> usize {
        (0..img.height)
            .find(|&j| zero_of_row(img, j, altitude_m) > zero)
            .unwrap_or(img.height)
    }

    #[test]
    fn a_dark_ground_goes_into_e_and_out_of_the_image() {
        let altitude_m = 0.0;
        let sky = |z: f64| 1.0 + 0.5 * z.cos();
        let img = image_of(altitude_m, |z, _| if z > FRAC_PI_2 { 0.1 * sky(z) } else { sky(z) });
        let em = pre_emphasis(&img, altitude_m);
        // The infill is the constant c₀ of the last row above the cut
        // (reflecting at the nadir, periodic in azimuth), κ the ground's
        // mean over c₀, V_c = 1 below the horizon since κ < 0.3, so E is
        // 0.1·sky(z)/c₀ there (to the spread of θ′ over a node's rows).
        let last_known = first_row_past(&img, altitude_m, CUT_ZERO) - 1;
        let c0 = sky(zero_of_row(&img, last_known, altitude_m));
        let (mut num, mut den) = (0.0, 0.0);
        for j in 0..img.height {
            let z = zero_of_row(&img, j, altitude_m);
            if z > FRAC_PI_2 {
                num += img.solid_angle(j) * 0.1 * sky(z);
                den += img.solid_angle(j) * c0;
            }
        }
        assert!((em.kappa - num / den).abs() < 1e-9, "κ {} vs {}", em.kappa, num / den);
        for (k, &e) in em.table.iter().enumerate() {
            let z = PI * k as f64 / 360.0;
            if k >= 182 {
                assert!((e - 0.1 * sky(z) / c0).abs() < 2e-4, "z {}°: E {e}", k as f64 / 2.0);
            } else if k <= 178 {
                assert_eq!(e, 1.0);
            }
        }
        // The sky's side keeps E(90°) ≈ 1.
        assert!((em.table[180] - 1.0).abs() < 0.01, "E(90°) {}", em.table[180]);
        // The pre-emphasised image runs on across the horizon: past the
        // node above it the ground is c₀ (the sky's value at the cut), and
        // in between it dips toward the ground's value but never above
        // the sky's.
        let row = |j: usize| em.image.values[j * img.width];
        let horizon = first_row_past(&img, altitude_m, FRAC_PI_2);
        let past = first_row_past(&img, altitude_m, 90.5f64.to_radians());
        let jump = (row(horizon - 1) - row(past)).abs();
        assert!(jump < 5e-3, "jump {jump} (the original's: 0.9)");
        for j in horizon..past {
            assert!(
                row(j) <= row(horizon - 1) && row(j) >= img.values[j * img.width],
                "row {j}: {}",
                row(j)
            );
        }
        assert!(round_trip_error(&img, &em, altitude_m) < 1e-14);

        // At the dataset's emphasis breaks: the same, the dip narrower.
        let breaks = super::super::breaks::emph_breaks(118);
        let (start, cpu) = (Instant::now(), thread_cpu_seconds());
        let em = pre_emphasis_at(&img, altitude_m, &breaks);
        let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
        println!("emphasis::pre_emphasis_at 1024×512 (θ-only sky): {cpu:.3} s CPU ({wall:.3} s wall)");
        assert_eq!(em.values.len(), 118);
        let next = breaks[breaks.partition_point(|&b| b <= FRAC_PI_2)];
        let past = first_row_past(&img, altitude_m, next);
        let jump = (em.image.values[(horizon - 1) * img.width] - em.image.values[past * img.width]).abs();
        assert!(jump < 5e-3, "jump {jump}");
        assert!(round_trip_error(&img, &em, altitude_m) < 1e-14);
    }

    #[test]
    fn a_dark_ground_seen_from_15_km_with_azimuthal_structure() {
        // The horizon at θ′ = 90° lies 3.9° below the geometric one.
        let altitude_m = 15_000.0;
        let sky = |z: f64, phi: f64| 1.0 + 0.5 * z.cos() + 0.3 * z.sin() * phi.cos();
        let img = image_of(
            altitude_m,
            |z, phi| if z > FRAC_PI_2 { 0.05 * sky(z, phi) } else { sky(z, phi) },
        );
        let (start, cpu) = (Instant::now(), thread_cpu_seconds());
        let em = pre_emphasis(&img, altitude_m);
        let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
        println!("emphasis::pre_emphasis 1024×512 (azimuthal sky, 15 km): {cpu:.3} s CPU ({wall:.3} s wall)");
        assert!(em.kappa < 0.3, "κ {}", em.kappa);
        let e_at = |deg: f64| em.factor(deg.to_radians());
        assert_eq!(e_at(60.0), 1.0);
        assert!(e_at(95.0) > 0.02 && e_at(95.0) < 0.1, "E(95°) {}", e_at(95.0));
        // Continuity across the horizon, column by column: the last row
        // above θ′ = 90° and the first past the node at 90.5°.
        let horizon = first_row_past(&img, altitude_m, FRAC_PI_2);
        let past = first_row_past(&img, altitude_m, 90.5f64.to_radians());
        let mut worst: f64 = 0.0;
        for i in 0..img.width {
            let (a, b) = (
                em.image.values[(horizon - 1) * img.width + i],
                em.image.values[past * img.width + i],
            );
            worst = worst.max((a - b).abs());
        }
        // The original steps by up to 1.3·0.95 ≈ 1.2 here; E is a row
        // mean, so what remains is where the infill's azimuthal part
        // differs from the sky's a degree below the cut.
        assert!(worst < 0.05, "worst step {worst}");
        assert!(round_trip_error(&img, &em, altitude_m) < 1e-14);
    }

    #[test]
    fn a_black_ground_gives_e_zero_and_the_guide_below() {
        let img = image_of(0.0, |z, _| if z > FRAC_PI_2 { 0.0 } else { 2.0 - z });
        let em = pre_emphasis(&img, 0.0);
        assert_eq!(em.kappa, 0.0);
        assert!(em.table[181..].iter().all(|&e| e == 0.0));
        // Below the horizon the image is the infill, everywhere finite:
        // the constant of the last row above the cut.
        assert!(em.image.values.iter().all(|v| v.is_finite()));
        let last_known = first_row_past(&img, 0.0, CUT_ZERO) - 1;
        let c0 = em.image.values[511 * img.width];
        assert!((c0 - (2.0 - zero_of_row(&img, last_known, 0.0))).abs() < 1e-8);
        for j in 0..img.height {
            let e = em.factor(zero_of_row(&img, j, 0.0));
            for c in j * img.width..(j + 1) * img.width {
                assert!((em.image.values[c] * e - img.values[c]).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn gaps_are_interpolated_and_tables_read_linearly() {
        // Rows on nodes 1 and 4 only (of 0, 0.5, 1, 1.5, 2.5, 3): the gaps
        // between are linear in θ′, the ends take the nearest value.
        let nodes = [0.0, 0.5, 1.0, 1.5, 2.5, 3.0];
        let row = |zero: f64, e: f64| RowRatio {
            zero,
            sum: 2.0 * e,
            mass: 2.0,
        };
        let e = bin(&[row(0.5, 2.0), row(2.5, 4.0)], &nodes);
        let expected = [2.0, 2.0, 2.5, 3.0, 4.0, 4.0];
        assert!(e.iter().zip(&expected).all(|(a, b)| (a - b).abs() < 1e-15), "{e:?}");
        // A row between nodes splits by nearness; across the horizon not.
        let nodes = [0.0, 1.0, FRAC_PI_2, 2.0, PI];
        let e = bin(&[row(0.25, 1.0), row(0.75, 3.0), row(1.7, 0.5)], &nodes);
        assert!(
            (e[0] - (0.75 * 1.0 + 0.25 * 3.0)).abs() < 1e-15 && (e[1] - (0.25 + 2.25) / 1.0).abs() < 1e-15,
            "{e:?}"
        );
        // The horizon node has no sky row: it is interpolated.
        assert!((e[2] - (2.5 - 2.0 * (FRAC_PI_2 - 1.0))).abs() < 1e-15);
        assert_eq!((e[3], e[4]), (0.5, 0.5));
        assert_eq!(bin(&[], &nodes), vec![1.0; 5]);
        let table = [1.0, 3.0, 2.0];
        assert_eq!(de_emphasis(&table, PI / 4.0), 2.0);
        assert_eq!(de_emphasis(&table, 3.0 * PI / 4.0), 2.5);
        assert_eq!(de_emphasis(&table, -1.0), 1.0);
        assert_eq!(de_emphasis(&table, 4.0), 2.0);
    }
}
