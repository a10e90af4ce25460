//! The view angles of the Prague sky model's runtime, for fitting and for
//! evaluation alike, so that a fitted table is read back at the angles it
//! was written at.
//!
//! Facts of the public runtime (`PragueSkyModel.cpp`), in its frame: z up,
//! lengths in metres, the planet a sphere of radius [`PLANET_RADIUS_M`]
//! whose centre lies at (0, 0, −R) below an observer standing on the z
//! axis. For an observer at altitude h (the runtime's altitude, its
//! 50 m safety offset already added) and d = R + h:
//!
//! - γ is the angle between the view v and the sun s (no correction);
//! - θ is the zenith angle of v; θ′ ("zero") that of the corrected view
//!   v′ = normalize(v + ẑ·t/d), t = √(d² − R²), which makes the horizon
//!   (the tangent to the planet) θ′ = 90° at every altitude;
//! - the shadow angle σ is the angle between v′ and the shadow point
//!   u, 90° above the sun in its azimuth: elevation η + 90°;
//! - α = σ when the sun is below the horizon (η < 0), θ′ otherwise: the
//!   zenith/shadow angle that a fitted radiance table is indexed by.
//!
//! Where the runtime takes `acos` of a dot product that rounding pushed
//! past ±1 (a NaN there) these functions clamp; nothing else differs.

use glam::DVec3;

/// The runtime's planet radius (m).
pub const PLANET_RADIUS_M: f64 = 6_378_000.0;
/// The runtime raises every viewpoint by this much (m) before it evaluates.
pub const SAFETY_ALTITUDE_M: f64 = 50.0;

/// A sun position in the runtime's frame: elevation and azimuth (radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunPosition {
    pub elevation: f64,
    pub azimuth: f64,
}

impl SunPosition {
    /// The unit vector toward the sun's centre.
    pub fn direction(&self) -> DVec3 {
        let (se, ce) = self.elevation.sin_cos();
        let (sa, ca) = self.azimuth.sin_cos();
        DVec3::new(ca * ce, sa * ce, se)
    }

    /// The shadow point: 90° above the sun in its azimuth.
    pub fn shadow_direction(&self) -> DVec3 {
        SunPosition {
            elevation: self.elevation + std::f64::consts::FRAC_PI_2,
            azimuth: self.azimuth,
        }
        .direction()
    }
}

/// The corrected view v′ for an observer at `altitude_m` (the runtime's
/// altitude): v itself at or below the ground's radius.
pub fn corrected_view(v: DVec3, altitude_m: f64) -> DVec3 {
    if altitude_m <= 0.0 {
        return v;
    }
    let d = PLANET_RADIUS_M + altitude_m;
    let c = (d * d - PLANET_RADIUS_M * PLANET_RADIUS_M).sqrt() / d;
    (v + DVec3::Z * c).normalize()
}

/// The inverse of [`corrected_view`]: the unit v whose corrected view is
/// the unit `w` (v = λ·w − c·ẑ with λ the positive root of |v| = 1).
pub fn uncorrected_view(w: DVec3, altitude_m: f64) -> DVec3 {
    if altitude_m <= 0.0 {
        return w;
    }
    let d = PLANET_RADIUS_M + altitude_m;
    let c = (d * d - PLANET_RADIUS_M * PLANET_RADIUS_M).sqrt() / d;
    let cz = c * w.z;
    let lambda = cz + (cz * cz - c * c + 1.0).max(0.0).sqrt();
    (w * lambda - DVec3::Z * c).normalize()
}

/// The angles of one view direction (radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewAngles {
    /// γ: to the sun, from the uncorrected view.
    pub gamma: f64,
    /// θ: zenith angle of the uncorrected view.
    pub theta: f64,
    /// θ′: zenith angle of the corrected view (the emphasis axis).
    pub zero: f64,
    /// σ: from the corrected view to the shadow point.
    pub shadow: f64,
}

impl ViewAngles {
    /// The angles of the unit view `v` for an observer on the z axis at
    /// `altitude_m` (the runtime's altitude) under `sun`.
    pub fn of(v: DVec3, sun: SunPosition, altitude_m: f64) -> ViewAngles {
        let w = corrected_view(v, altitude_m);
        ViewAngles {
            gamma: acos(v.dot(sun.direction())),
            theta: acos(v.z),
            zero: acos(w.z),
            shadow: acos(w.dot(sun.shadow_direction())),
        }
    }

    /// α, the zenith/shadow angle: σ for a sun below the horizon, θ′
    /// otherwise.
    pub fn alpha(&self, sun_elevation: f64) -> f64 {
        if sun_elevation < 0.0 { self.shadow } else { self.zero }
    }
}

fn acos(x: f64) -> f64 {
    x.clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn the_tangent_to_the_planet_is_the_corrected_horizon() {
        for h in [1.0, 50.0, 2000.0, 15_000.0] {
            // The tangent from radius R + h dips by acos(R/(R+h)).
            let dip = (PLANET_RADIUS_M / (PLANET_RADIUS_M + h)).acos();
            let v = DVec3::new(dip.cos(), 0.0, -dip.sin());
            let a = ViewAngles::of(
                v,
                SunPosition {
                    elevation: 0.3,
                    azimuth: 0.0,
                },
                h,
            );
            assert!((a.zero - FRAC_PI_2).abs() < 1e-9, "h {h}: θ′ {}", a.zero);
            assert!((a.theta - (FRAC_PI_2 + dip)).abs() < 1e-12);
        }
    }

    #[test]
    fn uncorrected_view_inverts_the_correction() {
        for h in [0.0, 10.0, 5000.0, 15_000.0] {
            for k in 0..50 {
                let t = PI * k as f64 / 49.0;
                let v = DVec3::new(t.sin() * 0.6, t.sin() * 0.8, t.cos());
                let back = uncorrected_view(corrected_view(v, h), h);
                assert!((back - v).length() < 1e-12, "h {h} θ {t}");
            }
        }
    }

    #[test]
    fn shadow_point_is_the_zenith_for_a_sun_on_the_horizon() {
        let sun = SunPosition {
            elevation: 0.0,
            azimuth: 1.0,
        };
        assert!((sun.shadow_direction() - DVec3::Z).length() < 1e-15);
        let sun = SunPosition {
            elevation: -0.05,
            azimuth: 0.0,
        };
        // u is perpendicular to s and 90° above it.
        assert!(sun.direction().dot(sun.shadow_direction()).abs() < 1e-15);
        assert!(sun.shadow_direction().z > 0.99);
        // At the ground (no correction) α = σ below the horizon, θ′ above.
        let v = DVec3::new(0.0, 1.0, 0.0);
        let a = ViewAngles::of(v, sun, 0.0);
        assert_eq!(a.alpha(-0.05), a.shadow);
        assert_eq!(a.alpha(0.05), a.zero);
        assert!((a.shadow - FRAC_PI_2).abs() < 1e-12);
    }
}
