//! The sun: a direction (the unit vector toward the sun's centre in the
//! observer's frame: x toward the sun's azimuth, z up) and an optional disc
//! of angular radius α with uniform radiance. Radiances are per unit
//! extraterrestrial irradiance normal to the beam (E0 = 1), so a direction
//! sampled uniformly in the disc carries the whole E0.

use glam::DVec3;

use crate::geometry::basis::orthonormal_basis;

/// The sun as seen from the observer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    /// Unit vector toward the sun's centre.
    pub direction: DVec3,
    /// Solar zenith angle at the observer (degrees).
    pub zenith_deg: f64,
    /// Angular radius of the disc (radians); 0 for a point sun.
    pub angular_radius: f64,
}

impl Sun {
    /// The sun at zenith angle `zenith_deg` (elevation 90° − zenith) in the
    /// plane x–z of the observer's frame: s = (cos η, 0, sin η).
    pub fn new(zenith_deg: f64, angular_radius_deg: f64) -> Sun {
        let eta = (90.0 - zenith_deg).to_radians();
        Sun {
            direction: DVec3::new(eta.cos(), 0.0, eta.sin()),
            zenith_deg,
            angular_radius: angular_radius_deg.to_radians(),
        }
    }

    /// cos of the solar zenith angle at the observer.
    pub fn mu0(&self) -> f64 {
        self.direction.z
    }

    /// Whether a point sun is hidden from `x` by a planet of radius
    /// `radius_km` centred at the origin: `x` lies in the half-cylinder of
    /// that radius behind the planet (a margin of 10⁻⁹ of the radius² keeps
    /// grazing rays out). The half-cylinder is convex, so a segment whose
    /// ends are both in it lies in it. Always false for a disc, whose
    /// umbra is narrower.
    pub fn hidden_by_planet(&self, radius_km: f64, x: DVec3) -> bool {
        if self.angular_radius != 0.0 {
            return false;
        }
        let along = x.dot(self.direction);
        along < 0.0 && x.length_squared() - along * along < radius_km * radius_km * (1.0 - 1e-9)
    }

    /// A direction toward the sun: the centre for a point sun, else uniform
    /// in solid angle over the disc.
    pub fn sample_direction(&self, u: [f64; 2]) -> DVec3 {
        if self.angular_radius == 0.0 {
            return self.direction;
        }
        let cos_max = self.angular_radius.cos();
        let cos_t = 1.0 - u[0] * (1.0 - cos_max);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * u[1];
        let (b1, b2) = orthonormal_basis(self.direction);
        (sin_t * (phi.cos() * b1 + phi.sin() * b2) + cos_t * self.direction).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::sampler::Sampler;

    #[test]
    fn direction_follows_the_convention() {
        // CONVENTIONS.md: s = (cos η, 0, sin η), η the elevation.
        let s = Sun::new(60.0, 0.0);
        assert!((s.direction - DVec3::new(30f64.to_radians().cos(), 0.0, 0.5)).length() < 1e-15);
        assert!((s.mu0() - 0.5).abs() < 1e-15);
        let below = Sun::new(94.2, 0.0);
        assert!(below.direction.z < 0.0);
    }

    #[test]
    fn the_planet_hides_the_sun_behind_it_and_nowhere_else() {
        // Sun 4.2° below the horizon of an observer on a 6378 km planet:
        // the observer is in the shadow, the air 30 km above is lit
        // (the shadow reaches up to R/cos 4.2° − R = 17.2 km there).
        let r = 6378.0;
        let s = Sun::new(94.2, 0.0);
        let up = |h: f64| DVec3::new(0.0, 0.0, r + h);
        assert!(s.hidden_by_planet(r, up(0.0)));
        assert!(s.hidden_by_planet(r, up(17.0)));
        assert!(!s.hidden_by_planet(r, up(17.4)));
        assert!(!s.hidden_by_planet(r, up(30.0)));
        // Toward the sun (x > 0) it rises out of the shadow; away from it
        // the shadow deepens.
        assert!(!s.hidden_by_planet(r, DVec3::new(500.0, 0.0, r)));
        assert!(s.hidden_by_planet(r, DVec3::new(-500.0, 0.0, r + 40.0)));
        // The sun above the horizon: nothing on the day side is hidden.
        assert!(!Sun::new(60.0, 0.0).hidden_by_planet(r, up(0.0)));
        // A disc is never taken as hidden (its umbra is narrower).
        assert!(!Sun::new(94.2, 0.2666).hidden_by_planet(r, up(0.0)));
    }

    #[test]
    fn disc_samples_fill_the_disc_uniformly_in_solid_angle() {
        let s = Sun::new(30.0, 0.2666);
        let cos_max = s.angular_radius.cos();
        let mut r = Sampler::new(&[3]);
        let n = 100_000;
        let mut inner = 0usize;
        let half = (1.0 + cos_max) / 2.0; // the cap of half the solid angle
        for _ in 0..n {
            let d = s.sample_direction(r.next2());
            let c = d.dot(s.direction);
            assert!(c >= cos_max - 1e-15 && (d.length() - 1.0).abs() < 1e-12);
            if c > half {
                inner += 1;
            }
        }
        let p = inner as f64 / n as f64;
        let se = (0.25 / n as f64).sqrt();
        assert!((p - 0.5).abs() < 4.0 * se, "{p}");
    }
}
