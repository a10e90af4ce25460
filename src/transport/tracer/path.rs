//! A path's state (throughputs and densities per channel, Stokes frame,
//! scattering order), the optical depths along one ray, the thread's reusable
//! work space, and Russian roulette.

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use crate::atmosphere::optics::PointOptics;
use crate::geometry::ray::{Ray, Segment, WalkEnd};
use crate::geometry::shell_exit::ShellExit;
use crate::job::options::MAX_ALBEDOS;
use crate::polarization::phase_mixture::PhaseMixture;
use crate::polarization::stokes::{Mueller, PhaseMatrix, Stokes};
use crate::sampling::sampler::Sampler;
use crate::transport::flight_density::{FlightDensity, MAX_FOLLOWED};
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
    /// Sun-aware connections along a flight: its segments and the density.
    pub(super) segments: Vec<Segment>,
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
    /// The sun-aware density of the sensor's own flight, its segments,
    /// and the ray and scene they were built for with whether it can be
    /// drawn from: kept on the thread from sample to sample (a direction's
    /// samples all fly the same view ray, and they depend on nothing
    /// else), never copied into a branch.
    pub(super) view_density: FlightDensity,
    pub(super) view_segments: Vec<Segment>,
    pub(super) view_key: Option<(ViewKey, bool)>,
    /// With it, for a polarised view ray that repeats: the density that
    /// follows the followed channels' Rayleigh single scattering along the
    /// same flight (c̄ = σ_Rayleigh), the control variate of Q and U
    /// (`Scene::polarization_control`), and whether it was built.
    pub(super) view_polarization: FlightDensity,
    pub(super) view_polarized: bool,
    /// The control variate's Z·v per followed channel for the view's
    /// frame axis it was computed for (`Scene::polarization_control`).
    pub(super) view_control: [Stokes; MAX_FOLLOWED],
    pub(super) view_control_e1: Option<DVec3>,
    /// The depths along the sensor's own flight of a view ray that
    /// repeats, how it leaves, and the scene and ray they were computed
    /// for: kept on the thread from sample to sample (what depends on the
    /// ray alone: the half chords, the basis vectors' depths; each sample
    /// combines its own spectra's), never copied into a branch
    /// (`Scene::flight_depths`).
    pub(super) view_depths: Depths,
    pub(super) view_end: Option<WalkEnd>,
    pub(super) view_depths_key: Option<ViewKey>,
    /// Whether the sensor's view ray repeats from sample to sample
    /// ([`ViewRay::Repeated`](super::view_ray::ViewRay)).
    pub(super) view_repeats: bool,
    /// The roulette's threshold for this path: the scene's, scaled by how
    /// likely the sensor's view is to scatter at all
    /// ([`Path::set_view_roulette`]).
    pub(super) roulette_threshold: f64,
    /// Whether the sensor's own flight connects to the sun along the whole
    /// flight where the scene's sun-aware connections serve the view alone
    /// ([`SunFollow::view_only`]: by day, repeated view rays and changing
    /// ones near the sun; [`ViewRay`](super::trace::ViewRay)).
    pub(super) view_sun_aware: bool,
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

/// What something kept for the sensor's own flight was computed for: its
/// owner (a scene, or a scene's [`SunFollow`], by its id), the view ray bit
/// for bit, and, for a sun-aware density, the most segments in a piece.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct ViewKey {
    owner: u64,
    origin: [u64; 3],
    dir: [u64; 3],
    layer: usize,
    pieces: usize,
}

impl ViewKey {
    pub(super) fn new(owner: u64, ray: &Ray, pieces: usize) -> ViewKey {
        let bits = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        ViewKey {
            owner,
            origin: bits(ray.origin),
            dir: bits(ray.dir),
            layer: ray.layer,
            pieces,
        }
    }
}

/// A new id for a [`Scene`](super::scene::Scene) or a [`SunFollow`]:
/// every one made in the process has its own, so what a thread keeps for
/// a view ray ([`Path::view_key`], [`Path::view_depths_key`]) never
/// serves another's.
pub(super) fn next_owner_id() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// The most segments in one piece of a sun-aware density along shared
/// paths, where building it costs per segment and followed channel
/// (chosen by measurement: docs/design-sun.md, "Sun connections along shared paths").
pub(super) const PIECE_SEGMENTS: usize = 4;

