//! Where samples are summed: per direction or pixel, the Stokes sums and their estimates.

pub mod image;
