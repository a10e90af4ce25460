//! Single-scattering phase functions and phase matrices, and their sampling.
//!
//! - Rayleigh scattering with molecular depolarisation factor `ρ`
//!   (Hansen & Travis 1974, Space Sci. Rev. 16, 527): with `D = (1 − ρ)/(1 + ρ/2)`,
//!   `P11 = D·3/4·(1 + cos²Θ) + (1 − D)`, `P12 = P21 = −D·3/4·sin²Θ`,
//!   `P22 = D·3/4·(1 + cos²Θ)`, `P33 = D·3/2·cos Θ`,
//!   `P44 = D·(1 − 2ρ)/(1 − ρ)·3/2·cos Θ`, all other elements zero.
//! - Henyey–Greenstein (Henyey & Greenstein 1941, ApJ 93, 70):
//!   `P11 = (1 − g²)/(1 + g² − 2g cos Θ)^{3/2}`. The project's documented
//!   default for its polarisation is "intensity lobe only": the phase matrix
//!   is a pure depolariser (only `P11` non-zero), so scattered light is
//!   unpolarised.
//!
//! The matrices are given in the scattering-plane frame (`e1` in the plane of
//! the incoming and outgoing directions), with the Stokes conventions of
//! [`crate::polarization::stokes`]; `Θ` is the angle between the incoming and outgoing
//! propagation directions. All phase functions are normalised as
//! `(1/4π) ∫ P11 dΩ = 1`, so the sampling pdf per steradian is `P11/(4π)`.
//!
//! Sampling draws `cos Θ` from `P11` by exact inversion of its CDF (a
//! depressed cubic for Rayleigh, solved with a cancellation-free form of
//! Cardano's formula; the standard closed form for Henyey–Greenstein) and the
//! azimuth uniformly. Uniform variates are passed in explicitly so that the
//! transport code owns its random streams.

use crate::geometry::basis::orthonormal_basis;
use crate::polarization::stokes::{Mueller, PhaseMatrix};
use glam::DVec3;
use std::f64::consts::PI;

/// The closed set of phase functions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhaseFunction {
    /// Rayleigh scattering with depolarisation factor `ρ` (0 ≤ ρ < 1;
    /// ≈ 0.028 for air in the visible). Validating `ρ` is the job loader's task.
    Rayleigh { depolarization: f64 },
    /// Henyey–Greenstein with asymmetry parameter `g` (−1 < g < 1), acting
    /// as a pure depolariser (no polarising elements).
    HenyeyGreenstein { g: f64 },
}

/// A sampled scattering direction relative to the incoming direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSample {
    /// Cosine of the scattering angle Θ.
    pub cos_theta: f64,
    /// Azimuth of the scattering plane, in `[0, 2π)`, about the incoming
    /// direction (measured from the first basis vector of
    /// [`orthonormal_basis`] when used via [`PhaseFunction::sample_direction`]).
    pub phi: f64,
    /// Probability density per steradian, `P11(cos Θ)/(4π)`.
    pub pdf: f64,
}

/// Rayleigh's `D = (1 − ρ)/(1 + ρ/2)`, the weight of the anisotropic part.
fn rayleigh_anisotropic_weight(rho: f64) -> f64 {
    (1.0 - rho) / (1.0 + 0.5 * rho)
}

impl PhaseFunction {
    /// Phase function `P11(cos Θ)`, normalised so that `(1/4π) ∫ P11 dΩ = 1`.
    pub fn p11(&self, cos_theta: f64) -> f64 {
        match *self {
            PhaseFunction::Rayleigh { depolarization } => {
                let d = rayleigh_anisotropic_weight(depolarization);
                d * 0.75 * (1.0 + cos_theta * cos_theta) + (1.0 - d)
            }
            PhaseFunction::HenyeyGreenstein { g } => {
                let denom = 1.0 + g * g - 2.0 * g * cos_theta;
                (1.0 - g * g) / (denom * denom.sqrt())
            }
        }
    }

    /// The 4×4 phase matrix in the scattering-plane frame.
    pub fn mueller(&self, cos_theta: f64) -> Mueller {
        self.matrix(cos_theta).mueller()
    }

