//! Reading and writing images: OpenEXR, Radiance `.hdr`, PFM, PNG (8/16-bit), JPEG, WebP
//! (read), and the texture containers KTX2 and DDS ([`crate::images::container`]: an image is
//! their level 0, a cube's as its face stack).  In memory an [`Image`] is linear float32, row 0 at the top (see
//! [`crate::frame::conventions`]), 1–4 interleaved channels named Y / Y,A / R,G,B / R,G,B,A.
//!
//! * Formats are recognised by their first bytes, not by the file name; a name that disagrees
//!   with the content is reported by [`inspect`] but does not stop reading.
//! * LDR files (PNG, JPEG, WebP) are sRGB-decoded to linear on read and encoded on write, unless
//!   `linear` is set (for data such as normal maps that is not colour).
//! * Header sizes are checked against [`Limits`] before any pixel memory is allocated.
//! * Writes are atomic (temporary file + rename; see [`crate::base::files::atomic_write`]).

use super::compress::{Encoding, LevelCompression};
use super::fold::fold_negatives;
use super::format::Format;
use super::Image;
use crate::base::error::{Error, Result};
use crate::base::files::atomic_write;
use std::io::{BufWriter, Cursor, Write};
use std::path::Path;

pub use super::limits::Limits;

/// How to read.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReadOptions {
    /// Treat LDR files as linear values (no sRGB decoding).
    pub linear: bool,
    pub limits: Limits,
}

/// How to write.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteOptions {
    /// Write LDR files without sRGB encoding.
    pub linear: bool,
    /// PNG bit depth: 8 (default) or 16.
    pub png16: bool,
    /// EXR sample type: half (16-bit float) instead of 32-bit float.  A value beyond the half
    /// range (±65504) is refused (an error naming the count and the largest) unless
    /// `clamp_half`: half would hold it as Inf.
    pub half: bool,
    /// With `half`: clamp values beyond the half range to ±65504 instead of refusing them.
    pub clamp_half: bool,
    /// KTX2 and DDS: how texels are encoded ([`crate::images::compress`]; `half` applies to
    /// `Float`).  Other formats refuse any encoding but `Float`.
    pub encode: Encoding,
    /// KTX2: Zstandard supercompression of each level at this level (1–22).
    pub zstd: Option<i32>,
}

/// The file formats that hold an encoding (`None`: any; float texels go everywhere).
pub fn encoding_formats(e: Encoding) -> Option<&'static [Format]> {
    match e {
        Encoding::Float => None,
        Encoding::Bc6h | Encoding::Rgb9e5 => Some(&[Format::Ktx2, Format::Dds]),
        Encoding::UastcHdr4x4 | Encoding::AstcHdr6x6 => Some(&[Format::Ktx2]),
        Encoding::Rgbd | Encoding::Rgbm => Some(&[Format::Png]),
    }
}

/// Zstandard's levels, as `--zstd` takes them.
pub const ZSTD_LEVELS: std::ops::RangeInclusive<i32> = 1..=22;

impl WriteOptions {
    /// Checks the encoding and supercompression against the output format, and that
    /// `clamp_half` comes with `half`; errors name `path`'s option.
    pub fn check_for(&self, path: &Path, format: Format) -> Result<()> {
        if self.clamp_half && !self.half {
            return Err(Error::param("clamp_half", "applies to half output (half)"));
        }
        if let Some(z) = self.zstd {
            if !ZSTD_LEVELS.contains(&z) {
                return Err(Error::param(
                    "zstd",
                    format!("Zstandard level {z}; the levels are 1 to 22"),
                ));
            }
            if format != Format::Ktx2 {
                return Err(Error::param(
                    "zstd",
                    format!(
                        "{}: Zstandard supercompression is written in KTX2 only, not {}",
                        path.display(),
                        format.name()
                    ),
                ));
            }
        }
        if let Some(allowed) = encoding_formats(self.encode).filter(|a| !a.contains(&format)) {
            let names: Vec<&str> = allowed.iter().map(|f| f.name()).collect();
            return Err(Error::param(
                "encode",
                format!(
                    "{}: {} is written in {}, not {}",
                    path.display(),
                    self.encode.name(),
                    names.join(" or "),
                    format.name()
                ),
            ));
        }
        Ok(())
    }
}

/// The largest finite half-float.
pub const HALF_MAX: f32 = 65504.0;

/// What encoding an image in a format loses: values the format cannot hold.  NaN and Inf that
/// the image holds are not counted (EXR and PFM keep them; the LDR formats and Radiance HDR
/// have no place for them and count them as clipped).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Losses {
    /// Values clipped to the format's range: PNG and JPEG hold [0, 1] (a value counts when it
    /// lies out of range by more than half a quantisation step), Radiance HDR holds no
    /// negative values; NaN and Inf in either.
    pub clipped: u64,
    /// Finite values beyond the half-float range (EXR with `half`): refused, or clamped to
    /// ±65504 with `clamp_half`.
    pub beyond_half: u64,
    /// The largest magnitude among `beyond_half`.
    pub largest: f32,
}

/// The counts of [`Losses`] a `--json` report carries: `clipped` and `clamped_half`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LossCounts {
    pub clipped: u64,
    pub clamped_half: u64,
}

impl From<Losses> for LossCounts {
    fn from(l: Losses) -> LossCounts {
        LossCounts {
            clipped: l.clipped,
            clamped_half: l.beyond_half,
        }
    }
}

