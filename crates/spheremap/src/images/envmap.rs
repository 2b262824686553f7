//! Environment maps in files: one image, or six cube faces — named one by one or by a
//! pattern (`{face}`, `{posx}`, `{side}`, `{index}`: [`cube_layout::FACE_TOKENS`]); cube layouts
//! converted to and from the internal face stack; the default output size.

use crate::base::error::{Error, Result};
use crate::images::codec::{
    check_nonfinite, encode_with_note, find_nonfinite, read_image, write_image_with_note,
    NonFinite, ReadOptions, WriteOptions,
};
use crate::images::cube_layout::{self, Layout};
use crate::images::format::Format;
use crate::images::note::MapNote;
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use std::path::Path;

/// The file or files that hold one environment map.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum EnvFiles {
    /// One image (a cube map in a layout), or a face pattern that names six.
    One(String),
    /// Six cube-face files in GL order +X, −X, +Y, −Y, +Z, −Z, and the pattern that named
    /// them, if one did.
    Faces {
        files: [String; 6],
        pattern: Option<String>,
    },
}

impl EnvFiles {
    /// `path` as given: six faces when it holds a face token.
    pub fn parse(path: &str) -> EnvFiles {
        match cube_layout::face_paths(path) {
            Some(files) => EnvFiles::Faces {
                files,
                pattern: Some(path.to_string()),
            },
            None => EnvFiles::One(path.to_string()),
        }
    }

    /// Every file path (six for faces).
    pub fn paths(&self) -> Vec<String> {
        match self {
            EnvFiles::One(p) => vec![p.clone()],
            EnvFiles::Faces { files, .. } => files.to_vec(),
        }
    }

    /// How errors and summaries name it: the path or pattern as given, or six named files
    /// joined by commas.
    pub fn label(&self) -> String {
        match self {
            EnvFiles::One(p)
            | EnvFiles::Faces {
                pattern: Some(p), ..
            } => p.clone(),
            EnvFiles::Faces { files, .. } => files.join(","),
        }
    }

    /// Checks, before any work, that these can be written as an output of `mapping`: six
    /// faces only for a cube, and every file's extension one spheremap writes.
    pub fn check_output(&self, mapping: Mapping) -> Result<()> {
        if matches!(self, EnvFiles::Faces { .. }) && !matches!(mapping, Mapping::Cube(_)) {
            return Err(Error::param(
                "output",
                format!(
                    "{}: six face files, but the output mapping is {}",
                    self.label(),
                    mapping.name()
                ),
            ));
        }
        for p in self.paths() {
            output_format(&p)?;
        }
        Ok(())
    }

    /// The first of its files (what the shape checks of a face stack are named after).
    pub fn first(&self) -> &str {
        match self {
            EnvFiles::One(p) => p,
            EnvFiles::Faces { files, .. } => &files[0],
        }
    }
}

/// Splits a conversion's positional paths into its input and its output: `IN OUT`, where a
/// cube side may instead be six face files in GL order (+X, −X, +Y, −Y, +Z, −Z) — so 2, 7 or
/// 12 paths.  Seven paths with a cube on both sides are ambiguous (six in and one out, or one
/// in and six out) and refused: one side must then be a face pattern or a single image.  Six
/// output files must be six different paths.
pub fn split_paths(
    paths: &[String],
    src_is_cube: bool,
    dst_is_cube: bool,
) -> Result<(EnvFiles, EnvFiles)> {
    let six = |p: &[String]| EnvFiles::Faces {
        files: std::array::from_fn(|i| p[i].clone()),
        pattern: None,
    };
    let (input, output) =
        match (paths.len(), src_is_cube, dst_is_cube) {
            (2, _, _) => (EnvFiles::parse(&paths[0]), EnvFiles::parse(&paths[1])),
            (7, true, false) => (six(&paths[..6]), EnvFiles::parse(&paths[6])),
            (7, false, true) => (EnvFiles::parse(&paths[0]), six(&paths[1..])),
            (7, true, true) => return Err(Error::param(
                "paths",
                "7 paths with a cube on both sides is ambiguous (six inputs and one output, or \
                 one input and six outputs): give that side as one image or a {face} pattern",
            )),
            (12, true, true) => (six(&paths[..6]), six(&paths[6..])),
            (n, src, dst) => {
                let expect = match (src, dst) {
                    (false, false) => "IN OUT",
                    (true, false) => "IN OUT, or six input faces (+X -X +Y -Y +Z -Z) and OUT",
                    (false, true) => "IN OUT, or IN and six output faces (+X -X +Y -Y +Z -Z)",
                    (true, true) => "IN OUT, or six input faces and six output faces",
                };
                return Err(Error::param(
                    "paths",
                    format!("got {n} paths; expected {expect}"),
                ));
            }
        };
    if let EnvFiles::Faces { files: f, .. } = &output {
        for (i, p) in f.iter().enumerate() {
            if f[..i].contains(p) {
                return Err(Error::param(
                    "output",
                    format!("{p}: named for two cube faces; the six outputs must differ"),
                ));
            }
        }
    }
    Ok((input, output))
}