    /// The phase matrix in the scattering-plane frame, in its block form.
    pub fn matrix(&self, cos_theta: f64) -> PhaseMatrix {
        match *self {
            PhaseFunction::Rayleigh { depolarization: rho } => {
                let d = rayleigh_anisotropic_weight(rho);
                let mu2 = cos_theta * cos_theta;
                PhaseMatrix {
                    p11: self.p11(cos_theta),
                    p12: -d * 0.75 * (1.0 - mu2),
                    p22: d * 0.75 * (1.0 + mu2),
                    p33: d * 1.5 * cos_theta,
                    p34: 0.0,
                    p44: d * (1.0 - 2.0 * rho) / (1.0 - rho) * 1.5 * cos_theta,
                }
            }
            // Depolarising: only P11.
            PhaseFunction::HenyeyGreenstein { .. } => PhaseMatrix {
                p11: self.p11(cos_theta),
                ..PhaseMatrix::default()
            },
        }
    }

    /// Probability density per steradian of scattering by `Θ`: `P11/(4π)`.
    pub fn pdf(&self, cos_theta: f64) -> f64 {
        self.p11(cos_theta) / (4.0 * PI)
    }

    /// Mean cosine of the scattering angle, `⟨cos Θ⟩`.
    pub fn mean_cosine(&self) -> f64 {
        match *self {
            PhaseFunction::Rayleigh { .. } => 0.0,
            PhaseFunction::HenyeyGreenstein { g } => g,
        }
    }

    /// Samples `cos Θ ∝ P11` from `u[0]` and the azimuth `φ = 2π·u[1]`.
    pub fn sample(&self, u: [f64; 2]) -> PhaseSample {
        let cos_theta = match *self {
            PhaseFunction::Rayleigh { depolarization } => {
                sample_rayleigh_cos_theta(rayleigh_anisotropic_weight(depolarization), u[0])
            }
            PhaseFunction::HenyeyGreenstein { g } => sample_hg_cos_theta(g, u[0]),
        };
        PhaseSample {
            cos_theta,
            phi: 2.0 * PI * u[1],
            pdf: self.pdf(cos_theta),
        }
    }

    /// Samples the outgoing propagation direction for a photon travelling
    /// along the unit vector `k_in`. With `(b1, b2) =`
    /// [`orthonormal_basis`]`(k_in)`, the outgoing direction is
    /// `sin Θ (cos φ·b1 + sin φ·b2) + cos Θ·k_in`, so the scattering plane
    /// holds `k_in` and `cos φ·b1 + sin φ·b2` (the `e1` of the incoming
    /// scattering-plane frame that [`PhaseFunction::mueller`] refers to).
    pub fn sample_direction(&self, k_in: DVec3, u: [f64; 2]) -> (DVec3, PhaseSample) {
        let sample = self.sample(u);
        (sample.direction(k_in), sample)
    }
}

impl PhaseSample {
    /// The outgoing propagation direction of this sample for a photon
    /// travelling along the unit vector `k_in`: with `(b1, b2) =`
    /// [`orthonormal_basis`]`(k_in)`, `sin Θ (cos φ·b1 + sin φ·b2) + cos Θ·k_in`
    /// (see [`PhaseFunction::sample_direction`]). Shared by every phase
    /// function so that all of them use one azimuth reference.
    pub fn direction(&self, k_in: DVec3) -> DVec3 {
        let (b1, b2) = orthonormal_basis(k_in);
        let sin_theta = (1.0 - self.cos_theta * self.cos_theta).max(0.0).sqrt();
        let (sin_phi, cos_phi) = self.phi.sin_cos();
        let k_out = sin_theta * (cos_phi * b1 + sin_phi * b2) + self.cos_theta * k_in;
        k_out.normalize()
    }
}

