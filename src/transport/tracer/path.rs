//! A path's state (throughputs and densities per channel, Stokes frame,
//! scattering order), the optical depths along one ray, the thread's reusable
//! work space, and Russian roulette.

use std::cell::RefCell;

use glam::DVec3;

use crate::atmosphere::optics::PointOptics;
use crate::geometry::ray::Segment;
use crate::geometry::shell_exit::ShellExit;
use crate::job::options::MAX_ALBEDOS;
use crate::polarization::phase_mixture::PhaseMixture;
use crate::polarization::stokes::{Mueller, PhaseMatrix, Stokes};
use crate::sampling::sampler::Sampler;
use crate::transport::flight_density::FlightDensity;
use crate::transport::sun_depth::SunDepth;

use super::spectra::ChannelSpectra;

/// A path's state; its per-wavelength vectors are reused from sample to
/// sample on each thread ([`WORK`]).
#[derive(Default, Clone)]
pub(super) struct Path {
    /// Per wavelength: its path integrand over the hero's path density.
    pub(super) throughput: Vec<Mueller>,
    /// Per wavelength: its path density over the hero's.
    pub(super) density_ratio: Vec<f64>,
    /// 1 / mean of `density_ratio` (the balance heuristic's denominator).
    pub(super) inv_mean_density: f64,
    pub(super) hero: usize,
    pub(super) frame_e1: DVec3,
    pub(super) order: u32,
    pub(super) albedo_weights: [f64; MAX_ALBEDOS],
    /// `[λ·albedos + albedo]`.
    pub(super) radiance: Vec<Stokes>,
    pub(super) albedos: usize,
    /// The depths along the current flight, and along the last shadow ray
    /// toward the sun (kept apart: sun-aware connections walk shadow rays
    /// before the flight's collision is drawn).
    pub(super) ray: Depths,
    pub(super) shadow: Depths,
    /// Scratch per wavelength: optical depths to the collision, forcing
    /// probabilities, phase mixtures and matrices at the last collision.
    pub(super) tau_hit: Vec<f64>,
    pub(super) forced: Vec<f64>,
    pub(super) mixtures: Vec<PhaseMixture>,
    pub(super) matrices: Vec<PhaseMatrix>,
    /// Sun-aware connections along a flight: its segments, the basis
    /// depths along it at each one's start, and the density.
    pub(super) segments: Vec<Segment>,
    pub(super) segment_tau: Vec<f64>,
    pub(super) density: FlightDensity,
    /// Per channel, the weight of a point connected to the sun off the
    /// collision (sun-aware or stratified), and the transmittance of the
    /// last shadow ray.
    pub(super) factors: Vec<f64>,
    pub(super) shadow_tr: Vec<f64>,
    /// Scratch: basis depths to a point.
    pub(super) point_basis: Vec<f64>,
    /// The hero's σ_t per layer, where the spectra do not hold it.
    pub(super) hero_sigma: Vec<f64>,
    /// Through merged layers: the residual's points along the current
    /// flight and, per point, every channel's product of factors up to it
    /// (`[point·channels + channel]`; `tracking`).
    pub(super) residual_t: Vec<f64>,
    pub(super) residual_tr: Vec<f64>,
}

/// Optical depths along one ray to where it leaves.
#[derive(Default, Clone)]
pub(super) struct Depths {
    /// Per basis vector (also scratch while a flight is located).
    pub(super) tau_basis: Vec<f64>,
    /// Per channel.
    pub(super) tau: Vec<f64>,
    /// Per level: the ray's half chords through concentric shells, and
    /// how it crosses them (spherical geometry).
    pub(super) chords: Vec<f64>,
    pub(super) exit: Option<ShellExit>,
    /// Scratch per basis vector: a shadow ray's residual at a point
    /// (`control`).
    pub(super) residual: Vec<f64>,
}

impl Depths {
    #[inline]
    pub(super) fn reset(&mut self, n: usize, levels: usize, basis: usize) {
        self.tau.resize(n, 0.0);
        self.tau_basis.resize(basis, 0.0);
        self.residual.resize(basis, 0.0);
        self.chords.resize(levels, 0.0);
    }
}

/// The most segments in one piece of a sun-aware density along shared
/// paths, where building it costs per segment and followed channel
/// (chosen by measurement: README, "Sun connections along shared paths").
pub(super) const PIECE_SEGMENTS: usize = 4;

/// What sun-aware connections along shared paths draw their point from:
/// the densities of the channels of the least and the largest column
/// extinction, each with its optics at its centre wavelength whatever a
/// path drew inside its band (any density will do that the contributions
/// are divided by; these need no work per path).
#[derive(Debug, Clone)]
pub(super) struct SunFollow {
    /// Their depths toward the sun, one profile each.
    pub(super) depth: SunDepth,
    pub(super) channels: Vec<usize>,
    /// Their coefficients per layer (`[layer·K + k]`).
    pub(super) coefficients: Vec<PointOptics>,
    /// The largest column extinction of the scene's channels, at their
    /// centre wavelengths (whether the sun lobe serves them with the sun
    /// up, `sun_lobe`).
    pub(super) max_column: f64,
}

