//! The subcommands of the `atmosim` binary: each one's arguments and the
//! code that turns them into library calls and output, one file per
//! subcommand plus the pieces they share.

pub mod atmosphere;
pub mod bench;
pub mod common;
#[cfg(test)]
mod doc_commands;
pub mod eval;
pub mod fit;
pub mod fit_report;
pub mod merge;
pub mod opac_tables;
pub mod plan;
pub mod progress;
pub mod render;
pub mod signals;
pub mod transmittance;
pub mod uvspec;
pub mod validate;
