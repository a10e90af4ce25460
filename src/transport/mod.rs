//! Light transport: the medium a path sees, free flights through it, the
//! polarised path tracer with its sun connections, and transmittance.

pub mod flight_density;
pub mod free_flight;
pub mod medium;
pub mod optical_depth;
pub mod scene_build;
pub mod sun_depth;
pub mod table_build;
pub mod tracer;
pub mod transmittance;
