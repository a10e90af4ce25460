//! An orthonormal basis around a unit vector: the frames of scattering
//! planes, of the sun's disc and of cosine-weighted ground directions.

use glam::DVec3;

/// Orthonormal basis `(b1, b2)` with `b1 × b2 = n` for a unit vector `n`,
/// branch-free except for the sign (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited", JCGT 6(1)).
#[inline]
pub fn orthonormal_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let b1 = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let b2 = DVec3::new(b, sign + n.y * n.y * a, -n.y);
    (b1, b2)
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::*;

    #[test]
    fn orthonormal_basis_is_right_handed() {
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        let mut dirs = vec![DVec3::Z, -DVec3::Z, DVec3::X, DVec3::new(0.0, 1e-12, -1.0).normalize()];
        for _ in 0..1000 {
            let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
            let phi = 2.0 * PI * rng.random::<f64>();
            let s = (1.0 - z * z).sqrt();
            dirs.push(DVec3::new(s * phi.cos(), s * phi.sin(), z));
        }
        for n in dirs {
            let (b1, b2) = orthonormal_basis(n);
            assert!((b1.length() - 1.0).abs() < 1e-12 && (b2.length() - 1.0).abs() < 1e-12);
            assert!(b1.dot(b2).abs() < 1e-12 && b1.dot(n).abs() < 1e-12 && b2.dot(n).abs() < 1e-12);
            assert!((b1.cross(b2) - n).length() < 1e-12);
        }
    }
}
