//! Stream keys: which random stream every sample of every estimate draws
//! from, written in one place.
//!
//! A sample's stream is `Sampler::new(&[seed, render, estimate, i])`, `i` the
//! sample index. The words are chosen so that the estimates of one render,
//! and the renders of one job, never share a stream:
//! - `render`: `task · 2³² + channel` for one channel (wavelength or band)
//!   of a task, `task · 2³² + 0xFFFF` for all of a task's channels along
//!   shared paths (a job has fewer than 0xFFFF channels), `task · 2³² +
//!   2¹⁶ + g` for group g of its channels along paths of their own
//!   (`render.spectral_groups`), `u64::MAX` for the calibration renders of
//!   `atmosim plan`; a transmittance table's words are its task and its
//!   table point.
//! - `estimate`: a direction's or a pixel's index (below 2⁴⁰), `2⁴⁰ + k` for
//!   uvspec's azimuthal average of its k-th `umu`, `2⁴¹ + d` for the pilot
//!   of a noise target at direction or pixel `d`, and the top values of u64
//!   for the hemispheric estimates (fluxes, their pilots, uvspec's mean
//!   intensities).
//!
//! The values are those of every earlier release: renders keep their bits.

use crate::sampling::sampler::Sampler;

/// The channels an estimate follows: one channel alone, or every channel of
/// the job along shared paths.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channels {
    One(usize),
    Shared,
    /// Group g of the task's channels (its spectral groups, in their
    /// order), along paths of their own.
    Group(usize),
}

/// The render an estimate belongs to: the key's second word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Render {
    /// A task of a job, for some of its channels.
    Task { task: usize, channels: Channels },
    /// The short renders from which `atmosim plan` calibrates its costs.
    Calibration,
}

/// The estimate within a render: the key's third word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Estimate {
    /// One viewing direction of a `directions` sensor, by index.
    Direction(usize),
    /// One pixel of an image, by index.
    Pixel(usize),
    /// The downward diffuse irradiance at the observer.
    FluxDown,
    /// The upward irradiance at the observer.
    FluxUp,
    /// uvspec's azimuthally averaged radiance of its `umu` number k.
    AzimuthalAverage(usize),
    /// uvspec's mean intensity of the light travelling down.
    MeanIntensityDown,
    /// uvspec's mean intensity of the light travelling up.
    MeanIntensityUp,
    /// The pilot of a noise target at a direction or pixel, by index: its
    /// samples set the allocation and are independent of the estimate's own.
    Pilot(usize),
    /// The pilot of the downward irradiance.
    PilotFluxDown,
    /// The pilot of the upward irradiance.
    PilotFluxUp,
    /// The radiance of the ground seen by an observer standing on it (the
    /// same in every direction below the horizon), which an image's pixels
    /// below the horizon share.
    GroundView,
    /// The pilot of the ground seen from the ground.
    PilotGroundView,
}

/// The channel word of shared paths.
const SHARED_CHANNEL: u64 = 0xFFFF;
/// The channel word of spectral group 0 (group g: this + g).
const FIRST_GROUP: u64 = 0x1_0000;
/// Indices of directions and pixels stay below this.
const INDEX_LIMIT: u64 = 1 << 40;

impl Render {
    /// The render of one channel of `task`.
    pub fn channel(task: usize, channel: usize) -> Render {
        Render::Task {
            task,
            channels: Channels::One(channel),
        }
    }

    /// The render of every channel of `task` along shared paths.
    pub fn shared(task: usize) -> Render {
        Render::Task {
            task,
            channels: Channels::Shared,
        }
    }

    fn word(self) -> u64 {
        match self {
            Render::Task { task, channels } => {
                let channel = match channels {
                    Channels::One(w) => w as u64,
                    Channels::Shared => SHARED_CHANNEL,
                    Channels::Group(g) => FIRST_GROUP + g as u64,
                };
                ((task as u64) << 32) | channel
            }
            Render::Calibration => u64::MAX,
        }
    }
}

impl Estimate {
    /// The upward (`up`) or downward irradiance.
    pub fn flux(up: bool) -> Estimate {
        if up { Estimate::FluxUp } else { Estimate::FluxDown }
    }

    /// The pilot of this estimate (a noise target's first stage): its own
    /// streams, never those of the estimate.
    pub fn pilot(self) -> Estimate {
        match self {
            Estimate::Direction(d) | Estimate::Pixel(d) | Estimate::Pilot(d) => Estimate::Pilot(d),
            Estimate::FluxDown | Estimate::PilotFluxDown => Estimate::PilotFluxDown,
            Estimate::FluxUp | Estimate::PilotFluxUp => Estimate::PilotFluxUp,
            Estimate::GroundView | Estimate::PilotGroundView => Estimate::PilotGroundView,
            Estimate::AzimuthalAverage(_) | Estimate::MeanIntensityDown | Estimate::MeanIntensityUp => {
                unreachable!("uvspec's estimates have no noise target")
            }
        }
    }

