//! The path tracer: backward (sensor-to-sun) polarised Monte Carlo, one
//! path carrying every channel of a task (N channels; N = 1 is a single
//! wavelength or band, with nothing special about it).
//!
//! A path starts at the observer looking along the viewing direction v and
//! is traced against the photon direction. Per channel its throughput is a
//! 4×4 Mueller matrix T (scalar factors folded in) mapping the Stokes
//! vector arriving at the current vertex, in the current reference frame,
//! to the Stokes vector at the sensor in the frame of v
//! (CONVENTIONS.md). Radiance is per unit solar irradiance normal to the
//! beam (E0 = 1) unless a source spectrum weights it (`with_source`).
//!
//! **What is shared and what is per channel.** The geometry of a path (its
//! vertices, directions and Stokes frames) is shared; each channel has its
//! own throughput and its own path density. One channel per path, drawn
//! uniformly (the hero), makes every sampling decision; channel λ scores
//! its path integrand over the mixture of the N channels' path densities,
//! f_λ(path) / ((1/N)·Σ_j p_j(path)): hero-wavelength spectral MIS with
//! the balance heuristic (Wilkie et al. 2014). Densities are carried as
//! ratios to the hero's, so nothing under- or overflows, and every weight
//! is at most N times the single-channel estimator's f_λ/p_λ, itself at
//! most 1 per flight and per scattering.
//!
//! **Free flights** (`flight`): one routine. Tentative collisions against
//! the hero's majorant, each real with probability σ_t/σ_maj (delta
//! tracking, in the smooth medium or with inflated majorants); with σ_t
//! itself the majorant (the layered medium) the first is real and is found
//! by inverting the hero's optical depth. A flight whose end would score
//! nothing (leaving through the top, a black ground) is forced to collide
//! (truncated exponential, weight 1 − e^(−τ)); one toward a reflecting
//! ground is analog, or at the sensor's first vertex split into both ends.
//! A collision at x has density σ_t,λ(x)·e^(−τ_λ(x)) at every channel
//! (over its forcing probability when forced). Absorption is a weight:
//! σ_s/σ_t at each collision.
//!
//! **Scattering**: the σ_s-weighted mixture of Rayleigh (with
//! depolarisation) and Henyey–Greenstein phase matrices, in the
//! scattering-plane frame (e2 = k_in × k_out normalised, e1 = e2 × k), the
//! path's frame rotated into it. The new direction comes from one channel's
//! phase function (picked uniformly) and one component (σ_i/σ_s); every
//! channel's weight is its matrix over the mean of the channels' P11
//! (one-sample MIS over channels and components).
//!
//! **Sun connections** (next-event estimation) at every scattering and
//! ground vertex, or along the whole flight instead: K stratified points
//! of the hero's forced density (`sun_samples_per_flight`), or one point
//! from a density following the sunlit single scattering (sun-aware,
//! [`FlightDensity`]). Such a point's density is the same for every
//! channel, so the path's MIS weight applies to it unchanged. Shadow rays
//! give every channel's transmittance, exact or ratio-tracked against the
//! largest of the channels' majorants, along the direct beam's path (in
//! pseudo-spherical geometry through spherical shells). A shadow ray that
//! meets the planet scores nothing; escaping paths score nothing (the
//! unscattered sun is not counted).
//!
//! **Ground**: Lambertian and depolarising. Every albedo of the scene comes
//! from the same paths: the throughput carries the albedos' mean ā, each
//! albedo a weight (a/ā)^k after k reflections.
//!
//! **Splitting and roulette**: the sensor's first vertex is split (both
//! ends of a flight toward a reflecting ground; two scattering directions
//! a quarter turn apart, half the weight each), into a spare path kept
//! per thread. After the second vertex, Russian roulette on the mean
//! effective T₀₀ over the channels (survival min(1, T₀₀/0.1), the survivor
//! divided by it).
//!
//! **Channels** may be bands (`band_width_nm` > 0): each path draws its
//! own wavelength inside each band, stratified over the estimate's samples
//! (`Sampler::stratified`); the optics at any wavelength come from the
//! atmosphere's terms (`spectral_terms`). Optical depths along a ray are
//! computed once per extinction basis vector (the atmosphere's extinction
//! terms, or the channels' own σ_t profiles for monochromatic channels of
//! the layered medium when there are fewer channels than terms) and
//! combined per channel, τ_λ = Σ_b W_λb·τ_b: in closed form through
//! spherical shells of the layered medium, else segment by segment (in the
//! smooth medium each term with its shape inside the layer, by
//! quadrature).
//!
//! What was measured and chosen (hero choice, roulette, splitting, the
//! sun-aware share): README, "Throughput" and "Sun connections".

use crate::job::spectrum::Channel;
use std::cell::RefCell;
use std::f64::consts::FRAC_1_PI;
use std::ops::ControlFlow;
use std::sync::Arc;

use glam::DVec3;

use crate::atmosphere::layer_shape::LayerShape;
use crate::atmosphere::optics::PointOptics;
use crate::atmosphere::spectral_terms::{SpectralTerms, TermOptics, TermShape};
use crate::geometry::shell::Geometry;
use crate::geometry::sun::Sun;
use crate::job::options::{MAX_ALBEDOS, Settings, SunTransmittance};
use crate::physics::solar::SolarSpectrum;
use crate::polarization::phase::PhaseFunction;
use crate::polarization::phase::PhaseMixture;
use crate::polarization::stokes::{Mueller, PhaseMatrix, Stokes};
use crate::sampling::sampler::Sampler;
use crate::transport::flight_density::FlightDensity;
use crate::transport::integrator::{
    INV_4PI, ROULETTE_THRESHOLD, SUN_AWARE_SHARE, cosine_hemisphere, phase_mixture, pick_component, quarter_turn,
    reference_albedo, reflects, scattering_frame, sun_ray,
};
use crate::transport::medium::{density_steps, shape_integrals};
use crate::transport::sun_depth::SunDepth;
use crate::transport::tracking::{self, FlightEnd, Ray, Segment, ShellExit, WalkEnd};

/// The widest wavelength cell of the direct irradiance's band average (nm).
pub const DIRECT_CELL_NM: f64 = 0.05;

/// What the channels' optics are on one path: each channel's term
/// responses (`[channel·terms + term]`), extinction weights on the
/// basis (`[channel·basis + b]`) and source factors (E0 at the channel's
/// wavelength, or 1 without a source spectrum).
#[derive(Debug, Clone, Default)]
struct ChannelSpectra {
    responses: Vec<TermOptics>,
    weights: Vec<f64>,
    source: Vec<f64>,
    /// Where every path shares them (monochromatic channels): each
    /// channel's σ_t per layer (`[channel·layers + layer]`; the layer mean in
    /// the smooth medium) and, in the layered medium, its coefficients per
    /// layer likewise; empty otherwise.
    sigma: Vec<f64>,
    coefficients: Vec<PointOptics>,
}

/// The basis optical depths are computed on.
#[derive(Debug, Clone)]
enum Basis {
    /// The extinction terms (their indices among the atmosphere's terms).
    Terms(Vec<usize>),
    /// One σ_t profile per (monochromatic) channel.
    Channels,
}

