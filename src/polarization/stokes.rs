//! Stokes vectors, Mueller matrices and the meridian reference frame.
//!
//! This module is the one place in the code where the polarisation
//! conventions of `CONVENTIONS.md` are implemented (they follow the
//! IPRT / libRadtran-MYSTIC conventions):
//!
//! - A Stokes vector `(I, Q, U, V)` describes light propagating along `k`,
//!   expressed in a reference frame `(e1, e2)` with `e1 ⟂ k`, `e2 ⟂ k` and
//!   `e1 × e2 = k`.
//! - `I = I(e1) + I(e2)`, `Q = I(e1) − I(e2)` (Q > 0: E-vector along `e1`),
//!   `U = I((e1 + e2)/√2) − I((e1 − e2)/√2)`, where `I(a)` is the intensity
//!   transmitted by an ideal linear polariser with its axis along `a`.
//! - For the light arriving from viewing direction `v` (the direction the
//!   sensor looks; the photon travels along `k = −v`) the frame is the
//!   meridian frame `e1 = ∂v/∂θ = (cos θ cos φ, cos θ sin φ, −sin θ)`,
//!   `e2 = (sin φ, −cos φ, 0)`, see [`meridian_frame`].
//! - Changing the reference axis by the angle `ψ` uses the rotation matrix
//!   `Q' = cos 2ψ·Q + sin 2ψ·U`, `U' = −sin 2ψ·Q + cos 2ψ·U`
//!   ([`Mueller::rotation`]), where `ψ` is the angle from the old `e1` to the
//!   new `e1`, counted positive from `e1` towards `e2`, i.e. counter-clockwise
//!   about `k` ([`rotation_angle`]). This is the usual rotation matrix L(ψ)
//!   (e.g. Hovenier, van der Mee & Domke 2004, "Transfer of Polarized Light
//!   in Planetary Atmospheres"); since references differ in the sign of ψ,
//!   the sign used here is derived from the intensity definitions above and
//!   pinned by the tests below, which compute Stokes vectors of explicit
//!   E-fields in both frames.
//!
//! (Over 600 lines with its unit tests, about 440 without: each matrix and
//! rotation is tested beside it against a closed form.)

use glam::DVec3;
use std::ops::{Add, AddAssign, Mul, Sub};

/// Stokes vector `[I, Q, U, V]` in some reference frame (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stokes(pub [f64; 4]);

/// 4×4 Mueller matrix acting on [`Stokes`] vectors, row-major: `m.0[row][col]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mueller(pub [[f64; 4]; 4]);

impl Stokes {
    pub const fn new(i: f64, q: f64, u: f64, v: f64) -> Self {
        Stokes([i, q, u, v])
    }

    pub const fn zero() -> Self {
        Stokes([0.0; 4])
    }

    /// Unpolarised light of intensity `i`.
    pub const fn unpolarized(i: f64) -> Self {
        Stokes([i, 0.0, 0.0, 0.0])
    }

    pub fn i(&self) -> f64 {
        self.0[0]
    }

    pub fn q(&self) -> f64 {
        self.0[1]
    }

    pub fn u(&self) -> f64 {
        self.0[2]
    }

    pub fn v(&self) -> f64 {
        self.0[3]
    }

    /// Degree of polarisation `√(Q² + U² + V²)/I` (0 for `I = 0`).
    pub fn degree_of_polarization(&self) -> f64 {
        let [i, q, u, v] = self.0;
        if i == 0.0 {
            return 0.0;
        }
        (q * q + u * u + v * v).sqrt() / i
    }

    /// Degree of linear polarisation `√(Q² + U²)/I` (0 for `I = 0`).
    pub fn degree_of_linear_polarization(&self) -> f64 {
        let [i, q, u, _] = self.0;
        if i == 0.0 {
            return 0.0;
        }
        q.hypot(u) / i
    }

    /// The same light re-expressed with its reference axis rotated by `psi`;
    /// equal to `Mueller::rotation(psi) * self` without the 4×4 product.
    pub fn rotated(self, psi: f64) -> Self {
        let (s, c) = (2.0 * psi).sin_cos();
        let [i, q, u, v] = self.0;
        Stokes([i, c * q + s * u, -s * q + c * u, v])
    }
}

