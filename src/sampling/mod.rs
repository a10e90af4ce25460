//! Random numbers: the keyed, counter-based streams every sample draws from.

pub mod sampler;
pub mod stream;