/// Everything a path needs: the atmosphere, its channels, the sun, the
/// ground and the transport's settings.
#[derive(Debug, Clone)]
pub struct Scene {
    pub geometry: Geometry,
    pub sun: Sun,
    /// Ground albedos, all estimated from the same paths (at most
    /// [`MAX_ALBEDOS`]): a path with k ground reflections scores a^k times
    /// its albedo-free contribution, so L(a) = Σ_k a^k L_k exactly. Flights
    /// toward the ground are forced only when no albedo reflects, so an
    /// albedo 0 in a list with reflecting ones is noisier than alone
    /// (README, "albedo").
    pub albedos: Vec<f64>,
    pub settings: Settings,
    levels_km: Vec<f64>,
    terms: SpectralTerms,
    channels: Vec<Channel>,
    basis: Basis,
    /// The number of basis vectors.
    basis_len: usize,
    /// σ of each basis vector per layer (`[layer·basis + b]`).
    basis_sigma: Vec<f64>,
    /// Its steps per level (`[b·levels + level]`, see `Medium::steps`).
    basis_steps: Vec<f64>,
    /// The spectra of monochromatic channels (all paths share them); for
    /// bands, each path has its own.
    fixed: Option<ChannelSpectra>,
    /// The extraterrestrial irradiance radiances are weighted by (absolute
    /// units); `None`: per unit E0.
    source: Option<Arc<SolarSpectrum>>,
    /// Sun-aware connections along every flight (`None`: connections at
    /// collisions).
    sun_follow: Option<SunFollow>,
    /// The smooth medium's shape of each layer (`None`: layered, σ constant
    /// in each layer).
    shapes: Option<Vec<LayerShape>>,
    /// How each term, and each basis vector, varies inside a smooth layer.
    term_shapes: Vec<TermShape>,
    basis_shapes: Vec<TermShape>,
    /// Majorants are this times a bound on σ_t over each layer (1 and the
    /// layered medium: σ_t itself, every tentative collision real).
    majorant_scale: f64,
    /// Pseudo-spherical geometry (a plane-parallel scene): the direct beam
    /// reaching a point at altitude z is attenuated along its path through
    /// spherical shells of this planet radius (km), as DISORT's
    /// pseudo-spherical mode does; everything else stays plane-parallel.
    pseudo_spherical_radius_km: Option<f64>,
}

/// How the medium between a scene's levels is modelled and tracked.
#[derive(Debug, Clone, Default)]
pub struct MediumSettings {
    /// The smooth medium's shape of each layer (`None`: layered).
    pub shapes: Option<Vec<LayerShape>>,
    /// Majorants over a bound on σ_t (≥ 1).
    pub majorant_scale: f64,
    /// Pseudo-spherical geometry's planet radius (km), in a plane-parallel
    /// scene.
    pub pseudo_spherical_radius_km: Option<f64>,
}

/// A path's state; its per-wavelength vectors are reused from sample to
/// sample on each thread ([`WORK`]).
#[derive(Default, Clone)]
struct Path {
    /// Per wavelength: its path integrand over the hero's path density.
    throughput: Vec<Mueller>,
    /// Per wavelength: its path density over the hero's.
    density_ratio: Vec<f64>,
    /// 1 / mean of `density_ratio` (the balance heuristic's denominator).
    inv_mean_density: f64,
    hero: usize,
    frame_e1: DVec3,
    order: u32,
    albedo_weights: [f64; MAX_ALBEDOS],
    /// `[λ·albedos + albedo]`.
    radiance: Vec<Stokes>,
    albedos: usize,
    /// The depths along the current flight, and along the last shadow ray
    /// toward the sun (kept apart: sun-aware connections walk shadow rays
    /// before the flight's collision is drawn).
    ray: Depths,
    shadow: Depths,
    /// Scratch per wavelength: optical depths to the collision, forcing
    /// probabilities, phase mixtures and matrices at the last collision.
    tau_hit: Vec<f64>,
    forced: Vec<f64>,
    mixtures: Vec<PhaseMixture>,
    matrices: Vec<PhaseMatrix>,
    /// Sun-aware connections along a flight: its segments, the basis
    /// depths along it at each one's start, and the density.
    segments: Vec<Segment>,
    segment_tau: Vec<f64>,
    density: FlightDensity,
    /// Per channel, the weight of a point connected to the sun off the
    /// collision (sun-aware or stratified), and the transmittance of the
    /// last shadow ray.
    factors: Vec<f64>,
    shadow_tr: Vec<f64>,
    /// Scratch: basis depths to a point.
    point_basis: Vec<f64>,
    /// The hero's σ_t per layer, where the spectra do not hold it.
    hero_sigma: Vec<f64>,
}

/// Optical depths along one ray to where it leaves.
#[derive(Default, Clone)]
struct Depths {
    /// Per basis vector (also scratch while a flight is located).
    tau_basis: Vec<f64>,
    /// Per channel.
    tau: Vec<f64>,
    /// Per level: the ray's half chords through concentric shells, and
    /// how it crosses them (spherical geometry).
    chords: Vec<f64>,
    exit: Option<ShellExit>,
}

impl Depths {
    fn reset(&mut self, n: usize, levels: usize, basis: usize) {
        self.tau.resize(n, 0.0);
        self.tau_basis.resize(basis, 0.0);
        self.chords.resize(levels, 0.0);
    }
}

/// The most segments in one piece of a sun-aware density along shared
/// paths, where building it costs per segment and followed channel
/// (chosen by measurement: README, "Sun connections along shared paths").
const PIECE_SEGMENTS: usize = 4;

/// What sun-aware connections along shared paths draw their point from:
/// the densities of the channels of the least and the largest column
/// extinction, each with its optics at its centre wavelength whatever a
/// path drew inside its band (any density will do that the contributions
/// are divided by; these need no work per path).
#[derive(Debug, Clone)]
struct SunFollow {
    /// Their depths toward the sun, one profile each.
    depth: SunDepth,
    channels: Vec<usize>,
    /// Their coefficients per layer (`[layer·K + k]`).
    coefficients: Vec<PointOptics>,
}

/// A thread's reusable state: the path, the spare the path's first vertex
/// splits into, and, for bands, its spectra.
#[derive(Default)]
struct Work {
    path: Path,
    spare: Path,
    spectra: ChannelSpectra,
}

thread_local! {
    static WORK: RefCell<Work> = RefCell::new(Work::default());
}

impl Path {
    fn reset(&mut self, n: usize, levels: usize, basis: usize, albedos: usize, frame_e1: DVec3, hero: usize) {
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
    }

    /// This path as a branch of `other`: its state (throughputs, densities,
    /// frame, order, albedo weights, radiance and the matrices of its last
    /// collision), with scratch of the same sizes but not its contents.
    fn branch_from(&mut self, other: &Path) {
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
    }

    /// Halves every wavelength's throughput (one of two branches).
    fn halve(&mut self) {
        for t in self.throughput.iter_mut() {
            *t = *t * 0.5;
        }
    }

    /// Multiplies wavelength `w`'s density ratio by `k`.
    fn scale_density(&mut self, w: usize, k: f64) {
        self.density_ratio[w] *= k;
    }

    /// Refreshes the balance heuristic's denominator after density changes.
    fn densities_changed(&mut self) {
        let mean = self.density_ratio.iter().sum::<f64>() / self.density_ratio.len() as f64;
        self.inv_mean_density = 1.0 / mean;
    }

    /// Adds wavelength `w`'s contribution `s` (throughput already in it),
    /// with the balance heuristic over the wavelengths' path densities.
    fn add(&mut self, w: usize, s: Stokes) {
        let s = s * self.inv_mean_density;
        let base = w * self.albedos;
        for a in 0..self.albedos {
            self.radiance[base + a] += s * self.albedo_weights[a];
        }
    }