/// A thread's reusable state: the path, the spare the path's first vertex
/// splits into, and, for bands, its spectra.
#[derive(Default)]
pub(super) struct Work {
    pub(super) path: Path,
    pub(super) spare: Path,
    pub(super) spectra: ChannelSpectra,
}

thread_local! {
    pub(super) static WORK: RefCell<Work> = RefCell::new(Work::default());
}

impl Path {
    #[inline]
    pub(super) fn reset(
        &mut self,
        n: usize,
        levels: usize,
        basis: usize,
        albedos: usize,
        frame_e1: DVec3,
        hero: usize,
    ) {
        self.throughput.clear();
        self.throughput.resize(n, Mueller::identity());
        self.density_ratio.clear();
        self.density_ratio.resize(n, 1.0);
        self.inv_mean_density = 1.0;
        self.hero = hero;
        self.frame_e1 = frame_e1;
        self.order = 0;
        self.albedo_weights = [1.0; MAX_ALBEDOS];
        self.radiance.clear();
        self.radiance.resize(n * albedos, Stokes::zero());
        self.albedos = albedos;
        for v in [&mut self.tau_hit, &mut self.forced, &mut self.shadow_tr] {
            v.resize(n, 0.0);
        }
        self.ray.reset(n, levels, basis);
        self.shadow.reset(n, levels, basis);
        self.residual_t.clear();
        self.residual_tr.clear();
    }

    /// This path as a branch of `other`: its state (throughputs, densities,
    /// frame, order, albedo weights, radiance and the matrices of its last
    /// collision), with scratch of the same sizes but not its contents.
    #[inline]
    pub(super) fn branch_from(&mut self, other: &Path) {
        self.throughput.clone_from(&other.throughput);
        self.density_ratio.clone_from(&other.density_ratio);
        self.inv_mean_density = other.inv_mean_density;
        self.hero = other.hero;
        self.frame_e1 = other.frame_e1;
        self.order = other.order;
        self.albedo_weights = other.albedo_weights;
        self.radiance.clone_from(&other.radiance);
        self.albedos = other.albedos;
        self.matrices.clone_from(&other.matrices);
        self.hero_sigma.clone_from(&other.hero_sigma);
        let n = other.throughput.len();
        for v in [&mut self.tau_hit, &mut self.forced, &mut self.shadow_tr] {
            v.resize(n, 0.0);
        }
        let (levels, basis) = (other.ray.chords.len(), other.ray.tau_basis.len());
        self.ray.reset(n, levels, basis);
        self.shadow.reset(n, levels, basis);
        self.residual_t.clear();
        self.residual_tr.clear();
    }

    /// Halves every wavelength's throughput (one of two branches).
    #[inline]
    pub(super) fn halve(&mut self) {
        for t in self.throughput.iter_mut() {
            *t = *t * 0.5;
        }
    }

    /// Multiplies wavelength `w`'s density ratio by `k`.
    #[inline]
    pub(super) fn scale_density(&mut self, w: usize, k: f64) {
        self.density_ratio[w] *= k;
    }

    /// Refreshes the balance heuristic's denominator after density changes.
    #[inline]
    pub(super) fn densities_changed(&mut self) {
        let mean = self.density_ratio.iter().sum::<f64>() / self.density_ratio.len() as f64;
        self.inv_mean_density = 1.0 / mean;
    }

    /// Adds wavelength `w`'s contribution `s` (throughput already in it),
    /// with the balance heuristic over the wavelengths' path densities.
    #[inline]
    pub(super) fn add(&mut self, w: usize, s: Stokes) {
        let s = s * self.inv_mean_density;
        let base = w * self.albedos;
        for a in 0..self.albedos {
            self.radiance[base + a] += s * self.albedo_weights[a];
        }
    }

    /// Russian roulette on the mean effective T₀₀ over the wavelengths (the
    /// largest kept paths alive as long as 320 nm needed: 1.5× the cost
    /// for a larger error at 320 nm at equal time) below `threshold`
    /// ([`Settings::roulette_threshold`](crate::job::options::Settings::roulette_threshold)).
    #[inline]
    pub(super) fn roulette(&mut self, threshold: f64, sampler: &mut Sampler) -> bool {
        let mean = self.throughput.iter().map(|t| t.0[0][0]).sum::<f64>() / self.throughput.len() as f64;
        let w = mean * self.inv_mean_density;
        if self.order < 2 || w >= threshold {
            return w > 0.0;
        }
        let q = w / threshold;
        if sampler.next_f64() >= q {
            return false;
        }
        for t in self.throughput.iter_mut() {
            *t = *t * (1.0 / q);
        }
        true
    }
}

/// How a shared flight ended.
pub(super) enum Outcome {
    /// Collision at distance `t` in `layer`.
    Collided {
        t: f64,
        layer: usize,
    },
    Ground {
        t: f64,
    },
    Escaped,
}
