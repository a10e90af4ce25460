//! Sensors: which directions a render looks along, and the Stokes frame each
//! is reported in.

pub mod camera;
pub mod direction;
pub mod symmetry;