/// Reads an environment map of `mapping` into its canvas (for a cube: the F×6F face stack).
///
/// A cube map comes from six files when `path` holds a face token ([`cube_layout::FACE_TOKENS`]), else
/// from one image in `layout` (or the layout its shape implies: 1:6 vstrip, 4:3 hcross, 3:4
/// vcross; a 6:1 strip must be named).
pub fn read_env(
    path: &str,
    mapping: Mapping,
    layout: Option<Layout>,
    opts: &ReadOptions,
) -> Result<Image> {
    read_env_files(&EnvFiles::parse(path), mapping, layout, opts)
}

/// [`read_env`] from [`EnvFiles`]: one image or six faces.
pub fn read_env_files(
    files: &EnvFiles,
    mapping: Mapping,
    layout: Option<Layout>,
    opts: &ReadOptions,
) -> Result<Image> {
    read_env_layout(files, mapping, layout, opts).map(|(img, _)| img)
}

/// How a job reads its environment: [`read_env_layout`], or a caller's own (the batch runner
/// reads an input once for all of a recipe's outputs and hands out copies).
pub type EnvReader<'a> = dyn FnMut(&EnvFiles, Mapping, Option<Layout>, &ReadOptions) -> Result<(Image, Option<Layout>)>
    + 'a;

/// [`read_env_files`], and the cube layout the image was read in (the one given, else the one
/// its shape implies; `None` for six faces and other mappings).
pub fn read_env_layout(
    files: &EnvFiles,
    mapping: Mapping,
    layout: Option<Layout>,
    opts: &ReadOptions,
) -> Result<(Image, Option<Layout>)> {
    let path = match files {
        EnvFiles::Faces { files: paths, .. } => {
            if !matches!(mapping, Mapping::Cube(_)) {
                return Err(Error::param(
                    "input",
                    format!(
                        "{}: six face files, but the input mapping is {}",
                        files.label(),
                        mapping.name()
                    ),
                ));
            }
            let faces = paths
                .iter()
                .map(|p| read_image(Path::new(p), opts))
                .collect::<Result<Vec<_>>>()?;
            return Ok((cube_layout::stack_faces(&faces, paths)?, None));
        }
        EnvFiles::One(p) => p,
    };
    let img = read_image(Path::new(path), opts)?;
    if let Mapping::Cube(_) = mapping {
        let layout = match layout {
            Some(l) => l,
            None => Layout::from_shape(img.width, img.height)
                .map_err(|e| Error::data(path, e.to_string()))?,
        };
        let stack = layout
            .to_stack(&img)
            .map_err(|e| Error::data(path, e.to_string()))?;
        return Ok((stack, Some(layout)));
    }
    mapping.check_input(img.width, img.height, path)?;
    Ok((img, None))
}

