//! Building the path tracer's scenes from a resolved job: which channels a
//! task's paths carry, with the job's albedos, medium and settings. (An
//! inherent `impl Job` here, so the job itself knows nothing of transport.)

use crate::geometry::shell::Geometry;
use crate::job::options::{
    AUTO_GROUPS_MIN_SPREAD, DAY_ROULETTE_MAX_COLUMN, DAY_ROULETTE_MIN_ELEVATION_DEG, DAY_ROULETTE_THRESHOLD,
    MediumModel, SpectralGroups, SunSampling,
};
use crate::job::spectrum::Channel;
use crate::job::{Job, Task};
use crate::transport::tracer::{MediumSettings, Scene, sun_peak_serves};

impl Job {
    /// The shared-spectral-path scene of a task: all channels at once, when
    /// the job has bands, or more than one wavelength with
    /// `render.shared_wavelengths` on (see `spectral`); `None` otherwise.
    pub fn spectral_scene(&self, task: &Task) -> Option<Scene> {
        let wanted = self.banded() || (self.render.shared_wavelengths && self.wavelengths_nm.len() > 1);
        wanted.then(|| self.scene_of(task, self.channels()))
    }

    /// The spectral groups of a task's shared paths: channel indices, each
    /// group with paths of its own (`render.spectral_groups`), the most
    /// extinct first. Channels are ranked by their column extinction at
    /// their centre wavelength and cut into groups at equal steps of its
    /// logarithm, so each group holds channels whose paths look alike
    /// (empty steps make no group). "auto" makes two groups where the
    /// column extinctions span at least [`AUTO_GROUPS_MIN_SPREAD`], else
    /// one.
    ///
    /// Why: the balance heuristic over channels whose optical depths differ
    /// several-fold gives the most extinct one little of the others' paths,
    /// and the roulette on the mean throughput shortens its paths. Along
    /// the sky model grid's eleven 40 nm bands from 320 nm (column
    /// extinction 1.37 to 0.27 at 20 km visibility, 0.81 to 0.068 at
    /// 131.8 km), two groups (320–480 and 480–760 nm) cost 0.5–0.8 times
    /// one group of eleven for the same worst-band noise with the sun at
    /// −1° and above, 0.8–0.96 times at −3° and −2°. At −4.2° one group
    /// was the cheaper until scattering directions were drawn in part
    /// toward the sun's horizon (`tracer::sun_lobe`, then a fixed lobe),
    /// which serves the 480–760 nm bands far more than 320–360 nm: with it
    /// two groups cost 0.57–0.69 times one (`bench --grid` tasks at −4.2°,
    /// 20 km visibility, docs/design.md "Spectral groups").
    pub fn spectral_groups(&self, task: &Task) -> Vec<Vec<usize>> {
        let n = self.wavelengths_nm.len();
        let ln_tau: Vec<f64> = (0..n)
            .map(|w| {
                let c = task.atmosphere.column(w);
                (c.tau_rayleigh + c.tau_absorption + c.tau_aerosol_ext).max(1e-12).ln()
            })
            .collect();
        let hi = ln_tau.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let lo = ln_tau.iter().copied().fold(f64::INFINITY, f64::min);
        let count = match self.render.spectral_groups {
            SpectralGroups::Count(k) => k,
            SpectralGroups::Auto if hi - lo >= AUTO_GROUPS_MIN_SPREAD.ln() => 2,
            SpectralGroups::Auto => 1,
        }
        .clamp(1, n.max(1));
        if count == 1 {
            return vec![(0..n).collect()];
        }
        let step = (hi - lo) / count as f64;
        let mut groups = vec![Vec::new(); count];
        for (w, &t) in ln_tau.iter().enumerate() {
            let g = if step > 0.0 {
                (((hi - t) / step) as usize).min(count - 1)
            } else {
                0
            };
            groups[g].push(w);
        }
        groups.retain(|g| !g.is_empty());
        groups
    }

