//! The ground seen from the ground. An observer standing on a Lambertian,
//! depolarising ground sees, in every direction below the horizon, the
//! ground right at the eye: one unpolarised radiance, L = a·E↓/π. An
//! image's rows below the horizon ([`Camera::rows_below_horizon`]) then
//! share one estimate of it, traced straight down, instead of tracing the
//! same radiance pixel by pixel (`run::layout::EstimateKind::GroundView`).
//!
//! The estimate is exact in what it estimates (no pixel's value is
//! smoothed or borrowed from another's), and its samples are its own
//! stream's. Its one error is shared by all those pixels, so it gets
//! [`GROUND_VIEW_SAMPLES`] times a pixel's samples (a quarter of a pixel's
//! standard error, or of a noise target's relative error) at the cost of
//! that many pixels.

use crate::job::Task;
use crate::sensor::camera::Camera;

/// The ground view's samples per pixel sample.
pub const GROUND_VIEW_SAMPLES: u64 = 16;

/// The rows of `camera` that are traced, from the top: all of them, or
/// those above the horizon when the observer of `task` stands on the
/// ground (the rows below share the ground view).
pub fn traced_rows(camera: &Camera, task: &Task) -> usize {
    if task.observer_on_ground() {
        camera.rows_below_horizon().start
    } else {
        camera.size().1
    }
}
