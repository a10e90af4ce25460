//! Speaking other tools' languages: libRadtran's uvspec input and output, and
//! the validation cases against published and libRadtran references.

pub mod stats;
pub mod uvspec;
pub mod validate;