    /// The scene of a task's channels `group` (indices), along shared paths.
    pub fn group_scene(&self, task: &Task, group: &[usize]) -> Scene {
        let channels = self.channels();
        self.scene_of(task, group.iter().map(|&w| channels[w]).collect())
    }

    /// The scene of `channels` for a task, with the job's albedos, medium
    /// and settings. Sun-aware connections as `render.sun_sampling` asks,
    /// where σ is constant per layer and flights are forced.
    fn scene_of(&self, task: &Task, channels: Vec<Channel>) -> Scene {
        let r = &self.render;
        let medium = MediumSettings {
            shapes: match r.medium {
                MediumModel::Layered => None,
                MediumModel::Smooth => task.atmosphere.layer_shapes.clone(),
            },
            majorant_scale: r.majorant_scale,
            pseudo_spherical_radius_km: self.pseudo_spherical_radius_km(),
        };
        // Sun-aware connections need forced flights through a layered
        // medium tracked at its own majorants.
        let sun_aware_possible = r.settings.forced_collisions && medium.shapes.is_none() && r.majorant_scale == 1.0;
        let sun_aware = sun_aware_possible
            && r.settings
                .sun_sampling
                .is_sun_aware(task.sun.zenith_deg, self.plane_parallel_transport());
        let view_sun_aware_possible = sun_aware_possible
            && r.settings.sun_sampling == SunSampling::Auto
            && matches!(self.geometry(), Geometry::Spherical { .. });
        let mut scene = Scene::new(
            self.geometry(),
            task.atmosphere.levels_km.clone(),
            task.atmosphere.terms.clone(),
            channels,
            task.sun,
            r.albedos.clone(),
            r.settings,
            medium,
        );
        // The roulette threshold by regime where the job left it (measured
        // on `bench --suite`, docs/performance.md): by day over thin
        // columns from 0.1 (`DAY_ROULETTE_THRESHOLD`).
        let thin = scene.largest_column_extinction() <= DAY_ROULETTE_MAX_COLUMN;
        if !r.given.roulette_threshold && 90.0 - task.sun.zenith_deg >= DAY_ROULETTE_MIN_ELEVATION_DEG && thin {
            scene.settings.roulette_threshold = DAY_ROULETTE_THRESHOLD;
        }
        // With `auto`, a sun low but up whose connections are at collisions
        // gets scattering directions drawn in part about it (`sun_peak`),
        // higher suns too seen from near the ground.
        let height_km = task.observer_altitude_km - task.atmosphere.levels_km[0];
        let sun_peak = !sun_aware
            && r.settings.sun_sampling == SunSampling::Auto
            && sun_peak_serves(task.sun.zenith_deg, height_km);
        // By day, with `auto`, over columns thin enough that one
        // wavelength's density serves (`DAY_ROULETTE_MAX_COLUMN`), views
        // connect along their own flight: every repeated view ray, a
        // changing one near the sun (`Scene::with_sun_aware_view`).
        let view_sun_aware = view_sun_aware_possible && !sun_aware && thin;
        let scene = if sun_aware {
            scene.with_sun_aware()
        } else if view_sun_aware && sun_peak {
            scene.with_sun_aware_view().with_sun_peak()
        } else if view_sun_aware {
            scene.with_sun_aware_view()
        } else if sun_peak {
            scene.with_sun_peak()
        } else {
            scene
        };
        match &self.solar {
            Some(solar) if self.tracer_weights_by_solar() => scene.with_solar_weights(solar.clone()),
            _ => scene,
        }
    }

    /// The scene of the first task at wavelength index `w`.
    pub fn scene(&self, w: usize) -> Scene {
        self.scene_for(&self.tasks[0], w)
    }

    /// The scene of a task at channel index `w` alone, with all the job's
    /// albedos.
    pub fn scene_for(&self, task: &Task, w: usize) -> Scene {
        self.scene_of(task, vec![self.channels()[w]])
    }
}