impl Losses {
    /// What writing `img` as `format` with `opts` loses.
    pub fn of(img: &Image, format: Format, opts: &WriteOptions) -> Losses {
        let c = img.channels.max(1);
        let mut l = Losses::default();
        match format {
            Format::Exr | Format::Ktx2 | Format::Dds if opts.half => {
                for &v in &img.data {
                    if v.is_finite()
                        && v.abs() > HALF_MAX
                        && exr::prelude::f16::from_f32(v).is_infinite()
                    {
                        l.beyond_half += 1;
                        l.largest = l.largest.max(v.abs());
                    }
                }
            }
            Format::Png if opts.encode.is_packing() => {
                let max = opts.encode.range().expect("a packing");
                l.clipped = img
                    .data
                    .chunks_exact(c)
                    .flat_map(|p| match p.len() {
                        1 | 2 => vec![p[0]; 3],
                        _ => p[..3].to_vec(),
                    })
                    .filter(|v| !(*v >= 0.0 && *v <= max))
                    .count() as u64;
            }
            Format::Png | Format::Jpeg => {
                let step = if format == Format::Png && opts.png16 {
                    65535.0
                } else {
                    255.0
                };
                let half_step = 0.5 / step;
                for (i, &v) in img.data.iter().enumerate() {
                    let alpha = (c == 2 || c == 4) && i % c == c - 1;
                    let e = if opts.linear || alpha || !v.is_finite() {
                        v
                    } else if v > 1.0 {
                        // sRGB's encoding past 1 (its formula continued): what would clip.
                        1.055 * v.powf(1.0 / 2.4) - 0.055
                    } else if v < 0.0 {
                        12.92 * v
                    } else {
                        0.5 // in range
                    };
                    if !e.is_finite() || e > 1.0 + half_step || e < -half_step {
                        l.clipped += 1;
                    }
                }
            }
            Format::Hdr => {
                l.clipped = img
                    .data
                    .iter()
                    .filter(|v| !(**v >= 0.0) || v.is_infinite())
                    .count() as u64;
            }
            _ => {}
        }
        l
    }
}

/// sRGB transfer function, decoding (IEC 61966-2-1).
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function, encoding; clamps to [0,1] (NaN → 0).
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Reads an image file (format by content).  A name whose extension names another format
/// than the content is read by its content, with a warning ([`crate::base::error::warn`]:
/// [`extension_warning`]).
pub fn read_image(path: &Path, opts: &ReadOptions) -> Result<Image> {
    decode_file(path, &crate::base::files::read_file(path)?, opts)
}

/// The bytes of the file `path`, decoded as [`read_image`] does: with a warning when the
/// content is another format than the name says.
pub fn decode_file(path: &Path, bytes: &[u8], opts: &ReadOptions) -> Result<Image> {
    if let Some(w) = extension_warning(path, bytes) {
        crate::base::error::warn(&w);
    }
    decode(path, bytes, opts)
}

/// The warning for a file whose extension names another format than its content holds (PNG
/// bytes named `.exr`), if it does.
pub fn extension_warning(path: &Path, bytes: &[u8]) -> Option<String> {
    let content = Format::sniff(bytes)?;
    let named = Format::from_extension(path).filter(|f| *f != content)?;
    Some(format!(
        "{}: the file holds {} but its extension names {}; reading it as {}",
        path.display(),
        content.name(),
        named.name(),
        content.name()
    ))
}

/// Decodes an image held in memory; `path` names it in messages.
pub fn decode(path: &Path, bytes: &[u8], opts: &ReadOptions) -> Result<Image> {
    let format = Format::sniff(bytes).ok_or_else(|| {
        Error::data(
            path,
            "not an image spheremap reads (expected OpenEXR, Radiance HDR, PFM, PNG, JPEG, WebP, \
             KTX2 or DDS)",
        )
    })?;
    // The JPEG decoder fills a cut-off file with grey instead of failing: a complete JPEG has
    // its end-of-image marker (FF D9) near the end (some writers pad after it).
    if format == Format::Jpeg {
        let tail = &bytes[bytes.len().saturating_sub(4096)..];
        if !tail.windows(2).any(|w| w == [0xFF, 0xD9]) {
            return Err(Error::data(
                path,
                "cannot decode JPEG: the file is truncated (no end-of-image marker)",
            ));
        }
    }
    match format {
        Format::Exr => decode_exr(path, bytes, &opts.limits),
        Format::Pfm => decode_pfm(path, bytes, &opts.limits),
        Format::Ktx2 | Format::Dds => {
            let mut tex = super::container::decode(path, bytes, &opts.limits)?;
            Ok(tex.levels.swap_remove(0))
        }
        Format::Png => {
            // An HDR packing (RGBD, RGBM) the note records is read as its raw bytes, unpacked.
            let packing =
                super::note::read(bytes).and_then(|t| super::compress::packing_of_note(&t));
            match packing {
                Some((e, range)) => {
                    let raw = ReadOptions {
                        linear: true,
                        ..*opts
                    };
                    let rgba = decode_with_image_crate(path, bytes, format, &raw)?;
                    if rgba.channels != 4 {
                        return Err(Error::data(
                            path,
                            format!(
                                "the note records {} but the PNG has {} channels, not RGBA",
                                e.name(),
                                rgba.channels
                            ),
                        ));
                    }
                    Ok(super::compress::unpack_image(&rgba, e, range))
                }
                None => decode_with_image_crate(path, bytes, format, opts),
            }
        }
        _ => decode_with_image_crate(path, bytes, format, opts),
    }
}

