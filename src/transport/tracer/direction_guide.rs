//! What a scattering direction is drawn from besides the channels' phase
//! functions, where the sun's position says more than the phase function
//! does (closed set): the lobe toward the sunlit air with the sun low or
//! set (`sun_lobe`), or the lobe about the sun with the sun low but up
//! (`sun_peak`). A direction comes from the guide with its share and
//! otherwise from the phase functions; every channel weighs it by its
//! matrix over the mixture of both densities (one-sample MIS, balance
//! heuristic).

use glam::DVec3;

use crate::sampling::sampler::Sampler;

use super::sun_lobe::{SUN_LOBE_SHARE, SunLobe};
use super::sun_peak::{SUN_PEAK_SHARE, SunPeak};

/// A vertex's guide.
#[derive(Debug, Clone, Copy)]
pub(super) enum DirectionGuide<'a> {
    SunLobe(SunLobe<'a>),
    SunPeak(SunPeak),
}

impl DirectionGuide<'_> {
    /// The share of directions drawn from the guide.
    pub(super) fn share(&self) -> f64 {
        match self {
            DirectionGuide::SunLobe(_) => SUN_LOBE_SHARE,
            DirectionGuide::SunPeak(_) => SUN_PEAK_SHARE,
        }
    }

    /// A propagation direction drawn from the guide.
    pub(super) fn sample(&self, sampler: &mut Sampler) -> DVec3 {
        match self {
            DirectionGuide::SunLobe(lobe) => lobe.sample(sampler),
            DirectionGuide::SunPeak(peak) => peak.sample(sampler),
        }
    }

    /// The inverse of the mixture's density (times 4π) of propagation
    /// direction `d` whose channels' mean P11 is `mean_p11`.
    pub(super) fn inverse_mixture(&self, mean_p11: f64, d: DVec3) -> f64 {
        let guide = match self {
            DirectionGuide::SunLobe(lobe) => lobe.density_4pi(d),
            DirectionGuide::SunPeak(peak) => peak.density_4pi(d),
        };
        let share = self.share();
        1.0 / ((1.0 - share) * mean_p11 + share * guide)
    }
}
