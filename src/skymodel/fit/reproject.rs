//! The re-projection of a rendered sky into the (γ, α) plane (the
//! supplement's section 1.6, steps 3 and 4): a 2D table F(γ, α) whose
//! axes the sky's features are aligned with, read from the image with
//! bilinear filtering, and the infill of the combinations of angles that
//! no direction has.
//!
//! For a node (γ, α) the direction is found on the cone of directions
//! with that α: the corrected view v′ (from which α is measured, section
//! 1.3) makes the angle α with the axis a, a = ẑ when the sun is up (α =
//! θ′) and a = u, the shadow point, when it is down (α = σ). With e₁ the
//! direction toward the sun perpendicular to a (x̂ by day, the sun s itself
//! by night, since s ⊥ u) and e₂ = ŷ,
//!
//!   v′(ψ) = cos α·a + sin α·(cos ψ·e₁ + sin ψ·e₂),  ψ ∈ [0, π],
//!
//! and the view v(ψ) = [`uncorrected_view`]`(v′(ψ))`, from which γ is
//! measured. ψ = 0 is the cone's point nearest the sun; γ(v(ψ)) grows with
//! ψ (exactly by day, where the altitude correction keeps the azimuth and
//! changes the zenith angle by a function of α alone; by night the tests
//! check it on a fine grid of ψ), so a node is valid when γ lies between
//! the ends γ(0) and γ(π), and its ψ is the root of γ(v(ψ)) = γ, found by
//! regula falsi (Illinois). The sky is mirror-symmetric about the sun's
//! vertical plane (y = 0), so the direction at −ψ has the same angles: the
//! value is the mean of the image at both, which halves the variance of
//! the renders' noise.
//!
//! The polarisation tables take α = θ′ at every sun elevation
//! ([`AlphaAxis::Zenith`]): the same cones about ẑ, by night too.
//!
//! In the image frame the sun's azimuth is 0 (x toward the sun).

use std::f64::consts::PI;

use glam::DVec3;

use super::laplace::{self, FillStats};
use super::{AngleTable, SphereImage};
use crate::skymodel::angles::{SunPosition, ViewAngles, uncorrected_view};

/// A node is valid when its γ lies within this much (rad) of the range
/// of γ on its α-cone: nodes on the boundary of the parallelogram (a
/// single direction, as γ = |α − 90°| with the sun on the horizon) count
/// as valid despite rounding.
pub const VALID_TOLERANCE: f64 = 1e-9;

/// The sun of the image frame: azimuth 0.
fn sun_at(sun_elevation: f64) -> SunPosition {
    SunPosition {
        elevation: sun_elevation,
        azimuth: 0.0,
    }
}

/// The angles of a view in the (γ, α) plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GammaAlpha {
    pub gamma: f64,
    pub alpha: f64,
}

/// The forward map: (γ, α) of the unit view `v` in the image frame for a
/// sun at `sun_elevation` (rad) and an observer at `altitude_m`, exactly
/// as the runtime computes them ([`ViewAngles`]).
pub fn gamma_alpha(v: DVec3, sun_elevation: f64, altitude_m: f64) -> GammaAlpha {
    let angles = ViewAngles::of(v, sun_at(sun_elevation), altitude_m);
    GammaAlpha {
        gamma: angles.gamma,
        alpha: angles.alpha(sun_elevation),
    }
}

/// The cone of corrected views with one α, and the γ-range on it.
struct Cone {
    sun: DVec3,
    axis: DVec3,
    toward_sun: DVec3,
    cos_alpha: f64,
    sin_alpha: f64,
    altitude_m: f64,
    /// γ at ψ = 0 and ψ = π.
    gamma_near: f64,
    gamma_far: f64,
}

/// Which angle the table's α is (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlphaAxis {
    /// The runtime's radiance axis: the shadow angle σ for a sun below the
    /// horizon, θ′ otherwise.
    ZenithOrShadow,
    /// θ′ at every sun elevation: the runtime's polarisation axis.
    Zenith,
}

