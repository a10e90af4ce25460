//! A scene: everything a path needs (the atmosphere's levels and terms, the
//! channels, the sun, the ground's albedos, the transport's settings), and
//! how one is made.

use std::sync::Arc;

use glam::DVec3;

use crate::atmosphere::layer_shape::LayerShape;
use crate::atmosphere::optics::PointOptics;
use crate::atmosphere::spectral_terms::{SpectralTerms, TermOptics, TermShape};
use crate::geometry::ray::Ray;
use crate::geometry::shell::Geometry;
use crate::geometry::sun::Sun;
use crate::job::options::{MAX_ALBEDOS, Settings, SunTransmittance, TrackingLayers};
use crate::job::spectrum::Channel;
use crate::physics::solar::SolarSpectrum;
use crate::polarization::phase_mixture::PhaseMixture;
use crate::transport::medium::density_steps;
use crate::transport::sun_depth::SunDepth;

use super::aerosol_phase::AerosolPhases;
use super::path::{AEROSOL_ANGLES, PIECE_SEGMENTS, Path, Shape, SunFollow};
use super::spectra::{Basis, ChannelSpectra};
use super::sun_lobe::{
    LocalFrame, SUN_LOBE_BINS, SUN_LOBE_SUN_UP_MAX_COLUMN, SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG, SunLobes,
};
use super::sun_peak::SunPeak;
use super::tracking::{AUTO_MIN_LAYERS, Tracking};
use super::vertex::{SUN_AWARE_SHARE, VIEW_PIECE_SEGMENTS, VIEW_SUN_AWARE_SHARE, reflects};
use super::view_ray::ViewRay;

/// By day, a view ray that changes from sample to sample (a jittered
/// pixel) connects along its own flight within this angle (°) of the sun
/// (`Scene::with_sun_aware_view`); a repeated one does wherever it looks.
/// Paired on `bench --suite` with every view's flight so connected against
/// none (2026-11-29, docs/performance.md): FOM of I 4.4× at 15° from a sun
/// 45° up, 7–9× at 3–5° and 224× at the sun itself (Mie, sun zenith 60°),
/// 1.2–1.5× at 20–30°, but 0.4–0.6× beyond 35°, a path with the view so
/// connected costing about 2.6 times one without: the density's building
/// at every sample, which a repeated ray does once (docs/design-sun.md,
/// "The view's own flight").
pub const VIEW_SUN_AWARE_MAX_ANGLE_DEG: f64 = 18.0;