/// Writes a canvas of `mapping` (cube: face stack), made for `view` ([`crate::frame::view`]; the
/// identity for the world frame), to `path`: six files for a face pattern, else one image
/// (cube maps in `layout`, default hcross; a `.ktx2` or `.dds` file without a layout, or in
/// the face stack's, holds a cube texture of six faces).  The output paths are returned.
pub fn write_env(
    path: &str,
    mapping: Mapping,
    img: &Image,
    layout: Option<Layout>,
    view: &crate::frame::view::Mat3,
    opts: &WriteOptions,
) -> Result<Vec<String>> {
    write_env_files(&EnvFiles::parse(path), mapping, img, layout, view, opts)
}

/// [`write_env`] to [`EnvFiles`].  Every file records its mapping, preset, cube layout or
/// face, and view ([`crate::images::note`]).  Written atomically: six faces are all encoded, then all
/// written beside their targets and renamed into place together
/// ([`crate::base::files::atomic_write_all`]), so a bad extension or a failed write leaves none of them.
pub fn write_env_files(
    files: &EnvFiles,
    mapping: Mapping,
    img: &Image,
    layout: Option<Layout>,
    view: &crate::frame::view::Mat3,
    opts: &WriteOptions,
) -> Result<Vec<String>> {
    let view = crate::frame::view::as_look_up(view);
    files.check_output(mapping)?;
    let path = match files {
        EnvFiles::Faces { files: paths, .. } => {
            let bytes = paths
                .iter()
                .zip(cube_layout::split_stack(img))
                .enumerate()
                .map(|(i, (p, face))| {
                    let tag = MapNote {
                        mapping,
                        layout: None,
                        face: Some(i),
                        view,
                    };
                    encode_with_note(
                        Path::new(p),
                        &face,
                        output_format(p)?,
                        opts,
                        Some(&tag.text()),
                    )
                })
                .collect::<Result<Vec<_>>>()?;
            let writes: Vec<(&Path, &[u8])> = paths
                .iter()
                .zip(&bytes)
                .map(|(p, b)| (Path::new(p.as_str()), b.as_slice()))
                .collect();
            crate::base::files::atomic_write_all(&writes)?;
            return Ok(paths.to_vec());
        }
        EnvFiles::One(p) => p,
    };
    let owned;
    let mut tag = MapNote {
        mapping,
        layout: None,
        face: None,
        view,
    };
    let stack = matches!(layout, None | Some(Layout::VStrip));
    if matches!(mapping, Mapping::Cube(_)) && Format::names_container(path) && stack {
        // A cube texture: its six faces, read back as the face stack (so a cube read from one
        // is written as one).
        tag.layout = Some(Layout::VStrip);
        let tex = crate::images::container::Texture {
            cube: true,
            levels: vec![img.clone()],
        };
        crate::images::codec::write_texture(Path::new(path), &tex, opts, Some(&tag.text()))?;
        return Ok(vec![path.to_string()]);
    }
    let out = if let Mapping::Cube(_) = mapping {
        let layout = layout.unwrap_or(Layout::HCross);
        tag.layout = Some(layout);
        owned = layout.from_stack(img)?;
        &owned
    } else {
        img
    };
    write_image_with_note(Path::new(path), out, opts, Some(&tag.text()))?;
    Ok(vec![path.to_string()])
}

/// The mapping the file `path` names records ([`crate::images::note`]; for a face pattern, its first
/// face's file), if it records one; an error when that file cannot be read.
pub fn read_note(path: &str) -> Result<Option<MapNote>> {
    let files = EnvFiles::parse(path);
    Ok(crate::images::note::read_file(Path::new(files.first()))?
        .as_deref()
        .and_then(MapNote::parse))
}

