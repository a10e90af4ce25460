//! Lorenz–Mie scattering by one homogeneous sphere.
//!
//! Conventions (Bohren & Huffman 1983, "Absorption and Scattering of Light by
//! Small Particles", ch. 4):
//! - time dependence e^(−iωt), so the relative refractive index is
//!   m = n + i·k with **k ≥ 0 for an absorbing sphere**. (Wiscombe's MIEV0 and
//!   the OPAC files write the same medium as n − i·k; the OPAC parser flips
//!   the sign, see `refractive.rs`.)
//! - size parameter x = 2πr/λ, with λ the wavelength in the surrounding
//!   medium (air: n = 1 here);
//! - the scattering angle Θ is measured from the forward direction and the
//!   amplitude functions S1 (E perpendicular to the scattering plane) and S2
//!   (E parallel to it) are BH Eq. 4.74:
//!   S1 = Σ (2n+1)/(n(n+1)) (aₙπₙ + bₙτₙ), S2 = Σ (2n+1)/(n(n+1)) (aₙτₙ + bₙπₙ).
//!
//! Numerics (Wiscombe 1980, "Improved Mie scattering algorithms", Appl. Opt.
//! 19, 1505–1509; BH appendix A):
//! - the series stops at N = x + 4.05·x^(1/3) + 2 (Wiscombe's criterion);
//! - the logarithmic derivative Dₙ(mx) = ψₙ′(mx)/ψₙ(mx) comes from the
//!   downward recurrence Dₙ₋₁ = n/(mx) − 1/(Dₙ + n/(mx)), started at zero
//!   16 + 8·|mx|^(1/3) orders above max(N, |mx|) (the start error decays
//!   only above |mx|, on the Airy scale |mx|^(1/3)); downward it is stable
//!   for any k;
//! - the Riccati–Bessel function ψₙ(x) = x·jₙ(x) goes upward while n ≤ x
//!   (where it oscillates and the recurrence is stable) and, above x, from
//!   the ratio ψₙ = ψₙ₋₁/(Dₙ(x) + n/x) with the real Dₙ(x) also from a
//!   downward recurrence, so that it stays accurate for small x;
//!   χₙ(x) = −x·yₙ(x) grows and goes upward; ξₙ = ψₙ − iχₙ;
//! - aₙ, bₙ from BH Eq. 4.88 with Dₙ(mx);
//! - πₙ, τₙ from the upward recurrences of BH Eq. 4.47.

use num_complex::Complex64;

use crate::error::{Error, Result};

/// Largest size parameter accepted (the tests go to 2·10⁴; the method is
/// stable further, but the arrays grow as |m|·x).
pub const MAX_SIZE_PARAMETER: f64 = 1.0e5;

/// Efficiencies and asymmetry parameter of one sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Efficiencies {
    /// Extinction efficiency Q_ext = C_ext/(πr²).
    pub q_ext: f64,
    /// Scattering efficiency Q_sca = C_sca/(πr²).
    pub q_sca: f64,
    /// Backscattering efficiency Q_back = 4|S1(180°)|²/x² (BH Eq. 4.82).
    pub q_back: f64,
    /// Asymmetry parameter g = ⟨cos Θ⟩ of the scattered light.
    pub g: f64,
}

/// The complex amplitude functions at one scattering angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Amplitudes {
    /// S1: incident E perpendicular to the scattering plane.
    pub s1: Complex64,
    /// S2: incident E parallel to the scattering plane.
    pub s2: Complex64,
}