/// Inverts the Rayleigh CDF in `μ = cos Θ`,
/// `F(μ) = D/8·(μ³ + 3μ + 4) + (1 − D)/2·(μ + 1)`.
///
/// `F(μ) = u` is the depressed cubic `μ³ + pμ + q = 0` with
/// `p = (4 − D)/D > 0` and `q = 4(1 − 2u)/D`, which has one real root.
/// Cardano gives `μ = −sgn(q)·(A − p/(3A))` with
/// `A = ∛(|q|/2 + √(q²/4 + p³/27))`; since `A⁶ − (p/3)³ = |q|·A³`, this is
/// `μ = −q·A²/(A⁴ + A²·p/3 + (p/3)²)`, free of cancellation.
fn sample_rayleigh_cos_theta(d: f64, u: f64) -> f64 {
    if d <= 0.0 {
        return 2.0 * u - 1.0;
    }
    let p3 = (4.0 - d) / (3.0 * d);
    let q = 4.0 * (1.0 - 2.0 * u) / d;
    let a = cube_root(0.5 * q.abs() + (0.25 * q * q + p3 * p3 * p3).sqrt());
    let a2 = a * a;
    (-q * a2 / (a2 * a2 + a2 * p3 + p3 * p3)).clamp(-1.0, 1.0)
}

/// ∛x to a relative 1e-14, faster than the correctly rounded `f64::cbrt`
/// (one per Rayleigh scattering): a first guess good to 3 % from the
/// exponent field (the bits divided by 3 plus the bias term), then two
/// steps of Halley's iteration y ← y·(y³ + 2x)/(2y³ + x), each of which
/// triples the correct digits (3 % → 2e-5 → 7e-15 at worst; a third step
/// would reach the last ulp, which sampling has no use for).
/// Zero, subnormals, infinities and NaN go to `f64::cbrt`.
fn cube_root(x: f64) -> f64 {
    if !x.is_normal() {
        return x.cbrt();
    }
    let sign = x.to_bits() & (1 << 63);
    let ax = x.abs();
    let mut y = f64::from_bits(ax.to_bits() / 3 + 0x2a9f_7893_0000_0000);
    for _ in 0..2 {
        let y3 = y * y * y;
        y *= (y3 + 2.0 * ax) / (2.0 * y3 + ax);
    }
    f64::from_bits(y.to_bits() | sign)
}

