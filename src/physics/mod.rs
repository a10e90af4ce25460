//! The physics of air, ozone, aerosol and the sun, independent of any job:
//! constants, cross sections, profiles, the solar spectrum and the data
//! tables they are read from.

pub mod aerosol;
pub mod constants;
pub mod data;
pub mod gas_columns;
pub mod kdistribution;
pub mod mie;
pub mod ozone;
pub mod profile;
pub mod rayleigh;
pub mod solar;
pub mod visibility;
