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

/// The largest map size N any operation makes (a sphere map's side, a lat-long's height, a cube
/// face): 32768.
pub const MAX_MAP_SIZE: usize = 1 << 15;

/// `n` as a map size for the argument `what` (1..=[`MAX_MAP_SIZE`]), or an error naming it.
pub fn check_map_size(what: &str, n: usize) -> Result<usize> {
    if n == 0 || n > MAX_MAP_SIZE {
        return Err(Error::param(
            what,
            format!("{n} is out of range 1..={MAX_MAP_SIZE}"),
        ));
    }
    Ok(n)
}

/// The memory a job may allocate unless told otherwise: `SPHEREMAP_MAX_MEMORY` (bytes, or with
/// a K/M/G/T suffix, powers of 1024) or else 16 GiB.
pub fn default_max_memory() -> u64 {
    std::env::var("SPHEREMAP_MAX_MEMORY")
        .ok()
        .and_then(|s| parse_bytes(&s))
        .unwrap_or(16 << 30)
}

/// A memory limit as users write it ("8G", "512M", bytes); the error names `what`.
pub fn parse_memory_limit(what: &str, text: &str) -> Result<u64> {
    parse_bytes(text).ok_or_else(|| {
        Error::param(
            what,
            format!("cannot read {text:?}; expected bytes or a size like 512M, 8G"),
        )
    })
}

/// "8G", "512M", "1000000" → bytes.
pub fn parse_bytes(s: &str) -> Option<u64> {
    let s = s.trim();
    let (num, shift) = match s.char_indices().last()? {
        (i, 'k' | 'K') => (&s[..i], 10),
        (i, 'm' | 'M') => (&s[..i], 20),
        (i, 'g' | 'G') => (&s[..i], 30),
        (i, 't' | 'T') => (&s[..i], 40),
        _ => (s, 0),
    };
    let v: f64 = num.trim().parse().ok()?;
    (v.is_finite() && v >= 0.0 && v * 2f64.powi(shift) < 1.8e19)
        .then(|| (v * 2f64.powi(shift)) as u64)
}

/// Refuses a job whose estimated allocation `bytes` is over `cap`.
pub fn check_memory(what: &str, bytes: u128, cap: u64) -> Result<()> {
    if bytes > cap as u128 {
        let gib = |b: f64| b / (1u64 << 30) as f64;
        return Err(Error::limit(
            what,
            format!(
                "the job needs about {:.1} GiB, over the memory limit of {:.1} GiB \
                 (--max-memory / max_memory= / SPHEREMAP_MAX_MEMORY raise it)",
                gib(bytes as f64),
                gib(cap as f64)
            ),
        ));
    }
    Ok(())
}

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