impl Amplitudes {
    /// The four independent scattering-matrix elements of a sphere, not
    /// normalised, in atmosim's convention (CONVENTIONS.md §11):
    /// [S11, S12, S33, S34] with S11 = ½(|S2|² + |S1|²),
    /// S12 = ½(|S2|² − |S1|²), S33 = Re(S1·S2*) and S34 = Im(S1·S2*).
    /// S11, S12 and S33 are Bohren & Huffman's Eq. 4.77; S34 has the
    /// opposite sign of theirs, which is the sign libRadtran (MIEV0, time
    /// dependence e^(+iωt)) stores and MYSTIC uses. S12 < 0 means
    /// polarisation perpendicular to the scattering plane, as for Rayleigh
    /// scattering.
    pub fn matrix_elements(&self) -> [f64; 4] {
        let i1 = self.s1.norm_sqr();
        let i2 = self.s2.norm_sqr();
        let c = self.s1 * self.s2.conj();
        [0.5 * (i2 + i1), 0.5 * (i2 - i1), c.re, c.im]
    }
}

/// The Mie coefficients aₙ, bₙ (n = 1..=N) of one sphere.
#[derive(Debug, Clone)]
pub struct Sphere {
    x: f64,
    /// aₙ at index n − 1.
    a: Vec<Complex64>,
    /// bₙ at index n − 1.
    b: Vec<Complex64>,
}

/// Wiscombe's (1980) number of terms: N = x + 4.05·x^(1/3) + 2, at least 1.
pub fn n_stop(x: f64) -> usize {
    ((x + 4.05 * x.cbrt() + 2.0).floor() as usize).max(1)
}

impl Sphere {
    /// Solves the sphere of size parameter `x` (0 < x ≤ 10⁵) and relative
    /// refractive index `m` = n + i·k (n > 0, k ≥ 0: absorbing).
    pub fn new(x: f64, m: Complex64) -> Result<Sphere> {
        if !(x > 0.0 && x <= MAX_SIZE_PARAMETER) {
            return Err(Error::data(
                "Mie sphere",
                format!("size parameter {x} outside (0, {MAX_SIZE_PARAMETER}]"),
            ));
        }
        if !(m.re > 0.0 && m.im >= 0.0 && m.re.is_finite() && m.im.is_finite()) {
            return Err(Error::data(
                "Mie sphere",
                format!(
                    "refractive index {} + {}i: need a positive real part and an imaginary part ≥ 0 \
                     (k ≥ 0 means absorbing)",
                    m.re, m.im
                ),
            ));
        }
        let n = n_stop(x);
        let mx = m * x;

        // Dₙ(mx) downward from well above max(N, |mx|): the error of the
        // zero start decays only above |mx|, on the scale |mx|^(1/3) of the
        // turning point (about e^(−40) after 8·|mx|^(1/3) orders), and
        // passes undamped through the orders below |mx|.
        let n_start = n.max(mx.norm().ceil() as usize) + 16 + (8.0 * mx.norm().cbrt()).ceil() as usize;
        let mut d = vec![Complex64::new(0.0, 0.0); n_start + 1];
        for k in (1..=n_start).rev() {
            let k_mx = k as f64 / mx;
            d[k - 1] = k_mx - 1.0 / (d[k] + k_mx);
        }

        // Real Dₙ(x) downward, needed only above n = x for ψₙ.
        let n_start_real = n + 16 + (4.0 * x.cbrt()).ceil() as usize;
        let mut d_real = vec![0.0; n_start_real + 1];
        for k in (1..=n_start_real).rev() {
            let k_x = k as f64 / x;
            d_real[k - 1] = k_x - 1.0 / (d_real[k] + k_x);
        }

        let (sin_x, cos_x) = x.sin_cos();
        let (mut psi_prev, mut psi) = (cos_x, sin_x); // ψ₋₁, ψ₀
        let (mut chi_prev, mut chi) = (-sin_x, cos_x); // χ₋₁, χ₀
        let mut a = Vec::with_capacity(n);
        let mut b = Vec::with_capacity(n);
        for k in 1..=n {
            let kf = k as f64;
            let psi_next = if kf <= x {
                (2.0 * kf - 1.0) / x * psi - psi_prev
            } else {
                psi / (d_real[k] + kf / x)
            };
            let chi_next = (2.0 * kf - 1.0) / x * chi - chi_prev;
            let xi = Complex64::new(psi_next, -chi_next);
            let xi_prev = Complex64::new(psi, -chi);
            let da = d[k] / m + kf / x;
            let db = d[k] * m + kf / x;
            a.push((da * psi_next - psi) / (da * xi - xi_prev));
            b.push((db * psi_next - psi) / (db * xi - xi_prev));
            (psi_prev, psi) = (psi, psi_next);
            (chi_prev, chi) = (chi, chi_next);
        }
        if a.iter().chain(&b).any(|c| !(c.re.is_finite() && c.im.is_finite())) {
            return Err(Error::data(
                "Mie sphere",
                format!("non-finite Mie coefficient at x = {x}, m = {m}"),
            ));
        }
        Ok(Sphere { x, a, b })
    }

