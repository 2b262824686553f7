//! Writing results: images (PNG, EXR), vertex data (CSV, `.npy`, OBJ with `vt`).
//!
//! Every file is written atomically: to a temporary file beside the target, then renamed over
//! it, so an error never leaves a half-written output.  Images here are linear float RGB, row 0
//! at the top (see [`crate::conventions`]); PNG output is sRGB-encoded.

use crate::error::{Error, Result};
use crate::mesh::Mesh;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A linear float image, row 0 at the top, `channels` interleaved values per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: Vec<f32>,
}

impl Image {
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        Image {
            width,
            height,
            channels,
            data: vec![0.0; width * height * channels],
        }
    }
    #[inline]
    pub fn pixel_mut(&mut self, x: usize, y: usize) -> &mut [f32] {
        let i = (y * self.width + x) * self.channels;
        &mut self.data[i..i + self.channels]
    }
    #[inline]
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }
}

/// Writes `path` atomically: `fill` writes into a temporary file in the same directory, which
/// is renamed to `path` only when `fill` succeeded.
pub fn atomic_write(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| Error::param("output", format!("{} is not a file path", path.display())))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
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

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::io(path, e)
}

/// Linear → sRGB transfer (IEC 61966-2-1), clamped to [0,1].
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes an image; the format follows the extension: `.png` (8-bit sRGB) or `.exr` (32-bit
/// float, linear).
pub fn write_image(path: &Path, img: &Image) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if !(img.channels == 3 || img.channels == 4) {
        return Err(Error::unsupported(
            format!("{}-channel image", img.channels),
            "only RGB and RGBA are written",
        ));
    }
    match ext.as_str() {
        "png" => {
            let bytes: Vec<u8> = img
                .data
                .chunks_exact(img.channels)
                .flat_map(|px| {
                    px.iter().enumerate().map(|(c, &v)| {
                        let e = if c == 3 {
                            v.clamp(0.0, 1.0)
                        } else {
                            linear_to_srgb(v)
                        };
                        (e * 255.0 + 0.5) as u8
                    })
                })
                .collect();
            let color = if img.channels == 3 {
                image::ExtendedColorType::Rgb8
            } else {
                image::ExtendedColorType::Rgba8
            };
            atomic_write(path, |f| {
                let enc = image::codecs::png::PngEncoder::new(std::io::BufWriter::new(f));
                image::ImageEncoder::write_image(
                    enc,
                    &bytes,
                    img.width as u32,
                    img.height as u32,
                    color,
                )
                .map_err(|e| Error::data(path, format!("cannot encode PNG: {e}")))
            })
        }
        "exr" => {
            let color = if img.channels == 3 {
                image::ExtendedColorType::Rgb32F
            } else {
                image::ExtendedColorType::Rgba32F
            };
            let bytes: Vec<u8> = img.data.iter().flat_map(|v| v.to_le_bytes()).collect();
            atomic_write(path, |f| {
                let enc = image::codecs::openexr::OpenExrEncoder::new(std::io::BufWriter::new(f));
                image::ImageEncoder::write_image(
                    enc,
                    &bytes,
                    img.width as u32,
                    img.height as u32,
                    color,
                )
                .map_err(|e| Error::data(path, format!("cannot encode EXR: {e}")))
            })
        }
        other => Err(Error::unsupported(
            format!("image extension {other:?}"),
            "write .png or .exr",
        )),
    }
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

/// Writes a mesh as OBJ with one `vt` per vertex (the texgen result) and `vn` normals.
/// `mtl`: optional (material library file name, material name) to reference.
pub fn write_obj_with_uv(
    path: &Path,
    mesh: &Mesh,
    uv: &[f32],
    mtl: Option<(&str, &str)>,
) -> Result<()> {
    assert_eq!(uv.len(), 2 * mesh.positions.len());
    atomic_write(path, |f| {
        let mut w = std::io::BufWriter::new(f);
        let e = io_err(path);
        writeln!(
            w,
            "# written by spheremap {}: vt = GL_SPHERE_MAP texgen (s,t)",
            env!("CARGO_PKG_VERSION")
        )
        .map_err(&e)?;
        if let Some((lib, _)) = mtl {
            writeln!(w, "mtllib {lib}").map_err(&e)?;
        }
        for p in &mesh.positions {
            writeln!(w, "v {:?} {:?} {:?}", p[0], p[1], p[2]).map_err(&e)?;
        }
        for st in uv.chunks_exact(2) {
            // NaN (singular) texcoords would break OBJ readers: write the centre and say so.
            let (s, t) = if st[0].is_finite() && st[1].is_finite() {
                (st[0], st[1])
            } else {
                (0.5, 0.5)
            };
            writeln!(w, "vt {s:?} {t:?}").map_err(&e)?;
        }
        for n in &mesh.normals {
            writeln!(w, "vn {:?} {:?} {:?}", n[0], n[1], n[2]).map_err(&e)?;
        }
        if let Some((_, name)) = mtl {
            writeln!(w, "usemtl {name}").map_err(&e)?;
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| i + 1);
            writeln!(w, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}").map_err(&e)?;
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
