//! The pieces of a path's vertices that do not depend on its channels:
//! phase-function choice and mixtures, the scattering-plane frame, the
//! quarter turn of the split first vertex, cosine-weighted ground
//! directions, the reference albedo and the direct beam's geometry.

use std::f64::consts::{FRAC_1_PI, PI};

use glam::DVec3;

use crate::atmosphere::optics::PointOptics;
use crate::geometry::basis::orthonormal_basis;
use crate::geometry::ray::Ray;
use crate::geometry::shell::Geometry;
use crate::polarization::phase_mixture::PhaseMixture;
use crate::polarization::stokes::StokesRotation;

pub(crate) const INV_4PI: f64 = 0.25 * FRAC_1_PI;

/// The geometry and ray along which the direct beam toward `ray.origin`
/// is attenuated: the ray itself, or in pseudo-spherical geometry (a
/// plane-parallel `geometry` with a planet radius) the same direction from
/// the point at the same altitude above the top of a sphere (where the
/// local vertical is +z, as in the slab).
#[inline]
pub(crate) fn sun_ray(geometry: Geometry, pseudo_spherical_radius_km: Option<f64>, ray: Ray) -> (Geometry, Ray) {
    match (pseudo_spherical_radius_km, geometry) {
        (Some(radius_km), Geometry::PlaneParallel) => (
            Geometry::Spherical { radius_km },
            Ray {
                origin: DVec3::new(0.0, 0.0, radius_km + ray.origin.z),
                ..ray
            },
        ),
        _ => (geometry, ray),
    }
}

/// Whether a ground of these albedos reflects at all.
#[inline]
pub(crate) fn reflects(albedos: &[f64]) -> bool {
    albedos.iter().any(|&a| a > 0.0)
}

/// The albedo a path's throughput carries at a ground reflection: the mean
/// of the scene's albedos (callers only reflect when one is positive).
#[inline]
pub(crate) fn reference_albedo(albedos: &[f64]) -> f64 {
    albedos.iter().sum::<f64>() / albedos.len() as f64
}

/// The σ_s-weighted mixture of a point's phase functions.
#[inline]
pub(crate) fn phase_mixture(c: &PointOptics) -> PhaseMixture {
    let sigma_s = c.sigma_s();
    if sigma_s <= 0.0 {
        return PhaseMixture::new(0.0, 0.0, 0.0, 0.0);
    }
    let inv = 1.0 / sigma_s;
    PhaseMixture::new(
        c.sigma_rayleigh * inv,
        c.rayleigh_depolarization,
        c.sigma_aerosol_sca * inv,
        c.aerosol_g,
    )
}

/// The share α of sun-aware points in the defensive mixture of
/// `spectral::Scene::sun_along_flight` where τ̃_sun is tabulated (spherical
/// geometry; exact in plane-parallel geometry, where α = 1): weights at most
/// 1/(1 − α) = 5 times those of sampling the flight alone. Single scattering
/// at 620 nm with ozone, sun −2°, three directions from the ground (200,000
/// paths): standard errors 1.1–1.9× smaller than with α = 0.5 or 0.97, within
/// 0.8–1.3× of α = 0.9, whose heavier tail read 2.4 % low (3.2σ) at 20,000
/// paths at −4.2° where α = 0.8 stays within 2.4σ
/// (`tests/twilight_single_scattering.rs`).
pub(crate) const SUN_AWARE_SHARE: f64 = 0.8;

/// The sun part's share α of the sun-aware density along the sensor's own
/// flight in spherical geometry (the view ray, scattering order 0; plane-
/// parallel scenes keep [`SUN_AWARE_SHARE`]), whose single scattering is
/// the bulk of the sky near the sun and at twilight's zenith: there the
/// density is built exact per layer segment ([`VIEW_PIECE_SEGMENTS`]) and
/// the flight part only guards the table's errors (weights at most 100
/// times those of sampling the flight alone). Paired against 0.8 with
/// pieces of four on `bench --suite` (2026-11-29, docs/performance.md):
/// single scattering seen 8° from a sun 2° up, relative standard error
/// 0.00228 → 0.00002 at equal paths; in all orders, FOM of I 1.85× there,
/// 1.07× the low sun's median, 1.41× twilight's (Q 1.88×, at the zenith
/// 3.4–4.3×), 1.10× from 15 km; 0.83–0.93× near the horizon at twilight
/// and in the aureole 2–6° from the sun, whose variance is of higher
/// orders and which pay the exact density's cost.
pub(crate) const VIEW_SUN_AWARE_SHARE: f64 = 0.99;

/// The most segments in one piece of the view flight's sun-aware density:
/// one, exact per segment ([`VIEW_SUN_AWARE_SHARE`]).
pub(crate) const VIEW_PIECE_SEGMENTS: usize = 1;

