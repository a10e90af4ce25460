//! `atmosim fit-report`: how well a dataset holds the renders it was
//! fitted from.

pub mod boxplot;
