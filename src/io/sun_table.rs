//! `sun.csv`: the transmitted direct sun per wavelength, which the diffuse
//! sky radiance never includes: the transmittance along the sun's direction
//! from the observer, the direct normal irradiance and, for a sun of finite
//! size, the radiance of its disc; for an image sensor, where the disc's
//! centre falls in the image.
//!
//! Columns (units as the job's: per unit E0, or absolute):
//! `wavelength_nm, sun_zenith_deg, transmittance, direct_normal_irradiance`,
//! then `sun_radiance` only for a sun with `angular_radius_deg > 0` (a
//! point sun has no radiance, only an irradiance), then `image_x, image_y`
//! (pixels from the image's top-left corner) only for an image sensor,
//! empty where the sun is outside the image (a fisheye of the other
//! hemisphere, behind a panorama). For bands, the band averages of T and
//! of the direct normal irradiance (in absolute units, of E0(λ)·T(λ)), on
//! a row named by the band's centre.

use crate::job::{Job, Task};
use crate::sensor::camera::Camera;

/// The file name.
pub const SUN_FILE: &str = "sun.csv";

/// The direct sun table of `task`; `camera` is the image sensor, if any.
pub fn sun_csv(job: &Job, task: &Task, camera: Option<&Camera>) -> String {
    let r = task.sun.angular_radius;
    let disc = r > 0.0;
    let mut s = String::from("wavelength_nm,sun_zenith_deg,transmittance,direct_normal_irradiance");
    if disc {
        s.push_str(",sun_radiance");
    }
    if camera.is_some() {
        s.push_str(",image_x,image_y");
    }
    s.push('\n');
    let position = camera.map(|c| c.point_of(task.sun.direction));
    let bands = if job.banded() { job.spectral_scene(task) } else { None };
    let h = task.observer_altitude_km;
    for (w, &lambda) in job.wavelengths_nm.iter().enumerate() {
        let (t, e) = match &bands {
            Some(scene) => (scene.direct_normal(h, w, false), scene.direct_normal(h, w, true)),
            None => {
                let t = job.scene_for(task, w).direct_normal(h, 0, false);
                (t, t * job.unit_scale(lambda))
            }
        };
        s.push_str(&format!("{lambda},{},{t:.9e},{e:.9e}", task.sun.zenith_deg));
        if disc {
            // A uniform disc of solid angle 2π(1 − cos r).
            let radiance = e / (2.0 * std::f64::consts::PI * (1.0 - r.cos()));
            s.push_str(&format!(",{radiance:.9e}"));
        }
        match position {
            Some(Some((x, y))) => s.push_str(&format!(",{x},{y}")),
            Some(None) => s.push_str(",,"),
            None => {}
        }
        s.push('\n');
    }
    s
}
