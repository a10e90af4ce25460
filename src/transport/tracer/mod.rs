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
//! beam (E0 = 1) unless the solar spectrum weights it (`with_solar_weights`).
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
//! σ_s/σ_t at each collision. Flights cross the layers of `tracking`: the
//! profile's, or in a fine profile runs of them merged, where every
//! density is the merged layers' and the integrand's transmittances carry a
//! ratio-tracked residual (`residual`), so the estimate is the profile's.
//!
//! **Scattering**: the σ_s-weighted mixture of Rayleigh (with
//! depolarisation) and Henyey–Greenstein phase matrices, in the
//! scattering-plane frame (e2 = k_in × k_out normalised, e1 = e2 × k), the
//! path's frame rotated into it. The new direction comes from one channel's
//! phase function (picked uniformly) and one component (σ_i/σ_s); every
//! channel's weight is its matrix over the mean of the channels' P11
//! (one-sample MIS over channels and components). With the sun set
//! (sun-aware connections, spherical geometry) 3 directions in 10 come
//! from a lobe tabulated per layer toward the sunlit air instead
//! (`sun_lobe`), and with the sun 10° to 25° up (to 50° seen from within
//! 1 km of the ground) 1 in 10 from a lobe about the sun (`sun_peak`); the weight's denominator is then the mixture of
//! both densities (`direction_guide`). Where the lobe toward the sunlit
//! air is used, 3 in 10 directions up from a reflecting ground come from
//! its ground row instead of the cosine, weighed the same way.
//!
//! **Sun connections** (next-event estimation) at every scattering and
//! ground vertex, or along the whole flight instead: K stratified points
//! of the hero's forced density (`sun_samples_per_flight`), or one point
//! from a density following the sunlit single scattering (sun-aware,
//! [`FlightDensity`](crate::transport::flight_density::FlightDensity)). Such a point's density is the same for every
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
//! a quarter turn apart, half the weight each, except under a noise target
//! of I without the key: `Settings::split_first_scattering`), into a spare
//! path kept per thread. After the second vertex, Russian roulette on the mean
//! effective T₀₀ over the channels (survival min(1, T₀₀/r), r the job's
//! `render.roulette_threshold`, 0.03 by default, and where sun
//! connections are at collisions scaled down for a thin view by its
//! chance to scatter, `path::view_roulette_scale`; the survivor divided by
//! it).
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
//! sun-aware share): docs/design.md, docs/design-sun.md and the lab notes
//! they link to.

mod aerosol_phase;
mod channel_optics;
mod direct;
mod direction_guide;
mod flight;
mod path;
mod residual;
mod scene;
mod spectra;
mod sun_connection;
mod sun_lobe;
mod sun_peak;
mod trace;
mod tracking;
mod vertex;
mod view_ray;

pub use scene::{DIRECT_CELL_NM, MediumSettings, Scene, VIEW_SUN_AWARE_MAX_ANGLE_DEG};
pub use sun_lobe::SUN_LOBE_SHARE;
pub use sun_peak::{
    SUN_PEAK_G, SUN_PEAK_LOW_OBSERVER_KM, SUN_PEAK_LOW_OBSERVER_MAX_ELEVATION_DEG, SUN_PEAK_MAX_ELEVATION_DEG,
    SUN_PEAK_MIN_ELEVATION_DEG, SUN_PEAK_SHARE, sun_peak_serves,
};
pub use tracking::{AUTO_MIN_LAYERS, MERGE_SPREAD};
pub use view_ray::ViewRay;