fn decode_with_image_crate(
    path: &Path,
    bytes: &[u8],
    format: Format,
    opts: &ReadOptions,
) -> Result<Image> {
    use image::ImageDecoder;
    let bad =
        |e: image::ImageError| Error::data(path, format!("cannot decode {}: {e}", format.name()));
    let cursor = Cursor::new(bytes);
    let decoder: Box<dyn image::ImageDecoder> = match format {
        Format::Png => Box::new(image::codecs::png::PngDecoder::new(cursor).map_err(bad)?),
        Format::Jpeg => Box::new(image::codecs::jpeg::JpegDecoder::new(cursor).map_err(bad)?),
        Format::Webp => Box::new(image::codecs::webp::WebPDecoder::new(cursor).map_err(bad)?),
        Format::Hdr => Box::new(image::codecs::hdr::HdrDecoder::new(cursor).map_err(bad)?),
        Format::Exr | Format::Pfm | Format::Ktx2 | Format::Dds => {
            unreachable!("decoded elsewhere")
        }
    };
    let (w, h) = decoder.dimensions();
    opts.limits.check(path, w as usize, h as usize)?;
    let img = image::DynamicImage::from_decoder(decoder).map_err(bad)?;
    let channels = img.color().channel_count() as usize;
    let ldr = format.is_ldr() && !opts.linear;
    // Alpha is never sRGB-encoded: the last channel of Y,A and R,G,B,A stays linear.
    let is_alpha = |i: usize| (channels == 2 || channels == 4) && i % channels == channels - 1;
    let data: Vec<f32> = match img {
        image::DynamicImage::ImageRgb32F(b) => b.into_raw(),
        image::DynamicImage::ImageRgba32F(b) => b.into_raw(),
        image::DynamicImage::ImageLuma8(_)
        | image::DynamicImage::ImageLumaA8(_)
        | image::DynamicImage::ImageRgb8(_)
        | image::DynamicImage::ImageRgba8(_) => {
            let lut: Vec<f32> = (0..256)
                .map(|v| decode_ldr(v as f32 / 255.0, ldr))
                .collect();
            let raw = img.into_bytes();
            raw.iter()
                .enumerate()
                .map(|(i, &v)| {
                    if is_alpha(i) {
                        v as f32 / 255.0
                    } else {
                        lut[v as usize]
                    }
                })
                .collect()
        }
        other => {
            // 16-bit PNG and anything else: go through u16.
            let raw: Vec<u16> = match channels {
                1 => other.to_luma16().into_raw(),
                2 => other.to_luma_alpha16().into_raw(),
                3 => other.to_rgb16().into_raw(),
                _ => other.to_rgba16().into_raw(),
            };
            raw.iter()
                .enumerate()
                .map(|(i, &v)| {
                    let x = v as f32 / 65535.0;
                    if is_alpha(i) {
                        x
                    } else {
                        decode_ldr(x, ldr)
                    }
                })
                .collect()
        }
    };
    Ok(Image {
        width: w as usize,
        height: h as usize,
        channels,
        data,
    })
}

#[inline]
fn decode_ldr(v: f32, srgb: bool) -> f32 {
    if srgb {
        srgb_to_linear(v)
    } else {
        v
    }
}

fn decode_exr(path: &Path, bytes: &[u8], limits: &Limits) -> Result<Image> {
    use exr::prelude::*;
    let bad = |e: exr::error::Error| {
        crate::base::error::Error::data(path, format!("cannot decode OpenEXR: {e}"))
    };
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(bad)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| crate::base::error::Error::data(path, "OpenEXR file without a layer"))?;
    let size = header.layer_size;
    limits.check(path, size.width(), size.height())?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(bad)?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let find = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq_case_insensitive(name))
    };
    let picked: Vec<&AnyChannel<FlatSamples>> =
        match (find("R"), find("G"), find("B"), find("A"), find("Y")) {
            (Some(r), Some(g), Some(b), a, _) => [Some(r), Some(g), Some(b), a]
                .into_iter()
                .flatten()
                .collect(),
            (_, _, _, a, Some(y)) => [Some(y), a].into_iter().flatten().collect(),
            _ => {
                let names: Vec<String> = layer
                    .channel_data
                    .list
                    .iter()
                    .map(|c| c.name.to_string())
                    .collect();
                return Err(crate::base::error::Error::unsupported(
                    format!("OpenEXR channels {names:?} in {}", path.display()),
                    "expected R,G,B[,A] or Y[,A]",
                ));
            }
        };
    let planes: Vec<Vec<f32>> = picked
        .iter()
        .map(|c| c.sample_data.values_as_f32().collect())
        .collect();
    let channels = planes.len();
    let mut data = vec![0.0f32; w * h * channels];
    for (c, plane) in planes.iter().enumerate() {
        for (i, v) in plane.iter().enumerate() {
            data[i * channels + c] = *v;
        }
    }
    Ok(super::Image {
        width: w,
        height: h,
        channels,
        data,
    })
}

