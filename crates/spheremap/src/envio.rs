//! Environment maps in files: one image, or six cube faces named by a `{face}` pattern; cube
//! layouts converted to and from the internal face stack; the default output size.

use crate::cube::{self, Layout};
use crate::error::{Error, Result};
use crate::image_io::{read_image, write_image, Image, ReadOptions, WriteOptions};
use crate::mapping::Mapping;
use std::path::Path;

/// Reads an environment map of `mapping` into its canvas (for a cube: the F×6F face stack).
///
/// A cube map comes from six files when `path` contains `{face}` (replaced by px nx py ny pz
/// nz), else from one image in `layout` (or the layout its shape implies: 1:6 vstrip, 4:3
/// hcross, 3:4 vcross; a 6:1 strip must be named).
pub fn read_env(
    path: &str,
    mapping: Mapping,
    layout: Option<Layout>,
    opts: &ReadOptions,
) -> Result<Image> {
    if let Some(paths) = cube::face_paths(path) {
        if !matches!(mapping, Mapping::Cube(_)) {
            return Err(Error::param(
                "input",
                format!(
                    "{path}: a {{face}} pattern names six cube faces, but the input mapping is {}",
                    mapping.name()
                ),
            ));
        }
        let faces = paths
            .iter()
            .map(|p| read_image(Path::new(p), opts))
            .collect::<Result<Vec<_>>>()?;
        return cube::stack_faces(&faces, &paths);
    }
    let img = read_image(Path::new(path), opts)?;
    if let Mapping::Cube(_) = mapping {
        let layout = match layout {
            Some(l) => l,
            None => Layout::from_shape(img.width, img.height)
                .map_err(|e| Error::data(path, e.to_string()))?,
        };
        return layout
            .to_stack(&img)
            .map_err(|e| Error::data(path, e.to_string()));
    }
    mapping.size_of(img.width, img.height, path)?;
    Ok(img)
}

/// Writes a canvas of `mapping` (cube: face stack) to `path`: six files for a `{face}` pattern,
/// else one image (cube maps in `layout`, default hcross).  Every file is written atomically;
/// the output paths are returned.
pub fn write_env(
    path: &str,
    mapping: Mapping,
    img: &Image,
    layout: Option<Layout>,
    opts: &WriteOptions,
) -> Result<Vec<String>> {
    if let Some(paths) = cube::face_paths(path) {
        if !matches!(mapping, Mapping::Cube(_)) {
            return Err(Error::param(
                "output",
                format!(
                    "{path}: a {{face}} pattern names six cube faces, but the output mapping is {}",
                    mapping.name()
                ),
            ));
        }
        // Encode all six before writing any, so a bad extension leaves nothing behind.
        for p in &paths {
            crate::image_io::Format::from_extension(Path::new(p)).ok_or_else(|| {
                Error::param(
                    "output",
                    format!("{p}: unknown image extension; use .exr, .hdr, .pfm, .png or .jpg"),
                )
            })?;
        }
        for (p, face) in paths.iter().zip(cube::split_stack(img)) {
            write_image(Path::new(p), &face, opts)?;
        }
        return Ok(paths.to_vec());
    }
    let owned;
    let out = if let Mapping::Cube(_) = mapping {
        owned = layout.unwrap_or(Layout::HCross).from_stack(img)?;
        &owned
    } else {
        img
    };
    write_image(Path::new(path), out, opts)?;
    Ok(vec![path.to_string()])
}

/// The input paths a `path` argument names (six for a `{face}` pattern).
pub fn env_paths(path: &str) -> Vec<String> {
    cube::face_paths(path).map_or_else(|| vec![path.to_string()], |p| p.to_vec())
}

/// Default output size N for converting a source of size `src_n` (see [`Mapping::canvas`]):
/// the same N, except that a cube face of F becomes a disc/lat-long of 2F and a disc or
/// lat-long of N becomes cube faces of N/2 — so that the output resolves about what the input
/// does near the view direction.
pub fn default_size(src: Mapping, src_n: usize, dst: Mapping) -> usize {
    match (
        matches!(src, Mapping::Cube(_)),
        matches!(dst, Mapping::Cube(_)),
    ) {
        (true, false) => 2 * src_n,
        (false, true) => (src_n / 2).max(1),
        _ => src_n,
    }
}

/// Whether two paths name the same existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}