impl Cone {
    fn new(alpha: f64, sun_elevation: f64, altitude_m: f64, axis: AlphaAxis) -> Cone {
        let sun = sun_at(sun_elevation);
        let (axis, toward_sun) = if sun_elevation < 0.0 && axis == AlphaAxis::ZenithOrShadow {
            (sun.shadow_direction(), sun.direction())
        } else {
            (DVec3::Z, DVec3::X)
        };
        let (sin_alpha, cos_alpha) = alpha.sin_cos();
        let mut cone = Cone {
            sun: sun.direction(),
            axis,
            toward_sun,
            cos_alpha,
            sin_alpha,
            altitude_m,
            gamma_near: 0.0,
            gamma_far: 0.0,
        };
        cone.gamma_near = angle(cone.view(1.0, 0.0), cone.sun);
        cone.gamma_far = angle(cone.view(-1.0, 0.0), cone.sun);
        cone
    }

    /// The view v(ψ) from cos ψ and sin ψ.
    #[inline]
    fn view(&self, cos_psi: f64, sin_psi: f64) -> DVec3 {
        let corrected = self.axis * self.cos_alpha + (self.toward_sun * cos_psi + DVec3::Y * sin_psi) * self.sin_alpha;
        uncorrected_view(corrected, self.altitude_m)
    }

    /// The view on the y ≥ 0 side with angle `gamma` to the sun, if any.
    fn solve(&self, gamma: f64) -> Option<DVec3> {
        if gamma < self.gamma_near - VALID_TOLERANCE || gamma > self.gamma_far + VALID_TOLERANCE {
            return None;
        }
        if gamma <= self.gamma_near {
            return Some(self.view(1.0, 0.0));
        }
        if gamma >= self.gamma_far {
            return Some(self.view(-1.0, 0.0));
        }
        // Regula falsi on c(ψ) = v(ψ)·s − cos γ, which falls from ≥ 0 at
        // ψ = 0 to ≤ 0 at π; Illinois halving keeps it superlinear.
        let target = gamma.cos();
        let f = |psi: f64| {
            let (s, c) = psi.sin_cos();
            let v = self.view(c, s);
            (v.dot(self.sun) - target, v)
        };
        let (mut a, mut b) = (0.0, std::f64::consts::PI);
        let (mut fa, mut fb) = (self.gamma_near.cos() - target, self.gamma_far.cos() - target);
        let (mut best, mut best_f) = (self.view(1.0, 0.0), fa);
        let mut side = 0;
        for _ in 0..100 {
            let psi = if fa != fb {
                (a * fb - b * fa) / (fb - fa)
            } else {
                0.5 * (a + b)
            };
            let psi = if psi > a && psi < b { psi } else { 0.5 * (a + b) };
            let (fp, v) = f(psi);
            if fp.abs() < best_f.abs() {
                (best, best_f) = (v, fp);
            }
            if fp == 0.0 || b - a < 1e-14 {
                break;
            }
            if (fp > 0.0) == (fa > 0.0) {
                (a, fa) = (psi, fp);
                if side == -1 {
                    fb *= 0.5;
                }
                side = -1;
            } else {
                (b, fb) = (psi, fp);
                if side == 1 {
                    fa *= 0.5;
                }
                side = 1;
            }
            if best_f.abs() < 1e-15 {
                break;
            }
        }
        Some(best)
    }
}

/// The angle between unit vectors, accurate near 0 and π too.
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The view on the y ≥ 0 side of the sun's vertical plane with the given
/// γ and α (rad) for a sun at `sun_elevation` and an observer at
/// `altitude_m`, or None where no view has them. [`gamma_alpha`] of it
/// gives them back.
pub fn direction_at(gamma: f64, alpha: f64, sun_elevation: f64, altitude_m: f64) -> Option<DVec3> {
    Cone::new(alpha, sun_elevation, altitude_m, AlphaAxis::ZenithOrShadow).solve(gamma)
}

/// The table F(γ, α) of `image` on `n` × `n` nodes over [0, π]² (row α,
/// column γ): at each node the mean of the bilinear samples at the view
/// and its mirror image in the sun's vertical plane. Nodes no view has are
/// marked invalid and hold 0.
pub fn to_angle_table(image: &SphereImage, sun_elevation: f64, altitude_m: f64, n: usize) -> AngleTable {
    to_angle_table_on(image, sun_elevation, altitude_m, n, AlphaAxis::ZenithOrShadow)
}

