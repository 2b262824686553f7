//! Files in and out: the input check every reader makes, the atomic-write primitive every
//! output goes through, and plain data outputs (CSV, `.npy`, text).  Images are written by
//! `crate::images::codec`, meshes with texture coordinates by `crate::mesh::write`.
//!
//! Every file is written atomically: to a temporary file beside the target, then renamed over
//! it, so an error never leaves a half-written output.

use crate::base::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Checks that an input can be read: it exists, is a regular file (a device or FIFO —
/// `/dev/zero` named by a careless MTL or a script — would be read forever) and is not empty.
/// The error names the file and the cause.
pub fn check_input(path: &Path) -> Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::data(
            path,
            if meta.is_dir() {
                "is a directory, not a file"
            } else {
                "not a regular file"
            },
        ));
    }
    if meta.len() == 0 {
        return Err(Error::data(path, "the file is empty"));
    }
    Ok(())
}

/// Reads a whole input file ([`check_input`] first).
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    check_input(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if bytes.is_empty() {
        return Err(Error::data(path, "the file is empty"));
    }
    Ok(bytes)
}

/// Writes `path` atomically: `fill` writes into a temporary file in the same directory, which
/// is renamed to `path` only when `fill` succeeded.
pub fn atomic_write(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> Result<()>,
) -> Result<()> {
    let tmp = temp_beside(path)?;
    let result = (|| {
        let mut f = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        fill(&mut f)?;
        f.sync_all().map_err(|e| Error::io(&tmp, e))?;
        drop(f);
        std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes several files as one: every file's bytes go to a temporary file beside it first, and
/// only when all of them are written and synced are they renamed into place — so an error in
/// any of them (a full disk, a missing directory) leaves none of the outputs behind.  (The
/// renames themselves, within each file's own directory, are what can still fail midway.)
pub fn atomic_write_all(files: &[(&Path, &[u8])]) -> Result<()> {
    let mut temps: Vec<PathBuf> = Vec::with_capacity(files.len());
    let result = (|| {
        for (path, bytes) in files {
            let tmp = temp_beside(path)?;
            temps.push(tmp.clone());
            let mut f = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
            f.write_all(bytes).map_err(|e| Error::io(&tmp, e))?;
            f.sync_all().map_err(|e| Error::io(&tmp, e))?;
        }
        for ((path, _), tmp) in files.iter().zip(&temps) {
            std::fs::rename(tmp, path).map_err(|e| Error::io(path, e))?;
        }
        Ok(())
    })();
    if result.is_err() {
        for t in &temps {
            let _ = std::fs::remove_file(t);
        }
    }
    result
}

/// The temporary file beside `path` that its atomic write goes through.
fn temp_beside(path: &Path) -> Result<PathBuf> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| Error::param("output", format!("{} is not a file path", path.display())))?;
    Ok(dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    )))
}

pub(crate) fn io_err(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::io(path, e)
}

/// Writes a float32 `.npy` array (NumPy format 1.0, little-endian, C order).
pub fn write_npy_f32(path: &Path, shape: &[usize], data: &[f32]) -> Result<()> {
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "shape does not match data"
    );
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape_txt = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape_txt}, }}");
    // Magic (6) + version (2) + header length (2) + header + '\n' is a multiple of 64.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    atomic_write(path, |f| {
        let mut w = std::io::BufWriter::new(f);
        let e = io_err(path);
        w.write_all(b"\x93NUMPY\x01\x00").map_err(&e)?;
        w.write_all(&(header.len() as u16).to_le_bytes())
            .map_err(&e)?;
        w.write_all(header.as_bytes()).map_err(&e)?;
        for v in data {
            w.write_all(&v.to_le_bytes()).map_err(&e)?;
        }
        w.flush().map_err(&e)
    })
}

/// Writes rows of values as CSV with a header line.  Floats are written with Rust's shortest
/// round-trip formatting, so reading them back gives the same f32 bits; NaN is `nan`.
pub fn write_csv(path: &Path, header: &[&str], data: &[f32]) -> Result<()> {
    let cols = header.len();
    atomic_write(path, |f| {
        let mut w = std::io::BufWriter::new(f);
        let e = io_err(path);
        writeln!(w, "{}", header.join(",")).map_err(&e)?;
        for row in data.chunks_exact(cols) {
            let line: Vec<String> = row
                .iter()
                .map(|v| {
                    if v.is_nan() {
                        "nan".into()
                    } else {
                        format!("{v:?}")
                    }
                })
                .collect();
            writeln!(w, "{}", line.join(",")).map_err(&e)?;
        }
        w.flush().map_err(&e)
    })
}

/// Writes a small text file atomically.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    atomic_write(path, |f| {
        f.write_all(text.as_bytes()).map_err(|e| Error::io(path, e))
    })
}
