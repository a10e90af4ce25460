//! Whether a view's ray repeats from sample to sample: what the caller of
//! [`Scene::radiance_sample`](super::Scene::radiance_sample) tells the tracer.

/// Whether a view's ray is the same from one sample to the next (every
/// sample of a direction, of a pixel's centre, straight down) or changes
/// with each (a pixel's jittered directions, a flux's hemisphere, an
/// azimuthal average). By day a repeated ray connects to the sun along its
/// own flight wherever it looks, from a density built once and kept
/// (`Path::view_density`); a changing one only within
/// [`VIEW_SUN_AWARE_MAX_ANGLE_DEG`](super::VIEW_SUN_AWARE_MAX_ANGLE_DEG)
/// of the sun, where the connection pays for building the density at every
/// sample (docs/design-sun.md, "The view's own flight").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewRay {
    Repeated,
    Changing,
}
