//! Speaking other tools' languages: libRadtran's uvspec input and output, and
//! the validation cases against published and libRadtran references.

pub mod significance;
pub mod uvspec;
pub mod validate;
