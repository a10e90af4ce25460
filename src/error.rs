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

    /// A file could not be read or written. The operating system's message
    /// is part of this error's own text, not a separate cause, so that it
    /// is printed once.
    #[error("{}: {error}", path.display())]
    Io { path: PathBuf, error: std::io::Error },
}

impl Error {
    /// True for errors caused by the user's input (job files, data files they
    /// named, values out of range); the binary exits with code 2 for these.
    pub fn is_user_error(&self) -> bool {
        match self {
            Error::JobSyntax { .. } | Error::InvalidValue { .. } | Error::Data { .. } | Error::Uvspec { .. } => true,
            Error::Io { error, .. } => is_user_io_error(error.kind()),
        }
    }

    /// An I/O error at `path`.
    pub fn io(path: impl Into<PathBuf>, error: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            error,
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

/// True for the I/O errors a user's paths cause (a file that is missing,
/// not a file, not readable or writable, a directory that is a file, bytes
/// that are not text), as opposed to a full disk or a failing device.
fn is_user_io_error(kind: std::io::ErrorKind) -> bool {
    use std::io::ErrorKind::*;
    matches!(
        kind,
        NotFound
            | PermissionDenied
            | NotADirectory
            | IsADirectory
            | ReadOnlyFilesystem
            | InvalidData
            | InvalidInput
            | InvalidFilename
            | AlreadyExists
            | DirectoryNotEmpty
    )
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