    /// Russian roulette on the mean effective T₀₀ over the wavelengths (the
    /// largest kept paths alive as long as 320 nm needed: 1.5× the cost
    /// for a larger error at 320 nm at equal time).
    fn roulette(&mut self, sampler: &mut Sampler) -> bool {
        let mean = self.throughput.iter().map(|t| t.0[0][0]).sum::<f64>() / self.throughput.len() as f64;
        let w = mean * self.inv_mean_density;
        if self.order < 2 || w >= ROULETTE_THRESHOLD {
            return w > 0.0;
        }
        let q = w / ROULETTE_THRESHOLD;
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
enum Outcome {
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

impl Scene {
    /// A scene of `channels` over an atmosphere's levels and terms.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        geometry: Geometry,
        levels_km: Vec<f64>,
        terms: SpectralTerms,
        channels: Vec<Channel>,
        sun: Sun,
        albedos: Vec<f64>,
        settings: Settings,
        medium: MediumSettings,
    ) -> Scene {
        let layers = levels_km.len() - 1;
        let n = channels.len();
        let banded = channels.iter().any(|c| c.band_width_nm > 0.0);
        let t = terms.terms.len();
        let mut centre = vec![TermOptics::default(); n * t];
        for (w, c) in channels.iter().enumerate() {
            terms.responses_into(c.lambda_nm, &mut centre[w * t..(w + 1) * t]);
        }
        let ext_terms: Vec<usize> = (0..t).filter(|&k| terms.terms[k].spectrum.has_extinction()).collect();
        // The channels' own profiles only where σ is constant per layer.
        let basis = if !banded && ext_terms.len() > n && medium.shapes.is_none() {
            Basis::Channels
        } else {
            Basis::Terms(ext_terms)
        };
        // Each basis vector's σ per layer.
        let profiles: Vec<Vec<f64>> = match &basis {
            Basis::Terms(k) => k.iter().map(|&k| terms.terms[k].amount.clone()).collect(),
            Basis::Channels => (0..n)
                .map(|w| {
                    (0..layers)
                        .map(|l| terms.layer_sum(l, &centre[w * t..(w + 1) * t]).ext)
                        .collect()
                })
                .collect(),
        };
        let b = profiles.len();
        let term_shapes: Vec<TermShape> = terms.terms.iter().map(|t| t.shape()).collect();
        let basis_shapes = match &basis {
            Basis::Terms(k) => k.iter().map(|&k| term_shapes[k]).collect(),
            Basis::Channels => vec![TermShape::Flat; b],
        };
        let basis_sigma = (0..layers).flat_map(|l| profiles.iter().map(move |p| p[l])).collect();
        let basis_steps = profiles.iter().flat_map(|p| density_steps(p)).collect();
        let mut scene = Scene {
            geometry,
            sun,
            albedos,
            settings,
            levels_km,
            terms,
            channels,
            basis,
            basis_len: b,
            basis_sigma,
            basis_steps,
            fixed: None,
            source: None,
            sun_follow: None,
            shapes: medium.shapes,
            term_shapes,
            basis_shapes,
            majorant_scale: medium.majorant_scale.max(1.0),
            pseudo_spherical_radius_km: medium.pseudo_spherical_radius_km,
        };
        if !banded {
            let mut fixed = ChannelSpectra {
                responses: centre,
                weights: vec![0.0; n * b],
                source: Vec::new(),
                sigma: Vec::new(),
                coefficients: Vec::new(),
            };
            scene.refresh_weights(&mut fixed);
            let layers = scene.levels_km.len() - 1;
            fixed.sigma = (0..n * layers)
                .map(|i| scene.sigma_t(&fixed, i % layers, i / layers))
                .collect();
            if scene.shapes.is_none() {
                let layers = scene.levels_km.len() - 1;
                fixed.coefficients = (0..n * layers)
                    .map(|i| scene.coefficients(&fixed, i % layers, i / layers, 0.0))
                    .collect();
            }
            scene.refresh_source(&mut fixed, |w| scene.channels[w].lambda_nm);
            scene.fixed = Some(fixed);
        }
        scene
    }

    /// The scene with radiances weighted by `source` at each path's
    /// wavelengths: absolute units, band averages of E0(λ)·L(λ). Every
    /// channel's wavelengths must lie inside the spectrum (the job checks
    /// it); outside, the source counts as 0.
    pub fn with_source(mut self, source: Arc<SolarSpectrum>) -> Scene {
        self.source = Some(source);
        if let Some(mut fixed) = self.fixed.take() {
            self.refresh_source(&mut fixed, |w| self.channels[w].lambda_nm);
            self.fixed = Some(fixed);
        }
        self
    }

    /// The scene with sun-aware connections: at every flight, one point
    /// drawn along it from a density that follows the sunlit single
    /// scattering of the channels ([`Scene::sun_along_flight`])
    /// instead of the connection at the collision.
    pub fn with_sun_aware(mut self) -> Scene {
        let layers = self.levels_km.len() - 1;
        // Each channel's coefficients per layer at its centre wavelength,
        // and its column extinction.
        let t = self.terms.terms.len();
        let mut responses = vec![TermOptics::default(); t];
        let mut centre: Vec<(f64, usize, Vec<PointOptics>)> = self
            .channels
            .iter()
            .enumerate()
            .map(|(w, c)| {
                self.terms.responses_into(c.lambda_nm, &mut responses);
                let coeffs: Vec<PointOptics> = (0..layers)
                    .map(|l| self.terms.layer_sum(l, &responses).coefficients())
                    .collect();
                let column = coeffs
                    .iter()
                    .enumerate()
                    .map(|(l, c)| c.sigma_t * (self.levels_km[l + 1] - self.levels_km[l]))
                    .sum::<f64>();
                (column, w, coeffs)
            })
            .collect();
        centre.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n = centre.len();
        let mut picks = vec![0, n - 1];
        picks.dedup();
        let followed: Vec<&(f64, usize, Vec<PointOptics>)> = picks.iter().map(|&i| &centre[i]).collect();
        let k = followed.len();
        let sigmas: Vec<Vec<f64>> = followed
            .iter()
            .map(|f| f.2.iter().map(|c| c.sigma_t).collect())
            .collect();
        let depth = SunDepth::of_profiles(
            &self.levels_km,
            &sigmas,
            &self.geometry,
            self.sun.direction,
            self.pseudo_spherical_radius_km.is_some(),
        );
        let mut coefficients = Vec::with_capacity(layers * k);
        for l in 0..layers {
            coefficients.extend(followed.iter().map(|f| f.2[l]));
        }
        self.sun_follow = Some(SunFollow {
            depth,
            channels: followed.iter().map(|f| f.1).collect(),
            coefficients,
        });
        self
    }

    /// Fills the spectra's source factors for the channels' wavelengths
    /// `lambda(channel)`.
    fn refresh_source(&self, spectra: &mut ChannelSpectra, lambda: impl Fn(usize) -> f64) {
        spectra.source.clear();
        spectra
            .source
            .extend((0..self.channels.len()).map(|w| match &self.source {
                Some(solar) => solar.irradiance(lambda(w)).unwrap_or(0.0),
                None => 1.0,
            }));
    }

    /// Fills the spectra's extinction weights on the basis from its
    /// responses.
    fn refresh_weights(&self, spectra: &mut ChannelSpectra) {
        let (n, t, b) = (self.channels.len(), self.terms.terms.len(), self.basis_len);
        match &self.basis {
            Basis::Terms(k) => {
                spectra.weights.resize(n * b, 0.0);
                for w in 0..n {
                    for (j, &k) in k.iter().enumerate() {
                        spectra.weights[w * b + j] = spectra.responses[w * t + k].ext;
                    }
                }
            }
            Basis::Channels => {
                spectra.weights.clear();
                spectra.weights.resize(n * n, 0.0);
                for w in 0..n {
                    spectra.weights[w * n + w] = 1.0;
                }
            }
        }
    }

    /// The spectra of one path: each band's wavelength drawn (stratified
    /// over the estimate's samples, one dimension per channel).
    fn draw_spectra(&self, spectra: &mut ChannelSpectra, sampler: &Sampler) {
        let t = self.terms.terms.len();
        spectra.responses.resize(self.channels.len() * t, TermOptics::default());
        let lambda = |w: usize| self.channels[w].wavelength(sampler.stratified(w as u64));
        for w in 0..self.channels.len() {
            self.terms
                .responses_into(lambda(w), &mut spectra.responses[w * t..(w + 1) * t]);
        }
        self.refresh_weights(spectra);
        self.refresh_source(spectra, lambda);
    }

    /// The direct solar irradiance on a horizontal plane at the observer
    /// in channel `w`: μ0·T(λ) (times the source at λ, when radiances are
    /// weighted by one), averaged over the band by the composite midpoint
    /// rule on cells of at most [`DIRECT_CELL_NM`] (the ozone data's
    /// spacing is 0.1 nm); a monochromatic channel's value at its
    /// wavelength. Optical depths are exact: one column per extinction
    /// term along the sun's direction, Σ_t response_t(λ)·τ_t.
    pub fn direct_horizontal(&self, altitude_km: f64, w: usize) -> f64 {
        let origin = self.geometry.observer_position(altitude_km);
        let mu0 = self.sun.direction.dot(self.geometry.up(origin));
        if mu0 <= 0.0 {
            return 0.0;
        }
        mu0 * self.direct_normal(altitude_km, w, true)
    }

    /// The direct beam at the observer in channel `w`, normal to it: the
    /// band average of T(λ), times the source at λ with `weighted` and a
    /// source spectrum (as [`Scene::direct_horizontal`]); 0 for a
    /// sun below the observer's horizon or behind the planet.
    pub fn direct_normal(&self, altitude_km: f64, w: usize, weighted: bool) -> f64 {
        let origin = self.geometry.observer_position(altitude_km);
        let dir = self.sun.direction;
        let mu0 = dir.dot(self.geometry.up(origin));
        if mu0 <= 0.0 {
            return 0.0;
        }
        let columns = match tracking::layer_at(&self.levels_km, altitude_km, mu0) {
            Some(layer) => match self.term_columns_in(
                sun_ray(
                    self.geometry,
                    self.pseudo_spherical_radius_km,
                    Ray { origin, dir, layer },
                ),
                f64::INFINITY,
            ) {
                Some(c) => c,
                None => return 0.0,
            },
            None => vec![0.0; self.terms.terms.len()],
        };
        self.band_average(w, &columns, weighted)
    }

    /// Each term's amount integrated along `ray` over at most `length` (km),
    /// or `None` when the ray meets the ground first.
    pub fn term_columns(&self, ray: &Ray, length: f64) -> Option<Vec<f64>> {
        self.term_columns_in((self.geometry, *ray), length)
    }

    /// [`Scene::term_columns`] along a ray of a given geometry.
    fn term_columns_in(&self, (geometry, ray): (Geometry, Ray), length: f64) -> Option<Vec<f64>> {
        let terms = &self.terms.terms;
        let mut columns = vec![0.0; terms.len()];
        let end = tracking::walk(&geometry, &self.levels_km, &ray, |seg| {
            let t1 = seg.t1.min(length);
            if t1 > seg.t0 {
                let integrals = match &self.shapes {
                    None => [t1 - seg.t0; 3],
                    Some(shapes) => {
                        let bounds = (self.levels_km[seg.layer], self.levels_km[seg.layer + 1]);
                        shape_integrals(&shapes[seg.layer], bounds, &geometry, ray.origin, ray.dir, seg.t0, t1)
                    }
                };
                for ((c, t), shape) in columns.iter_mut().zip(terms).zip(&self.term_shapes) {
                    *c += t.amount[seg.layer] * integrals[shape.index()];
                }
            }
            if seg.t1 >= length {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        // A ray ending on the ground within a millimetre of `length` (a
        // point on the ground) reaches it.
        match end {
            WalkEnd::Ground { t } if t < length - 1e-6 => None,
            _ => Some(columns),
        }
    }

    /// The band average over channel `w` of e^(−Σ_t response_t(λ)·column_t)
    /// (times the source at λ with `weighted` and a source spectrum), by
    /// the composite midpoint rule on cells of at most [`DIRECT_CELL_NM`]
    /// (the ozone data's spacing is 0.1 nm); a monochromatic channel's
    /// value at its wavelength.
    pub fn band_average(&self, w: usize, columns: &[f64], weighted: bool) -> f64 {
        let source = self.source.as_ref().filter(|_| weighted).map(|solar| {
            self.cell_wavelengths(w)
                .map(|lambda| solar.irradiance(lambda).unwrap_or(0.0))
                .collect::<Vec<f64>>()
        });
        Scene::band_average_of(&self.band_cells(w), columns, source.as_deref())
    }

    /// The midpoints of channel `w`'s cells (its wavelength alone for a
    /// monochromatic channel).
    fn cell_wavelengths(&self, w: usize) -> impl Iterator<Item = f64> {
        let channel = self.channels[w];
        let cells = (channel.band_width_nm / DIRECT_CELL_NM).ceil().max(1.0) as usize;
        (0..cells).map(move |k| channel.wavelength((k as f64 + 0.5) / cells as f64))
    }

    /// The extinction responses of every term at the midpoints of channel
    /// `w`'s cells (`[cell·terms + term]`), for [`Scene::band_average_of`].
    pub fn band_cells(&self, w: usize) -> Vec<f64> {
        let mut responses = vec![TermOptics::default(); self.terms.terms.len()];
        let mut out = Vec::new();
        for lambda in self.cell_wavelengths(w) {
            self.terms.responses_into(lambda, &mut responses);
            out.extend(responses.iter().map(|r| r.ext));
        }
        out
    }

    /// The mean over a band's cells (responses from
    /// [`Scene::band_cells`]) of e^(−Σ response·column), each cell
    /// times its `source` value when given.
    pub fn band_average_of(cells: &[f64], columns: &[f64], source: Option<&[f64]>) -> f64 {
        let t = columns.len().max(1);
        let n = (cells.len() / t).max(1);
        let sum: f64 = cells
            .chunks_exact(t)
            .enumerate()
            .map(|(k, r)| {
                let tau = r.iter().zip(columns).map(|(a, c)| a * c).sum::<f64>().max(0.0);
                (-tau).exp() * source.map_or(1.0, |s| s[k])
            })
            .sum();
        sum / n as f64
    }

    /// The atmosphere's levels (km).
    pub fn levels_km(&self) -> &[f64] {
        &self.levels_km
    }

    /// The number of channels.
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// σ_t of channel `w` in `layer`.
    #[inline]
    fn sigma_t(&self, spectra: &ChannelSpectra, layer: usize, w: usize) -> f64 {
        if let Some(&sigma) = spectra.sigma.get(w * (self.levels_km.len() - 1) + layer) {
            return sigma;
        }
        self.basis_parts(spectra, layer, w)
            .map(|(x, _)| x)
            .sum::<f64>()
            .max(0.0)
    }

    /// Channel `w`'s σ_t in `layer` by basis vector: each vector's share
    /// W·σ, and how it varies inside a smooth layer.
    #[inline]
    fn basis_parts<'a>(
        &'a self,
        spectra: &'a ChannelSpectra,
        layer: usize,
        w: usize,
    ) -> impl Iterator<Item = (f64, TermShape)> + 'a {
        let b = self.basis_len;
        let weights = &spectra.weights[w * b..(w + 1) * b];
        let sigma = &self.basis_sigma[layer * b..(layer + 1) * b];
        weights
            .iter()
            .zip(sigma)
            .zip(&self.basis_shapes)
            .map(|((a, s), shape)| (a * s, *shape))
    }

    /// Adds every basis vector's σ·`len` of `layer` to `tau`.
    #[inline]
    fn accumulate(&self, tau: &mut [f64], layer: usize, len: f64) {
        let b = tau.len();
        for (t, s) in tau.iter_mut().zip(&self.basis_sigma[layer * b..(layer + 1) * b]) {
            *t += s * len;
        }
    }

    /// Each channel's optical depth from the basis depths.
    fn combine(spectra: &ChannelSpectra, tau_basis: &[f64], tau: &mut [f64]) {
        let b = tau_basis.len();
        for (w, t) in tau.iter_mut().enumerate() {
            let weights = &spectra.weights[w * b..(w + 1) * b];
            *t = weights.iter().zip(tau_basis).map(|(a, s)| a * s).sum::<f64>().max(0.0);
        }
    }

    fn reflects(&self) -> bool {
        reflects(&self.albedos)
    }

    fn order_done(&self, order: u32) -> bool {
        self.settings.order_done(order)
    }

    /// The coefficients of channel `w` at fraction `f` of `layer` (see
    /// [`Scene::fraction`]).
    fn coefficients(&self, spectra: &ChannelSpectra, layer: usize, w: usize, f: f64) -> PointOptics {
        if let Some(c) = spectra.coefficients.get(w * (self.levels_km.len() - 1) + layer) {
            return *c;
        }
        let t = self.terms.terms.len();
        let responses = &spectra.responses[w * t..(w + 1) * t];
        let sum = match &self.shapes {
            None => self.terms.layer_sum(layer, responses),
            Some(shapes) => self.terms.point_sum(layer, responses, |k| {
                self.term_shapes[k].factor(Some(&shapes[layer]), f)
            }),
        };
        let mut c = sum.coefficients();
        // The extinction the flights see (the same sum, on the basis).
        c.sigma_t = self.sigma_t_point(spectra, layer, w, f);
        c
    }

    /// Whether σ_t is constant in each layer and tracked against itself:
    /// optical depths in closed form, every tentative collision real.
    fn exact_majorant(&self) -> bool {
        self.shapes.is_none() && self.majorant_scale == 1.0
    }

    /// Whether flights that would end without contributing are forced to
    /// collide ([`Settings::forced_collisions`], with an exact majorant).
    fn forced(&self) -> bool {
        self.settings.forced_collisions && self.exact_majorant()
    }

    /// Where `x` lies in `layer` of `geometry`, 0 at its bottom and 1 at its
    /// top, for the smooth medium's shapes (0 in the layered medium, where
    /// nothing depends on it).
    #[inline]
    fn fraction(&self, geometry: &Geometry, layer: usize, x: DVec3) -> f64 {
        if self.shapes.is_none() {
            return 0.0;
        }
        let (z0, z1) = (self.levels_km[layer], self.levels_km[layer + 1]);
        ((geometry.altitude(x) - z0) / (z1 - z0)).clamp(0.0, 1.0)
    }

    /// σ_t of channel `w` at fraction `f` of `layer`.
    #[inline]
    fn sigma_t_point(&self, spectra: &ChannelSpectra, layer: usize, w: usize, f: f64) -> f64 {
        let Some(shapes) = &self.shapes else {
            return self.sigma_t(spectra, layer, w);
        };
        let shape = Some(&shapes[layer]);
        self.basis_parts(spectra, layer, w)
            .map(|(x, kind)| x * kind.factor(shape, f))
            .sum::<f64>()
            .max(0.0)
    }

    /// The majorant of channel `w` in `layer`: `majorant_scale` times a
    /// bound on its σ_t over the layer (σ_t itself in the layered medium;
    /// in the smooth one, each basis vector's largest factor).
    fn majorant(&self, spectra: &ChannelSpectra, layer: usize, w: usize) -> f64 {
        let bound = match &self.shapes {
            None => self.sigma_t(spectra, layer, w),
            Some(shapes) => {
                let shape = Some(&shapes[layer]);
                self.basis_parts(spectra, layer, w)
                    .map(|(x, kind)| x.abs() * kind.max_factor(shape))
                    .sum::<f64>()
            }
        };
        self.majorant_scale * bound
    }

    /// Adds every basis vector's optical depth over [t0, t1] of `ray` (in
    /// `layer` of `geometry`) to `tau`.
    fn accumulate_along(&self, tau: &mut [f64], geometry: &Geometry, ray: &Ray, layer: usize, t0: f64, t1: f64) {
        let Some(shapes) = &self.shapes else {
            return self.accumulate(tau, layer, t1 - t0);
        };
        let bounds = (self.levels_km[layer], self.levels_km[layer + 1]);
        let integrals = shape_integrals(&shapes[layer], bounds, geometry, ray.origin, ray.dir, t0, t1);
        let b = tau.len();
        let sigma = &self.basis_sigma[layer * b..(layer + 1) * b];
        for ((t, s), shape) in tau.iter_mut().zip(sigma).zip(&self.basis_shapes) {
            *t += s * integrals[shape.index()];
        }
    }

    /// Position of an observer at `altitude_km` (on the z axis).
    pub fn observer_position(&self, altitude_km: f64) -> DVec3 {
        self.geometry.observer_position(altitude_km)
    }

    /// The number of values a sample gives: channels × albedos.
    pub fn value_count(&self) -> usize {
        self.channels.len() * self.albedos.len().min(MAX_ALBEDOS)
    }

    /// One sample of the diffuse Stokes radiance arriving at the observer at
    /// `altitude_km` from viewing direction `view` (unit, observer frame),
    /// referred to the axis `e1` (unit, ⟂ `view`; e.g. the meridian axis,
    /// see [`crate::polarization::stokes_frame`]), at every channel and albedo, into
    /// `out[channel·albedos + albedo]` ([`Scene::value_count`] values).
    pub fn radiance_sample(&self, altitude_km: f64, view: DVec3, e1: DVec3, sampler: &mut Sampler, out: &mut [Stokes]) {
        WORK.with_borrow_mut(|work| {
            let Work { path, spare, spectra } = work;
            let spectra = match &self.fixed {
                Some(fixed) => fixed,
                None => {
                    self.draw_spectra(spectra, sampler);
                    &*spectra
                }
            };
            let n = self.channels.len();
            let albedos = self.albedos.len().min(MAX_ALBEDOS);
            let hero = ((sampler.next_f64() * n as f64) as usize).min(n - 1);
            let levels = &self.levels_km;
            path.reset(n, levels.len(), self.basis_len, albedos, e1, hero);
            if spectra.sigma.is_empty() {
                path.hero_sigma.clear();
                path.hero_sigma
                    .extend((0..levels.len() - 1).map(|l| self.sigma_t(spectra, l, hero)));
            }
            let origin = self.geometry.observer_position(altitude_km);
            let up = self.geometry.up(origin);
            match tracking::layer_at(levels, altitude_km, view.dot(up)) {
                Some(layer) => self.trace(
                    path,
                    spectra,
                    Ray {
                        origin,
                        dir: view,
                        layer,
                    },
                    sampler,
                    Some(spare),
                ),
                None => {
                    if altitude_km <= levels[0] && view.dot(up) < 0.0 {
                        self.trace_on_from_ground(path, spectra, origin, sampler);
                    }
                }
            }
            out.copy_from_slice(&path.radiance);
            if self.source.is_some() {
                for (w, per_albedo) in out.chunks_mut(albedos).enumerate() {
                    for s in per_albedo {
                        *s = *s * spectra.source[w];
                    }
                }
            }
        })
    }

    /// Follows a path from `ray` to its end. With a `spare` path to split
    /// into and [`Settings::first_vertex_splitting`], the sensor's first
    /// vertex is split: a forced flight toward
    /// a reflecting ground follows both ends (the ground with weight
    /// e^(−τ_λ) at every λ, a decision taken for all wavelengths alike, so
    /// no density changes; the collision forced), and the first scattering
    /// goes on in the sampled direction and its quarter turn, which every
    /// wavelength's phase function gives the same density.
    fn trace(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        mut ray: Ray,
        sampler: &mut Sampler,
        mut spare: Option<&mut Path>,
    ) {
        let n = self.channels.len();
        if !self.settings.first_vertex_splitting {
            spare = None;
        }
        let forced = self.forced();
        loop {
            let Some(end) = self.exit_depths(&mut path.ray, spectra, &self.geometry, &ray) else {
                return;
            };
            // A forced flight toward a reflecting ground is split at the
            // sensor's first vertex, else analog.
            let to_ground = matches!(end, WalkEnd::Ground { .. }) && self.reflects();
            let split = forced && to_ground && path.order == 0 && spare.is_some();
            let forced_flight = forced && (split || !to_ground);
            // Sun connections along the whole flight (sun-aware, or
            // stratified on a forced flight), with the throughput and
            // densities before its collision.
            let sun_done = !self.order_done(path.order)
                && (self.sun_along_flight(path, spectra, &ray, sampler)
                    || (forced_flight
                        && self.settings.sun_samples_per_flight > 1
                        && self.sun_stratified(path, spectra, &ray, sampler)));
            if let (true, WalkEnd::Ground { t }, Some(branch)) = (split, end, spare.as_deref_mut()) {
                branch.branch_from(path);
                for (m, tau) in branch.throughput.iter_mut().zip(&path.ray.tau) {
                    *m = *m * (-tau).exp();
                }
                self.trace_on_from_ground(branch, spectra, ray.origin + t * ray.dir, sampler);
                std::mem::swap(&mut path.radiance, &mut branch.radiance);
            }
            match self.flight(path, spectra, &ray, end, forced_flight, sampler) {
                Outcome::Escaped => return,
                Outcome::Ground { t } => {
                    let x = ray.origin + t * ray.dir;
                    if !self.ground(path, spectra, x, sampler) {
                        return;
                    }
                    let dir = cosine_hemisphere(self.geometry.up(x), sampler.next2());
                    ray = Ray {
                        origin: x,
                        dir,
                        layer: 0,
                    };
                }
                Outcome::Collided { t, layer } => {
                    let x = ray.origin + t * ray.dir;
                    let k_out = -ray.dir;
                    path.order += 1;
                    if !sun_done {
                        // At the collision, with every channel's phase mixture there.
                        self.sun_from(path, spectra, x, layer, k_out, sampler, false);
                    }
                    if self.order_done(path.order) {
                        return;
                    }
                    // Direction from one wavelength's phase function, picked
                    // uniformly, weighted by the mixture of all wavelengths'
                    // densities.
                    let pick = ((sampler.next_f64() * n as f64) as usize).min(n - 1);
                    let f = self.fraction(&self.geometry, layer, x);
                    let coeffs = self.coefficients(spectra, layer, pick, f);
                    let component = pick_component(&coeffs, sampler.next_f64());
                    let (k_in, _) = component.sample_direction(k_out, sampler.next2());
                    let cos = k_in.dot(k_out);
                    path.matrices.clear();
                    path.matrices.extend(path.mixtures.iter().map(|m| m.matrix(cos)));
                    if let (1, Some(branch)) = (path.order, spare.as_deref_mut()) {
                        branch.branch_from(path);
                        branch.halve();
                        if let Some(next) = self.scattered(branch, quarter_turn(k_out, k_in), k_out, x, layer, sampler)
                        {
                            self.trace(branch, spectra, next, sampler, None);
                        }
                        std::mem::swap(&mut path.radiance, &mut branch.radiance);
                        path.halve();
                    }
                    match self.scattered(path, k_in, k_out, x, layer, sampler) {
                        Some(next) => ray = next,
                        None => return,
                    }
                }
            }
        }
    }

    /// Scatters the path at `x` (in `layer`) from light along k_in into
    /// k_out with every wavelength's matrix at the last collision
    /// (`path.matrices`); the ray it goes on along, or `None` when roulette
    /// ends it.
    fn scattered(
        &self,
        path: &mut Path,
        k_in: DVec3,
        k_out: DVec3,
        x: DVec3,
        layer: usize,
        sampler: &mut Sampler,
    ) -> Option<Ray> {
        let inv_mean_p11 = path.matrices.len() as f64 / path.matrices.iter().map(|m| m.p11).sum::<f64>();
        let (rotation, e1_in) = scattering_frame(path.frame_e1, k_in, k_out);
        for (t, m) in path.throughput.iter_mut().zip(&path.matrices) {
            *t = if self.settings.polarized {
                rotation.right_of_then(t, &m.scaled(inv_mean_p11))
            } else {
                *t * Mueller::depolarizer(m.p11 * inv_mean_p11)
            };
        }
        path.frame_e1 = e1_in;
        if !path.roulette(sampler) {
            return None;
        }
        Some(Ray {
            origin: x,
            dir: -k_in,
            layer,
        })
    }

    /// A ground vertex at `x` and the rest of the path from it (unsplit).
    fn trace_on_from_ground(&self, path: &mut Path, spectra: &ChannelSpectra, x: DVec3, sampler: &mut Sampler) {
        if self.ground(path, spectra, x, sampler) {
            let dir = cosine_hemisphere(self.geometry.up(x), sampler.next2());
            self.trace(
                path,
                spectra,
                Ray {
                    origin: x,
                    dir,
                    layer: 0,
                },
                sampler,
                None,
            );
        }
    }

    /// Every channel's optical depth from the ray's origin to where it
    /// leaves (top or ground) into `d.tau`, through `geometry`, and how it
    /// leaves; `None` for an endless (horizontal plane-parallel) ray.
    fn exit_depths(&self, d: &mut Depths, spectra: &ChannelSpectra, geometry: &Geometry, ray: &Ray) -> Option<WalkEnd> {
        let levels = &self.levels_km;
        let b = self.basis_len;
        let tau = &mut d.tau_basis;
        tau.fill(0.0);
        let end = match *geometry {
            // Closed form through concentric shells where σ is constant in
            // each layer.
            Geometry::Spherical { radius_km } if self.shapes.is_none() => {
                let exit = tracking::shell_exit(radius_km, levels, ray);
                let range = exit.levels();
                let c = &mut d.chords[..range.len()];
                tracking::half_chords_into(radius_km, &levels[range], exit.h, c);
                let base = &self.basis_sigma[ray.layer * b..(ray.layer + 1) * b];
                let stride = levels.len();
                for (j, (t, s)) in tau.iter_mut().zip(base).enumerate() {
                    *t = exit.depth(*s, &self.basis_steps[j * stride..(j + 1) * stride], c);
                }
                let end = exit.end(radius_km, levels, ray);
                d.exit = Some(exit);
                Some(end)
            }
            _ => {
                d.exit = None;
                let mut endless = false;
                let end = tracking::walk(geometry, levels, ray, |seg| {
                    if seg.t1.is_finite() {
                        self.accumulate_along(tau, geometry, ray, seg.layer, seg.t0, seg.t1);
                    } else {
                        endless = true;
                    }
                    ControlFlow::Continue(())
                });
                (!endless).then_some(end)
            }
        };
        Self::combine(spectra, &d.tau_basis, &mut d.tau);
        end
    }

    /// Every channel's optical depth along a shadow ray to the top into
    /// `d.tau`; false (and nothing computed) when it meets the ground
    /// first. Through spherical shells of the layered medium in closed
    /// form, the half chords summed with the steps directly for a single
    /// basis vector (no chords kept: nothing is located along a shadow ray).
    fn shadow_depths(&self, d: &mut Depths, spectra: &ChannelSpectra, geometry: &Geometry, ray: &Ray) -> bool {
        let Geometry::Spherical { radius_km } = *geometry else {
            return matches!(self.exit_depths(d, spectra, geometry, ray), Some(WalkEnd::Top { .. }));
        };
        if self.shapes.is_some() || self.basis_len != 1 {
            return matches!(self.exit_depths(d, spectra, geometry, ray), Some(WalkEnd::Top { .. }));
        }
        let levels = &self.levels_km;
        let exit = tracking::shell_exit(radius_km, levels, ray);
        if exit.ground {
            return false;
        }
        let steps = &self.basis_steps;
        let sum = |r: &std::ops::Range<usize>| {
            tracking::weighted_half_chords(radius_km, &levels[r.clone()], &steps[r.clone()], exit.h)
        };
        d.tau_basis[0] = -exit.b * self.basis_sigma[ray.layer] + 2.0 * sum(&exit.twice) + sum(&exit.once);
        Self::combine(spectra, &d.tau_basis, &mut d.tau);
        true
    }

    /// Samples the flight's outcome with the path's hero wavelength; every
    /// wavelength's integrand and density go in over the hero's density.
    /// `path.ray` holds the depths to the flight's `end`.
    ///
    /// One free-flight routine: tentative collisions against the hero's
    /// majorant, each real with probability σ_t/σ_maj (delta tracking; with
    /// the majorant σ_t itself, every one is real and this is the analog
    /// free path, drawn by inversion). A `forced` flight (majorant σ_t)
    /// draws its one tentative collision from the exponential truncated to
    /// the flight, probability 1 − e^(−τ) per wavelength; otherwise the
    /// flight may end on the ground or escape. A real collision at x has
    /// the density σ_t(x)·e^(−τ(x)) at every wavelength (over the forcing
    /// probability for a forced flight), whatever the majorant. At a
    /// collision, `path.mixtures` gets every channel's phase mixture there.
    fn flight(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        end: WalkEnd,
        forced: bool,
        sampler: &mut Sampler,
    ) -> Outcome {
        let n = self.channels.len();
        let hero = path.hero;
        let exact = self.exact_majorant();
        // The collision: by inverting the hero's optical depth where σ_t
        // is the majorant (the first tentative collision is real; rounding
        // may leave a forced one beyond the end: the end), else by delta
        // tracking. `hero_depth` is the hero's depth to it (exact majorant).
        let (hit, hero_depth) = if exact {
            let target = if forced {
                for (p, t) in path.forced.iter_mut().zip(&path.ray.tau) {
                    *p = -(-t).exp_m1();
                }
                if path.forced[hero] <= 0.0 {
                    return Outcome::Escaped;
                }
                tracking::forced_distance(sampler.next_f64(), path.forced[hero])
            } else {
                -(1.0 - sampler.next_f64()).ln()
            };
            let inside = forced || target < path.ray.tau[hero];
            (inside.then(|| self.locate(path, spectra, ray, target)), target)
        } else {
            (self.delta_track(path, spectra, ray, sampler), f64::NAN)
        };
        let Some((t, layer)) = hit else {
            let WalkEnd::Ground { t } = end else {
                return Outcome::Escaped;
            };
            // The ground, reached with probability e^(−τ) at every λ.
            let tau_hero = path.ray.tau[hero];
            for w in 0..n {
                let k = if w == hero {
                    1.0
                } else {
                    (tau_hero - path.ray.tau[w]).exp()
                };
                path.throughput[w] = path.throughput[w] * k;
                path.scale_density(w, k);
            }
            path.densities_changed();
            return Outcome::Ground { t };
        };
        // Every channel's depth to the collision (from the basis, walked
        // again where σ_t is the majorant and there are other channels).
        if exact && n == 1 {
            path.tau_hit[hero] = hero_depth;
        } else {
            if exact {
                self.basis_depths_to(path, ray, t);
            }
            Self::combine(spectra, &path.ray.tau_basis, &mut path.tau_hit);
        }
        let geometry = &self.geometry;
        // The collision's density per wavelength, over the hero's: the
        // hero's e^(−τ) cancels, so each channel's transmittance comes in
        // relative to the hero's (none to compute for the hero).
        let f = self.fraction(geometry, layer, ray.origin + t * ray.dir);
        let density = |sigma_t: f64, p: f64| {
            if !forced {
                sigma_t
            } else if p > 0.0 {
                sigma_t / p
            } else {
                0.0
            }
        };
        let inv_hero = 1.0 / density(self.sigma_t_point(spectra, layer, hero, f), path.forced[hero]);
        let tau_hero = path.tau_hit[hero];
        path.mixtures.clear();
        for w in 0..n {
            let c = self.coefficients(spectra, layer, w, f);
            path.mixtures.push(phase_mixture(&c));
            let transmittance = if w == hero {
                1.0
            } else {
                (tau_hero - path.tau_hit[w]).exp()
            };
            let k = density(c.sigma_t, path.forced[w]) * transmittance * inv_hero;
            path.throughput[w] = path.throughput[w] * (c.sigma_s() * transmittance * inv_hero);
            path.scale_density(w, k);
        }
        path.densities_changed();
        Outcome::Collided { t, layer }
    }

    /// The point at the hero's optical depth `target` along the flight
    /// (σ_t exact per layer): from the half chords `exit_depths` left, or
    /// walked; the end if rounding leaves the target beyond it.
    fn locate(&self, path: &Path, spectra: &ChannelSpectra, ray: &Ray, target: f64) -> (f64, usize) {
        let layers = self.levels_km.len() - 1;
        let sigma = match spectra.sigma.get(path.hero * layers..(path.hero + 1) * layers) {
            Some(shared) => shared,
            None => &path.hero_sigma,
        };
        let c = match &path.ray.exit {
            Some(exit) => exit.locate(sigma, &path.ray.chords, target),
            None => tracking::locate_with(sigma, &self.geometry, &self.levels_km, ray, target),
        };
        (c.t, c.layer)
    }

    /// Every basis vector's depth along the flight to distance `t` into
    /// `path.ray.tau_basis`.
    fn basis_depths_to(&self, path: &mut Path, ray: &Ray, t: f64) {
        let geometry = &self.geometry;
        let Depths {
            tau_basis: tau,
            chords,
            exit,
            ..
        } = &mut path.ray;
        tau.fill(0.0);
        let visit = |s: Segment| {
            self.accumulate_along(tau, geometry, ray, s.layer, s.t0, s.t1.min(t));
            if s.t1 >= t {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        match exit {
            Some(exit) => {
                let _ = exit.try_for_each_segment(chords, visit);
            }
            None => {
                tracking::walk(geometry, &self.levels_km, ray, visit);
            }
        }
    }

    /// Delta tracking of the hero against its majorant (the smooth medium,
    /// or inflated majorants; [`tracking::sample_t_maj`]): the first real
    /// collision, with every basis vector's depth to it in
    /// `path.ray.tau_basis`, or `None` past the end.
    fn delta_track(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        sampler: &mut Sampler,
    ) -> Option<(f64, usize)> {
        let hero = path.hero;
        let geometry = &self.geometry;
        let majorant = |layer| self.majorant(spectra, layer, hero);
        let end = tracking::sample_t_maj(majorant, geometry, &self.levels_km, ray, sampler, |c, s| {
            let f = self.fraction(geometry, c.layer, ray.origin + c.t * ray.dir);
            s.next_f64() * c.sigma_maj >= self.sigma_t_point(spectra, c.layer, hero, f)
        });
        let FlightEnd::Collided(c) = end else {
            return None;
        };
        self.basis_depths_to(path, ray, c.t);
        Some((c.t, c.layer))
    }

    /// The current flight's segments into `path.segments`, and every basis
    /// vector's depth at each one's start into `path.segment_tau`
    /// (`path.ray` holds its exit; σ constant per layer); false for an
    /// endless flight.
    fn flight_segments(&self, path: &mut Path, ray: &Ray) -> bool {
        let Path {
            segments,
            segment_tau,
            point_basis,
            ray: depths,
            ..
        } = path;
        segments.clear();
        segment_tau.clear();
        point_basis.clear();
        point_basis.resize(self.basis_len, 0.0);
        let push = |seg: Segment| {
            segments.push(seg);
            segment_tau.extend_from_slice(point_basis);
            if seg.t1.is_finite() {
                self.accumulate(point_basis, seg.layer, seg.t1 - seg.t0);
            }
            ControlFlow::<()>::Continue(())
        };
        match &depths.exit {
            Some(exit) => {
                let _ = exit.try_for_each_segment(&depths.chords, push);
            }
            None => {
                tracking::walk(&self.geometry, &self.levels_km, ray, push);
            }
        }
        segments.iter().all(|seg| seg.t1.is_finite())
    }

    /// A sun connection from the point at distance `t` in segment `i` of
    /// the flight (`path.segments`), drawn with density `q` (the same for
    /// every channel, so the path's spectral MIS weight applies to it
    /// unchanged): channel w scores e^(−τ_w)·σ_s,w·[R·M_w/(4π)]·T_sun,w/q.
    fn sun_at_point(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        ray: &Ray,
        (i, t): (usize, f64),
        q: f64,
        sampler: &mut Sampler,
    ) {
        let b = self.basis_len;
        let seg = path.segments[i];
        // Every channel's depth along the flight to the point.
        path.point_basis.clear();
        path.point_basis
            .extend_from_slice(&path.segment_tau[i * b..(i + 1) * b]);
        self.accumulate(&mut path.point_basis, seg.layer, (t - seg.t0).max(0.0));
        Self::combine(spectra, &path.point_basis, &mut path.tau_hit);
        path.mixtures.clear();
        path.factors.clear();
        for w in 0..self.channels.len() {
            let c = self.coefficients(spectra, seg.layer, w, 0.0);
            path.mixtures.push(phase_mixture(&c));
            path.factors.push((-path.tau_hit[w]).exp() / q * c.sigma_s());
        }
        self.sun_from(
            path,
            spectra,
            ray.origin + t * ray.dir,
            seg.layer,
            -ray.dir,
            sampler,
            true,
        );
    }

    /// Stratified sun connections along a forced flight
    /// ([`Settings::sun_samples_per_flight`] = K points): point k at the
    /// hero's forced distance for the variate (k + u_k)/K, connected with
    /// 1/K of its weight (`sun_at_point`, density K·σ_t,h·e^(−τ_h)/(1 −
    /// e^(−τ_h,end)) at the point). The path goes on from its own
    /// collision. Returns false (nothing done) for an endless flight.
    fn sun_stratified(&self, path: &mut Path, spectra: &ChannelSpectra, ray: &Ray, sampler: &mut Sampler) -> bool {
        if !self.flight_segments(path, ray) {
            return false;
        }
        let hero = path.hero;
        let p = -(-path.ray.tau[hero]).exp_m1();
        if p <= 0.0 {
            return true;
        }
        let k = self.settings.sun_samples_per_flight;
        for i in 0..k {
            let target = tracking::forced_distance((i as f64 + sampler.next_f64()) / k as f64, p);
            let mut acc = 0.0;
            let mut point = None;
            for (j, seg) in path.segments.iter().enumerate() {
                let sigma = self.sigma_t(spectra, seg.layer, hero);
                let d = sigma * (seg.t1 - seg.t0);
                if sigma > 0.0 {
                    point = Some((j, (seg.t0 + (target - acc) / sigma).min(seg.t1), sigma));
                    if acc + d >= target {
                        break;
                    }
                }
                acc += d;
            }
            if let Some((j, t, sigma)) = point {
                let q = k as f64 * sigma * (-target).exp() / p;
                self.sun_at_point(path, spectra, ray, (j, t), q, sampler);
            }
        }
        true
    }

    /// Next-event estimation along a whole flight (`path.ray` holds its
    /// depths), every channel from one point. The point is drawn from the
    /// mixture q = (1/K)·Σ_k q_k over the K ≤ 2 followed channels (the
    /// least and the most extinct, with their centre wavelengths' optics,
    /// [`SunFollow`]), each q_k a defensive mixture,
    /// α·q_sun,k + (1 − α)·q_flight,k with
    /// q_sun,k ∝ c̄·e^(−τ_k)·e^(−τ̃_sun,k) and q_flight,k ∝ c̄·e^(−τ_k),
    /// c̄ the mean σ_s·P11 at the sun's centre, piecewise exponential over
    /// runs of the flight's segments ([`FlightDensity`]; α = 0.8). Channel w scores
    /// e^(−τ_w)·σ_s,w·[R·M_w/(4π)]·T_sun,w/q: unbiased for its
    /// single-scattering integral along the flight whatever the hero, since
    /// q > 0 wherever σ_s > 0. Following the least extinct channel bounds
    /// the weight of every channel more extinct than it in every layer by
    /// K/(1 − α) times their ratio of σ_s (its e^(−τ) and T_sun are the
    /// smaller); ozone's bands, and a band's own wavelengths, can break that
    /// order in places. The point's density is the same for every channel,
    /// so the path's spectral MIS weight (over the densities of the vertices
    /// before) applies unchanged. Returns false (nothing done) without
    /// sun-aware connections or for an endless flight.
    fn sun_along_flight(&self, path: &mut Path, spectra: &ChannelSpectra, ray: &Ray, sampler: &mut Sampler) -> bool {
        let Some(follow) = &self.sun_follow else {
            return false;
        };
        if !self.flight_segments(path, ray) {
            return false;
        }
        if path.segments.is_empty() {
            return true;
        }
        let depth = &follow.depth;
        let nk = follow.channels.len();
        let s0 = self.sun.direction;
        let cos0 = (-s0).dot(-ray.dir);
        // Rayleigh's and the aerosol's P11 at the sun's centre per followed
        // channel, recomputed only when the parameters change.
        let mut rayleigh = [(f64::NAN, 0.0); 2];
        let mut aerosol = [(f64::NAN, 0.0); 2];
        let optics = |_: usize, seg: &Segment| {
            let len = seg.t1 - seg.t0;
            let mut o = [(0.0, 0.0); 2];
            for (k, ok) in o.iter_mut().enumerate().take(nk) {
                let c = follow.coefficients[seg.layer * nk + k];
                if rayleigh[k].0 != c.rayleigh_depolarization {
                    let depolarization = c.rayleigh_depolarization;
                    rayleigh[k] = (depolarization, PhaseFunction::Rayleigh { depolarization }.p11(cos0));
                }
                let mut sca = c.sigma_rayleigh * rayleigh[k].1;
                if c.sigma_aerosol_sca > 0.0 {
                    if aerosol[k].0 != c.aerosol_g {
                        let g = c.aerosol_g;
                        aerosol[k] = (g, PhaseFunction::HenyeyGreenstein { g }.p11(cos0));
                    }
                    sca += c.sigma_aerosol_sca * aerosol[k].1;
                }
                *ok = (c.sigma_t * len, sca);
            }
            o
        };
        if !path
            .density
            .build(ray, &path.segments, nk, PIECE_SEGMENTS, optics, depth, s0)
        {
            return true;
        }
        let Some(point) = path.density.sample(&path.segments, SUN_AWARE_SHARE, sampler) else {
            return true;
        };
        self.sun_at_point(path, spectra, ray, (point.segment, point.t), point.pdf, sampler);
        true
    }

    /// Every channel's transmittance toward the sun from `x` (in `layer`)
    /// into `path.shadow_tr`, along the direct beam's path (`sun_ray`):
    /// exact, or ratio-tracked against the largest of the channels'
    /// majorants ([`SunTransmittance`]); false when the shadow ray hits the
    /// planet or carries nothing.
    fn sun_transmittances(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        x: DVec3,
        dir: DVec3,
        layer: usize,
        sampler: &mut Sampler,
    ) -> bool {
        let (geometry, ray) = sun_ray(
            self.geometry,
            self.pseudo_spherical_radius_km,
            Ray { origin: x, dir, layer },
        );
        match self.settings.sun_transmittance {
            SunTransmittance::Analytic => {
                if !self.shadow_depths(&mut path.shadow, spectra, &geometry, &ray) {
                    return false;
                }
                for (tr, tau) in path.shadow_tr.iter_mut().zip(&path.shadow.tau) {
                    *tr = (-tau).exp();
                }
                true
            }
            SunTransmittance::RatioTracking => {
                // A horizontal ray of a slab never leaves it.
                if geometry == Geometry::PlaneParallel && ray.dir.z == 0.0 {
                    return false;
                }
                let n = self.channels.len();
                let tr = &mut path.shadow_tr;
                tr.fill(1.0);
                let majorant = |layer| (0..n).map(|w| self.majorant(spectra, layer, w)).fold(0.0, f64::max);
                let end = tracking::sample_t_maj(majorant, &geometry, &self.levels_km, &ray, sampler, |c, _| {
                    let f = self.fraction(&geometry, c.layer, ray.origin + c.t * ray.dir);
                    let mut alive = false;
                    for (w, tr) in tr.iter_mut().enumerate() {
                        *tr *= 1.0 - self.sigma_t_point(spectra, c.layer, w, f) / c.sigma_maj;
                        alive |= *tr != 0.0;
                    }
                    alive
                });
                matches!(end, FlightEnd::Top { .. })
            }
        }
    }

    /// One shadow ray toward the sun from a scattering at `x` for every
    /// channel, each with its phase mixture in `path.mixtures` and, when
    /// `weighted`, times `path.factors[w]`.
    #[allow(clippy::too_many_arguments)]
    fn sun_from(
        &self,
        path: &mut Path,
        spectra: &ChannelSpectra,
        x: DVec3,
        layer: usize,
        k_out: DVec3,
        sampler: &mut Sampler,
        weighted: bool,
    ) {
        let s = self.sun.sample_direction(sampler.next2());
        if !self.sun_transmittances(path, spectra, x, s, layer, sampler) {
            return;
        }
        let k_in = -s;
        let cos = k_in.dot(k_out);
        let (rotation, _) = scattering_frame(path.frame_e1, k_in, k_out);
        for w in 0..self.channels.len() {
            let tr = path.shadow_tr[w];
            if tr == 0.0 {
                continue;
            }
            let m = path.mixtures[w].matrix(cos);
            let column = if self.settings.polarized {
                rotation.column_of(&path.throughput[w], &m)
            } else {
                path.throughput[w] * Stokes::new(m.p11, 0.0, 0.0, 0.0)
            };
            let factor = if weighted { path.factors[w] } else { 1.0 };
            path.add(w, column * (factor * tr * INV_4PI));
        }
    }

    /// A ground vertex: NEE to the sun for every wavelength, then the
    /// Lambertian weight. Returns whether the path goes on.
    fn ground(&self, path: &mut Path, spectra: &ChannelSpectra, x: DVec3, sampler: &mut Sampler) -> bool {
        if !self.reflects() {
            return false;
        }
        path.order += 1;
        let a_ref = reference_albedo(&self.albedos);
        // Lambertian and depolarising: only the first column survives.
        for t in path.throughput.iter_mut() {
            for row in t.0.iter_mut() {
                *row = [row[0] * a_ref, 0.0, 0.0, 0.0];
            }
        }
        for (w, a) in path.albedo_weights.iter_mut().zip(&self.albedos) {
            *w *= a / a_ref;
        }
        let up = self.geometry.up(x);
        let s = self.sun.sample_direction(sampler.next2());
        let mu_s = s.dot(up);
        if mu_s > 0.0 && self.sun_transmittances(path, spectra, x, s, 0, sampler) {
            for w in 0..self.channels.len() {
                let f = FRAC_1_PI * mu_s * path.shadow_tr[w];
                let m = &path.throughput[w].0;
                let column = Stokes::new(m[0][0], m[1][0], m[2][0], m[3][0]);
                path.add(w, column * f);
            }
        }
        if self.order_done(path.order) {
            return false;
        }
        path.roulette(sampler)
    }
}
