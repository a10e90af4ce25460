//! The planet's geometry: spherical shells and rays through them, and the
//! sun's direction and disc.

pub mod basis;
pub mod chord_kernels;
pub mod ray;
pub mod shell;
pub mod shell_exit;
pub mod sun;