/// The widest wavelength cell of the direct irradiance's band average (nm).
pub const DIRECT_CELL_NM: f64 = 0.05;

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
    /// (docs/job-files.md, "albedo").
    pub albedos: Vec<f64>,
    pub settings: Settings,
    pub(super) levels_km: Vec<f64>,
    pub(super) terms: SpectralTerms,
    pub(super) channels: Vec<Channel>,
    pub(super) basis: Basis,
    /// The number of basis vectors.
    pub(super) basis_len: usize,
    /// σ of each basis vector per layer (`[layer·basis + b]`).
    pub(super) basis_sigma: Vec<f64>,
    /// The spectra of monochromatic channels (all paths share them); for
    /// bands, each path has its own.
    pub(super) fixed: Option<ChannelSpectra>,
    /// Per channel and term (`[channel·terms + term]`): whether the term
    /// may respond anywhere in the channel's band; a path's drawn spectra
    /// skip the others, whose response there is zero
    /// ([`Spectrum::may_respond_in`](crate::atmosphere::spectral_terms::Spectrum::may_respond_in)).
    pub(super) term_active: Vec<bool>,
    /// The extraterrestrial irradiance radiances are weighted by (absolute
    /// units); `None`: per unit E0.
    pub(super) solar: Option<Arc<SolarSpectrum>>,
    /// Sun-aware connections along every flight (`None`: connections at
    /// collisions).
    pub(super) sun_follow: Option<SunFollow>,
    /// Where the sunlit air lies, per tracked layer, for scattering
    /// directions with the sun low or set (`sun_lobe`; `None` where the
    /// lobe is not used).
    pub(super) sun_lobes: Option<SunLobes>,
    /// The lobe about the sun for scattering directions with the sun low
    /// but up (`sun_peak`; `None` where it is not used).
    pub(super) sun_peak: Option<SunPeak>,
    /// The smooth medium's shape of each layer (`None`: layered, σ constant
    /// in each layer).
    pub(super) shapes: Option<Vec<LayerShape>>,
    /// How each term, and each basis vector, varies inside a smooth layer.
    pub(super) term_shapes: Vec<TermShape>,
    pub(super) basis_shapes: Vec<TermShape>,
    /// Majorants are this times a bound on σ_t over each layer (1 and the
    /// layered medium: σ_t itself, every tentative collision real).
    pub(super) majorant_scale: f64,
    /// Pseudo-spherical geometry (a plane-parallel scene): the direct beam
    /// reaching a point at altitude z is attenuated along its path through
    /// spherical shells of this planet radius (km), as DISORT's
    /// pseudo-spherical mode does; everything else stays plane-parallel.
    pub(super) pseudo_spherical_radius_km: Option<f64>,
    /// The aerosol's tabulated phase matrices (`None`: Henyey–Greenstein).
    pub(super) aerosol_phases: Option<AerosolPhases>,
    /// The layers paths are tracked through: the profile's, or merged
    /// (`TrackingLayers::Merged`, `tracking`).
    pub(super) track: Tracking,
    /// Its own id in the process (`path::next_owner_id`; a clone shares
    /// it): what a thread keeps for a view ray from sample to sample
    /// (`Path::view_depths`) is this scene's alone.
    pub(super) id: u64,
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
        let basis_sigma: Vec<f64> = (0..layers).flat_map(|l| profiles.iter().map(move |p| p[l])).collect();
        // "auto" tracks paths through merged layers in a fine profile;
        // merging needs the layered medium, spherical shells and analytic
        // shadow rays (`tracking`).
        let mut settings = settings;
        let mergeable = medium.shapes.is_none()
            && matches!(geometry, Geometry::Spherical { .. })
            && settings.sun_transmittance == SunTransmittance::Analytic;
        settings.tracking_layers = match settings.tracking_layers {
            TrackingLayers::Auto | TrackingLayers::Merged if !mergeable => TrackingLayers::Profile,
            TrackingLayers::Auto if layers <= AUTO_MIN_LAYERS => TrackingLayers::Profile,
            TrackingLayers::Auto => TrackingLayers::Merged,
            other => other,
        };
        let track = if settings.tracking_layers == TrackingLayers::Merged {
            Tracking::merged(&levels_km, &basis_sigma, b)
        } else {
            let steps = profiles.iter().flat_map(|p| density_steps(p)).collect();
            Tracking::exact(&levels_km, &basis_sigma, steps)
        };
        let range_nm = channels.iter().fold((f64::MAX, f64::MIN), |(lo, hi), c| {
            let half = 0.5 * c.band_width_nm;
            (lo.min(c.lambda_nm - half), hi.max(c.lambda_nm + half))
        });
        let aerosol_phases = AerosolPhases::of_terms(&terms, layers, range_nm);
        let term_active = channels
            .iter()
            .flat_map(|c| terms.terms.iter().map(|t| t.spectrum.may_respond_in(c.band_nm())))
            .collect();
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
            fixed: None,
            term_active,
            solar: None,
            sun_follow: None,
            sun_lobes: None,
            sun_peak: None,
            shapes: medium.shapes,
            term_shapes,
            basis_shapes,
            majorant_scale: medium.majorant_scale.max(1.0),
            pseudo_spherical_radius_km: medium.pseudo_spherical_radius_km,
            aerosol_phases,
            track,
            id: super::path::next_owner_id(),
        };
        if !banded {
            let mut fixed = ChannelSpectra {
                responses: centre,
                weights: vec![0.0; n * b],
                solar: Vec::new(),
                phase_nodes: Vec::new(),
                sigma: Vec::new(),
                coefficients: Vec::new(),
            };
            scene.refresh_weights(&mut fixed);
            let layers = scene.track.layers();
            fixed.sigma = (0..n * layers)
                .map(|i| scene.sigma_t(&fixed, i % layers, i / layers))
                .collect();
            if scene.shapes.is_none() {
                let layers = scene.levels_km.len() - 1;
                fixed.coefficients = (0..n * layers)
                    .map(|i| scene.coefficients(&fixed, i % layers, i / layers, 0.0))
                    .collect();
            }
            scene.refresh_solar(&mut fixed, |w| scene.channels[w].lambda_nm);
            scene.refresh_phase_nodes(&mut fixed, |w| scene.channels[w].lambda_nm);
            scene.fixed = Some(fixed);
        }
        scene
    }

    /// The scene with radiances weighted by `solar` at each path's
    /// wavelengths: absolute units, band averages of E0(λ)·L(λ). Every
    /// channel's wavelengths must lie inside the spectrum (the job checks
    /// it); outside, E0 counts as 0.
    pub fn with_solar_weights(mut self, solar: Arc<SolarSpectrum>) -> Scene {
        self.solar = Some(solar);
        if let Some(mut fixed) = self.fixed.take() {
            self.refresh_solar(&mut fixed, |w| self.channels[w].lambda_nm);
            self.fixed = Some(fixed);
        }
        self
    }

    /// The scene with scattering directions drawn in part about the sun
    /// (`sun_peak`), for a sun low but up whose connections are at
    /// collisions.
    pub fn with_sun_peak(mut self) -> Scene {
        self.sun_peak = Some(SunPeak::new(self.sun.direction));
        self
    }

    /// Sun-aware connections along the sensor's own flight alone: every
    /// repeated view ray's, and a changing one's within
    /// [`VIEW_SUN_AWARE_MAX_ANGLE_DEG`] of the sun (the aerosol's forward
    /// peak makes single scattering along the view most of such a view's
    /// light and of its variance). The density follows single scattering
    /// almost exactly ([`VIEW_SUN_AWARE_SHARE`] over segments).
    /// Every other flight connects at its collision; no lobe toward the
    /// sunlit air.
    ///
    /// [`VIEW_SUN_AWARE_SHARE`]: super::vertex::VIEW_SUN_AWARE_SHARE
    pub fn with_sun_aware_view(self) -> Scene {
        let mut scene = self.with_sun_aware();
        if let Some(follow) = scene.sun_follow.as_mut() {
            follow.view_only = true;
        }
        scene.sun_lobes = None;
        scene
    }

    /// The least cosine between a view and the sun at which its own flight
    /// connects along the flight (above 1, never, unless every flight
    /// does): where only the view's flight does, any angle for a repeated
    /// view ray, within [`VIEW_SUN_AWARE_MAX_ANGLE_DEG`] for a changing one.
    pub(super) fn view_sun_aware_min_cos(&self, ray: ViewRay) -> f64 {
        match &self.sun_follow {
            Some(f) if f.view_only && ray == ViewRay::Repeated => -1.0,
            Some(f) if f.view_only => VIEW_SUN_AWARE_MAX_ANGLE_DEG.to_radians().cos(),
            Some(_) => -1.0,
            None => 2.0,
        }
    }

    /// The largest column extinction (ground to top) of the scene's
    /// channels at their centre wavelengths.
    pub fn largest_column_extinction(&self) -> f64 {
        let mut responses = vec![TermOptics::default(); self.terms.terms.len()];
        self.channels
            .iter()
            .map(|c| {
                self.terms.responses_into(c.lambda_nm, &mut responses);
                (0..self.levels_km.len() - 1)
                    .map(|l| {
                        self.terms.layer_sum(l, &responses).coefficients().sigma_t
                            * (self.levels_km[l + 1] - self.levels_km[l])
                    })
                    .sum::<f64>()
            })
            .fold(0.0, f64::max)
    }

    /// The scene with sun-aware connections: at every flight, one point
    /// drawn along it from a density that follows the sunlit single
    /// scattering of the channels (`Scene::sun_along_flight`)
    /// instead of the connection at the collision.
    pub fn with_sun_aware(mut self) -> Scene {
        // Per tracking layer: the optics of its (middle) profile layer, a
        // density to draw points from like any other.
        let track = &self.track;
        let layers = track.layers();
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
                    .map(|m| self.terms.layer_sum(track.middle_layer(m), &responses).coefficients())
                    .collect();
                let column = coeffs
                    .iter()
                    .enumerate()
                    .map(|(m, c)| c.sigma_t * (track.levels_km[m + 1] - track.levels_km[m]))
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
            &track.levels_km,
            &sigmas,
            &self.geometry,
            self.sun.direction,
            self.pseudo_spherical_radius_km.is_some(),
        );
        let mut coefficients = Vec::with_capacity(layers * k);
        for l in 0..layers {
            coefficients.extend(followed.iter().map(|f| f.2[l]));
        }
        // The aerosol's own P11 where it scatters by tables (its forward
        // peak is several times Henyey–Greenstein's at the same g).
        let mut aerosol_p11 = Vec::new();
        if let Some(phases) = &self.aerosol_phases {
            let tables = self.phase_tables();
            aerosol_p11.reserve(layers * k * AEROSOL_ANGLES);
            for l in 0..layers {
                for f in &followed {
                    let node = phases.node(self.channels[f.1].lambda_nm);
                    let mut aerosol = PhaseMixture::new(0.0, 0.0, 0.0, f.2[l].aerosol_g);
                    phases.add_to(&mut aerosol, track.middle_layer(l), node, 1.0);
                    aerosol_p11.extend((0..AEROSOL_ANGLES).map(|a| {
                        let theta = a as f64 * (std::f64::consts::PI / (AEROSOL_ANGLES - 1) as f64);
                        aerosol.matrix(&tables.locate(theta.cos())).p11
                    }));
                }
            }
        }
        self.sun_follow = Some(SunFollow {
            id: super::path::next_owner_id(),
            depth,
            channels: followed.iter().map(|f| f.1).collect(),
            coefficients,
            max_column: centre[n - 1].0,
            aerosol_p11,
            view_only: false,
            // Measured in spherical geometry; plane-parallel scenes keep
            // every flight's density for the view too (docs/design-sun.md,
            // "The view's own flight": with it, libRadtran B's sun
            // direction shows a difference from DISORT not yet settled).
            view_density: match self.geometry {
                Geometry::Spherical { .. } => (VIEW_SUN_AWARE_SHARE, VIEW_PIECE_SEGMENTS),
                _ => (SUN_AWARE_SHARE, PIECE_SEGMENTS),
            },
        });
        self.sun_lobes = self.build_sun_lobes();
        self
    }

    /// Whether scattering directions are drawn in part from the lobe: with
    /// sun-aware connections in spherical geometry, and the sun below the
    /// observer's horizon, or less than [`SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG`]
    /// above it for channels whose column extinction is at most
    /// [`SUN_LOBE_SUN_UP_MAX_COLUMN`].
    fn sun_lobe_used(&self) -> bool {
        let Some(follow) = self.sun_follow.as_ref() else {
            return false;
        };
        let elevation = 90.0 - self.sun.zenith_deg;
        let used = elevation < 0.0
            || (elevation < SUN_LOBE_SUN_UP_MAX_ELEVATION_DEG && follow.max_column <= SUN_LOBE_SUN_UP_MAX_COLUMN);
        used && matches!(self.geometry, Geometry::Spherical { .. })
    }

    /// The lobe's table: per tracked layer, the sunlit single scattering
    /// along each bin's central direction from the layer's middle on the
    /// observer's vertical (`None` where the lobe is not used).
    fn build_sun_lobes(&self) -> Option<SunLobes> {
        if !self.sun_lobe_used() {
            return None;
        }
        let follow = self.sun_follow.as_ref()?;
        let levels = &self.track.levels_km;
        let layers = self.track.layers();
        let sun = self.sun.direction;
        let mut path = Path::default();
        // Row `layers` is the ground's: from the ground itself, up only,
        // the square root of F times the cosine a Lambertian ground weighs
        // a direction by (`GROUND_LOBE_SHARE`).
        let values = SunLobes::values(layers + 1, |m, mu, phi| {
            let ground = m == layers;
            if ground && mu <= 0.0 {
                return 0.0;
            }
            let altitude = if ground {
                levels[0]
            } else {
                0.5 * (levels[m] + levels[m + 1])
            };
            let origin = self.geometry.observer_position(altitude);
            let ray = Ray {
                origin,
                dir: LocalFrame::new(self.geometry.up(origin), sun).direction(mu, phi, 1.0),
                layer: m.min(layers - 1),
            };
            if !self.flight_segments(&mut path, &ray) || path.segments.is_empty() {
                return 0.0;
            }
            if !self.build_sun_density(
                follow,
                &path.segments,
                &mut path.density,
                &ray,
                PIECE_SEGMENTS,
                Shape::Sunlit,
            ) {
                return 0.0;
            }
            if ground {
                (path.density.sunlit_integral() * mu).sqrt()
            } else {
                path.density.sunlit_integral()
            }
        });
        let (rows, ground) = values.split_at(layers * SUN_LOBE_BINS);
        Some(SunLobes::from_values(layers, rows, ground))
    }

    /// The atmosphere's levels (km).
    pub fn levels_km(&self) -> &[f64] {
        &self.levels_km
    }

    /// The number of layers paths are tracked through (the profile's, or
    /// fewer where they are merged: `Settings::tracking_layers`).
    pub fn tracked_layers(&self) -> usize {
        self.track.layers()
    }

    /// The number of channels.
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// The number of values a sample gives: channels × albedos.
    pub fn value_count(&self) -> usize {
        self.channels.len() * self.albedos.len().min(MAX_ALBEDOS)
    }

    /// Position of an observer at `altitude_km` (on the z axis).
    pub fn observer_position(&self, altitude_km: f64) -> DVec3 {
        self.geometry.observer_position(altitude_km)
    }

    pub(super) fn reflects(&self) -> bool {
        reflects(&self.albedos)
    }

    pub(super) fn order_done(&self, order: u32) -> bool {
        self.settings.order_done(order)
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path as FsPath;

    use crate::job::Job;

    /// The built-in default atmosphere at 500 nm with the sun at
    /// `elevation_deg`, seen from the ground.
    fn job(elevation_deg: f64) -> Job {
        let text = format!(
            "[sun]\nelevation_deg = {elevation_deg}\n[spectrum]\nwavelengths_nm = [500.0]\n\
             [sensor]\ntype = \"directions\"\ndirections = [[0.0, 0.0]]\n[render]\nsamples = 1\n"
        );
        Job::parse(&text, "test.toml", FsPath::new(".")).expect("a valid job")
    }

    #[test]
    fn the_lobe_table_looks_where_the_sunlit_air_is() {
        // With the sun 4.2° down, the sunlit air lies toward the sun's
        // azimuth, low: near the horizon from the ground, just below the
        // local horizon (the sunlit limb) from the stratosphere; looking
        // down into the shadow finds none. With the sun 45° up there is no
        // table at all.
        let scene = job(-4.2).scene(0);
        let lobes = scene.sun_lobes.as_ref().expect("a table with the sun set");
        let sun = scene.sun.direction;
        let levels = &scene.track.levels_km;
        let layer_at = |z: f64| levels.partition_point(|&l| l <= z) - 1;
        for z in [0.5, 3.5, 8.5, 15.5, 25.5] {
            let layer = layer_at(z);
            let up = scene.geometry.up(scene.geometry.observer_position(z));
            let east = (sun - sun.dot(up) * up).normalize();
            let north = up.cross(east);
            let dir = |mu: f64, phi: f64| {
                let s = (1.0 - mu * mu).sqrt();
                s * phi.cos() * east + s * phi.sin() * north + mu * up
            };
            let at = lobes.at(layer, up, sun);
            let toward = at.density_4pi(dir(0.1, 0.1));
            let away = at.density_4pi(dir(0.1, 3.0));
            let down = at.density_4pi(dir(-0.9, 0.0));
            assert!(toward > 10.0 * away, "{z} km: toward the sun {toward}, away {away}");
            assert!(down < 0.01 * toward, "{z} km: down {down}, toward the sun {toward}");
            if z > 15.0 {
                let limb = at.density_4pi(dir(-0.03, 0.1));
                assert!(limb > toward, "{z} km: the limb {limb}, above the horizon {toward}");
            }
        }
        assert!(job(45.0).scene(0).sun_lobes.is_none());
    }

    #[test]
    fn the_sun_aware_density_reads_the_aerosols_own_p11() {
        // OPAC continental_average (Mie tables), sun 4.2° down, 500 and
        // 740 nm: the followed channels' aerosol P11 on the 0.25° grid,
        // read between its nodes, stays within 2 % of the tables' own
        // value there (from the forward peak to the back), and its forward
        // peak is well above Henyey–Greenstein's at the layer's g, which
        // the density used before.
        use crate::polarization::phase::PhaseFunction;
        use crate::polarization::phase_mixture::PhaseMixture;
        let text = "[sun]\nelevation_deg = -4.2\n[atmosphere]\naerosol = \"continental_average\"\n\
                    [spectrum]\nwavelengths_nm = [500.0, 740.0]\n";
        let job = Job::parse(text, "test.toml", FsPath::new(".")).expect("a valid job");
        let scene = job.spectral_scene(&job.tasks[0]).expect("a scene");
        let follow = scene.sun_follow.as_ref().expect("sun-aware connections at twilight");
        let phases = scene.aerosol_phases.as_ref().expect("Mie tables");
        let k = follow.channels.len();
        assert_eq!(k, 2);
        assert_eq!(
            follow.aerosol_p11.len(),
            scene.track.layers() * k * super::AEROSOL_ANGLES
        );
        for layer in [0, 2, 5] {
            for (j, &w) in follow.channels.iter().enumerate() {
                let g = follow.coefficients[layer * k + j].aerosol_g;
                let mut aerosol = PhaseMixture::new(0.0, 0.0, 0.0, g);
                let node = phases.node(scene.channels[w].lambda_nm);
                phases.add_to(&mut aerosol, scene.track.middle_layer(layer), node, 1.0);
                for theta_deg in [0.1f64, 0.6, 1.3, 3.7, 7.7, 20.2, 45.1, 120.6, 170.3] {
                    let cos = theta_deg.to_radians().cos();
                    let exact = aerosol.matrix(&scene.phase_tables().locate(cos)).p11;
                    let grid = follow.aerosol_p11_at(layer, j, k, super::SunFollow::aerosol_angle(cos));
                    assert!(
                        (grid / exact - 1.0).abs() < 0.02,
                        "layer {layer}, channel {w}, {theta_deg}°: {grid} against {exact}"
                    );
                }
                let forward = follow.aerosol_p11_at(layer, j, k, (0, 0.0));
                let hg = PhaseFunction::HenyeyGreenstein { g }.p11(1.0);
                assert!(
                    forward > 2.0 * hg,
                    "layer {layer}, channel {w}: {forward} against HG {hg}"
                );
            }
        }
    }

    #[test]
    fn auto_draws_about_the_sun_from_10_to_25_degrees_or_to_50_seen_from_low() {
        // The lobe about the sun with `auto` and the sun 10° to 25° up, or
        // to 50° from within 1 km of the ground; below, the lobe toward
        // the sunlit air where it serves (both never); above, and with
        // `sun_sampling = "collision"`, neither.
        for (elevation, altitude_km, peak) in [
            (-4.2, 0.0, false),
            (2.0, 0.0, false),
            (9.5, 0.0, false),
            (10.0, 0.0, true),
            (17.0, 10.0, true),
            (25.0, 0.0, true),
            (25.0, 2.0, false),
            (45.0, 1.0, true),
            (45.0, 5.0, false),
            (60.0, 0.0, false),
        ] {
            let text = format!(
                "[sun]\nelevation_deg = {elevation}\n[spectrum]\nwavelengths_nm = [500.0]\n\
                 [observer]\naltitude_km = {altitude_km:?}\n[sensor]\ntype = \"directions\"\n\
                 directions = [[0.0, 0.0]]\n[render]\nsamples = 1\n"
            );
            let scene = Job::parse(&text, "test.toml", FsPath::new("."))
                .expect("a valid job")
                .scene(0);
            assert_eq!(scene.sun_peak.is_some(), peak, "sun {elevation}°, {altitude_km} km");
            assert!(
                !(scene.sun_peak.is_some() && scene.sun_lobes.is_some()),
                "sun {elevation}°"
            );
        }
        let text = "[sun]\nelevation_deg = 17.0\n[spectrum]\nwavelengths_nm = [500.0]\n[render]\nsun_sampling = \"collision\"\n";
        let collision = Job::parse(text, "test.toml", FsPath::new(".")).expect("a valid job");
        assert!(collision.scene(0).sun_peak.is_none());
    }

    #[test]
    fn by_day_repeated_view_rays_connect_along_their_flight_anywhere_changing_ones_near_the_sun() {
        use super::super::view_ray::ViewRay;
        let day = |sampling: &str| {
            let text = format!(
                "[atmosphere]\nprofile = \"us_standard\"\n[sun]\nzenith_deg = 45.0\n[spectrum]\n\
                 wavelengths_nm = [540.0]\n[render]\nsamples = 1\nsun_sampling = \"{sampling}\"\n"
            );
            Job::parse(&text, "test.toml", FsPath::new("."))
                .expect("a valid job")
                .scene(0)
        };
        let auto = day("auto");
        assert!(auto.sun_follow.as_ref().is_some_and(|f| f.view_only));
        assert_eq!(auto.view_sun_aware_min_cos(ViewRay::Repeated), -1.0);
        let near = super::VIEW_SUN_AWARE_MAX_ANGLE_DEG.to_radians().cos();
        assert_eq!(auto.view_sun_aware_min_cos(ViewRay::Changing), near);
        // Without sun-aware connections no view connects along its
        // flight; with them on every flight, every view does.
        let collision = day("collision");
        assert!(collision.view_sun_aware_min_cos(ViewRay::Repeated) > 1.0);
        assert!(collision.view_sun_aware_min_cos(ViewRay::Changing) > 1.0);
        let aware = day("sun_aware");
        assert_eq!(aware.view_sun_aware_min_cos(ViewRay::Changing), -1.0);
    }

    #[test]
    fn what_a_view_ray_keeps_between_samples_gives_the_samples_computed_afresh() {
        // By day a repeated view ray connects along its own flight, from
        // a density each thread keeps while the view ray stays the same,
        // and every repeated view ray keeps its depths. Every sample, with
        // them kept from the previous one (of the same or of another
        // direction, or of another scene: two scenes that differ only in
        // their aerosol) or computed afresh, is the same bit for bit.
        use crate::polarization::stokes::Stokes;
        use crate::sampling::stream::{Estimate, Render, StreamKey};
        use crate::sensor::direction::Direction;

        use super::super::path::WORK;
        use super::super::view_ray::ViewRay;

        let scene = |tau: f64| {
            let text = format!(
                "[atmosphere]\nprofile = \"us_standard\"\n[[atmosphere.aerosol_layers]]\nbottom_km = 0.0\n\
                 top_km = 2.0\ntau = {tau}\nssa = 0.95\ng = 0.7\n[sun]\nzenith_deg = 45.0\n[spectrum]\n\
                 wavelengths_nm = [540.0]\n[ground]\nalbedo = 0.2\n[sensor]\ntype = \"directions\"\n\
                 directions = [[30.0, 0.0]]\n[render]\nsamples = 1\n"
            );
            Job::parse(&text, "test.toml", FsPath::new("."))
                .expect("a valid job")
                .scene(0)
        };
        let scenes = [scene(0.2), scene(0.6)];
        assert!(scenes[0].sun_follow.as_ref().is_some_and(|f| f.view_only));
        let views: Vec<Direction> = [(30.0, 0.0), (60.0, 0.0), (45.0, 10.0)]
            .iter()
            .map(|&(z, a)| Direction {
                view_zenith_deg: z,
                azimuth_deg: a,
            })
            .collect();
        let mut out = vec![Stokes::zero(); scenes[0].value_count()];
        let mut sample = |s: usize, d: usize, i: u64, fresh: bool| {
            if fresh {
                WORK.with_borrow_mut(|w| {
                    w.path.view_key = None;
                    w.path.view_depths_key = None;
                });
            }
            let key = StreamKey::new(3, Render::channel(0, 0), Estimate::Direction(d));
            let (v, e1) = (views[d].vector(), views[d].meridian_axis());
            scenes[s].radiance_sample(0.0, v, e1, ViewRay::Repeated, &mut key.sampler(i), &mut out);
            out[0].0
        };
        let (mut kept, mut kept_depths) = (0, 0);
        for i in 0..300 {
            for (s, d) in [(0, 0), (0, 0), (1, 0), (0, 1), (0, 2), (1, 2), (1, 2), (0, 0)] {
                let warm = sample(s, d, i, false);
                let cold = sample(s, d, i, true);
                assert_eq!(
                    warm.map(f64::to_bits),
                    cold.map(f64::to_bits),
                    "scene {s}, direction {d}, sample {i}"
                );
                WORK.with_borrow(|w| {
                    kept += usize::from(w.path.view_key.is_some());
                    kept_depths += usize::from(w.path.view_depths_key.is_some());
                });
            }
        }
        // The views used a density and depths (and kept them).
        assert!(kept > 300, "{kept}");
        assert_eq!(kept_depths, 2400);
    }
}