    /// The size parameter.
    pub fn x(&self) -> f64 {
        self.x
    }

    /// The number of terms N of the series.
    pub fn terms(&self) -> usize {
        self.a.len()
    }

    /// Q_ext, Q_sca, Q_back and g (BH Eqs. 4.61, 4.62, 4.82, 4.92 with the
    /// asymmetry sum of BH p. 120).
    pub fn efficiencies(&self) -> Efficiencies {
        let (mut ext, mut sca, mut gq) = (0.0, 0.0, 0.0);
        let mut back = Complex64::new(0.0, 0.0);
        let n = self.a.len();
        for i in 0..n {
            let k = (i + 1) as f64;
            let (an, bn) = (self.a[i], self.b[i]);
            let c = 2.0 * k + 1.0;
            ext += c * (an.re + bn.re);
            sca += c * (an.norm_sqr() + bn.norm_sqr());
            gq += c / (k * (k + 1.0)) * (an * bn.conj()).re;
            if i + 1 < n {
                let (an1, bn1) = (self.a[i + 1], self.b[i + 1]);
                gq += k * (k + 2.0) / (k + 1.0) * (an * an1.conj() + bn * bn1.conj()).re;
            }
            let sign = if (i + 1) % 2 == 0 { 1.0 } else { -1.0 };
            back += sign * c * (an - bn);
        }
        let x2 = self.x * self.x;
        let q_sca = 2.0 * sca / x2;
        Efficiencies {
            q_ext: 2.0 * ext / x2,
            q_sca,
            q_back: back.norm_sqr() / x2,
            g: if q_sca > 0.0 { 4.0 * gq / x2 / q_sca } else { 0.0 },
        }
    }

    /// S1 and S2 at cos Θ = `mu` (−1 ≤ μ ≤ 1).
    pub fn amplitudes(&self, mu: f64) -> Amplitudes {
        let mut s1 = Complex64::new(0.0, 0.0);
        let mut s2 = Complex64::new(0.0, 0.0);
        // πₙ₋₁ and πₙ, starting from π₀ = 0, π₁ = 1.
        let (mut pi_prev, mut pi) = (0.0, 1.0);
        for i in 0..self.a.len() {
            let k = (i + 1) as f64;
            let tau = k * mu * pi - (k + 1.0) * pi_prev;
            let c = (2.0 * k + 1.0) / (k * (k + 1.0));
            let (an, bn) = (self.a[i], self.b[i]);
            s1 += c * (an * pi + bn * tau);
            s2 += c * (an * tau + bn * pi);
            let pi_next = ((2.0 * k + 1.0) * mu * pi - (k + 1.0) * pi_prev) / k;
            (pi_prev, pi) = (pi, pi_next);
        }
        Amplitudes { s1, s2 }
    }

    /// The coefficients aₙ and bₙ, n = 1..=N at index n − 1.
    pub fn coefficients(&self) -> (&[Complex64], &[Complex64]) {
        (&self.a, &self.b)
    }

    /// The coefficient aₙ (n ≥ 1), for tests.
    pub fn a(&self, n: usize) -> Complex64 {
        self.a[n - 1]
    }

