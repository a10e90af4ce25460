//! The planet's geometry: spherical shells and rays through them, and the sun's direction and disc.

pub mod shell;
pub mod sun;