/// What sun-aware connections along shared paths draw their point from:
/// the densities of the channels of the least and the largest column
/// extinction, in that order (the second gets the larger share of the
/// draws, [`MOST_EXTINCT_SHARE`](crate::transport::flight_density::MOST_EXTINCT_SHARE)),
/// each with its optics at its centre wavelength whatever a path drew
/// inside its band (any density will do that the contributions are
/// divided by; these need no work per path).
#[derive(Debug, Clone)]
pub(super) struct SunFollow {
    /// Its own id in the process ([`next_owner_id`]).
    pub(super) id: u64,
    /// Their depths toward the sun, one profile each.
    pub(super) depth: SunDepth,
    pub(super) channels: Vec<usize>,
    /// Their coefficients per layer (`[layer·K + k]`).
    pub(super) coefficients: Vec<PointOptics>,
    /// The largest column extinction of the scene's channels, at their
    /// centre wavelengths (whether the sun lobe serves them with the sun
    /// up, `sun_lobe`).
    pub(super) max_column: f64,
    /// Where the aerosol scatters by tables: its P11 per layer and
    /// followed channel (aerosol alone, the layer's middle, the channel's
    /// centre wavelength) at [`AEROSOL_ANGLES`] scattering angles from 0
    /// to 180° (`[(layer·K + k)·AEROSOL_ANGLES + a]`); empty otherwise.
    pub(super) aerosol_p11: Vec<f64>,
    /// Only the sensor's own flight (scattering order 0) of a view that
    /// asks for it ([`Path::view_sun_aware`]) connects along the flight; every
    /// other flight connects at its collision (`Scene::with_sun_aware_view`).
    pub(super) view_only: bool,
    /// The view's own flight's density: the sun part's share and the most
    /// segments in a piece (spherical geometry: [`VIEW_SUN_AWARE_SHARE`]
    /// and [`VIEW_PIECE_SEGMENTS`]; else those of every flight).
    ///
    /// [`VIEW_SUN_AWARE_SHARE`]: super::vertex::VIEW_SUN_AWARE_SHARE
    /// [`VIEW_PIECE_SEGMENTS`]: super::vertex::VIEW_PIECE_SEGMENTS
    pub(super) view_density: (f64, usize),
}

/// What a flight's sun-following density follows: the sunlit single
/// scattering of I (σ_s·P11 at the sun's centre), or Rayleigh's alone
/// (σ_Rayleigh; the control variate of Q and U,
/// `Scene::polarization_control`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Shape {
    Sunlit,
    Rayleigh,
}

/// The scattering angles of [`SunFollow::aerosol_p11`]: every 0.25°.
pub(super) const AEROSOL_ANGLES: usize = 721;

impl SunFollow {
    /// The grid position of scattering-angle cosine `cos_theta` in
    /// [`SunFollow::aerosol_p11`]: its lower node and the fraction on.
    pub(super) fn aerosol_angle(cos_theta: f64) -> (usize, f64) {
        let x = cos_theta.clamp(-1.0, 1.0).acos() * ((AEROSOL_ANGLES - 1) as f64 / std::f64::consts::PI);
        let a = (x as usize).min(AEROSOL_ANGLES - 2);
        (a, x - a as f64)
    }

    /// The aerosol's tabulated P11 in `layer` for followed channel `k` of
    /// `followed`, at grid position `(a, f)` ([`SunFollow::aerosol_angle`]).
    #[inline]
    pub(super) fn aerosol_p11_at(&self, layer: usize, k: usize, followed: usize, (a, f): (usize, f64)) -> f64 {
        let row = &self.aerosol_p11[(layer * followed + k) * AEROSOL_ANGLES..];
        row[a] + (row[a + 1] - row[a]) * f
    }
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
        self.roulette_threshold = other.roulette_threshold;
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

    /// The roulette's threshold for a path whose sensor's view has the
    /// channels' optical depths `self.ray.tau` (to where it leaves the
    /// atmosphere or meets the ground): `threshold` times
    /// [`view_roulette_scale`] of their mean.
    #[inline]
    pub(super) fn set_view_roulette(&mut self, threshold: f64) {
        let tau = self.ray.tau.iter().sum::<f64>() / self.ray.tau.len().max(1) as f64;
        self.roulette_threshold = threshold * view_roulette_scale(tau);
    }

