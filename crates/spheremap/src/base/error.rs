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
    /// The input or the job is over a configured limit (image dimensions in a header, the
    /// memory a job would need); `what` names the file or parameter.
    #[error("{what}: {reason}")]
    Limit { what: String, reason: String },
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
    /// The same error with its parameter named `name` (a parser's error, named as the caller
    /// spells the argument); other errors unchanged.
    pub fn named(self, name: &str) -> Self {
        match self {
            Error::InvalidParameter { reason, .. } => Error::param(name, reason),
            other => other,
        }
    }

    /// The same error said of `to` where it names `from` (a parameter, or the source of bad
    /// data): how a caller names its own argument or file in a callee's errors.
    pub fn renamed(self, from: &str, to: &str) -> Self {
        match self {
            Error::InvalidParameter { name, reason } if name == from => Error::param(to, reason),
            Error::InvalidData {
                source_name,
                reason,
            } if source_name.as_os_str() == from => Error::data(to, reason),
            e => e,
        }
    }

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
    pub fn limit(what: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Limit {
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

/// Where [`warn`] sends a warning: `None` prints it on stderr.
static WARNING_SINK: std::sync::RwLock<Option<fn(&str)>> = std::sync::RwLock::new(None);

/// Installs the function that receives every warning (Python's glue queues them and emits a
/// `UserWarning` for each); `None` restores printing on stderr.  Returns the sink it replaces.
pub fn set_warning_sink(sink: Option<fn(&str)>) -> Option<fn(&str)> {
    std::mem::replace(
        &mut *WARNING_SINK.write().unwrap_or_else(|e| e.into_inner()),
        sink,
    )
}

/// Something the user must hear that does not stop the work (a file whose content disagrees
/// with its name): one line, naming the file.  Printed on stderr as `spheremap: warning: …`
/// unless a sink is installed ([`set_warning_sink`]).
pub fn warn(msg: &str) {
    match *WARNING_SINK.read().unwrap_or_else(|e| e.into_inner()) {
        Some(sink) => sink(msg),
        None => eprintln!("spheremap: warning: {msg}"),
    }
}

thread_local! {
    static GUARDED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs third-party parsing code that may panic on malformed input (the `gltf` crate has
/// `unwrap`s and `unreachable!`s that a crafted file reaches — found by our fuzzer) and turns a
/// panic into [`Error::InvalidData`] about `path`.  While it runs, [`panic_is_guarded`] is true
/// on this thread so panic hooks (the CLI's, the Python module's) can stay quiet.
pub fn guard_parser<T>(
    path: &std::path::Path,
    what: &str,
    f: impl FnOnce() -> Result<T>,
) -> Result<T> {
    GUARDED.with(|g| g.set(true));
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    GUARDED.with(|g| g.set(false));
    match r {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(Error::data(
                path,
                format!("malformed {what} file (the reader stopped: {msg})"),
            ))
        }
    }
}

/// True while [`guard_parser`] runs on this thread (for panic hooks).
pub fn panic_is_guarded() -> bool {
    GUARDED.with(|g| g.get())
}
