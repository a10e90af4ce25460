//! Building the path tracer's scenes from a resolved job: which channels a
//! task's paths carry, with the job's albedos, medium and settings. (An
//! inherent `impl Job` here, so the job itself knows nothing of transport.)

use crate::job::options::MediumModel;
use crate::job::spectrum::Channel;
use crate::job::{Job, Task};
use crate::transport::tracer::{MediumSettings, Scene};

impl Job {
    /// The shared-spectral-path scene of a task: all channels at once, when
    /// the job has bands, or more than one wavelength with
    /// `render.shared_wavelengths` on (see `spectral`); `None` otherwise.
    pub fn spectral_scene(&self, task: &Task) -> Option<Scene> {
        let wanted = self.banded() || (self.render.shared_wavelengths && self.wavelengths_nm.len() > 1);
        wanted.then(|| self.scene_of(task, self.channels()))
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
        let sun_aware = r
            .settings
            .sun_sampling
            .is_sun_aware(task.sun.zenith_deg, self.plane_parallel_transport())
            && r.settings.forced_collisions
            && medium.shapes.is_none()
            && r.majorant_scale == 1.0;
        let scene = Scene::new(
            self.geometry(),
            task.atmosphere.levels_km.clone(),
            task.atmosphere.terms.clone(),
            channels,
            task.sun,
            r.albedos.clone(),
            r.settings,
            medium,
        );
        let scene = if sun_aware { scene.with_sun_aware() } else { scene };
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
