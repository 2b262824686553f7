//! Errors, classified by who is at fault, so that each boundary (CLI, Python) maps them once:
//! the caller passed a bad parameter, a file holds bad data, the request is valid but not
//! supported, or the operating system failed us.

use std::path::PathBuf;

/// Every error the core returns.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter is out of its domain (wrong shape, unknown name, non-finite where finite is
    /// required). `name` is the parameter's name as the caller spelled it.
    #[error("{name}: {reason}")]
    InvalidParameter { name: String, reason: String },
    /// A file or buffer holds data we cannot use (corrupt, inconsistent, out of range).
    #[error("{}: {reason}", source_name.display())]
    InvalidData {
        source_name: PathBuf,
        reason: String,
    },
    /// Valid input that this version does not handle (say, an unknown file format).
    #[error("{what} is not supported: {reason}")]
    Unsupported { what: String, reason: String },
    /// The caller cancelled the work (Ctrl-C, or a `Progress::cancel` flag); nothing was
    /// produced.
    #[error("{what} was cancelled")]
    Cancelled { what: String },
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    pub fn param(name: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::InvalidParameter {
            name: name.into(),
            reason: reason.into(),
        }
    }
    pub fn data(source_name: impl Into<PathBuf>, reason: impl Into<String>) -> Self {
        Error::InvalidData {
            source_name: source_name.into(),
            reason: reason.into(),
        }
    }
    pub fn unsupported(what: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Unsupported {
            what: what.into(),
            reason: reason.into(),
        }
    }
    pub fn cancelled(what: impl Into<String>) -> Self {
        Error::Cancelled { what: what.into() }
    }
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