    fn word(self) -> u64 {
        match self {
            Estimate::Direction(d) | Estimate::Pixel(d) => d as u64,
            Estimate::AzimuthalAverage(k) => INDEX_LIMIT + k as u64,
            Estimate::Pilot(d) => 2 * INDEX_LIMIT + d as u64,
            Estimate::PilotFluxDown => u64::MAX - 5,
            Estimate::PilotFluxUp => u64::MAX - 6,
            Estimate::FluxDown => u64::MAX - 1,
            Estimate::FluxUp => u64::MAX - 2,
            Estimate::MeanIntensityDown => u64::MAX - 3,
            Estimate::MeanIntensityUp => u64::MAX - 4,
            Estimate::GroundView => u64::MAX - 7,
            Estimate::PilotGroundView => u64::MAX - 8,
        }
    }
}

/// The key of one estimate's streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StreamKey {
    pub seed: u64,
    pub render: Render,
    pub estimate: Estimate,
}

impl StreamKey {
    pub fn new(seed: u64, render: Render, estimate: Estimate) -> StreamKey {
        StreamKey { seed, render, estimate }
    }

    /// The three words that, with a sample index, seed a stream.
    pub fn words(self) -> [u64; 3] {
        [self.seed, self.render.word(), self.estimate.word()]
    }

    /// The stream of sample `i` of this estimate.
    pub fn sampler(self, i: u64) -> Sampler {
        let [a, b, c] = self.words();
        Sampler::new(&[a, b, c, i])
    }

    /// This estimate's key for another estimate of the same render.
    pub fn with(self, estimate: Estimate) -> StreamKey {
        StreamKey { estimate, ..self }
    }
}

/// The stream of sample `i` at table point `point` of the transmittance
/// table of task `task`.
pub fn transmittance_sampler(seed: u64, task: usize, point: usize, i: u64) -> Sampler {
    Sampler::new(&[seed, task as u64, point as u64, i])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_those_of_the_earlier_constants() {
        // The layout every earlier render used: changing it changes bits.
        let k = StreamKey::new(7, Render::channel(3, 2), Estimate::Direction(5));
        assert_eq!(k.words(), [7, (3 << 32) | 2, 5]);
        assert_eq!(Render::shared(1).word(), (1 << 32) | 0xFFFF);
        let group = Render::Task {
            task: 1,
            channels: Channels::Group(2),
        };
        assert_eq!(group.word(), (1 << 32) | 0x1_0002);
        assert_eq!(Render::Calibration.word(), u64::MAX);
        assert_eq!(Estimate::FluxDown.word(), u64::MAX - 1);
        assert_eq!(Estimate::FluxUp.word(), u64::MAX - 2);
        assert_eq!(Estimate::AzimuthalAverage(2).word(), (1 << 40) + 2);
        assert_eq!(Estimate::MeanIntensityDown.word(), u64::MAX - 3);
        assert_eq!(Estimate::MeanIntensityUp.word(), u64::MAX - 4);
    }

    #[test]
    fn estimates_of_one_render_never_share_a_word() {
        let mut words: Vec<u64> = [
            Estimate::FluxDown,
            Estimate::FluxUp,
            Estimate::MeanIntensityDown,
            Estimate::MeanIntensityUp,
            Estimate::Direction(0),
            Estimate::Direction(INDEX_LIMIT as usize - 1),
            Estimate::AzimuthalAverage(0),
            Estimate::AzimuthalAverage(1000),
            Estimate::Pilot(0),
            Estimate::Pilot(INDEX_LIMIT as usize - 1),
            Estimate::PilotFluxDown,
            Estimate::PilotFluxUp,
            Estimate::GroundView,
            Estimate::PilotGroundView,
        ]
        .iter()
        .map(|e| e.word())
        .collect();
        let n = words.len();
        words.sort_unstable();
        words.dedup();
        assert_eq!(words.len(), n);
    }

    #[test]
    fn a_sampler_follows_its_words() {
        let k = StreamKey::new(1, Render::shared(0), Estimate::Pixel(9));
        let [a, b, c] = k.words();
        assert_eq!(k.sampler(4).next_f64(), Sampler::new(&[a, b, c, 4]).next_f64());
        assert_ne!(
            k.sampler(4).next_f64(),
            k.with(Estimate::Pixel(8)).sampler(4).next_f64()
        );
    }
}