/// PFM: a text header `PF` (RGB) or `Pf` (grey), `width height`, and a scale whose sign gives the
/// byte order (negative = little-endian); then float rows from the **bottom** up.
fn decode_pfm(path: &Path, bytes: &[u8], limits: &Limits) -> Result<Image> {
    let bad = |why: &str| Error::data(path, format!("not a valid PFM file: {why}"));
    let mut fields = Vec::new();
    let mut pos = 0;
    while fields.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 32 {
            return Err(bad("truncated or malformed header"));
        }
        fields
            .push(std::str::from_utf8(&bytes[start..pos]).map_err(|_| bad("header is not text"))?);
    }
    pos += 1; // the single whitespace byte that ends the header
    let channels = match fields[0] {
        "PF" => 3,
        "Pf" => 1,
        _ => return Err(bad("expected PF or Pf")),
    };
    let w: usize = fields[1].parse().map_err(|_| bad("bad width"))?;
    let h: usize = fields[2].parse().map_err(|_| bad("bad height"))?;
    let scale: f32 = fields[3].parse().map_err(|_| bad("bad scale"))?;
    if !scale.is_finite() || scale == 0.0 {
        return Err(bad("scale must be finite and non-zero"));
    }
    limits.check(path, w, h)?;
    let need = w * h * channels * 4;
    let body = bytes.get(pos..).unwrap_or(&[]);
    if body.len() < need {
        return Err(bad(&format!(
            "truncated: {} bytes of pixel data, {need} needed",
            body.len()
        )));
    }
    let little = scale < 0.0;
    let mut data = vec![0.0f32; w * h * channels];
    let row = w * channels;
    for y in 0..h {
        let src_row = h - 1 - y; // stored bottom-up
        for i in 0..row {
            let o = (src_row * row + i) * 4;
            let b = [body[o], body[o + 1], body[o + 2], body[o + 3]];
            data[y * row + i] = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
        }
    }
    Ok(super::Image {
        width: w,
        height: h,
        channels,
        data,
    })
}

/// Writes an image; the format follows the extension.
pub fn write_image(path: &Path, img: &Image, opts: &WriteOptions) -> Result<()> {
    write_image_with_note(path, img, opts, None)
}

/// [`write_image`] with a note recorded in the file ([`crate::images::note`]: the mapping it holds).
pub fn write_image_with_note(
    path: &Path,
    img: &Image,
    opts: &WriteOptions,
    note: Option<&str>,
) -> Result<()> {
    let format = Format::from_extension(path).ok_or_else(|| {
        Error::param(
            "output",
            format!(
                "{}: unknown image extension; use .exr, .hdr, .pfm, .png, .jpg, .ktx2 or .dds",
                path.display()
            ),
        )
    })?;
    if img.data.len() != img.width * img.height * img.channels || !(1..=4).contains(&img.channels) {
        return Err(Error::param("image", "inconsistent size or channel count"));
    }
    if img.width == 0 || img.height == 0 {
        return Err(Error::param("image", "empty image"));
    }
    let bytes = encode_with_note(path, img, format, opts, note)?;
    atomic_write(path, |f| {
        f.write_all(&bytes).map_err(|e| Error::io(path, e))
    })
}

/// The texel solid angles of `img` by the mapping its note records (equal weights for a cube
/// layout or a map without a note).
fn note_weights(note: Option<&str>, img: &Image) -> Vec<f64> {
    let mapping = note
        .and_then(super::note::MapNote::parse)
        .filter(|n| n.layout.is_none())
        .map(|n| n.mapping);
    super::compress::texel_weights(mapping, false, img.width, img.height)
}

/// Encodes into memory in `format`.
pub fn encode(path: &Path, img: &Image, format: Format, opts: &WriteOptions) -> Result<Vec<u8>> {
    encode_with_note(path, img, format, opts, None)
}