/// The Stokes rotation from the path's frame (axis `e1_out`, light along k_out)
/// into the scattering-plane frame of k_out, and the scattering-plane axis
/// e1 for the incoming light k_in. Scattering plane normal n = k_in × k_out;
/// e1 = n × k. For forward or backward scattering the plane is undefined and
/// the path's own frame is kept.
///
/// Nothing is normalised: the rotation depends only on the directions of
/// the two axes ([`StokesRotation::between`] is scale-invariant), so n and
/// the axes keep the length |n| (sin Θ, or |e1_out| when the plane is
/// undefined), and the returned axis is rescaled only when its length
/// would otherwise drift toward underflow over very long paths.
#[inline]
pub(crate) fn scattering_frame(e1_out: DVec3, k_in: DVec3, k_out: DVec3) -> (StokesRotation, DVec3) {
    let cross = k_in.cross(k_out);
    let n = if cross.length_squared() > 1e-24 {
        cross
    } else {
        k_out.cross(e1_out)
    };
    let e1_sc_out = n.cross(k_out);
    let mut e1_in = n.cross(k_in);
    if e1_in.length_squared() < 1e-100 {
        e1_in = e1_in.normalize();
    }
    // S(e1_out) = R(ψ) S(e1_sc_out).
    (StokesRotation::between(e1_sc_out, e1_out, k_out), e1_in)
}

/// A cosine-weighted direction in the hemisphere around `up`.
/// `v` turned a quarter turn about the unit `axis` (right-handed): the
/// same angle to the axis, 90° further in azimuth. A direction sampled from
/// a phase function about `axis` and its quarter turn have the same
/// density; their Stokes frames differ by 90°, so the linear polarisation
/// each contributes through a Rayleigh scattering (cos 2ψ, sin 2ψ) has
/// opposite sign, and their mean cancels most of the noise of ψ.
#[inline]
pub(crate) fn quarter_turn(axis: DVec3, v: DVec3) -> DVec3 {
    v.dot(axis) * axis + axis.cross(v)
}

#[inline]
pub(crate) fn cosine_hemisphere(up: DVec3, u: [f64; 2]) -> DVec3 {
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    let (b1, b2) = orthonormal_basis(up);
    let z = (1.0 - u[0]).max(0.0).sqrt();
    (r * phi.cos() * b1 + r * phi.sin() * b2 + z * up).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polarization::phase::PhaseFunction;
    use crate::polarization::stokes::{Mueller, rotation_angle};
    use crate::sampling::sampler::Sampler;

    fn unit(s: &mut Sampler) -> DVec3 {
        let [u, v] = s.next2();
        let z = 2.0 * u - 1.0;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * v;
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    #[test]
    fn unnormalised_scattering_frames_give_the_unit_frames_rotation() {
        // The written definition with unit vectors: n = k_in × k_out
        // normalised, e1 = n × k, ψ from `rotation_angle`. The path's axis
        // may have any length (1 down to 1e-45 here), and nearly forward
        // scattering keeps the path's own frame.
        let mut s = Sampler::new(&[31]);
        for i in 0..10_000 {
            let k_out = unit(&mut s);
            let k_in = if i % 10 == 0 { k_out } else { unit(&mut s) };
            let (b1, b2) = orthonormal_basis(k_out);
            let a = 2.0 * PI * s.next_f64();
            let e1_unit = a.cos() * b1 + a.sin() * b2;
            let scale = 10f64.powf(-45.0 * s.next_f64());
            let (rotation, e1_in) = scattering_frame(e1_unit * scale, k_in, k_out);
            let cross = k_in.cross(k_out);
            let n = if cross.length() > 1e-12 {
                cross.normalize()
            } else {
                k_out.cross(e1_unit).normalize()
            };
            let expected = StokesRotation::from_angle(rotation_angle(n.cross(k_out), e1_unit, k_out));
            assert!(
                (rotation.cos_2psi - expected.cos_2psi).abs() < 1e-12,
                "{rotation:?} vs {expected:?}"
            );
            assert!(
                (rotation.sin_2psi - expected.sin_2psi).abs() < 1e-12,
                "{rotation:?} vs {expected:?}"
            );
            let len = e1_in.length();
            assert!(len > 1e-60 && (e1_in / len - n.cross(k_in)).length() < 1e-12);
            assert!(e1_in.dot(k_in).abs() <= 1e-12 * len);
        }
    }

    #[test]
    fn a_quarter_turn_keeps_the_scattering_angle_and_flips_the_linear_polarisation() {
        // Same angle to the axis, unit length, 90° of azimuth; through a
        // Rayleigh matrix, unpolarised light from k_in and from its quarter
        // turn reaches k_out with the same I and opposite Q and U.
        let mut s = Sampler::new(&[32]);
        for _ in 0..10_000 {
            let k_out = unit(&mut s);
            let k_in = unit(&mut s);
            let k_q = quarter_turn(k_out, k_in);
            assert!((k_q.length() - 1.0).abs() < 1e-14);
            assert!((k_q.dot(k_out) - k_in.dot(k_out)).abs() < 1e-14);
            let (p_in, p_q) = (k_in - k_in.dot(k_out) * k_out, k_q - k_q.dot(k_out) * k_out);
            assert!(p_in.dot(p_q).abs() < 1e-14);
            assert!(p_in.cross(p_q).dot(k_out) >= -1e-14);
            let (b1, _) = orthonormal_basis(k_out);
            let m = PhaseFunction::Rayleigh { depolarization: 0.03 }.matrix(k_in.dot(k_out));
            let column = |k_in: DVec3| scattering_frame(b1, k_in, k_out).0.column_of(&Mueller::identity(), &m);
            let (a, b) = (column(k_in), column(k_q));
            assert!((a.0[0] - b.0[0]).abs() < 1e-13);
            for i in 1..3 {
                assert!((a.0[i] + b.0[i]).abs() < 1e-12, "{a:?} vs {b:?}");
            }
        }
    }
}