/// [`to_angle_table`] with α the chosen angle (θ′ throughout for the
/// polarisation, which the runtime reads on θ′ at every sun elevation).
pub fn to_angle_table_on(
    image: &SphereImage,
    sun_elevation: f64,
    altitude_m: f64,
    n: usize,
    axis: AlphaAxis,
) -> AngleTable {
    let mut table = AngleTable {
        n,
        values: vec![0.0; n * n],
        valid: vec![false; n * n],
    };
    for row in 0..n {
        // A single node is the pole of both angles (AngleTable::angle would
        // divide by n − 1 = 0).
        let node = |k: usize| if n > 1 { PI * k as f64 / (n - 1) as f64 } else { 0.0 };
        let cone = Cone::new(node(row), sun_elevation, altitude_m, axis);
        for col in 0..n {
            if let Some(v) = cone.solve(node(col)) {
                let mirror = DVec3::new(v.x, -v.y, v.z);
                table.values[row * n + col] = 0.5 * (image.sample(v) + image.sample(mirror));
                table.valid[row * n + col] = true;
            }
        }
    }
    table
}

/// Fills the invalid nodes of `table` harmonically from the valid ones
/// (the supplement's dilation and `regionfill` in one: every invalid node
/// gets a smooth continuation, so that a fit read at another sun elevation,
/// whose parallelogram differs, never reads undefined values), and marks
/// every node valid. Reflecting at the table's edges.
pub fn fill_invalid(table: &mut AngleTable) -> FillStats {
    let n = table.n;
    let stats = laplace::fill(&mut table.values, &table.valid, n, n, false);
    table.valid.fill(true);
    stats
}