/// [`encode`] with a note recorded in the file where the format has a place for one
/// ([`crate::images::note`]).
pub fn encode_with_note(
    path: &Path,
    img: &Image,
    format: Format,
    opts: &WriteOptions,
    note: Option<&str>,
) -> Result<Vec<u8>> {
    let bad =
        |e: image::ImageError| Error::data(path, format!("cannot encode {}: {e}", format.name()));
    let mut buf = Cursor::new(Vec::new());
    let (w, h, c) = (img.width as u32, img.height as u32, img.channels);
    opts.check_for(path, format)?;
    let float = opts.encode == Encoding::Float;
    if matches!(format, Format::Exr | Format::Ktx2 | Format::Dds)
        && opts.half
        && !opts.clamp_half
        && float
    {
        let l = Losses::of(img, format, opts);
        if l.beyond_half > 0 {
            return Err(beyond_half_error(path, &l));
        }
    }
    match format {
        Format::Exr => encode_exr(path, img, opts.half, note, &mut buf)?,
        Format::Pfm => encode_pfm(img, &mut buf),
        Format::Ktx2 | Format::Dds => {
            let tex = super::container::Texture {
                cube: false,
                levels: vec![img.clone()],
            };
            return encode_texture(path, &tex, format, opts, note).map(|(b, _)| b);
        }
        Format::Hdr => {
            // No negative values: their light moved into their neighbours.
            let (img, _) = fold_negatives(img, || note_weights(note, img));
            let img = img.as_ref();
            let rgb = to_rgb(img);
            let px: Vec<image::Rgb<f32>> = rgb
                .chunks_exact(3)
                .map(|p| image::Rgb([p[0].max(0.0), p[1].max(0.0), p[2].max(0.0)]))
                .collect();
            image::codecs::hdr::HdrEncoder::new(&mut buf)
                .encode(&px, w as usize, h as usize)
                .map_err(bad)?;
        }
        Format::Png if opts.encode.is_packing() => {
            // Negative values' light moved into their neighbours; values beyond the range
            // clamped, with the power that loses.
            let (folded, neg) = fold_negatives(img, || note_weights(note, img));
            let (raw, over) = super::compress::pack_image(&folded, opts.encode);
            let clamped = over + neg.values;
            if clamped > 0 {
                let omega = note_weights(note, img);
                let lost = super::compress::range_loss(img, &omega, opts.encode, &folded);
                crate::base::error::warn(&format!(
                    "{}: {clamped} value{} outside {}'s range [0, {}] clamped to it (the light \
                     of negative ones moved into their neighbours); the image's power changes \
                     by {:+.4} % (R), {:+.4} % (G), {:+.4} % (B)",
                    path.display(),
                    if clamped == 1 { "" } else { "s" },
                    opts.encode.name(),
                    opts.encode.range().expect("a packing"),
                    100.0 * lost[0],
                    100.0 * lost[1],
                    100.0 * lost[2]
                ));
            }
            let e = image::codecs::png::PngEncoder::new(&mut buf);
            image::ImageEncoder::write_image(e, &raw, w, h, image::ExtendedColorType::Rgba8)
                .map_err(bad)?;
            let text = super::compress::packing_note(note, opts.encode);
            return Ok(crate::images::note::insert(format, buf.into_inner(), &text));
        }
        Format::Png | Format::Jpeg => {
            let srgb = !opts.linear;
            let enc = |v: f32, k: usize| {
                let alpha = (c == 2 || c == 4) && k == c - 1;
                if srgb && !alpha {
                    linear_to_srgb(v)
                } else if v.is_nan() {
                    0.0
                } else {
                    v.clamp(0.0, 1.0)
                }
            };
            let color = |sixteen: bool| match (c, sixteen) {
                (1, false) => image::ExtendedColorType::L8,
                (2, false) => image::ExtendedColorType::La8,
                (3, false) => image::ExtendedColorType::Rgb8,
                (_, false) => image::ExtendedColorType::Rgba8,
                (1, true) => image::ExtendedColorType::L16,
                (2, true) => image::ExtendedColorType::La16,
                (3, true) => image::ExtendedColorType::Rgb16,
                (_, true) => image::ExtendedColorType::Rgba16,
            };
            if format == Format::Png && opts.png16 {
                let raw: Vec<u8> = img
                    .data
                    .iter()
                    .enumerate()
                    .flat_map(|(i, &v)| ((enc(v, i % c) * 65535.0 + 0.5) as u16).to_ne_bytes()) // the encoder takes native-endian u16
                    .collect();
                let e = image::codecs::png::PngEncoder::new(&mut buf);
                image::ImageEncoder::write_image(e, &raw, w, h, color(true)).map_err(bad)?;
            } else {
                let raw: Vec<u8> = img
                    .data
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (enc(v, i % c) * 255.0 + 0.5) as u8)
                    .collect();
                if format == Format::Png {
                    let e = image::codecs::png::PngEncoder::new(&mut buf);
                    image::ImageEncoder::write_image(e, &raw, w, h, color(false)).map_err(bad)?;
                } else {
                    if c == 2 || c == 4 {
                        return Err(Error::unsupported(
                            "JPEG with alpha",
                            "write PNG or EXR to keep the alpha channel",
                        ));
                    }
                    let e = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 95);
                    image::ImageEncoder::write_image(e, &raw, w, h, color(false)).map_err(bad)?;
                }
            }
        }
        Format::Webp => {
            return Err(Error::unsupported(
                "writing WebP",
                "spheremap reads WebP; write PNG instead",
            ))
        }
    }
    let bytes = buf.into_inner();
    Ok(match note {
        Some(t) if format != Format::Exr => crate::images::note::insert(format, bytes, t),
        _ => bytes,
    })
}

/// The error for values a half-float write would turn into Inf.
pub fn beyond_half_error(path: &Path, l: &Losses) -> Error {
    Error::data(
        path,
        format!(
            "{} value{} beyond the half-float range (the largest {:e}; half ends at \
             65504) would be written as Inf: write 32-bit floats (no --half, \
             half=False) or clamp them to 65504 (--clamp-half, clamp_half=True)",
            l.beyond_half,
            if l.beyond_half == 1 { " lies" } else { "s lie" },
            l.largest
        ),
    )
}

/// Encodes a texture (mip levels, cube faces) as KTX2 or DDS: float texels (`opts.half`:
/// 16-bit, values beyond the half range refused unless `opts.clamp_half`, as for EXR) or
/// encoded ones (`opts.encode`, keeping the light: [`crate::images::compress`]; their report
/// per level is returned); `note` goes into KTX2's key/value data (DDS has no place for it)
/// and gives a 2D map's mapping, whose texel solid angles weigh the light.
pub fn encode_texture(
    path: &Path,
    tex: &super::container::Texture,
    format: Format,
    opts: &WriteOptions,
    note: Option<&str>,
) -> Result<(Vec<u8>, Option<Vec<LevelCompression>>)> {
    use super::container::{Stored, StoredLevels};
    if !format.is_container() {
        return Err(Error::param(
            "output",
            format!("{} holds one image, not a texture", format.name()),
        ));
    }
    opts.check_for(path, format)?;
    tex.check("texture")?;
    let (stored, report) = if opts.encode == Encoding::Float {
        let mut clamped;
        let mut tex = tex;
        if opts.half {
            let mut beyond = Losses::default();
            for l in &tex.levels {
                let x = Losses::of(l, format, opts);
                beyond.beyond_half += x.beyond_half;
                beyond.largest = beyond.largest.max(x.largest);
            }
            if beyond.beyond_half > 0 {
                if !opts.clamp_half {
                    return Err(beyond_half_error(path, &beyond));
                }
                clamped = tex.clone();
                for l in &mut clamped.levels {
                    for v in &mut l.data {
                        if v.is_finite() {
                            *v = v.clamp(-HALF_MAX, HALF_MAX);
                        }
                    }
                }
                tex = &clamped;
            }
        }
        (StoredLevels::float(tex, opts.half)?, None)
    } else {
        let mapping = note
            .and_then(super::note::MapNote::parse)
            .filter(|n| n.layout.is_none() || tex.cube)
            .map(|n| n.mapping);
        let c = super::compress::compress(
            &path.display().to_string(),
            &tex.levels,
            tex.cube,
            opts.encode,
            mapping,
        )?;
        (
            StoredLevels {
                cube: tex.cube,
                size: tex.size(),
                stored: Stored::Encoded(c.encoding),
                surfaces: c.surfaces,
            },
            Some(c.report),
        )
    };
    let bytes = match format {
        Format::Ktx2 => {
            let extra: Vec<(&str, &str)> =
                note.map(|n| (super::note::KEY, n)).into_iter().collect();
            super::container::encode_ktx2_stored(&stored, &extra, opts.zstd)?
        }
        _ => super::container::encode_dds_stored(&stored),
    };
    Ok((bytes, report))
}

