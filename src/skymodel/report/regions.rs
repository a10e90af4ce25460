//! Where on the sphere an error lies: the regions a sky model must get
//! right and whose renders are the hardest, told apart by the runtime's
//! angles of a view.
//!
//! - the sun's aureole: within [`AUREOLE_DEG`] of the sun's centre (the
//!   aerosol's forward peak, the brightest sky);
//! - the horizon: the corrected zenith angle θ′ within [`HORIZON_DEG`] of
//!   90° (θ′ = 90° is the tangent to the planet at every altitude), outside
//!   the aureole;
//! - below: θ′ beyond the horizon band (the ground seen through the air,
//!   or the air below a high observer);
//! - the sky: the rest, above the horizon band.
//!
//! At twilight the shadowed air (the Earth's shadow, lit only by light
//! scattered more than once) is the sky away from the sun: the sky region
//! of the tasks with the sun below the horizon.

use crate::skymodel::runtime::Parameters;

/// The aureole's radius about the sun's centre (deg).
pub const AUREOLE_DEG: f64 = 10.0;
/// The horizon band's half-width in θ′ (deg).
pub const HORIZON_DEG: f64 = 3.0;

/// A region of the sphere (closed set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    Aureole,
    Horizon,
    Below,
    Sky,
}

impl Region {
    /// Every region, in the order of [`Region::index`].
    pub const ALL: [Region; 4] = [Region::Aureole, Region::Horizon, Region::Below, Region::Sky];

    /// The region of a view with the runtime's angles `p`.
    pub fn of(p: &Parameters) -> Region {
        let zero_deg = p.zero.to_degrees();
        if p.gamma.to_degrees() < AUREOLE_DEG {
            Region::Aureole
        } else if (zero_deg - 90.0).abs() <= HORIZON_DEG {
            Region::Horizon
        } else if zero_deg > 90.0 {
            Region::Below
        } else {
            Region::Sky
        }
    }

    pub fn index(self) -> usize {
        self as usize
    }

    /// The region's name in reports and CSV columns.
    pub fn name(self) -> &'static str {
        match self {
            Region::Aureole => "aureole",
            Region::Horizon => "horizon",
            Region::Below => "below",
            Region::Sky => "sky",
        }
    }
}

/// Sums per region, to be turned into shares of their total.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RegionSums(pub [f64; 4]);

impl RegionSums {
    pub fn add(&mut self, region: Region, value: f64) {
        self.0[region.index()] += value;
    }

    /// Each region's share of the total (0 for a total of 0).
    pub fn shares(&self) -> [f64; 4] {
        let total: f64 = self.0.iter().sum();
        self.0.map(|v| if total != 0.0 { v / total } else { 0.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skymodel::angles::{SunPosition, ViewAngles};

    fn params(v: glam::DVec3, elevation_deg: f64, altitude_m: f64) -> Parameters {
        let elevation = elevation_deg.to_radians();
        let a = ViewAngles::of(
            v,
            SunPosition {
                elevation,
                azimuth: 0.0,
            },
            altitude_m,
        );
        Parameters {
            theta: a.theta,
            gamma: a.gamma,
            shadow: a.shadow,
            zero: a.zero,
            elevation,
            altitude_m,
            visibility_km: 40.0,
            albedo: 0.3,
        }
    }

    #[test]
    fn views_fall_in_their_regions() {
        let dir = |zenith_deg: f64, azimuth_deg: f64| {
            let (t, p) = (zenith_deg.to_radians(), azimuth_deg.to_radians());
            glam::DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
        };
        // Sun 20° up: 5° from it, the aureole; the horizon opposite; the
        // zenith the sky; the nadir below.
        assert_eq!(Region::of(&params(dir(65.0, 0.0), 20.0, 0.0)), Region::Aureole);
        assert_eq!(Region::of(&params(dir(91.0, 180.0), 20.0, 0.0)), Region::Horizon);
        assert_eq!(Region::of(&params(dir(0.0, 0.0), 20.0, 0.0)), Region::Sky);
        assert_eq!(Region::of(&params(dir(180.0, 0.0), 20.0, 0.0)), Region::Below);
        // From 15 km the horizon is 3.9° below the horizontal: a view 4°
        // down lies on it, one 10° down below it.
        assert_eq!(Region::of(&params(dir(94.0, 180.0), 20.0, 15_000.0)), Region::Horizon);
        assert_eq!(Region::of(&params(dir(100.0, 180.0), 20.0, 15_000.0)), Region::Below);
        let mut sums = RegionSums::default();
        sums.add(Region::Sky, 3.0);
        sums.add(Region::Aureole, 1.0);
        assert_eq!(sums.shares(), [0.25, 0.0, 0.0, 0.75]);
    }
}
