//! Polarisation: Stokes vectors, Mueller and phase matrices (closed-form and
//! tabulated), and the frames Stokes vectors are given in.

pub mod phase;
pub mod phase_mixture;
pub mod phase_table_set;
pub mod stokes;
pub mod stokes_frame;
pub mod tabulated_phase;