/// Writes a texture atomically as KTX2 or DDS, by the extension of `path`; returns what
/// encoding did to each level's light when `opts.encode` is not `Float`.
pub fn write_texture(
    path: &Path,
    tex: &super::container::Texture,
    opts: &WriteOptions,
    note: Option<&str>,
) -> Result<Option<Vec<LevelCompression>>> {
    let format = Format::from_extension(path)
        .filter(|f| f.is_container())
        .ok_or_else(|| {
            Error::param(
                "output",
                format!(
                    "{}: a texture with mip levels or cube faces is written as .ktx2 or .dds",
                    path.display()
                ),
            )
        })?;
    let (bytes, report) = encode_texture(path, tex, format, opts, note)?;
    atomic_write(path, |f| {
        f.write_all(&bytes).map_err(|e| Error::io(path, e))
    })?;
    Ok(report)
}

/// Reads a KTX2 or DDS file with all its levels (a cube's as face stacks).
pub fn read_texture(path: &Path, opts: &ReadOptions) -> Result<super::container::Texture> {
    let bytes = crate::base::files::read_file(path)?;
    super::container::decode(path, &bytes, &opts.limits)
}

/// RGB values of any image (grey repeated, alpha dropped).
fn to_rgb(img: &Image) -> Vec<f32> {
    img.data
        .chunks_exact(img.channels)
        .flat_map(|p| {
            if img.channels >= 3 {
                [p[0], p[1], p[2]]
            } else {
                [p[0]; 3]
            }
        })
        .collect()
}