/// A phase matrix of the block form of scattering by a macroscopically
/// isotropic, mirror-symmetric medium (in the scattering-plane frame):
///
/// ```text
/// | p11 p12  0    0  |
/// | p12 p22  0    0  |
/// |  0   0  p33  p34 |
/// |  0   0 −p34  p44 |
/// ```
///
/// Rayleigh (with depolarisation) and the depolarising Henyey–Greenstein
/// matrix both have it; products with it take 6 of the 16 columns' work.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseMatrix {
    pub p11: f64,
    pub p12: f64,
    pub p22: f64,
    pub p33: f64,
    pub p34: f64,
    pub p44: f64,
}

impl PhaseMatrix {
    /// The full 4×4 matrix.
    pub fn mueller(&self) -> Mueller {
        let p = self;
        Mueller([
            [p.p11, p.p12, 0.0, 0.0],
            [p.p12, p.p22, 0.0, 0.0],
            [0.0, 0.0, p.p33, p.p34],
            [0.0, 0.0, -p.p34, p.p44],
        ])
    }

    /// `a·self + b·other`, element by element.
    pub fn mix(&self, a: f64, other: &PhaseMatrix, b: f64) -> PhaseMatrix {
        PhaseMatrix {
            p11: a * self.p11 + b * other.p11,
            p12: a * self.p12 + b * other.p12,
            p22: a * self.p22 + b * other.p22,
            p33: a * self.p33 + b * other.p33,
            p34: a * self.p34 + b * other.p34,
            p44: a * self.p44 + b * other.p44,
        }
    }

    /// Every element times `k`.
    pub fn scaled(&self, k: f64) -> PhaseMatrix {
        self.mix(k, &PhaseMatrix::default(), 0.0)
    }
}

impl Mueller {
    pub const fn identity() -> Self {
        Mueller([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ])
    }

    pub const fn zero() -> Self {
        Mueller([[0.0; 4]; 4])
    }

    /// Stokes rotation matrix for a change of reference axis by `psi`
    /// (radians, from the old `e1` towards the old `e2`):
    /// `Q' = cos 2ψ·Q + sin 2ψ·U`, `U' = −sin 2ψ·Q + cos 2ψ·U`.
    pub fn rotation(psi: f64) -> Self {
        StokesRotation::from_angle(psi).mueller()
    }

    /// Ideal depolariser: only the element `[0][0] = a` is non-zero.
    pub const fn depolarizer(a: f64) -> Self {
        let mut m = [[0.0; 4]; 4];
        m[0][0] = a;
        Mueller(m)
    }

    /// Ideal linear polariser with its transmission axis at angle `theta`
    /// from `e1` (towards `e2`): the axis is `cos θ·e1 + sin θ·e2`.
    pub fn linear_polarizer(theta: f64) -> Self {
        let (s, c) = (2.0 * theta).sin_cos();
        Mueller([
            [0.5, 0.5 * c, 0.5 * s, 0.0],
            [0.5 * c, 0.5 * c * c, 0.5 * c * s, 0.0],
            [0.5 * s, 0.5 * c * s, 0.5 * s * s, 0.0],
            [0.0, 0.0, 0.0, 0.0],
        ])
    }

    pub fn transpose(&self) -> Self {
        let mut t = [[0.0; 4]; 4];
        for (r, row) in self.0.iter().enumerate() {
            for (c, &x) in row.iter().enumerate() {
                t[c][r] = x;
            }
        }
        Mueller(t)
    }
}

impl Mul for Mueller {
    type Output = Mueller;

    fn mul(self, rhs: Mueller) -> Mueller {
        let mut out = [[0.0; 4]; 4];
        for (r, row) in out.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = (0..4).map(|k| self.0[r][k] * rhs.0[k][c]).sum();
            }
        }
        Mueller(out)
    }
}

impl Mul<Stokes> for Mueller {
    type Output = Stokes;

    fn mul(self, s: Stokes) -> Stokes {
        let mut out = [0.0; 4];
        for (x, row) in out.iter_mut().zip(&self.0) {
            *x = row.iter().zip(&s.0).map(|(m, v)| m * v).sum();
        }
        Stokes(out)
    }
}

impl Mul<f64> for Mueller {
    type Output = Mueller;

    fn mul(mut self, a: f64) -> Mueller {
        // A plain loop: `array::map` here was left uninlined (4 % of a
        // shared spectral path's time).
        for row in self.0.iter_mut() {
            for x in row.iter_mut() {
                *x *= a;
            }
        }
        self
    }
}