#[cfg(test)]
mod tests {
    use super::super::laplace::thread_cpu_seconds;
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};
    use std::time::Instant;

    /// The table's valid nodes are the parallelogram of a cone axis `zeta`
    /// half degrees from the sun: |j − ζ| ≤ i ≤ min(j + ζ, 720 − ζ − j)
    /// (γ = i/2°, α = j/2°).
    fn assert_parallelogram(t: &AngleTable, zeta: i64) {
        for j in 0..361i64 {
            for i in 0..361i64 {
                let expected = (j - zeta).abs() <= i && i <= (j + zeta).min(720 - zeta - j);
                assert_eq!(
                    t.valid[(j * 361 + i) as usize],
                    expected,
                    "ζ {zeta}: γ {}°, α {}°",
                    i as f64 / 2.0,
                    j as f64 / 2.0
                );
            }
        }
    }

    /// An image whose pixels hold f(γ, α) of their own directions.
    fn image_of(f: impl Fn(GammaAlpha) -> f64, sun_elevation: f64, altitude_m: f64) -> SphereImage {
        let mut img = SphereImage::zeros(1024, 512);
        for j in 0..img.height {
            for i in 0..img.width {
                let ga = gamma_alpha(img.direction(i, j), sun_elevation, altitude_m);
                img.values[j * img.width + i] = f(ga);
            }
        }
        img
    }

    #[test]
    fn the_parallelogram_of_a_sun_on_the_horizon_and_of_a_sun_below_it() {
        // At the ground the α-cone's axis is 90° from the sun in both
        // cases (ẑ for η = 0, the shadow point u for η < 0), so γ ranges
        // over |α − 90°| … min(α + 90°, 270° − α): in half degrees,
        // |j − 180| ≤ i ≤ min(j + 180, 540 − j).
        let img = SphereImage::zeros(8, 4);
        for eta in [0.0, -5f64.to_radians(), -0.3] {
            assert_parallelogram(&to_angle_table(&img, eta, 0.0, 361), 180);
        }
        // A day sun at η = 20°: the axis is ζ = 70° from the sun.
        let t = to_angle_table(&img, 20f64.to_radians(), 0.0, 361);
        assert_parallelogram(&t, 140);
    }

    #[test]
    fn found_views_have_their_nodes_angles() {
        for (eta_deg, altitude_m) in [
            (10.0, 0.0),
            (35.0, 15_000.0),
            (0.0, 15_000.0),
            (-4.0, 15_000.0),
            (-12.0, 2_000.0),
            (-4.0, 0.0),
        ] {
            let eta = f64::to_radians(eta_deg);
            let mut valid = 0;
            for j in 0..=90 {
                for i in 0..=90 {
                    let (gamma, alpha) = (PI * i as f64 / 90.0, PI * j as f64 / 90.0);
                    if let Some(v) = direction_at(gamma, alpha, eta, altitude_m) {
                        valid += 1;
                        assert!(v.y >= -1e-12 && (v.length() - 1.0).abs() < 1e-12);
                        let back = gamma_alpha(v, eta, altitude_m);
                        // acos of a dot product near ±1 (the runtime's way)
                        // resolves angles near 0 and π only to ~1.5e-8.
                        assert!(
                            (back.gamma - gamma).abs() < 1e-7 && (back.alpha - alpha).abs() < 1e-7,
                            "η {eta_deg}°, h {altitude_m}: ({gamma}, {alpha}) → {back:?}"
                        );
                    }
                }
            }
            assert!(valid > 91 * 91 / 3, "η {eta_deg}°: {valid} valid");
        }
    }

    #[test]
    fn validity_at_15_km_matches_the_cone_ranges() {
        // By day the view's zenith angle θ is a function of α alone (the
        // correction is vertical): γ spans |θ − ζ| … min(θ + ζ, 2π − θ − ζ)
        // with ζ = 90° − η. By night the range is found by sampling the
        // cone densely, which also checks that γ(ψ) is monotone.
        let h = 15_000.0;
        for eta in [12f64.to_radians(), -6f64.to_radians()] {
            let n = 121;
            let img = SphereImage::zeros(8, 4);
            let t = to_angle_table(&img, eta, h, n);
            for j in 0..n {
                let alpha = t.angle(j);
                let cone = Cone::new(alpha, eta, h, AlphaAxis::ZenithOrShadow);
                let (lo, hi) = if eta >= 0.0 {
                    let theta = cone.view(1.0, 0.0).z.clamp(-1.0, 1.0).acos();
                    let zeta = FRAC_PI_2 - eta;
                    ((theta - zeta).abs(), (theta + zeta).min(2.0 * PI - theta - zeta))
                } else {
                    let samples: Vec<f64> = (0..=4000)
                        .map(|k| PI * k as f64 / 4000.0)
                        .map(|psi| angle(cone.view(psi.cos(), psi.sin()), cone.sun))
                        .collect();
                    assert!(
                        samples.windows(2).all(|w| w[1] >= w[0] - 1e-12),
                        "γ(ψ) not monotone at α {alpha}"
                    );
                    (samples[0], samples[4000])
                };
                for i in 0..n {
                    let gamma = t.angle(i);
                    if (gamma - lo).abs() < 1e-7 || (gamma - hi).abs() < 1e-7 {
                        continue;
                    }
                    assert_eq!(
                        t.valid[j * n + i],
                        gamma > lo && gamma < hi,
                        "η {eta}: γ {gamma}, α {alpha}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_zenith_axis_keeps_theta_prime_below_the_horizon_too() {
        // α = θ′ for a sun at η = −10°: the parallelogram of the zenith
        // angle with ζ = 100°, |j − 200| ≤ i ≤ min(j + 200, 520 − j) in
        // half degrees, and the found views have θ′ = α.
        let eta = -10f64.to_radians();
        let img = SphereImage::zeros(8, 4);
        let t = to_angle_table_on(&img, eta, 0.0, 361, AlphaAxis::Zenith);
        assert_parallelogram(&t, 200);
        for h in [0.0, 15_000.0] {
            let cone = Cone::new(1.2, eta, h, AlphaAxis::Zenith);
            let v = cone
                .solve(0.5 * (cone.gamma_near + cone.gamma_far))
                .unwrap_or(DVec3::ZERO);
            let angles = ViewAngles::of(v, sun_at(eta), h);
            assert!(
                (angles.zero - 1.2).abs() < 1e-9
                    && (angles.gamma - 0.5 * (cone.gamma_near + cone.gamma_far)).abs() < 1e-9
            );
        }
    }

    #[test]
    fn gamma_grows_along_every_cone() {
        // The solver's premise, on a fine grid of ψ, for suns below and
        // above the horizon and observers up to 15 km.
        for eta_deg in [-15.0, -6.0, -0.5, 0.0, 3.0, 40.0] {
            for h in [0.0, 1_000.0, 15_000.0] {
                for alpha_deg in 0..=180 {
                    let cone = Cone::new(
                        f64::from(alpha_deg).to_radians(),
                        f64::to_radians(eta_deg),
                        h,
                        AlphaAxis::ZenithOrShadow,
                    );
                    let mut last = cone.gamma_near;
                    for k in 1..=2000 {
                        let psi = PI * k as f64 / 2000.0;
                        let gamma = angle(cone.view(psi.cos(), psi.sin()), cone.sun);
                        assert!(gamma >= last - 1e-12, "η {eta_deg}°, h {h}, α {alpha_deg}°, ψ {psi}");
                        last = gamma;
                    }
                }
            }
        }
    }

    #[test]
    fn a_function_of_the_angles_is_read_back_at_the_nodes() {
        // Smooth on the sphere: functions of cos γ and cos α only (γ and α
        // themselves have cone points at the sun, zenith or shadow point),
        // plus a part odd in y that the mirror average cancels.
        let f = |ga: GammaAlpha| {
            1.0 + 0.5 * ga.gamma.cos() + 0.3 * ga.alpha.cos() + 0.2 * (2.0 * ga.alpha).cos() * (2.0 * ga.gamma).cos()
        };
        for (eta, h) in [
            (25f64.to_radians(), 0.0),
            (-3f64.to_radians(), 0.0),
            (5f64.to_radians(), 15_000.0),
            (-8f64.to_radians(), 15_000.0),
        ] {
            let mut img = image_of(f, eta, h);
            for j in 0..img.height {
                for i in 0..img.width {
                    img.values[j * img.width + i] += 0.1 * img.direction(i, j).y;
                }
            }
            let (start, cpu) = (Instant::now(), thread_cpu_seconds());
            let t = to_angle_table(&img, eta, h, 361);
            let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
            println!(
                "reproject::to_angle_table 1024×512 → 361×361 (η {:.0}°, h {h} m): {cpu:.3} s CPU ({wall:.3} s wall)",
                eta.to_degrees()
            );
            // Bilinear error: pixel² · |f″| / 8 with pixels of 0.35°, f″ ≲ 2.
            // Within half a degree of the image's poles the sample is
            // clamped to the first or last row's centre, 0.18° away, an
            // error of |f′|·0.003: those nodes are left out.
            let mut worst: f64 = 0.0;
            let near_pole = |i: usize, j: usize| {
                let v = direction_at(t.angle(i), t.angle(j), eta, h);
                v.is_some_and(|v| v.z.abs() > 0.5f64.to_radians().cos())
            };
            for j in 0..361 {
                for i in 0..361 {
                    if t.valid[j * 361 + i] && !near_pole(i, j) {
                        let expected = f(GammaAlpha {
                            gamma: t.angle(i),
                            alpha: t.angle(j),
                        });
                        worst = worst.max((t.values[j * 361 + i] - expected).abs());
                    }
                }
            }
            assert!(worst < 2e-4, "η {eta}, h {h}: worst {worst}");
        }
    }

    #[test]
    fn degenerate_sizes() {
        let img = SphereImage::zeros(8, 4);
        let t = to_angle_table(&img, 0.2, 0.0, 0);
        assert!(t.values.is_empty());
        // γ = 0 at α = 0 only for a sun in the zenith.
        let t = to_angle_table(&img, 0.2, 0.0, 1);
        assert_eq!(t.valid, vec![false]);
        let t = to_angle_table(&img, FRAC_PI_2, 0.0, 1);
        assert_eq!(t.valid, vec![true]);
    }

    #[test]
    fn invalid_nodes_are_filled_smoothly() {
        let img = image_of(|ga| 2.0 + ga.gamma - 0.5 * ga.alpha, 0.0, 0.0);
        let mut t = to_angle_table(&img, 0.0, 0.0, 361);
        let invalid = t.valid.iter().filter(|&&v| !v).count();
        assert!(invalid > 361 * 361 / 4);
        let (start, cpu) = (Instant::now(), thread_cpu_seconds());
        let stats = fill_invalid(&mut t);
        let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
        println!("reproject::fill_invalid 361×361: {cpu:.3} s CPU ({wall:.3} s wall), {stats:?}");
        assert_eq!(stats.unknowns, invalid);
        assert!(t.valid.iter().all(|&v| v));
        // The fill of a linear function bounded by the parallelogram:
        // within the range of the known values, and without jumps.
        let (lo, hi) = (2.0 - 0.5 * PI, 2.0 + PI);
        assert!(t.values.iter().all(|&v| v > lo - 1e-3 && v < hi + 1e-3));
        for j in 0..361 {
            for i in 1..361 {
                assert!((t.values[j * 361 + i] - t.values[j * 361 + i - 1]).abs() < 0.05);
            }
        }
    }
}