/// Inverts the Henyey–Greenstein CDF
/// `F(μ) = (1 − g²)/(2g)·[(1 + g² − 2gμ)^{-1/2} − (1 + g)^{-1}]`.
///
/// The closed form `μ = (1 + g² − w²)/(2g)`, `w = (1 − g²)/(1 + g·s)`,
/// `s = 2u − 1`, loses digits as `1/g` for small `|g|`; there the same root is
/// evaluated as the expanded polynomial
/// `μ = [s + g(s² + 3)/2 + g²s + g³(s² − 1)/2]/(1 + g·s)²`, which tends to the
/// isotropic `μ = s` and is exact at `g = 0`.
fn sample_hg_cos_theta(g: f64, u: f64) -> f64 {
    let s = 2.0 * u - 1.0;
    let denom = 1.0 + g * s;
    let mu = if g.abs() < 0.25 {
        let numer = s + 0.5 * g * (s * s + 3.0) + g * g * s + 0.5 * g * g * g * (s * s - 1.0);
        numer / (denom * denom)
    } else {
        let w = (1.0 - g * g) / denom;
        (1.0 + g * g - w * w) / (2.0 * g)
    };
    mu.clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    #[test]
    fn fast_cube_root_is_within_1e_14() {
        // Every binade from 1e-300 to 1e300, both signs, against std's
        // correctly rounded cube root.
        let mut s = crate::sampling::sampler::Sampler::new(&[41]);
        let mut worst = 0.0f64;
        for i in 0..200_000 {
            let e = -300.0 + 600.0 * s.next_f64();
            let x = 10f64.powf(e) * if i % 2 == 0 { 1.0 } else { -1.0 };
            let (fast, exact) = (super::cube_root(x), x.cbrt());
            worst = worst.max(((fast - exact) / exact).abs());
        }
        assert!(worst <= 1e-14, "{worst}");
        for x in [0.0, -0.0, f64::INFINITY, f64::MIN_POSITIVE / 4.0] {
            assert_eq!(super::cube_root(x), x.cbrt(), "{x}");
        }
        assert!(super::cube_root(f64::NAN).is_nan());
    }

    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// χ² critical value for 49 degrees of freedom at p = 0.001.
    const CHI2_CRIT_49_DOF_P001: f64 = 85.3506;

    const RHO_AIR: f64 = 0.02837;

    fn all_test_phase_functions() -> Vec<PhaseFunction> {
        let mut v: Vec<_> = [0.0, RHO_AIR, 0.1]
            .map(|depolarization| PhaseFunction::Rayleigh { depolarization })
            .to_vec();
        for g in [0.0, 0.7, -0.3, 0.9, 0.75, -0.5, 1e-7, -0.2, 0.99, -0.95] {
            v.push(PhaseFunction::HenyeyGreenstein { g });
        }
        v
    }

    /// Composite Simpson rule on [−1, 1] with `n` (even) intervals.
    fn simpson(f: impl Fn(f64) -> f64, n: usize) -> f64 {
        let h = 2.0 / n as f64;
        let inner: f64 = (1..n)
            .map(|i| {
                let w = if i % 2 == 1 { 4.0 } else { 2.0 };
                w * f(-1.0 + i as f64 * h)
            })
            .sum();
        (f(-1.0) + f(1.0) + inner) * h / 3.0
    }

    /// Exact CDF of `μ = cos Θ`, written independently of the sampler.
    fn exact_cdf(phase: &PhaseFunction, mu: f64) -> f64 {
        match *phase {
            PhaseFunction::Rayleigh { depolarization: rho } => {
                // ½∫_{−1}^{μ} [D·3/4(1 + x²) + 1 − D] dx.
                let d = (1.0 - rho) / (1.0 + rho / 2.0);
                0.5 * (d * 0.75 * (mu + mu.powi(3) / 3.0 + 4.0 / 3.0) + (1.0 - d) * (mu + 1.0))
            }
            PhaseFunction::HenyeyGreenstein { g } => {
                // (1 − g²)/(2g)·(1/a − 1/b) with a = √(1 + g² − 2gμ), b = 1 + g,
                // using b − a = 2g(1 + μ)/(a + b) so that g → 0 is exact.
                let a = (1.0 + g * g - 2.0 * g * mu).sqrt();
                let b = 1.0 + g;
                (1.0 - g * g) * (1.0 + mu) / (a * b * (a + b))
            }
        }
    }

    #[test]
    fn normalisation_by_quadrature() {
        for phase in [
            PhaseFunction::Rayleigh { depolarization: 0.0 },
            PhaseFunction::Rayleigh {
                depolarization: RHO_AIR,
            },
            PhaseFunction::HenyeyGreenstein { g: 0.7 },
            PhaseFunction::HenyeyGreenstein { g: -0.3 },
            PhaseFunction::HenyeyGreenstein { g: 0.9 },
        ] {
            // (1/4π)∫P11 dΩ = ½∫P11 dμ. Simpson's error at 2·10⁵ intervals is
            // below 1e-9 even for the g = 0.9 forward peak.
            let norm = 0.5 * simpson(|mu| phase.p11(mu), 200_000);
            assert!((norm - 1.0).abs() < 1e-9, "{phase:?}: {norm}");
            let solid_angle_norm = 2.0 * PI * simpson(|mu| phase.pdf(mu), 200_000);
            assert!((solid_angle_norm - 1.0).abs() < 1e-9, "{phase:?}: {solid_angle_norm}");
        }
    }

    #[test]
    fn rayleigh_elements_match_chandrasekhar_form() {
        // Independent evaluation via Chandrasekhar's γ = ρ/(2 − ρ):
        // P = 3/(4(1 + 2γ))·[(1 + 3γ) + (1 − γ)μ², −(1 − γ)(1 − μ²),
        //     (1 − γ)(1 + μ²), 2(1 − γ)μ, 2(1 − 3γ)μ].
        for rho in [0.0, 0.028, RHO_AIR, 0.1] {
            let phase = PhaseFunction::Rayleigh { depolarization: rho };
            let gamma = rho / (2.0 - rho);
            let c = 3.0 / (4.0 * (1.0 + 2.0 * gamma));
            for deg in [0.0, 10.0, 45.0, 90.0, 120.0, 170.0, 180.0] {
                let mu = f64::to_radians(deg).cos();
                let m = phase.mueller(mu);
                let expected = [
                    [
                        c * ((1.0 + 3.0 * gamma) + (1.0 - gamma) * mu * mu),
                        -c * (1.0 - gamma) * (1.0 - mu * mu),
                        0.0,
                        0.0,
                    ],
                    [
                        -c * (1.0 - gamma) * (1.0 - mu * mu),
                        c * (1.0 - gamma) * (1.0 + mu * mu),
                        0.0,
                        0.0,
                    ],
                    [0.0, 0.0, 2.0 * c * (1.0 - gamma) * mu, 0.0],
                    [0.0, 0.0, 0.0, 2.0 * c * (1.0 - 3.0 * gamma) * mu],
                ];
                for (r, (row, expected_row)) in m.0.iter().zip(&expected).enumerate() {
                    for (col, (x, e)) in row.iter().zip(expected_row).enumerate() {
                        let diff = (x - e).abs();
                        assert!(diff < 1e-14, "rho {rho} Θ {deg}° [{r}][{col}]: {diff}");
                    }
                }
                assert_eq!(phase.p11(mu), m.0[0][0]);
            }
            // Degree of polarisation at 90° for unpolarised incidence: (1 − ρ)/(1 + ρ).
            let m = phase.mueller(0.0);
            assert!((-m.0[0][1] / m.0[0][0] - (1.0 - rho) / (1.0 + rho)).abs() < 1e-14);
        }
        // Pure Rayleigh at 90°: P11 = 3/4 and P12 = −3/4 (E ⟂ scattering plane).
        let m = PhaseFunction::Rayleigh { depolarization: 0.0 }.mueller(0.0);
        assert!((m.0[0][0] - 0.75).abs() < 1e-15 && (m.0[1][0] + 0.75).abs() < 1e-15);
    }

    #[test]
    fn henyey_greenstein_is_a_pure_depolariser() {
        let phase = PhaseFunction::HenyeyGreenstein { g: 0.7 };
        for mu in [-1.0, -0.3, 0.0, 0.5, 1.0] {
            let m = phase.mueller(mu);
            let expected_p11 = (1.0 - 0.49) / (1.49 - 1.4 * mu).powf(1.5);
            assert!((m.0[0][0] - expected_p11).abs() < 1e-12 * expected_p11);
            assert_eq!(m, Mueller::depolarizer(m.0[0][0]));
        }
    }

    #[test]
    fn henyey_greenstein_mean_cosine_by_quadrature() {
        for g in [0.7, -0.3, 0.9] {
            let phase = PhaseFunction::HenyeyGreenstein { g };
            let mean = 0.5 * simpson(|mu| mu * phase.p11(mu), 200_000);
            assert!((mean - g).abs() < 1e-9, "g {g}: {mean}");
            assert_eq!(phase.mean_cosine(), g);
        }
    }

    /// Monte Carlo mean of `f(cos Θ)` and its standard error.
    fn mc_mean(phase: &PhaseFunction, f: impl Fn(f64) -> f64, n: usize, seed: u64) -> (f64, f64) {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let x = f(phase.sample([rng.random(), rng.random()]).cos_theta);
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        let var = (sum2 / n as f64 - mean * mean) * n as f64 / (n as f64 - 1.0);
        (mean, (var / n as f64).sqrt())
    }

    #[test]
    fn mean_cosines_by_monte_carlo() {
        for (n, phase) in all_test_phase_functions().iter().enumerate() {
            let (mean, sigma) = mc_mean(phase, |mu| mu, 200_000, 100 + n as u64);
            let exact = phase.mean_cosine();
            assert!((mean - exact).abs() < 4.0 * sigma, "{phase:?}: {mean} ± {sigma}");
        }
        // Rayleigh second moment: ⟨μ²⟩ = 2D/5 + (1 − D)/3.
        for rho in [0.0, RHO_AIR, 0.1] {
            let phase = PhaseFunction::Rayleigh { depolarization: rho };
            let d = (1.0 - rho) / (1.0 + rho / 2.0);
            let exact = 0.4 * d + (1.0 - d) / 3.0;
            let (mean, sigma) = mc_mean(&phase, |mu| mu * mu, 200_000, 7);
            assert!((mean - exact).abs() < 4.0 * sigma, "rho {rho}: {mean} ± {sigma}");
        }
    }

    #[test]
    fn chi_squared_of_sampled_cos_theta() {
        const BINS: usize = 50;
        const SAMPLES: usize = 200_000;
        for (n, phase) in [
            PhaseFunction::Rayleigh { depolarization: 0.0 },
            PhaseFunction::Rayleigh { depolarization: 0.1 },
            PhaseFunction::HenyeyGreenstein { g: 0.0 },
            PhaseFunction::HenyeyGreenstein { g: 0.75 },
            PhaseFunction::HenyeyGreenstein { g: -0.5 },
        ]
        .iter()
        .enumerate()
        {
            let mut rng = Pcg64Mcg::seed_from_u64(1000 + n as u64);
            let mut counts = [0usize; BINS];
            for _ in 0..SAMPLES {
                let mu = phase.sample([rng.random(), rng.random()]).cos_theta;
                let bin = (((mu + 1.0) * 0.5 * BINS as f64) as usize).min(BINS - 1);
                counts[bin] += 1;
            }
            let edge = |i: usize| -1.0 + 2.0 * i as f64 / BINS as f64;
            let chi2: f64 = (0..BINS)
                .map(|i| {
                    let expected = SAMPLES as f64 * (exact_cdf(phase, edge(i + 1)) - exact_cdf(phase, edge(i)));
                    assert!(expected >= 5.0, "{phase:?}: bin {i} expects {expected}");
                    (counts[i] as f64 - expected).powi(2) / expected
                })
                .sum();
            assert!(chi2 < CHI2_CRIT_49_DOF_P001, "{phase:?}: χ² = {chi2}");
        }
    }

    #[test]
    fn inverse_cdf_roundtrip() {
        // The samplers invert the independently written CDF.
        for phase in all_test_phase_functions() {
            for i in 0..=1000 {
                let u = i as f64 / 1000.0;
                let mu = phase.sample([u, 0.0]).cos_theta;
                assert!((-1.0..=1.0).contains(&mu));
                let err = (exact_cdf(&phase, mu) - u).abs();
                assert!(err < 1e-11, "{phase:?}: F(F⁻¹({u})) off by {err}");
            }
        }
    }

    #[test]
    fn sample_pdf_matches_pdf() {
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        for phase in all_test_phase_functions() {
            for _ in 0..10_000 {
                let s = phase.sample([rng.random(), rng.random()]);
                let pdf = phase.pdf(s.cos_theta);
                assert!((s.pdf - pdf).abs() <= 1e-12 * pdf);
                assert!((0.0..2.0 * PI).contains(&s.phi));
            }
        }
    }

    #[test]
    fn sampled_directions_are_unit_and_at_the_sampled_angle() {
        let mut rng = Pcg64Mcg::seed_from_u64(21);
        for phase in all_test_phase_functions() {
            for _ in 0..5_000 {
                let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
                let phi = 2.0 * PI * rng.random::<f64>();
                let s = (1.0 - z * z).sqrt();
                let k_in = DVec3::new(s * phi.cos(), s * phi.sin(), z);
                let (k_out, sample) = phase.sample_direction(k_in, [rng.random(), rng.random()]);
                assert!((k_out.length() - 1.0).abs() < 1e-12);
                assert!((k_out.dot(k_in) - sample.cos_theta).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn sampled_directions_have_mean_g_times_k_in() {
        // ⟨k_out⟩ = g·k_in: the transverse components average out only if φ
        // is uniform about k_in. Each component is checked at 4σ.
        let k_in = DVec3::new(0.3, -0.5, 0.8).normalize();
        for (n, phase) in all_test_phase_functions().iter().enumerate() {
            let mut rng = Pcg64Mcg::seed_from_u64(300 + n as u64);
            let count = 100_000;
            let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
            for _ in 0..count {
                let (k_out, _) = phase.sample_direction(k_in, [rng.random(), rng.random()]);
                sum += k_out;
                sum2 += k_out * k_out;
            }
            let mean = sum / count as f64;
            let var = (sum2 / count as f64 - mean * mean) * (count as f64 / (count as f64 - 1.0));
            let sigma = (var / count as f64).to_array().map(f64::sqrt);
            let exact = (phase.mean_cosine() * k_in).to_array();
            for c in 0..3 {
                let diff = (mean.to_array()[c] - exact[c]).abs();
                assert!(
                    diff < 4.0 * sigma[c],
                    "{phase:?} component {c}: {diff} vs σ {}",
                    sigma[c]
                );
            }
        }
    }
}