impl Mul<Mueller> for f64 {
    type Output = Mueller;

    fn mul(self, m: Mueller) -> Mueller {
        m * self
    }
}

impl Add for Mueller {
    type Output = Mueller;

    fn add(mut self, rhs: Mueller) -> Mueller {
        self += rhs;
        self
    }
}

impl AddAssign for Mueller {
    fn add_assign(&mut self, rhs: Mueller) {
        for (row, rrow) in self.0.iter_mut().zip(&rhs.0) {
            for (x, y) in row.iter_mut().zip(rrow) {
                *x += y;
            }
        }
    }
}

impl Mul<f64> for Stokes {
    type Output = Stokes;

    fn mul(mut self, a: f64) -> Stokes {
        for x in self.0.iter_mut() {
            *x *= a;
        }
        self
    }
}

impl Mul<Stokes> for f64 {
    type Output = Stokes;

    fn mul(self, s: Stokes) -> Stokes {
        s * self
    }
}

impl Add for Stokes {
    type Output = Stokes;

    fn add(mut self, rhs: Stokes) -> Stokes {
        self += rhs;
        self
    }
}

impl AddAssign for Stokes {
    fn add_assign(&mut self, rhs: Stokes) {
        for (x, y) in self.0.iter_mut().zip(&rhs.0) {
            *x += y;
        }
    }
}

impl Sub for Stokes {
    type Output = Stokes;

    fn sub(self, rhs: Stokes) -> Stokes {
        Stokes(std::array::from_fn(|n| self.0[n] - rhs.0[n]))
    }
}

/// Meridian frame `(e1, e2)` of the viewing direction `v` (the direction the
/// sensor looks; the light propagates along `k = −v`), in the local frame
/// with `+z` up:
/// `e1 = ∂v/∂θ = (cos θ cos φ, cos θ sin φ, −sin θ)`, `e2 = (sin φ, −cos φ, 0)`,
/// so that `e1 × e2 = k`.
///
/// At exactly the zenith or the nadir (`v.x = v.y = 0`) the azimuth is
/// undefined and `phi_fallback` (radians) is used as `φ`. `v` need not be
/// normalised but must be non-zero.
pub fn meridian_frame(v: DVec3, phi_fallback: f64) -> (DVec3, DVec3) {
    let v = v.normalize();
    let sin_theta = v.x.hypot(v.y);
    let cos_theta = v.z;
    let (sin_phi, cos_phi) = if sin_theta > 0.0 {
        (v.y / sin_theta, v.x / sin_theta)
    } else {
        phi_fallback.sin_cos()
    };
    let e1 = DVec3::new(cos_theta * cos_phi, cos_theta * sin_phi, -sin_theta);
    let e2 = DVec3::new(sin_phi, -cos_phi, 0.0);
    (e1, e2)
}

/// Angle `ψ` (radians, in `(−π, π]`) such that `Mueller::rotation(ψ)` turns a
/// Stokes vector referred to the axis `e1_from` into the same light referred
/// to the axis `e1_to`. Both axes are unit vectors perpendicular to the
/// propagation direction `k`; the second axes are `e2 = k × e1` in both frames.
///
/// `ψ` is the angle from `e1_from` to `e1_to`, positive when turning from
/// `e1_from` towards `e2_from` (counter-clockwise about `k`). Linearly
/// polarised light along `e1_from` (`Q = 1, U = 0`) becomes
/// `Q' = cos 2ψ, U' = −sin 2ψ`.
pub fn rotation_angle(e1_from: DVec3, e1_to: DVec3, k: DVec3) -> f64 {
    let sin_psi = k.dot(e1_from.cross(e1_to));
    let cos_psi = e1_from.dot(e1_to);
    sin_psi.atan2(cos_psi)
}

/// A Stokes rotation by ψ held as (cos 2ψ, sin 2ψ), the only two numbers
/// the rotation matrix needs: built from two frames without trigonometric
/// functions (the hot path of the tracer does one per scattering).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StokesRotation {
    pub cos_2psi: f64,
    pub sin_2psi: f64,
}

impl StokesRotation {
    /// The rotation by angle ψ.
    pub fn from_angle(psi: f64) -> Self {
        let (sin_2psi, cos_2psi) = (2.0 * psi).sin_cos();
        StokesRotation { cos_2psi, sin_2psi }
    }

