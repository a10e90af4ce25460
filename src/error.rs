//! The library's error type. Every variant that a user can cause names what
//! caused it: the file, the job key and the valid range.

use std::path::PathBuf;

/// Errors of the atmosim library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The job file is not valid TOML or does not match the job schema
    /// (unknown key, wrong type). The message is TOML's, with line and column.
    #[error("{file}: {message}")]
    JobSyntax { file: String, message: String },

    /// A job key has a value outside its valid range.
    #[error("{file}: `{key}` = {value}: {reason} (valid: {valid})")]
    InvalidValue {
        file: String,
        key: String,
        value: String,
        reason: String,
        valid: String,
    },

    /// A data table (built-in or user-supplied) is malformed or does not cover
    /// what the job asks for.
    #[error("{source_name}: {message}")]
    Data { source_name: String, message: String },

    /// A uvspec input file (`atmosim uvspec`) has a line atmosim cannot use:
    /// an unknown keyword, a missing or bad value, an unsupported option.
    #[error("{file}:{line}: {message}")]
    Uvspec { file: String, line: usize, message: String },

    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// True for errors caused by the user's input (job files, data files they
    /// named, values out of range); the binary exits with code 2 for these.
    pub fn is_user_error(&self) -> bool {
        match self {
            Error::JobSyntax { .. } | Error::InvalidValue { .. } | Error::Data { .. } | Error::Uvspec { .. } => true,
            Error::Io { source, .. } => source.kind() == std::io::ErrorKind::NotFound,
        }
    }

    /// Shorthand for a data error.
    pub fn data(source_name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Data {
            source_name: source_name.into(),
            message: message.into(),
        }
    }
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