    /// Russian roulette on the mean effective T₀₀ over the wavelengths (the
    /// largest kept paths alive as long as 320 nm needed: 1.5× the cost
    /// for a larger error at 320 nm at equal time) below the path's
    /// threshold (`roulette_threshold`).
    #[inline]
    pub(super) fn roulette(&mut self, sampler: &mut Sampler) -> bool {
        let threshold = self.roulette_threshold;
        let mean = self.throughput.iter().map(|t| t.0[0][0]).sum::<f64>() / self.throughput.len() as f64;
        let w = mean * self.inv_mean_density;
        // A NaN weight ends the path too: one that cannot be weighed must
        // not fly on forever.
        debug_assert!(!w.is_nan(), "NaN path weight at order {}", self.order);
        if w.is_nan() || w <= 0.0 {
            return false;
        }
        if self.order < 2 || w >= threshold {
            return true;
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

/// A view whose chance to scatter at all, 1 − e^(−τ), is at least this
/// keeps the scene's roulette threshold.
pub(super) const VIEW_ROULETTE_REFERENCE: f64 = 0.4;

/// The least factor on the roulette threshold, for the thinnest views.
pub(super) const VIEW_ROULETTE_MIN_SCALE: f64 = 0.03;

/// The factor on the roulette threshold for a sensor's view of optical
/// depth `tau`: (1 − e^(−τ)) / [`VIEW_ROULETTE_REFERENCE`], between
/// [`VIEW_ROULETTE_MIN_SCALE`] and 1.
///
/// A path's throughput after its first vertex is about the chance that its
/// view scatters (the forced first flight's weight), so a fixed threshold
/// cuts short the paths of thin views, such as looking up from 15 km,
/// whose radiance is small and comes, with a bright ground, largely from
/// light that went down to the ground and back: their rouletted survivors
/// carry weights large against it. Scaled so, the roulette acts at the
/// same level relative to the view's own radiance. Any threshold leaves
/// the estimate unbiased; this one is set before the path's first
/// roulette. The tracer scales it only where sun connections are at
/// collisions (by day with `auto`). Measured (docs/design.md, "Transport":
/// directions jobs in the sky model grid's atmosphere, the cost to a noise
/// target in every direction, Σ over directions of time × the worst
/// band's and albedo's variance per path): from 15 km with the sun at 45°
/// and 10° 0.50 and 0.71 times; from the ground (views of optical depth
/// 0.5 or more) unchanged; on `bench --grid` the day tasks seen from 15 km
/// cost 0.75–0.92 times, and with sun-aware connections (the sun below
/// 10°) those seen from 15 km 1.02–1.19 times, so they keep the scene's
/// threshold.
#[inline]
pub(super) fn view_roulette_scale(tau: f64) -> f64 {
    let scatters = -(-tau.max(0.0)).exp_m1();
    (scatters / VIEW_ROULETTE_REFERENCE).clamp(VIEW_ROULETTE_MIN_SCALE, 1.0)
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
    /// A collision where no channel scatters: the path ends there.
    Absorbed,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thin_views_roulette_in_proportion_to_their_chance_to_scatter() {
        // Views that scatter at least as often as the reference keep the
        // threshold; thinner ones scale it by their chance to scatter,
        // down to the floor (an empty view).
        let reference_tau = -(1.0 - VIEW_ROULETTE_REFERENCE).ln();
        for tau in [reference_tau, 1.0, 5.0, f64::INFINITY] {
            assert!((view_roulette_scale(tau) - 1.0).abs() < 1e-12, "τ {tau}");
        }
        for tau in [0.02_f64, 0.1, 0.3] {
            let want: f64 = (1.0 - (-tau).exp()) / VIEW_ROULETTE_REFERENCE;
            assert!((view_roulette_scale(tau) - want).abs() < 1e-12, "τ {tau}");
        }
        assert_eq!(view_roulette_scale(0.0), VIEW_ROULETTE_MIN_SCALE);
        assert_eq!(view_roulette_scale(1e-4), VIEW_ROULETTE_MIN_SCALE);
        // A path's threshold from its view's mean optical depth.
        let mut path = Path::default();
        path.ray.tau = vec![0.01, 0.03];
        path.set_view_roulette(0.03);
        assert!((path.roulette_threshold - 0.03 * view_roulette_scale(0.02)).abs() < 1e-15);
    }
}