fn encode_exr(
    path: &Path,
    img: &Image,
    half: bool,
    note: Option<&str>,
    buf: &mut Cursor<Vec<u8>>,
) -> Result<()> {
    use exr::prelude::*;
    let (w, h, c) = (img.width, img.height, img.channels);
    let plane = |k: usize| -> FlatSamples {
        let v = img.data.iter().skip(k).step_by(c).copied();
        if half {
            // Finite values beyond the half range are clamped to it (refused before this unless
            // the caller asked for clamping); NaN and Inf stay what they are.
            let clamp = |x: f32| {
                if x.is_finite() {
                    x.clamp(-HALF_MAX, HALF_MAX)
                } else {
                    x
                }
            };
            FlatSamples::F16(v.map(|x| f16::from_f32(clamp(x))).collect())
        } else {
            FlatSamples::F32(v.collect())
        }
    };
    let names = img.channel_names();
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = (0..c)
        .map(|k| AnyChannel::new(names[k], plane(k)))
        .collect();
    let mut attributes = LayerAttributes::default();
    if let Some(t) = note {
        attributes.other.insert(
            Text::from(crate::images::note::KEY),
            AttributeValue::Text(Text::from(t)),
        );
    }
    let layer = Layer::new(
        (w, h),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    Image::from_layer(layer)
        .write()
        .to_buffered(buf)
        .map_err(|e| crate::base::error::Error::data(path, format!("cannot encode OpenEXR: {e}")))
}

fn encode_pfm(img: &Image, buf: &mut Cursor<Vec<u8>>) {
    let grey = img.channels == 1;
    let mut w = BufWriter::new(buf);
    let _ = write!(
        w,
        "{}\n{} {}\n-1.0\n",
        if grey { "Pf" } else { "PF" },
        img.width,
        img.height
    );
    let rgb = if grey { img.data.clone() } else { to_rgb(img) };
    let row = img.width * if grey { 1 } else { 3 };
    for y in (0..img.height).rev() {
        for v in &rgb[y * row..(y + 1) * row] {
            let _ = w.write_all(&v.to_le_bytes());
        }
    }
    let _ = w.flush();
}

/// What `spheremap info` reports about a file.
#[derive(Clone, Debug)]
pub struct Inspection {
    pub format: Format,
    /// The extension names another format than the content.
    pub extension_mismatch: Option<Format>,
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub channel_names: Vec<String>,
    /// Per channel (min, max, mean) over finite values.
    pub stats: Vec<(f32, f32, f64)>,
    pub nan_count: usize,
    pub inf_count: usize,
    pub negative_count: usize,
    /// (x, y) of the first non-finite value.
    pub first_non_finite: Option<(usize, usize)>,
    /// A guess of the environment mapping, labelled as such.
    pub mapping_guess: (&'static str, &'static str),
    /// The note spheremap recorded in the file when it wrote it ([`crate::images::note`]), as text.
    pub note: Option<String>,
}

/// Reads a file and describes it.
pub fn inspect(path: &Path, opts: &ReadOptions) -> Result<Inspection> {
    let bytes = crate::base::files::read_file(path)?;
    let img = decode(path, &bytes, opts)?;
    let format = Format::sniff(&bytes).expect("decoded, so sniffed");
    let ext = Format::from_extension(path);
    let c = img.channels;
    let mut stats = vec![(f32::INFINITY, f32::NEG_INFINITY, 0.0f64); c];
    let mut counts = vec![0usize; c];
    let (mut nan, mut inf, mut neg, mut first) = (0, 0, 0, None);
    for (i, px) in img.data.chunks_exact(c).enumerate() {
        for (k, &v) in px.iter().enumerate() {
            if v.is_finite() {
                let s = &mut stats[k];
                s.0 = s.0.min(v);
                s.1 = s.1.max(v);
                s.2 += v as f64;
                counts[k] += 1;
                if v < 0.0 {
                    neg += 1;
                }
            } else {
                if v.is_nan() {
                    nan += 1
                } else {
                    inf += 1
                }
                first.get_or_insert((i % img.width, i / img.width));
            }
        }
    }
    for (s, n) in stats.iter_mut().zip(&counts) {
        s.2 /= (*n).max(1) as f64;
    }
    Ok(Inspection {
        format,
        extension_mismatch: ext.filter(|e| *e != format),
        width: img.width,
        height: img.height,
        channels: c,
        channel_names: img.channel_names().iter().map(|s| s.to_string()).collect(),
        stats,
        nan_count: nan,
        inf_count: inf,
        negative_count: neg,
        first_non_finite: first,
        mapping_guess: guess_mapping(&img),
        note: crate::images::note::read(&bytes),
    })
}

/// Guesses the environment mapping from the shape (and, for square images, whether the corners
/// outside the inscribed disc are empty).  Returns (name, reason).  A guess, never a fact.
pub fn guess_mapping(img: &Image) -> (&'static str, &'static str) {
    let (w, h) = (img.width, img.height);
    if w == 2 * h {
        return (
            "latlong",
            "width is twice the height (a side-by-side dual paraboloid has this shape too)",
        );
    }
    if w == 6 * h || h == 6 * w {
        return ("cube (strip)", "one side is six times the other");
    }
    if 3 * w == 4 * h || 4 * w == 3 * h {
        return ("cube (cross)", "4:3 aspect ratio");
    }
    if w == h {
        // Mean brightness of the four corners outside the disc vs the whole image.
        let k = (w / 16).max(1);
        let mut corner = 0.0f64;
        let mut all = 0.0f64;
        let lum = |p: &[f32]| {
            p.iter()
                .take(3)
                .map(|v| if v.is_finite() { v.abs() as f64 } else { 0.0 })
                .sum::<f64>()
        };
        for y in 0..h {
            for x in 0..w {
                let v = lum(img.pixel(x, y));
                all += v;
                if (x < k || x >= w - k) && (y < k || y >= h - k) {
                    corner += v;
                }
            }
        }
        let corner_mean = corner / (4 * k * k) as f64;
        let mean = all / (w * h) as f64;
        if corner_mean <= 0.02 * mean.max(1e-12) {
            return (
                "sphere / mirror ball / angular (disc)",
                "square with empty corners outside the inscribed disc",
            );
        }
        if is_rim_gutter(img) {
            return (
                "sphere / angular (disc, with a gutter)",
                "square whose corners mirror the inscribed disc across its rim, as spheremap's gutter fills them",
            );
        }
        return (
            "octahedral or a single cube face",
            "square with content in the corners",
        );
    }
    if h == 2 * w {
        return (
            "dual paraboloid (stacked)",
            "two squares, one above the other",
        );
    }
    ("unknown", "no recognised aspect ratio")
}

/// Whether the corners of a square image outside its inscribed disc are the disc's radial
/// mirror image across the rim — what [`crate::resample::Outside::Gutter`] writes there: the
/// point at radius `r > 1` (in units of the disc's radius, centre at the canvas centre) shows
/// what radius `2 − r` shows, in the same direction from the centre.  The test reads a grid of
/// points in each corner, `r` in [1.1, 1.35] (clear of the rim texels, whose footprints straddle
/// it), and compares each with the image bilinearly read at its mirror point: the summed
/// absolute differences must be under 8 % of the summed larger magnitudes of each pair.
/// spheremap's sphere and angular gutters of a real HDRI measure 0.2–4 %; its octahedral maps
/// and cube faces, which continue across the inscribed circle without this symmetry, 15–70 %.
fn is_rim_gutter(img: &Image) -> bool {
    let n = img.width;
    if n < 32 || img.height != n {
        return false;
    }
    let ch = img.channels.clamp(1, 3);
    let val = |x: usize, y: usize, k: usize| -> f64 {
        let v = img.pixel(x, y)[k];
        if v.is_finite() {
            v as f64
        } else {
            0.0
        }
    };
    // Bilinear read at pixel coordinates (texel centres at integer + ½), clamped to the canvas.
    let bilinear = |px: f64, py: f64, k: usize| -> f64 {
        let (fx, fy) = (
            (px - 0.5).clamp(0.0, (n - 1) as f64),
            (py - 0.5).clamp(0.0, (n - 1) as f64),
        );
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(n - 1), (y0 + 1).min(n - 1));
        let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
        let top = val(x0, y0, k) * (1.0 - tx) + val(x1, y0, k) * tx;
        let bot = val(x0, y1, k) * (1.0 - tx) + val(x1, y1, k) * tx;
        top * (1.0 - ty) + bot * ty
    };
    let half = n as f64 / 2.0;
    let (mut diff, mut mag, mut count) = (0.0f64, 0.0f64, 0usize);
    let steps = 24;
    for j in 0..steps {
        for i in 0..steps {
            // A grid over the top-left corner square, then its images in the other three.
            let (cx, cy) = (
                (i as f64 + 0.5) / steps as f64 * 0.3 * n as f64,
                (j as f64 + 0.5) / steps as f64 * 0.3 * n as f64,
            );
            for (px, py) in [
                (cx, cy),
                (n as f64 - cx, cy),
                (cx, n as f64 - cy),
                (n as f64 - cx, n as f64 - cy),
            ] {
                let (a, b) = ((px - half) / half, (py - half) / half);
                let r = a.hypot(b);
                if !(1.1..=1.35).contains(&r) {
                    continue;
                }
                let m = (2.0 - r) / r;
                let (qx, qy) = (half + a * m * half, half + b * m * half);
                for k in 0..ch {
                    let (v, w) = (bilinear(px, py, k), bilinear(qx, qy, k));
                    diff += (v - w).abs();
                    mag += v.abs().max(w.abs());
                }
                count += 1;
            }
        }
    }
    count > 0 && mag > 0.0 && diff <= 0.08 * mag
}