/// The mapping to read a file as: the `name` and `preset` given, each one absent taken from
/// the file's note `recorded` (its preset only when the note is of the same mapping: a
/// `--from sphere` on a file noted `mapping=sphere preset=skylibs` reads it as skylibs), else
/// `default` with its own preset.  `None` when there is no name, note or default.
pub fn mapping_for(
    name: Option<&str>,
    preset: Option<&str>,
    recorded: Option<&MapNote>,
    default: Option<&str>,
) -> Result<Option<Mapping>> {
    let noted = recorded.map(|t| t.mapping);
    let name = match (name, noted) {
        (Some(n), _) => Mapping::parse(n, None)?.name(),
        (None, Some(m)) => m.name(),
        (None, None) => match default {
            Some(d) => d,
            None => return Ok(None),
        },
    };
    let preset = preset.or(noted.filter(|m| m.name() == name).map(|m| m.preset_name()));
    Mapping::parse(name, preset).map(Some)
}

/// Refuses outputs that are one of the inputs (`{face}` patterns on either side stand for
/// their six files): an error naming the output.  Commands skip it when told to overwrite.
pub fn refuse_overwrite(inputs: &[String], outputs: &[String]) -> Result<()> {
    let inputs: Vec<String> = inputs.iter().flat_map(|i| env_paths(i)).collect();
    for o in outputs.iter().flat_map(|o| env_paths(o)) {
        if inputs
            .iter()
            .any(|i| same_file(Path::new(i), Path::new(&o)))
        {
            return Err(Error::data(
                &o,
                "the output would overwrite the input (use --force to allow)",
            ));
        }
    }
    Ok(())
}

/// An environment map file's mapping and cube layout: the names given, else what the file's
/// note records, else `default` (with its own preset).  An empty `path` (no file) records
/// nothing.  The rule `render --env`, `generate --env` and Python's `render(env=path)` follow.
pub fn env_mapping_of(
    path: &str,
    name: Option<&str>,
    preset: Option<&str>,
    layout: Option<&str>,
    default: &str,
) -> Result<(Mapping, Option<Layout>)> {
    let note = match path {
        "" => None,
        p => read_note(p)?,
    };
    let mapping = mapping_for(name, preset, note.as_ref(), Some(default))?
        .expect("a default mapping is given");
    let layout = layout_for(layout, note.as_ref(), mapping)?;
    Ok((mapping, layout))
}

/// The cube layout to read a file in: the `layout` given, else the one its note `recorded`
/// names when the note is of `mapping` (the mapping it is read as).
pub fn layout_for(
    layout: Option<&str>,
    recorded: Option<&MapNote>,
    mapping: Mapping,
) -> Result<Option<Layout>> {
    match layout {
        Some(l) => Layout::parse(l).map(Some),
        None => Ok(recorded
            .filter(|t| t.mapping.name() == mapping.name())
            .and_then(|t| t.layout)),
    }
}

/// The format an output path's extension asks for (one spheremap writes: not WebP).
fn output_format(path: &str) -> Result<Format> {
    match Format::from_extension(Path::new(path)) {
        Some(f) if f != Format::Webp => Ok(f),
        found => Err(Error::param(
            "output",
            format!(
                "{path}: {}; use .exr, .hdr, .pfm, .png, .jpg, .ktx2 or .dds",
                if found.is_some() {
                    "spheremap reads WebP but does not write it"
                } else {
                    "unknown image extension"
                }
            ),
        )),
    }
}

/// [`check_nonfinite`] for a map read from `files`: a NaN/Inf in a stack of six faces is
/// reported against its own face file, at its pixel in that face.
pub fn check_nonfinite_env(img: &mut Image, files: &EnvFiles, policy: NonFinite) -> Result<()> {
    if let (EnvFiles::Faces { files: f, .. }, NonFinite::Error) = (files, policy) {
        if let Some((_, _, y)) = find_nonfinite(img) {
            let face = img.width.max(1);
            let k = img.width * face * img.channels;
            let i = (y / face).min(5);
            let mut one = Image {
                width: img.width,
                height: face,
                channels: img.channels,
                data: img.data[i * k..(i + 1) * k].to_vec(),
            };
            return check_nonfinite(&mut one, policy, &f[i]);
        }
    }
    check_nonfinite(img, policy, files.first())
}

/// The input paths a `path` argument names (six for a face pattern).
pub fn env_paths(path: &str) -> Vec<String> {
    EnvFiles::parse(path).paths()
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