    /// The rotation of [`rotation_angle`]`(e1_from, e1_to, k)`: with
    /// c = cos ψ and s = sin ψ from the frames, cos 2ψ = (c² − s²)/(c² + s²)
    /// and sin 2ψ = 2cs/(c² + s²).
    pub fn between(e1_from: DVec3, e1_to: DVec3, k: DVec3) -> Self {
        let s = k.dot(e1_from.cross(e1_to));
        let c = e1_from.dot(e1_to);
        let r2 = c * c + s * s;
        if r2 == 0.0 {
            return StokesRotation {
                cos_2psi: 1.0,
                sin_2psi: 0.0,
            };
        }
        let inv = 1.0 / r2;
        StokesRotation {
            cos_2psi: (c * c - s * s) * inv,
            sin_2psi: 2.0 * c * s * inv,
        }
    }

    /// The rotation matrix (the same as [`Mueller::rotation`]).
    pub fn mueller(&self) -> Mueller {
        let (c, s) = (self.cos_2psi, self.sin_2psi);
        Mueller([
            [1.0, 0.0, 0.0, 0.0],
            [0.0, c, s, 0.0],
            [0.0, -s, c, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ])
    }

    /// `R · s` for a Stokes vector.
    pub fn apply(&self, s: Stokes) -> Stokes {
        let (c, n) = (self.cos_2psi, self.sin_2psi);
        Stokes([s.0[0], c * s.0[1] + n * s.0[2], -n * s.0[1] + c * s.0[2], s.0[3]])
    }

    /// `m · R · p` for a block phase matrix `p`, element by element.
    pub fn right_of_then(&self, m: &Mueller, p: &PhaseMatrix) -> Mueller {
        let (c, n) = (self.cos_2psi, self.sin_2psi);
        let mut out = Mueller::zero();
        for (o, row) in out.0.iter_mut().zip(&m.0) {
            let (u0, u1, u2, u3) = (row[0], c * row[1] - n * row[2], n * row[1] + c * row[2], row[3]);
            *o = [
                u0 * p.p11 + u1 * p.p12,
                u0 * p.p12 + u1 * p.p22,
                u2 * p.p33 - u3 * p.p34,
                u2 * p.p34 + u3 * p.p44,
            ];
        }
        out
    }

    /// `m · R · p · (1, 0, 0, 0)`: unpolarised light scattered by `p`, rotated
    /// and seen through `m`.
    pub fn column_of(&self, m: &Mueller, p: &PhaseMatrix) -> Stokes {
        let (c, n) = (self.cos_2psi * p.p12, self.sin_2psi * p.p12);
        let mut out = [0.0; 4];
        for (o, row) in out.iter_mut().zip(&m.0) {
            *o = p.p11 * row[0] + c * row[1] - n * row[2];
        }
        Stokes(out)
    }

    /// `m · R` without the full product (R mixes columns 1 and 2 only).
    pub fn right_of(&self, m: &Mueller) -> Mueller {
        let (c, n) = (self.cos_2psi, self.sin_2psi);
        let mut out = *m;
        for row in out.0.iter_mut() {
            let (a, b) = (row[1], row[2]);
            row[1] = c * a - n * b;
            row[2] = n * a + c * b;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;
    use std::f64::consts::{FRAC_PI_2, PI};

    const TOL: f64 = 1e-12;

    #[test]
    fn block_phase_products_equal_the_full_products() {
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        for _ in 0..100 {
            let mut m = Mueller::zero();
            for x in m.0.iter_mut().flatten() {
                *x = rng.random_range(-1.0..1.0);
            }
            let p = PhaseMatrix {
                p11: rng.random_range(0.0..2.0),
                p12: rng.random_range(-1.0..1.0),
                p22: rng.random_range(-1.0..1.0),
                p33: rng.random_range(-1.0..1.0),
                p34: rng.random_range(-1.0..1.0),
                p44: rng.random_range(-1.0..1.0),
            };
            let r = StokesRotation::from_angle(rng.random_range(-PI..PI));
            let full = m * r.mueller() * p.mueller();
            let fast = r.right_of_then(&m, &p);
            let column = full * Stokes::unpolarized(1.0);
            let fast_column = r.column_of(&m, &p);
            for i in 0..4 {
                assert!((fast_column.0[i] - column.0[i]).abs() < TOL);
                for j in 0..4 {
                    assert!((fast.0[i][j] - full.0[i][j]).abs() < TOL);
                }
            }
        }
    }

    #[test]
    fn trig_free_rotation_equals_the_angle_form() {
        let mut rng = Pcg64Mcg::seed_from_u64(77);
        for _ in 0..500 {
            let k = DVec3::new(
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
            )
            .normalize();
            let (a, _) = crate::geometry::basis::orthonormal_basis(k);
            let b = (a * (rng.random::<f64>() - 0.5) + k.cross(a) * (rng.random::<f64>() - 0.5)).normalize();
            let fast = StokesRotation::between(a, b, k);
            let slow = Mueller::rotation(rotation_angle(a, b, k));
            let m = fast.mueller();
            for r in 0..4 {
                for c in 0..4 {
                    assert!((m.0[r][c] - slow.0[r][c]).abs() < 1e-12);
                }
            }
            let t = Mueller([
                [1.0, 2.0, 3.0, 4.0],
                [5.0, 6.0, 7.0, 8.0],
                [9.0, 1.0, 2.0, 3.0],
                [4.0, 5.0, 6.0, 7.0],
            ]);
            let (x, y) = (fast.right_of(&t), t * m);
            let sv = Stokes([1.0, 0.3, -0.2, 0.1]);
            assert!((fast.apply(sv).0[2] - (m * sv).0[2]).abs() < 1e-12);
            for r in 0..4 {
                for c in 0..4 {
                    assert!((x.0[r][c] - y.0[r][c]).abs() < 1e-12);
                }
            }
        }
    }

    fn assert_stokes_close(a: Stokes, b: Stokes, tol: f64) {
        for n in 0..4 {
            assert!((a.0[n] - b.0[n]).abs() < tol, "{a:?} != {b:?} (element {n})");
        }
    }

    fn assert_mueller_close(a: Mueller, b: Mueller, tol: f64) {
        for r in 0..4 {
            for c in 0..4 {
                assert!((a.0[r][c] - b.0[r][c]).abs() < tol, "{a:?} != {b:?} at [{r}][{c}]");
            }
        }
    }

    fn random_unit(rng: &mut Pcg64Mcg) -> DVec3 {
        let z = 2.0 * rng.random::<f64>() - 1.0;
        let phi = 2.0 * PI * rng.random::<f64>();
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// A random unit vector perpendicular to `k`.
    fn random_perpendicular(rng: &mut Pcg64Mcg, k: DVec3) -> DVec3 {
        loop {
            let a = random_unit(rng);
            let p = a - a.dot(k) * k;
            if p.length() > 1e-3 {
                return p.normalize();
            }
        }
    }

    /// Stokes vector of the (partially elliptical) field `E = a + i·b`, plus an
    /// unpolarised intensity `i_unpol`, computed straight from the intensity
    /// definitions of CONVENTIONS.md in the frame `(e1, e2 = k × e1)`.
    /// `V` is the frame-independent `2(a1 b2 − a2 b1)`.
    fn stokes_from_field(a: DVec3, b: DVec3, i_unpol: f64, e1: DVec3, k: DVec3) -> Stokes {
        let e2 = k.cross(e1);
        // Intensity behind an ideal linear polariser with axis `axis`.
        let intensity = |axis: DVec3| a.dot(axis).powi(2) + b.dot(axis).powi(2) + 0.5 * i_unpol;
        let diag_plus = (e1 + e2) / 2f64.sqrt();
        let diag_minus = (e1 - e2) / 2f64.sqrt();
        Stokes([
            intensity(e1) + intensity(e2),
            intensity(e1) - intensity(e2),
            intensity(diag_plus) - intensity(diag_minus),
            2.0 * (a.dot(e1) * b.dot(e2) - a.dot(e2) * b.dot(e1)),
        ])
    }

    #[test]
    fn rotation_by_pi_is_identity() {
        assert_mueller_close(Mueller::rotation(PI), Mueller::identity(), TOL);
        assert_mueller_close(Mueller::rotation(-PI), Mueller::identity(), TOL);
        assert_eq!(Mueller::rotation(0.0), Mueller::identity());
    }

    #[test]
    fn rotation_inverse_and_composition() {
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        for _ in 0..100 {
            let a = 4.0 * PI * (rng.random::<f64>() - 0.5);
            let b = 4.0 * PI * (rng.random::<f64>() - 0.5);
            let inv = Mueller::rotation(a) * Mueller::rotation(-a);
            assert_mueller_close(inv, Mueller::identity(), TOL);
            let composed = Mueller::rotation(a) * Mueller::rotation(b);
            assert_mueller_close(composed, Mueller::rotation(a + b), TOL);
            // The transpose of a rotation is its inverse.
            assert_mueller_close(Mueller::rotation(a).transpose(), Mueller::rotation(-a), TOL);
            let s = Stokes::new(1.0, 0.3, -0.2, 0.1);
            assert_stokes_close(s.rotated(a), Mueller::rotation(a) * s, TOL);
        }
    }

    #[test]
    fn rotation_matrix_elements_match_conventions() {
        let psi = 0.3;
        let s = Mueller::rotation(psi) * Stokes::new(2.0, 0.5, -0.25, 0.125);
        let (s2, c2) = (2.0 * psi).sin_cos();
        let expected = Stokes::new(2.0, c2 * 0.5 + s2 * -0.25, -s2 * 0.5 + c2 * -0.25, 0.125);
        assert_stokes_close(s, expected, TOL);
    }

    #[test]
    fn malus_law() {
        let i0 = 3.0;
        for n in 0..=24 {
            let alpha = n as f64 * PI / 24.0;
            let first = Mueller::linear_polarizer(0.4);
            let second = Mueller::linear_polarizer(0.4 + alpha);
            let out = second * first * Stokes::unpolarized(i0);
            assert!((out.i() - 0.5 * i0 * alpha.cos().powi(2)).abs() < TOL);
            // The output is fully polarised along the second polariser.
            if out.i() > 1e-6 {
                assert!((out.degree_of_linear_polarization() - 1.0).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn polarizer_is_rotated_zero_angle_polarizer() {
        // A polariser at θ equals: change to the frame whose e1 is its axis,
        // apply the polariser at 0, change back.
        for theta in [-1.2, -0.3, 0.2, 0.7, 2.5] {
            let built = Mueller::rotation(-theta) * Mueller::linear_polarizer(0.0) * Mueller::rotation(theta);
            assert_mueller_close(built, Mueller::linear_polarizer(theta), TOL);
        }
        // Axis at 45°, i.e. along (e1 + e2)/√2, passes pure +U.
        let out = Mueller::linear_polarizer(PI / 4.0) * Stokes::unpolarized(1.0);
        assert_stokes_close(out, Stokes::new(0.5, 0.0, 0.5, 0.0), TOL);
    }

    #[test]
    fn rotation_angle_sign_for_polarised_light_along_e1() {
        // Frame with k = +z, e1 = +x, e2 = k × e1 = +y. New e1 at α
        // counter-clockwise about k: Q' = cos 2α, U' = −sin 2α.
        let k = DVec3::Z;
        let e1 = DVec3::X;
        for alpha in [0.1f64, 0.4, 1.0, 2.0, -0.7] {
            let e1_to = DVec3::new(alpha.cos(), alpha.sin(), 0.0);
            let psi = rotation_angle(e1, e1_to, k);
            assert!((psi - alpha).abs() < TOL, "psi = {psi}, alpha = {alpha}");
            let s = Mueller::rotation(psi) * Stokes::new(1.0, 1.0, 0.0, 0.0);
            let expected = Stokes::new(1.0, (2.0 * alpha).cos(), -(2.0 * alpha).sin(), 0.0);
            assert_stokes_close(s, expected, TOL);
            // Directly from the definitions, E along the old e1.
            let direct = stokes_from_field(e1, DVec3::ZERO, 0.0, e1_to, k);
            assert_stokes_close(s, direct, TOL);
        }
        // Turning the axis onto e2 swaps the roles: Q' = −Q.
        assert!((rotation_angle(e1, DVec3::Y, k) - FRAC_PI_2).abs() < TOL);
        // Reversing the axis changes nothing.
        let s = Stokes::new(1.0, 0.3, 0.4, 0.2);
        assert_stokes_close(s.rotated(rotation_angle(e1, -e1, k)), s, TOL);
    }

    #[test]
    fn rotation_matches_stokes_from_physical_field() {
        let mut rng = Pcg64Mcg::seed_from_u64(2024);
        for _ in 0..500 {
            let k = random_unit(&mut rng);
            let e1_from = random_perpendicular(&mut rng, k);
            let e1_to = random_perpendicular(&mut rng, k);
            // Elliptically polarised field plus an unpolarised part.
            let a = random_perpendicular(&mut rng, k) * rng.random::<f64>();
            let b = random_perpendicular(&mut rng, k) * rng.random::<f64>();
            let i_unpol = rng.random::<f64>();
            let s_from = stokes_from_field(a, b, i_unpol, e1_from, k);
            let s_to = stokes_from_field(a, b, i_unpol, e1_to, k);
            let psi = rotation_angle(e1_from, e1_to, k);
            assert_stokes_close(Mueller::rotation(psi) * s_from, s_to, 1e-12);
            assert!((psi + rotation_angle(e1_to, e1_from, k)).abs() < 1e-12 || (psi.abs() - PI).abs() < 1e-9);
        }
    }

    #[test]
    fn meridian_frame_is_right_handed_and_matches_formula() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        for _ in 0..1000 {
            let theta = PI * rng.random::<f64>();
            let phi = 2.0 * PI * rng.random::<f64>();
            let v = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let (e1, e2) = meridian_frame(v, 0.0);
            let k = -v;
            assert!((e1.length() - 1.0).abs() < TOL && (e2.length() - 1.0).abs() < TOL);
            assert!(e1.dot(e2).abs() < TOL && e1.dot(v).abs() < TOL && e2.dot(v).abs() < TOL);
            assert!((e1.cross(e2) - k).length() < 1e-12);
            // e1 = ∂v/∂θ and e2 as written in CONVENTIONS.md.
            let e1_expected = DVec3::new(theta.cos() * phi.cos(), theta.cos() * phi.sin(), -theta.sin());
            let e2_expected = DVec3::new(phi.sin(), -phi.cos(), 0.0);
            assert!((e1 - e1_expected).length() < 1e-12);
            assert!((e2 - e2_expected).length() < 1e-12);
            // e1 lies in the meridian plane (holds z and v); e2 is horizontal.
            assert!(v.cross(DVec3::Z).dot(e1).abs() < 1e-12);
            assert_eq!(e2.z, 0.0);
        }
    }

    #[test]
    fn meridian_frame_zenith_and_nadir_use_fallback_azimuth() {
        for phi in [0.0f64, 0.5, 2.0, -1.0] {
            let (e1, e2) = meridian_frame(DVec3::Z, phi);
            assert!((e1 - DVec3::new(phi.cos(), phi.sin(), 0.0)).length() < TOL);
            assert!((e2 - DVec3::new(phi.sin(), -phi.cos(), 0.0)).length() < TOL);
            assert!((e1.cross(e2) - -DVec3::Z).length() < TOL);

            let (e1, e2) = meridian_frame(-DVec3::Z, phi);
            assert!((e1 - DVec3::new(-phi.cos(), -phi.sin(), 0.0)).length() < TOL);
            assert!((e2 - DVec3::new(phi.sin(), -phi.cos(), 0.0)).length() < TOL);
            assert!((e1.cross(e2) - DVec3::Z).length() < TOL);

            // The fallback is the limit θ → 0 along the azimuth φ.
            let theta: f64 = 1e-9;
            let v = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let (e1_near, e2_near) = meridian_frame(v, phi + 1.0);
            let (e1_zen, e2_zen) = meridian_frame(DVec3::Z, phi);
            assert!((e1_near - e1_zen).length() < 1e-8 && (e2_near - e2_zen).length() < 1e-8);
        }
    }

    #[test]
    fn stokes_and_mueller_arithmetic() {
        let s = Stokes::new(1.0, 0.5, -0.5, 0.25);
        assert_eq!(s + s, 2.0 * s);
        assert_eq!((s * 2.0) - s, s);
        let mut acc = Stokes::zero();
        acc += s;
        assert_eq!(acc, s);
        assert_eq!(Mueller::identity() * s, s);
        assert_eq!(Mueller::zero() * s, Stokes::zero());
        assert_eq!(Mueller::depolarizer(0.5) * s, Stokes::unpolarized(0.5));
        let m = Mueller::rotation(0.3) * 2.0;
        assert_eq!(m + m, 4.0 * Mueller::rotation(0.3));
        let mut acc = Mueller::zero();
        acc += m;
        assert_eq!(acc, m);
        assert!((Stokes::new(2.0, 1.0, 0.0, 0.0).degree_of_polarization() - 0.5).abs() < TOL);
        assert_eq!(Stokes::zero().degree_of_polarization(), 0.0);
    }
}