crate::base::named::named_enum! {
    /// What to do with NaN/Inf pixel values in an input.
    #[derive(Default)]
    pub enum NonFinite: "value" as "nonfinite" {
        /// Refuse the input, naming the count and the first location (default: a NaN spreads
        /// through every filter that touches it).
        #[default]
        Error = "error",
        /// Replace them with 0.
        Zero = "zero",
        /// Keep them as they are.
        Keep = "keep",
    }
}

/// Count of NaN/Inf values and the (x, y) of the first pixel holding one.
pub fn find_nonfinite(img: &Image) -> Option<(usize, usize, usize)> {
    if all_finite(&img.data) {
        return None;
    }
    let c = img.channels.max(1);
    let first = img.data.iter().position(|v| !v.is_finite())?;
    let count = img.data.iter().filter(|v| !v.is_finite()).count();
    let px = first / c;
    Some((count, px % img.width.max(1), px / img.width.max(1)))
}

/// Whether every value is finite: a branch-free test of the exponent bits over blocks in
/// parallel (the common answer, yes, costs one pass at memory speed).
pub fn all_finite(data: &[f32]) -> bool {
    use rayon::prelude::*;
    data.par_chunks(1 << 16).all(|b| {
        // All-ones exponent: Inf or NaN.
        let bad = b.iter().fold(0u32, |m, v| {
            m | u32::from(v.to_bits() & 0x7F80_0000 == 0x7F80_0000)
        });
        bad == 0
    })
}

/// Applies the policy to an input named `what`.
pub fn check_nonfinite(img: &mut Image, policy: NonFinite, what: &str) -> Result<()> {
    if policy == NonFinite::Keep {
        return Ok(());
    }
    let Some((count, x, y)) = find_nonfinite(img) else {
        return Ok(());
    };
    match policy {
        NonFinite::Error => Err(Error::data(
            what,
            format!(
                "{count} NaN/Inf values (the first at pixel x={x}, y={y}); \
                 --nonfinite zero replaces them, --nonfinite keep keeps them"
            ),
        )),
        _ => {
            img.data
                .iter_mut()
                .filter(|v| !v.is_finite())
                .for_each(|v| *v = 0.0);
            Ok(())
        }
    }
}

/// Writes `frames` (linear RGB, values in [0, 1]; tone-map HDR first) as an animated GIF that
/// loops forever, `delay_ms` per frame, sRGB-encoded and quantized to 256 colours per frame by
/// the `image` crate's NeuQuant. Atomic like every write.
pub fn write_gif(path: &Path, frames: &[Image], delay_ms: u32) -> Result<()> {
    use image::codecs::gif::{GifEncoder, Repeat};
    if frames.is_empty() {
        return Err(Error::param("frames", "no frames to write"));
    }
    let bad = |e: image::ImageError| Error::data(path, format!("cannot encode GIF: {e}"));
    let mut buf = Vec::new();
    {
        let mut enc = GifEncoder::new_with_speed(&mut buf, 10);
        enc.set_repeat(Repeat::Infinite).map_err(bad)?;
        for img in frames {
            let rgb = to_rgb(img);
            let mut rgba = Vec::with_capacity(img.width * img.height * 4);
            for p in rgb.chunks_exact(3) {
                for v in p {
                    rgba.push((linear_to_srgb(*v) * 255.0 + 0.5) as u8);
                }
                rgba.push(255);
            }
            let buffer = image::RgbaImage::from_raw(img.width as u32, img.height as u32, rgba)
                .ok_or_else(|| Error::param("frames", "inconsistent frame size"))?;
            let delay = image::Delay::from_numer_denom_ms(delay_ms, 1);
            enc.encode_frame(image::Frame::from_parts(buffer, 0, 0, delay))
                .map_err(bad)?;
        }
    }
    atomic_write(path, |f| f.write_all(&buf).map_err(|e| Error::io(path, e)))
}