    /// The coefficient bₙ (n ≥ 1), for tests.
    pub fn b(&self, n: usize) -> Complex64 {
        self.b[n - 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(re: f64, im: f64) -> Complex64 {
        Complex64::new(re, im)
    }

    /// |got − printed| within half a unit of the printed number's last digit
    /// (`digits` significant digits).
    fn assert_printed(got: f64, printed: f64, digits: i32, what: &str) {
        let unit = 10f64.powi(printed.abs().log10().floor() as i32 - (digits - 1));
        assert!(
            (got - printed).abs() <= 0.5 * unit * (1.0 + 1e-9),
            "{what}: {got} vs printed {printed} ({digits} digits)"
        );
    }

    /// Bohren & Huffman (1983), Appendix A, p. 482: the sample output of
    /// their program for a sphere of radius 0.525 µm, m = 1.55, in light of
    /// 0.6328 µm (x = 5.213): Q_sca = 3.10543, Q_ext = 3.10543,
    /// Q_back = 2.92534, g = 0.63314 (all printed with 5 decimals).
    #[test]
    fn bohren_huffman_appendix_a() {
        let x = 2.0 * std::f64::consts::PI * 0.525 / 0.6328;
        let e = Sphere::new(x, c(1.55, 0.0)).unwrap().efficiencies();
        for (got, printed, what) in [
            (e.q_ext, 3.10543, "Q_ext"),
            (e.q_sca, 3.10543, "Q_sca"),
            (e.q_back, 2.92534, "Q_back"),
            (e.g, 0.63314, "g"),
        ] {
            assert!(
                (got - printed).abs() <= 0.5e-5 * (1.0 + 1e-9),
                "{what}: {got} vs {printed}"
            );
        }
    }

    /// Wiscombe (1979, rev. 1996), "Mie scattering calculations: advances
    /// in technique and fast, vector-speed computer codes", NCAR/TN-140+STR,
    /// test cases 5–19 as tabulated in the test driver MVTstNew.f that ships
    /// with MIEV0: Q_ext, Q_sca and g·Q_sca to 7 significant digits. MIEV0
    /// writes m = n − i·k; here k enters with a plus sign. (Cases 1–4 are
    /// perfectly conducting spheres, not a refractive index.)
    ///
    /// Three printed values are not the series to 7 digits, and those cases
    /// are checked to 6: for |m|x < 0.1 (case 5, x = 0.099, and case 12,
    /// x = 0.055) MIEV0 uses its small-particle expansion instead of the
    /// series, and case 6 (x = 0.101) sits just above that switch. A 40-digit
    /// evaluation of the series from mpmath's Bessel functions gives
    /// g·Q_sca = 1.0742773e-8 (case 5, printed 1.074279e-8), 5.5585369e-9
    /// (case 12, printed 5.558541e-9) and Q_ext = Q_sca = 8.0335381e-6
    /// (case 6, printed 8.033542e-6); this solver gives the 40-digit values.
    #[test]
    fn wiscombe_miev0_test_cases() {
        #[rustfmt::skip]
        let cases: [(f64, f64, f64, f64, f64, f64); 15] = [
            // n, k, x, Q_ext, Q_sca, g·Q_sca
            (0.75, 0.0, 0.099, 7.417859e-06, 7.417859e-06, 1.074279e-08),
            (0.75, 0.0, 0.101, 8.033542e-06, 8.033542e-06, 1.211000e-08),
            (0.75, 0.0, 10.0, 2.232265e+00, 2.232265e+00, 2.001164e+00),
            (0.75, 0.0, 1000.0, 1.997908e+00, 1.997908e+00, 1.688121e+00),
            (1.33, 1e-5, 1.0, 9.395198e-02, 9.392330e-02, 1.733048e-02),
            (1.33, 1e-5, 100.0, 2.101321e+00, 2.096594e+00, 1.821854e+00),
            (1.33, 1e-5, 10000.0, 2.004089e+00, 1.723857e+00, 1.564987e+00),
            (1.5, 1.0, 0.055, 1.014910e-01, 1.131687e-05, 5.558541e-09),
            (1.5, 1.0, 0.056, 1.033467e-01, 1.216311e-05, 6.193255e-09),
            (1.5, 1.0, 1.0, 2.336321e+00, 6.634538e-01, 1.274736e-01),
            (1.5, 1.0, 100.0, 2.097502e+00, 1.283697e+00, 1.091466e+00),
            (1.5, 1.0, 10000.0, 2.004368e+00, 1.236574e+00, 1.046525e+00),
            (10.0, 10.0, 1.0, 2.532993e+00, 2.049405e+00, -2.267961e-01),
            (10.0, 10.0, 100.0, 2.071124e+00, 1.836785e+00, 1.021648e+00),
            (10.0, 10.0, 10000.0, 2.005914e+00, 1.795393e+00, 9.842238e-01),
        ];
        for (n, k, x, q_ext, q_sca, gq) in cases {
            let e = Sphere::new(x, c(n, k)).unwrap().efficiencies();
            let what = format!("m = {n} + {k}i, x = {x}");
            let digits = if x == 0.099 || x == 0.101 || x == 0.055 { 6 } else { 7 };
            assert_printed(e.q_ext, q_ext, digits, &format!("{what}: Q_ext"));
            assert_printed(e.q_sca, q_sca, digits, &format!("{what}: Q_sca"));
            assert_printed(e.g * e.q_sca, gq, digits, &format!("{what}: g Q_sca"));
        }
    }

    /// The same report's cases 5 and 6 also print the backscatter amplitude
    /// S1(180°) = 1.81756e-8 − 1.64810e-4 i and 2.04875e-8 − 1.74965e-4 i in
    /// MIEV0's e^(+iωt) convention: the complex conjugate of ours.
    #[test]
    fn wiscombe_backscatter_amplitudes() {
        for (x, re, im) in [(0.099, 1.81756e-8, -1.64810e-4), (0.101, 2.04875e-8, -1.74965e-4)] {
            let s = Sphere::new(x, c(0.75, 0.0)).unwrap();
            let s1 = s.amplitudes(-1.0).s1;
            assert_printed(s1.re, re, 6, "Re S1(180)");
            assert_printed(s1.im, -im, 6, "Im S1(180)");
            let q_back = s.efficiencies().q_back;
            assert!((q_back - 4.0 * s1.norm_sqr() / (x * x)).abs() < 1e-12 * q_back);
        }
    }

    /// Small spheres (x = 0.01): Q_sca = (8/3)x⁴|K|², Q_abs = 4x·Im K with
    /// K = (m² − 1)/(m² + 2) (BH Eqs. 5.8, 5.9), g → 0, P12/P11 = −1 at 90°.
    /// The Mie series differs from these by O(x²) relative.
    #[test]
    fn rayleigh_limit() {
        let x = 0.01;
        let m = c(1.5, 0.1);
        let m2 = m * m;
        let kk = (m2 - 1.0) / (m2 + 2.0);
        let s = Sphere::new(x, m).unwrap();
        let e = s.efficiencies();
        let q_sca = 8.0 / 3.0 * x.powi(4) * kk.norm_sqr();
        let q_abs = 4.0 * x * kk.im;
        let tol = 4.0 * x * x;
        assert!((e.q_sca / q_sca - 1.0).abs() < tol, "{} vs {q_sca}", e.q_sca);
        assert!(
            ((e.q_ext - e.q_sca) / q_abs - 1.0).abs() < tol,
            "{} vs {q_abs}",
            e.q_ext - e.q_sca
        );
        assert!(e.g.abs() < tol, "g = {}", e.g);
        let p = s.amplitudes(0.0).matrix_elements();
        assert!((p[1] / p[0] + 1.0).abs() < tol, "{p:?}");
        assert!(p[2].abs() / p[0] < tol, "{p:?}");
        // Forward: S12 = 0, S33 = S11.
        let f = s.amplitudes(1.0).matrix_elements();
        assert!(f[1].abs() < 1e-12 * f[0] && (f[2] / f[0] - 1.0).abs() < 1e-12);
    }

    /// Optical theorem: Q_ext = (4/x²) Re S(0), with S1(0) = S2(0).
    #[test]
    fn optical_theorem() {
        for (x, m) in [(0.5, c(1.33, 0.0)), (50.0, c(1.53, 0.008)), (300.0, c(1.75, 0.44))] {
            let s = Sphere::new(x, m).unwrap();
            let a = s.amplitudes(1.0);
            let e = s.efficiencies();
            assert!((a.s1 - a.s2).norm() < 1e-12 * a.s1.norm());
            let q = 4.0 / (x * x) * a.s1.re;
            assert!((q / e.q_ext - 1.0).abs() < 1e-12, "x = {x}: {q} vs {}", e.q_ext);
        }
    }

    /// The amplitudes integrate to Q_sca and g: (2/x²)∫S11 dμ = Q_sca and
    /// (2/x²)∫S11 μ dμ = g·Q_sca (Gauss–Legendre in μ, exact for the
    /// polynomial of degree 2N).
    #[test]
    fn amplitudes_integrate_to_q_sca_and_g() {
        let x = 8.0;
        let s = Sphere::new(x, c(1.5, 0.02)).unwrap();
        let e = s.efficiencies();
        let (nodes, weights) = gauss_legendre(2 * s.terms() + 4);
        let (mut q, mut gq) = (0.0, 0.0);
        for (&mu, &w) in nodes.iter().zip(&weights) {
            let s11 = s.amplitudes(mu).matrix_elements()[0];
            q += w * s11;
            gq += w * s11 * mu;
        }
        let (q, gq) = (2.0 * q / (x * x), 2.0 * gq / (x * x));
        assert!((q / e.q_sca - 1.0).abs() < 1e-12, "{q} vs {}", e.q_sca);
        assert!((gq / (e.g * e.q_sca) - 1.0).abs() < 1e-12, "{gq} vs {}", e.g * e.q_sca);
    }

    /// Large and strongly absorbing spheres stay finite and approach the
    /// geometric-optics limit Q_ext → 2.
    #[test]
    fn large_spheres_stay_finite() {
        for m in [c(1.5, 0.0), c(1.33, 1e-8), c(1.75, 0.44), c(1.1, 1.0)] {
            let e = Sphere::new(2.0e4, m).unwrap().efficiencies();
            assert!((e.q_ext - 2.0).abs() < 0.01, "{m}: {e:?}");
            assert!(
                e.q_sca <= e.q_ext * (1.0 + 1e-12) && e.g > 0.5 && e.g < 1.0,
                "{m}: {e:?}"
            );
        }
        let e = Sphere::new(1.0e-3, c(1.5, 0.0)).unwrap().efficiencies();
        assert!(e.q_sca > 0.0 && e.q_sca < 1e-11, "{e:?}");
    }

    #[test]
    fn refuses_bad_input() {
        assert!(Sphere::new(0.0, c(1.5, 0.0)).is_err());
        assert!(Sphere::new(f64::NAN, c(1.5, 0.0)).is_err());
        let e = Sphere::new(1.0, c(1.5, -0.01)).unwrap_err().to_string();
        assert!(e.contains("absorbing"), "{e}");
    }

    /// Gauss–Legendre nodes and weights on [−1, 1] (Newton on Pₙ).
    fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut x = vec![0.0; n];
        let mut w = vec![0.0; n];
        for i in 0..n {
            let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            loop {
                let (mut p0, mut p1) = (1.0, z);
                for k in 2..=n {
                    let kf = k as f64;
                    (p0, p1) = (p1, ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf);
                }
                let dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
                let dz = p1 / dp;
                z -= dz;
                if dz.abs() < 1e-15 {
                    let (mut p0, mut p1) = (1.0, z);
                    for k in 2..=n {
                        let kf = k as f64;
                        (p0, p1) = (p1, ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf);
                    }
                    let dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
                    x[i] = z;
                    w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
                    break;
                }
            }
        }
        (x, w)
    }
}
