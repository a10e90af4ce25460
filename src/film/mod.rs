//! Where samples are summed: per direction or pixel, the Stokes sums and
//! their estimates.

pub mod directions;
pub mod fluxes;
pub mod ground_view;
pub mod image;
pub mod noise;
pub mod pixel_counts;
pub mod quantile;
pub mod results;
pub mod tally;
