//! KTX2 and DDS: the GPU texture containers engines load, holding every mip level and, for a
//! cube map, the six faces.  Texels are floats, BC6H blocks, RGB9E5, or (KTX2) UASTC HDR 4x4
//! and ASTC HDR 6x6 blocks ([`crate::images::compress`]); KTX2 levels may be
//! Zstandard-supercompressed.
//!
//! ## What is written
//!
//! Every texel as RGBA, 16-bit (`half`) or 32-bit float: grey is written to R, G and B, a
//! missing alpha as 1.  Level i of a W×H texture is max(1, W >> i) × max(1, H >> i); a cube's
//! faces are square.
//!
//! * **KTX2** (Khronos KTX 2.0): `VK_FORMAT_R16G16B16A16_SFLOAT` (97) or
//!   `VK_FORMAT_R32G32B32A32_SFLOAT` (109), a basic data format descriptor (RGBSDA, BT.709
//!   primaries, linear transfer, four signed float samples), no supercompression.  The key/value
//!   data hold `KTXorientation` = `rd` (s to the right, t down: row 0 is t = 0),
//!   `KTXwriter`, and the map note under `spheremap` ([`crate::images::note`]).  Levels are
//!   stored smallest first, each aligned to its texel size, as the format asks.
//! * **DDS** (DirectX): the DX10 header extension, `DXGI_FORMAT_R16G16B16A16_FLOAT` (10) or
//!   `DXGI_FORMAT_R32G32B32A32_FLOAT` (2), a 2D texture resource, `DDS_RESOURCE_MISC_TEXTURECUBE`
//!   and `DDSCAPS2_CUBEMAP_ALLFACES` for a cube; data face by face, each with its mip chain.
//!   DDS has no place for a note.
//!
//! ## Cube faces
//!
//! Both formats store the faces in the order +X, −X, +Y, −Y, +Z, −Z, each with row 0 at t = 0
//! of the GL face table ([`crate::mappings::cube`]), which Vulkan and Direct3D share: a
//! level's six faces one after another are exactly spheremap's face stack (layout `vstrip`).
//! A cube file therefore reads as the face stack of its level 0, noted `mapping=cube
//! preset=gl layout=vstrip` unless the file records another note.
//!
//! Encoded texels ([`crate::images::compress`]): BC6H as KTX2 `VK_FORMAT_BC6H_UFLOAT_BLOCK`
//! (143; typeSize 1, a BC6H data format descriptor: model 133, 4×4 texel blocks, one 128-bit
//! unsigned float sample) and DDS `DXGI_FORMAT_BC6H_UF16` (95, with a linear size instead of
//! a pitch); RGB9E5 as KTX2 `VK_FORMAT_E5B9G9R9_UFLOAT_PACK32` (123, the six-sample
//! descriptor of Khronos's `dfdutils`) and DDS `DXGI_FORMAT_R9G9B9E5_SHAREDEXP` (67); UASTC
//! HDR 4x4 and ASTC HDR 6x6 as KTX2 `VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK` (1000066000) and
//! `VK_FORMAT_ASTC_6x6_SFLOAT_BLOCK` (1000066004) with the descriptors Basis Universal writes
//! (models 167 and 162).  A level smaller than a block takes one block.  With Zstandard
//! supercompression (KTX2 only, scheme 2), each level is compressed on its own, without
//! padding between levels, and its index
//! records both lengths.
//!
//! ## What is read
//!
//! KTX2 with the float formats R16, RGB16, RGBA16, R32, RGB32 or RGBA32 (`SFLOAT`), BC6H
//! (unsigned) or E5B9G9R9, uncompressed or Zstandard-supercompressed, any `KTXorientation`
//! (rows or columns running the other way are turned to row 0 at the top; not for BC6H,
//! whose blocks are stored as written); DDS with a DX10 header of the same DXGI formats, or a
//! legacy header with the D3D float codes (111 R16F, 113 A16B16G16R16F, 114 R32F, 116
//! A32B32G32R32F).  BC6H decodes through `bcdec_rs` to 3 channels, RGB9E5 to 3 channels,
//! UASTC HDR 4x4 and ASTC HDR 6x6 through the pure-Rust Basis Universal transcoder (`basisu`)
//! to 3 channels of half floats.
//! Other block-compressed, integer, BasisLZ/zlib-supercompressed, 3D and array textures are
//! refused with the reason.  Sizes are checked against [`Limits`] before anything is
//! allocated, and every offset against the file's length.

use super::compress::{self, Encoding};
use super::limits::Limits;
use super::Image;
use crate::base::error::{Error, Result};
use std::path::Path;

/// KTX2's file identifier.
pub const KTX2_MAGIC: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];
/// DDS's file identifier.
pub const DDS_MAGIC: &[u8; 4] = b"DDS ";

/// A texture: its mip levels (level 0 first), each the image (2D) or the face stack (cube:
/// F × 6F, faces +X, −X, +Y, −Y, +Z, −Z from the top).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub cube: bool,
    pub levels: Vec<Image>,
}

/// The container formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    Ktx2,
    Dds,
}

/// How a level's texels are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stored {
    /// Floats of `bytes` (2: half, 4: float) per value, `channels` values per texel.
    Float { bytes: usize, channels: usize },
    /// Encoded texels (BC6H blocks, RGB9E5).
    Encoded(Encoding),
}

impl Stored {
    /// Bytes a `w`×`h` surface (one face of one level) takes.
    pub fn surface_bytes(self, w: usize, h: usize) -> usize {
        match self {
            Stored::Float { bytes, channels } => w * h * bytes * channels,
            Stored::Encoded(e) => compress::surface_bytes(e, w, h).expect("encoded"),
        }
    }

    /// A KTX2 level's alignment without supercompression: lcm(texel block size, 4).
    fn align(self) -> usize {
        match self {
            Stored::Float { bytes, channels } => (bytes * channels).max(4).next_multiple_of(4),
            Stored::Encoded(Encoding::Bc6h) => 16,
            Stored::Encoded(e) if e.is_basis() => 16,
            Stored::Encoded(_) => 4,
        }
    }

    fn vk_format(self) -> u32 {
        match self {
            Stored::Float { bytes: 2, .. } => 97,
            Stored::Float { .. } => 109,
            Stored::Encoded(Encoding::Bc6h) => 143,
            Stored::Encoded(Encoding::Rgb9e5) => 123,
            Stored::Encoded(e) if e.is_basis() => compress::basis::vk_format(e),
            Stored::Encoded(_) => unreachable!("float and the PNG packings are not stored here"),
        }
    }

    fn dxgi_format(self) -> u32 {
        match self {
            Stored::Float { bytes: 2, .. } => 10,
            Stored::Float { .. } => 2,
            Stored::Encoded(Encoding::Bc6h) => 95,
            Stored::Encoded(Encoding::Rgb9e5) => 67,
            Stored::Encoded(_) => unreachable!("float and the PNG packings are not stored here"),
        }
    }

    fn type_size(self) -> u32 {
        match self {
            Stored::Float { bytes, .. } => bytes as u32,
            Stored::Encoded(Encoding::Bc6h) => 1,
            Stored::Encoded(e) if e.is_basis() => 1,
            Stored::Encoded(_) => 4,
        }
    }

    /// Decodes a `w`×`h` surface.
    fn decode(self, raw: &[u8], w: usize, h: usize) -> Image {
        match self {
            Stored::Float { bytes, channels } => texels(raw, w, h, channels, bytes),
            Stored::Encoded(e) => compress::decode_surface(e, raw, w, h),
        }
    }

    /// The KTX2 data format descriptor (its total size first).
    fn dfd(self) -> Vec<u8> {
        if let Stored::Encoded(e) = self {
            if e.is_basis() {
                return compress::basis::dfd(e);
            }
        }
        // (bit offset, bit length, channel with qualifiers, lower, upper)
        type Sample = (u16, u8, u8, u32, u32);
        let (model, block, plane, samples): (u8, [u8; 4], u8, Vec<Sample>) = match self {
            Stored::Float { bytes, .. } => {
                let bits = (bytes * 8) as u16;
                (
                    1, // RGBSDA
                    [0; 4],
                    (4 * bytes) as u8,
                    [0u8, 1, 2, 15]
                        .into_iter()
                        .enumerate()
                        .map(|(i, ch)| {
                            // float, signed; -1.0 .. 1.0
                            (
                                i as u16 * bits,
                                (bits - 1) as u8,
                                ch | 0xC0,
                                0xBF80_0000,
                                0x3F80_0000,
                            )
                        })
                        .collect(),
                )
            }
            // KHR_DF_MODEL_BC6H, 4×4 blocks of 16 bytes, one unsigned float sample 0.0 .. 1.0.
            Stored::Encoded(Encoding::Bc6h) => {
                (133, [3, 3, 0, 0], 16, vec![(0, 127, 0x80, 0, 0x3F80_0000)])
            }
            // E5B9G9R9 as Khronos's dfdutils describe it: per channel a 9-bit mantissa (upper
            // 8448) and the shared 5-bit exponent (qualifier EXPONENT, bias 15, upper 31).
            Stored::Encoded(Encoding::Rgb9e5) => (
                1,
                [0; 4],
                4,
                (0u8..3)
                    .flat_map(|ch| [(9 * ch as u16, 8, ch, 0, 8448), (27, 4, ch | 0x20, 15, 31)])
                    .collect(),
            ),
            Stored::Encoded(_) => unreachable!("float and the PNG packings are not stored here"),
        };
        let block_size = 24 + 16 * samples.len();
        let mut dfd = Vec::with_capacity(4 + block_size);
        dfd.extend(((4 + block_size) as u32).to_le_bytes());
        dfd.extend(0u32.to_le_bytes()); // vendor 0 (Khronos), descriptor type 0 (basic)
        dfd.extend(2u16.to_le_bytes()); // version 2
        dfd.extend((block_size as u16).to_le_bytes());
        dfd.extend([model, 1, 1, 0]); // BT.709 primaries, linear, straight alpha
        dfd.extend(block);
        dfd.extend([plane, 0, 0, 0, 0, 0, 0, 0]);
        for (offset, len, channel, lower, upper) in samples {
            dfd.extend(offset.to_le_bytes());
            dfd.push(len);
            dfd.push(channel);
            dfd.extend([0u8; 4]);
            dfd.extend(lower.to_le_bytes());
            dfd.extend(upper.to_le_bytes());
        }
        dfd
    }
}

/// A texture's stored bytes: per level, per face.
#[derive(Clone, Debug)]
pub struct StoredLevels {
    pub cube: bool,
    /// Level 0's width and height (a cube's: its face's).
    pub size: (usize, usize),
    pub stored: Stored,
    pub surfaces: Vec<Vec<Vec<u8>>>,
}

impl Texture {
    /// Level 0's width and height (a cube's: the face's).
    pub fn size(&self) -> (usize, usize) {
        let l = &self.levels[0];
        if self.cube {
            (l.width, l.width)
        } else {
            (l.width, l.height)
        }
    }

    /// The size level `i` of a texture whose level 0 is `w`×`h` has.
    pub fn level_size(w: usize, h: usize, i: usize) -> (usize, usize) {
        ((w >> i).max(1), (h >> i).max(1))
    }

    /// The most levels a `w`×`h` texture has (down to 1×1).
    pub fn max_levels(w: usize, h: usize) -> usize {
        (usize::BITS - w.max(h).max(1).leading_zeros()) as usize
    }

    /// Checks that the levels halve as a mip chain does and share a channel count; errors name
    /// `what`.
    pub fn check(&self, what: &str) -> Result<()> {
        let bad = |m: String| Err(Error::param(what, m));
        let Some(first) = self.levels.first() else {
            return bad("a texture needs at least one level".into());
        };
        if self.cube && first.height != 6 * first.width {
            return bad(format!(
                "a cube map's level is its F x 6F face stack; level 0 is {}x{}",
                first.width, first.height
            ));
        }
        let (w, h) = self.size();
        if self.levels.len() > Texture::max_levels(w, h) {
            return bad(format!(
                "{} levels for a {w}x{h} texture, which has at most {}",
                self.levels.len(),
                Texture::max_levels(w, h)
            ));
        }
        for (i, l) in self.levels.iter().enumerate() {
            let (lw, lh) = Texture::level_size(w, h, i);
            let lh = if self.cube { 6 * lh } else { lh };
            if l.width != lw || l.height != lh {
                return bad(format!(
                    "level {i} is {}x{}; a mip chain's level {i} is {lw}x{lh}",
                    l.width, l.height
                ));
            }
            if l.channels != first.channels || !(1..=4).contains(&l.channels) {
                return bad(format!("level {i} has {} channels", l.channels));
            }
            if l.data.len() != l.width * l.height * l.channels {
                return bad(format!("level {i}'s pixels do not match its size"));
            }
        }
        Ok(())
    }
}

/// The container a file's first bytes identify.
pub fn sniff(head: &[u8]) -> Option<Container> {
    if head.starts_with(&KTX2_MAGIC) {
        Some(Container::Ktx2)
    } else if head.starts_with(DDS_MAGIC) {
        Some(Container::Dds)
    } else {
        None
    }
}

/// RGBA of a pixel of 1–4 channels (grey to R, G, B; alpha 1 when absent).
fn rgba(p: &[f32]) -> [f32; 4] {
    match p.len() {
        1 => [p[0], p[0], p[0], 1.0],
        2 => [p[0], p[0], p[0], p[1]],
        3 => [p[0], p[1], p[2], 1.0],
        _ => [p[0], p[1], p[2], p[3]],
    }
}

fn put_texels(out: &mut Vec<u8>, data: &[f32], channels: usize, bytes: usize) {
    out.reserve(data.len() / channels * 4 * bytes);
    for p in data.chunks_exact(channels) {
        for v in rgba(p) {
            match bytes {
                2 => out.extend(exr::prelude::f16::from_f32(v).to_le_bytes()),
                _ => out.extend(v.to_le_bytes()),
            }
        }
    }
}

impl StoredLevels {
    /// A texture's texels as RGBA floats (`half`: 16-bit).
    pub fn float(tex: &Texture, half: bool) -> Result<StoredLevels> {
        tex.check("texture")?;
        let bytes = if half { 2 } else { 4 };
        let nf = if tex.cube { 6 } else { 1 };
        let surfaces = tex
            .levels
            .iter()
            .map(|l| {
                let n = l.data.len() / nf;
                (0..nf)
                    .map(|f| {
                        let mut out = Vec::new();
                        put_texels(&mut out, &l.data[f * n..(f + 1) * n], l.channels, bytes);
                        out
                    })
                    .collect()
            })
            .collect();
        Ok(StoredLevels {
            cube: tex.cube,
            size: tex.size(),
            stored: Stored::Float { bytes, channels: 4 },
            surfaces,
        })
    }
}

/// Encodes `tex` as KTX2 (`half`: 16-bit floats) with `extra` key/value pairs (beside
/// `KTXorientation` and `KTXwriter`).
pub fn encode_ktx2(tex: &Texture, half: bool, extra: &[(&str, &str)]) -> Result<Vec<u8>> {
    encode_ktx2_stored(&StoredLevels::float(tex, half)?, extra, None)
}

/// Encodes stored levels as KTX2 with `extra` key/value pairs, each level Zstandard-compressed
/// at `zstd`'s level when given.
pub fn encode_ktx2_stored(
    t: &StoredLevels,
    extra: &[(&str, &str)],
    zstd: Option<i32>,
) -> Result<Vec<u8>> {
    let (w, h) = t.size;
    let faces = if t.cube { 6 } else { 1 };
    let dfd = t.stored.dfd();
    // Key/value data, sorted by key.
    let writer = format!("spheremap {}", env!("CARGO_PKG_VERSION"));
    let mut kv: Vec<(&str, &str)> = vec![("KTXorientation", "rd"), ("KTXwriter", &writer)];
    kv.extend_from_slice(extra);
    kv.sort();
    let mut kvd = Vec::new();
    for (k, v) in kv {
        let len = k.len() + 1 + v.len() + 1;
        kvd.extend((len as u32).to_le_bytes());
        kvd.extend(k.bytes());
        kvd.push(0);
        kvd.extend(v.bytes());
        kvd.push(0);
        kvd.resize(kvd.len().next_multiple_of(4), 0);
    }
    let n = t.surfaces.len();
    let header = 12 + 9 * 4 + 4 * 4 + 2 * 8 + 3 * 8 * n;
    let dfd_at = header;
    let kvd_at = dfd_at + dfd.len();
    let data_at = kvd_at + kvd.len();
    // Supercompressed levels are not padded.
    let align = if zstd.is_some() { 1 } else { t.stored.align() };
    // Levels smallest first: (offset, stored length, uncompressed length).
    let mut index = vec![(0usize, 0usize, 0usize); n];
    let mut body = Vec::new();
    for i in (0..n).rev() {
        let pad = (data_at + body.len()).next_multiple_of(align) - (data_at + body.len());
        body.resize(body.len() + pad, 0);
        let start = data_at + body.len();
        let raw: Vec<u8> = t.surfaces[i].concat();
        match zstd {
            Some(level) => {
                let z = zstd::bulk::compress(&raw, level).map_err(|e| {
                    Error::param("zstd", format!("Zstandard compression failed: {e}"))
                })?;
                body.extend(&z);
            }
            None => body.extend(&raw),
        }
        index[i] = (start, data_at + body.len() - start, raw.len());
    }
    let mut out = Vec::with_capacity(data_at + body.len());
    out.extend(KTX2_MAGIC);
    let scheme = if zstd.is_some() { 2 } else { 0 };
    for v in [
        t.stored.vk_format(),
        t.stored.type_size(),
        w as u32,
        h as u32,
        0,
        0,
        faces,
        n as u32,
        scheme,
    ] {
        out.extend(v.to_le_bytes());
    }
    for v in [dfd_at, dfd.len(), kvd_at, kvd.len()] {
        out.extend((v as u32).to_le_bytes());
    }
    out.extend(0u64.to_le_bytes());
    out.extend(0u64.to_le_bytes());
    for (at, len, raw) in &index {
        out.extend((*at as u64).to_le_bytes());
        out.extend((*len as u64).to_le_bytes());
        out.extend((*raw as u64).to_le_bytes());
    }
    debug_assert_eq!(out.len(), dfd_at);
    out.extend(dfd);
    out.extend(kvd);
    out.extend(body);
    Ok(out)
}

/// Encodes `tex` as DDS with the DX10 header (`half`: 16-bit floats).
pub fn encode_dds(tex: &Texture, half: bool) -> Result<Vec<u8>> {
    Ok(encode_dds_stored(&StoredLevels::float(tex, half)?))
}

/// Encodes stored levels as DDS with the DX10 header.
pub fn encode_dds_stored(t: &StoredLevels) -> Vec<u8> {
    let (w, h) = t.size;
    let n = t.surfaces.len() as u32;
    let mut out = Vec::new();
    out.extend(DDS_MAGIC);
    let caps = 0x1000 | if n > 1 { 0x8 | 0x40_0000 } else { 0 } | if t.cube { 0x8 } else { 0 };
    let caps2: u32 = if t.cube { 0x200 | 0xFC00 } else { 0 };
    // CAPS | HEIGHT | WIDTH | PIXELFORMAT | MIPMAPCOUNT, and PITCH (uncompressed) or
    // LINEARSIZE (block-compressed).
    let (size_flag, pitch) = match t.stored {
        Stored::Encoded(Encoding::Bc6h) => (0x8_0000, t.stored.surface_bytes(w, h)),
        s => (0x8, s.surface_bytes(w, 1)),
    };
    let flags = 0x1 | 0x2 | 0x4 | size_flag | 0x1000 | 0x2_0000u32;
    for v in [124u32, flags, h as u32, w as u32, pitch as u32, 0, n] {
        out.extend(v.to_le_bytes());
    }
    out.extend([0u8; 44]); // reserved
                           // The pixel format: a FourCC, "DX10".
    for v in [32u32, 0x4] {
        out.extend(v.to_le_bytes());
    }
    out.extend(b"DX10");
    out.extend([0u8; 20]);
    for v in [caps as u32, caps2, 0, 0, 0] {
        out.extend(v.to_le_bytes());
    }
    let misc = if t.cube { 0x4 } else { 0 };
    for v in [t.stored.dxgi_format(), 3, misc, 1, 0] {
        out.extend(v.to_le_bytes());
    }
    let faces = if t.cube { 6 } else { 1 };
    for f in 0..faces {
        for l in &t.surfaces {
            out.extend(&l[f]);
        }
    }
    out
}

struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    what: &'static str,
}

impl Reader<'_> {
    fn u32(&self, at: usize) -> Result<u32> {
        self.bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
            .ok_or_else(|| self.truncated())
    }
    fn u64(&self, at: usize) -> Result<u64> {
        self.bytes
            .get(at..at + 8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
            .ok_or_else(|| self.truncated())
    }
    fn truncated(&self) -> Error {
        Error::data(
            self.path,
            format!("cannot decode {}: the file is truncated", self.what),
        )
    }
    fn bad(&self, m: impl std::fmt::Display) -> Error {
        Error::data(self.path, format!("cannot decode {}: {m}", self.what))
    }
    /// `len` bytes at `at`, inside the file.
    fn slice(&self, at: u64, len: u64) -> Result<&[u8]> {
        let end = at.checked_add(len).ok_or_else(|| self.truncated())?;
        if end > self.bytes.len() as u64 {
            return Err(self.truncated());
        }
        Ok(&self.bytes[at as usize..end as usize])
    }
}

/// Texels `raw` (`channels` values of `texel` each) as an image `w`×`h`.
fn texels(raw: &[u8], w: usize, h: usize, channels: usize, bytes: usize) -> Image {
    let data = match bytes {
        2 => raw
            .chunks_exact(2)
            .map(|b| exr::prelude::f16::from_le_bytes([b[0], b[1]]).to_f32())
            .collect(),
        _ => raw
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
    };
    Image {
        width: w,
        height: h,
        channels,
        data,
    }
}

/// Decodes a KTX2 or DDS file held in memory; `path` names it in messages.
pub fn decode(path: &Path, bytes: &[u8], limits: &Limits) -> Result<Texture> {
    match sniff(bytes) {
        Some(Container::Ktx2) => decode_ktx2(path, bytes, limits).map(|(t, _)| t),
        Some(Container::Dds) => decode_dds(path, bytes, limits),
        None => Err(Error::data(path, "not a KTX2 or DDS file")),
    }
}

/// Checks a texture's level-0 size against the limits (a cube: its face stack).
fn check_size(path: &Path, w: usize, h: usize, cube: bool, limits: &Limits) -> Result<()> {
    if w == 0 || h == 0 {
        return Err(Error::data(
            path,
            format!("the header gives an empty texture ({w}x{h})"),
        ));
    }
    limits.check(path, w, if cube { h.saturating_mul(6) } else { h })
}

/// A KTX2 file's key/value pairs.
pub type KeyValues = Vec<(String, Vec<u8>)>;

/// Decodes KTX2; also returns its key/value pairs.
pub fn decode_ktx2(path: &Path, bytes: &[u8], limits: &Limits) -> Result<(Texture, KeyValues)> {
    let r = Reader {
        path,
        bytes,
        what: "KTX2",
    };
    let f = |i: usize| r.u32(12 + 4 * i);
    let (vk, w, h, depth, layers, faces, levels, scheme) =
        (f(0)?, f(2)?, f(3)?, f(4)?, f(5)?, f(6)?, f(7)?, f(8)?);
    let float = |bytes, channels| Stored::Float { bytes, channels };
    let stored = match vk {
        76 => float(2, 1),
        90 => float(2, 3),
        97 => float(2, 4),
        100 => float(4, 1),
        106 => float(4, 3),
        109 => float(4, 4),
        143 => Stored::Encoded(Encoding::Bc6h),
        123 => Stored::Encoded(Encoding::Rgb9e5),
        1_000_066_000 | 1_000_066_004 => {
            // UASTC HDR 4x4 / ASTC HDR 6x6: Basis Universal's transcoder reads the whole file.
            let cube = faces == 6;
            check_size(path, w as usize, (h as usize).max(1), cube, limits)?;
            let levels = compress::basis::decode_ktx2(path, bytes)?;
            let kv = Vec::new();
            return Ok((Texture { cube, levels }, kv));
        }
        0 => {
            return Err(r.bad(
                "the format is VK_FORMAT_UNDEFINED (Basis Universal or another \
                               encoded payload); spheremap reads float, BC6H and RGB9E5 textures",
            ))
        }
        _ => {
            return Err(r.bad(format!(
                "VkFormat {vk} is not a format spheremap reads (R16/R16G16B16/R16G16B16A16/\
                 R32/R32G32B32/R32G32B32A32_SFLOAT, BC6H_UFLOAT_BLOCK, E5B9G9R9_UFLOAT_PACK32)"
            )))
        }
    };
    if scheme != 0 && scheme != 2 {
        return Err(r.bad(format!(
            "supercompression scheme {scheme} (BasisLZ or zlib) is not read; spheremap \
             reads uncompressed and Zstandard-supercompressed levels"
        )));
    }
    if depth > 1 {
        return Err(r.bad("3D textures are not read"));
    }
    if layers > 1 {
        return Err(r.bad(format!("texture arrays ({layers} layers) are not read")));
    }
    let cube = match faces {
        1 => false,
        6 => true,
        _ => return Err(r.bad(format!("{faces} faces (1 or 6 expected)"))),
    };
    let (w, h) = (w as usize, (h as usize).max(1));
    if cube && w != h {
        return Err(r.bad(format!("a cube map with {w}x{h} faces (faces are square)")));
    }
    check_size(path, w, h, cube, limits)?;
    let n = (levels as usize).max(1);
    if n > Texture::max_levels(w, h) {
        return Err(r.bad(format!("{n} mip levels for a {w}x{h} texture")));
    }
    // Key/value data.
    let (kvd_at, kvd_len) = (r.u32(56)? as u64, r.u32(60)? as u64);
    let kvd = r.slice(kvd_at, kvd_len)?;
    let mut kv = Vec::new();
    let mut at = 0usize;
    while at + 4 <= kvd.len() {
        let len = u32::from_le_bytes(kvd[at..at + 4].try_into().expect("4")) as usize;
        let entry = kvd
            .get(at + 4..(at + 4).saturating_add(len))
            .ok_or_else(|| r.bad("a key/value entry runs past its data"))?;
        let nul = entry.iter().position(|&b| b == 0).unwrap_or(entry.len());
        let key = String::from_utf8_lossy(&entry[..nul]).into_owned();
        let value = entry.get(nul + 1..).unwrap_or(&[]);
        let value = value.strip_suffix(&[0]).unwrap_or(value).to_vec();
        kv.push((key, value));
        at = (at + 4 + len).next_multiple_of(4);
    }
    let orientation = kv
        .iter()
        .find(|(k, _)| k == "KTXorientation")
        .map(|(_, v)| v.clone())
        .unwrap_or_else(|| b"rd".to_vec());
    let flip_x = orientation.first() == Some(&b'l');
    let flip_y = orientation.get(1) == Some(&b'u');
    let nf = if cube { 6 } else { 1 };
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (lw, lh) = Texture::level_size(w, h, i);
        let at = r.u64(80 + 24 * i)?;
        let len = r.u64(80 + 24 * i + 8)?;
        let want = (stored.surface_bytes(lw, lh) * nf) as u64;
        let raw_len = r.u64(80 + 24 * i + 16)?;
        let stored_bytes = r.slice(at, len)?;
        let inflated;
        let raw = if scheme == 2 {
            if raw_len != want {
                return Err(r.bad(format!(
                    "level {i} inflates to {raw_len} bytes; a {lw}x{lh} level of {nf} \
                     face(s) holds {want}"
                )));
            }
            inflated = zstd::bulk::decompress(stored_bytes, want as usize)
                .map_err(|e| r.bad(format!("level {i}'s Zstandard data: {e}")))?;
            if inflated.len() as u64 != want {
                return Err(r.bad(format!(
                    "level {i} inflates to {} bytes, not {want}",
                    inflated.len()
                )));
            }
            &inflated[..]
        } else {
            if len != want {
                return Err(r.bad(format!(
                    "level {i} holds {len} bytes; a {lw}x{lh} level of {nf} face(s) holds {want}"
                )));
            }
            stored_bytes
        };
        let face_bytes = stored.surface_bytes(lw, lh);
        let faces: Vec<Image> = (0..nf)
            .map(|f| stored.decode(&raw[f * face_bytes..(f + 1) * face_bytes], lw, lh))
            .collect();
        let mut img = stack(faces);
        if (flip_x || flip_y) && matches!(stored, Stored::Encoded(Encoding::Bc6h)) {
            return Err(r.bad(format!(
                "KTXorientation {:?} on BC6H blocks is not read (write rows top first, \"rd\")",
                String::from_utf8_lossy(&orientation)
            )));
        }
        if flip_x || flip_y {
            for f in 0..nf {
                flip(&mut img, f * lh, lh, flip_x, flip_y);
            }
        }
        out.push(img);
    }
    Ok((Texture { cube, levels: out }, kv))
}

/// Surfaces of one size stacked top to bottom.
fn stack(faces: Vec<Image>) -> Image {
    if faces.len() == 1 {
        return faces.into_iter().next().expect("one");
    }
    let (w, h, c) = (faces[0].width, faces[0].height, faces[0].channels);
    Image {
        width: w,
        height: h * faces.len(),
        channels: c,
        data: faces.into_iter().flat_map(|f| f.data).collect(),
    }
}

/// Mirrors rows `y0..y0+h` of `img` in x and/or y.
fn flip(img: &mut Image, y0: usize, h: usize, fx: bool, fy: bool) {
    let (w, c) = (img.width, img.channels);
    let src = img.clone();
    for y in 0..h {
        let sy = if fy { h - 1 - y } else { y };
        for x in 0..w {
            let sx = if fx { w - 1 - x } else { x };
            let (d, s) = (((y0 + y) * w + x) * c, ((y0 + sy) * w + sx) * c);
            img.data[d..d + c].copy_from_slice(&src.data[s..s + c]);
        }
    }
}

/// Decodes DDS.
pub fn decode_dds(path: &Path, bytes: &[u8], limits: &Limits) -> Result<Texture> {
    let r = Reader {
        path,
        bytes,
        what: "DDS",
    };
    if r.u32(4)? != 124 {
        return Err(r.bad("the header size is not 124"));
    }
    let (h, w) = (r.u32(12)? as usize, r.u32(16)? as usize);
    let depth = r.u32(24)?;
    let mips = r.u32(28)?.max(1) as usize;
    let pf_flags = r.u32(80)?;
    let fourcc = r.u32(84)?;
    let caps2 = r.u32(112)?;
    let mut at = 128usize;
    let dx10 = pf_flags & 0x4 != 0 && &bytes[84..88] == b"DX10";
    let float = |bytes, channels| Stored::Float { bytes, channels };
    let (stored, cube) = if dx10 {
        let (dxgi, dim, misc, array) = (r.u32(128)?, r.u32(132)?, r.u32(136)?, r.u32(140)?);
        at += 20;
        if dim != 3 {
            return Err(r.bad(format!(
                "resource dimension {dim} (only 2D textures, dimension 3, are read)"
            )));
        }
        if array > 1 {
            return Err(r.bad(format!("texture arrays ({array} elements) are not read")));
        }
        let s = match dxgi {
            2 => float(4, 4),
            6 => float(4, 3),
            10 => float(2, 4),
            41 => float(4, 1),
            54 => float(2, 1),
            95 => Stored::Encoded(Encoding::Bc6h),
            67 => Stored::Encoded(Encoding::Rgb9e5),
            _ => {
                return Err(r.bad(format!(
                    "DXGI format {dxgi} is not a format spheremap reads (R16G16B16A16_FLOAT, \
                     R32G32B32A32_FLOAT, R32G32B32_FLOAT, R32_FLOAT, R16_FLOAT, BC6H_UF16, \
                     R9G9B9E5_SHAREDEXP)"
                )))
            }
        };
        (s, misc & 0x4 != 0)
    } else {
        let s = match (pf_flags & 0x4 != 0, fourcc) {
            (true, 111) => float(2, 1),
            (true, 113) => float(2, 4),
            (true, 114) => float(4, 1),
            (true, 116) => float(4, 4),
            _ => {
                return Err(r.bad(
                    "not a float texture (spheremap reads DDS with a DX10 header of a float \
                     format, or the D3D float codes 111, 113, 114, 116)",
                ))
            }
        };
        let cube = caps2 & 0x200 != 0;
        if cube && caps2 & 0xFC00 != 0xFC00 {
            return Err(r.bad("a cube map without all six faces"));
        }
        (s, cube)
    };
    if depth > 1 && caps2 & 0x20_0000 != 0 {
        return Err(r.bad("volume textures are not read"));
    }
    if cube && w != h {
        return Err(r.bad(format!("a cube map with {w}x{h} faces (faces are square)")));
    }
    check_size(path, w, h, cube, limits)?;
    if mips > Texture::max_levels(w, h) {
        return Err(r.bad(format!("{mips} mip levels for a {w}x{h} texture")));
    }
    let nf = if cube { 6 } else { 1 };
    let mut faces: Vec<Vec<Image>> = vec![Vec::with_capacity(nf); mips];
    let mut pos = at as u64;
    for _ in 0..nf {
        for (i, l) in faces.iter_mut().enumerate() {
            let (lw, lh) = Texture::level_size(w, h, i);
            let len = stored.surface_bytes(lw, lh) as u64;
            l.push(stored.decode(r.slice(pos, len)?, lw, lh));
            pos += len;
        }
    }
    Ok(Texture {
        cube,
        levels: faces.into_iter().map(stack).collect(),
    })
}

/// The value of key `key` in a KTX2 file's key/value data (without its NUL), read from the
/// header alone; `None` when there is none or the bytes are not a readable KTX2 header.
pub fn ktx2_value(bytes: &[u8], key: &str) -> Option<Vec<u8>> {
    if sniff(bytes)? != Container::Ktx2 {
        return None;
    }
    let u = |at: usize| -> Option<usize> {
        Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?) as usize)
    };
    let (kvd_at, kvd_len) = (u(56)?, u(60)?);
    let kvd = bytes.get(kvd_at..kvd_at.checked_add(kvd_len)?)?;
    let mut at = 0;
    while at + 4 <= kvd.len() {
        let len = u32::from_le_bytes(kvd[at..at + 4].try_into().ok()?) as usize;
        let entry = kvd.get(at + 4..(at + 4).checked_add(len)?)?;
        if let Some(v) = entry
            .strip_prefix(key.as_bytes())
            .and_then(|v| v.strip_prefix(&[0]))
        {
            return Some(v.strip_suffix(&[0]).unwrap_or(v).to_vec());
        }
        at = (at + 4 + len).next_multiple_of(4);
    }
    None
}

/// Whether a KTX2 or DDS file's header says it holds a cube map.
pub fn is_cube(bytes: &[u8]) -> bool {
    let u = |at: usize| -> Option<u32> {
        Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
    };
    match sniff(bytes) {
        Some(Container::Ktx2) => u(36) == Some(6),
        Some(Container::Dds) => {
            let dx10_cube =
                bytes.get(84..88) == Some(b"DX10") && u(136).is_some_and(|m| m & 0x4 != 0);
            dx10_cube || u(112).is_some_and(|c| c & 0x200 != 0)
        }
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize, c: usize, k: f32) -> Image {
        let mut img = Image::new(w, h, c);
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = k + i as f32 * 0.25;
        }
        img
    }

    fn chain(w: usize, h: usize, c: usize, n: usize, cube: bool) -> Texture {
        Texture {
            cube,
            levels: (0..n)
                .map(|i| {
                    let (lw, lh) = Texture::level_size(w, h, i);
                    ramp(lw, if cube { 6 * lh } else { lh }, c, i as f32)
                })
                .collect(),
        }
    }

    #[test]
    fn round_trips_2d_and_cube_in_both_formats() {
        let limits = Limits::default();
        for cube in [false, true] {
            let tex = if cube {
                chain(8, 8, 4, 4, true)
            } else {
                chain(16, 8, 4, 5, false)
            };
            for half in [false, true] {
                let k = encode_ktx2(
                    &tex,
                    half,
                    &[("spheremap", "mapping=latlong preset=blender")],
                )
                .unwrap();
                let (back, kv) = decode_ktx2(Path::new("t.ktx2"), &k, &limits).unwrap();
                let d = encode_dds(&tex, half).unwrap();
                let back_d = decode_dds(Path::new("t.dds"), &d, &limits).unwrap();
                for b in [&back, &back_d] {
                    assert_eq!(b.cube, cube);
                    assert_eq!(b.levels.len(), tex.levels.len());
                    for (x, y) in b.levels.iter().zip(&tex.levels) {
                        assert_eq!((x.width, x.height, x.channels), (y.width, y.height, 4));
                        // Ramp values are exact in half up to 2048 by quarters.
                        assert_eq!(x.data, y.data);
                    }
                }
                assert!(kv.iter().any(|(k, v)| k == "KTXorientation" && v == b"rd"));
                assert_eq!(
                    ktx2_value(&k, "spheremap").as_deref(),
                    Some(&b"mapping=latlong preset=blender"[..])
                );
                assert_eq!(ktx2_value(&k, "nothing"), None);
                assert_eq!((is_cube(&k), is_cube(&d)), (cube, cube));
            }
        }
    }

    #[test]
    fn ktx2_layout_is_pinned() {
        let tex = chain(4, 2, 3, 2, false);
        let k = encode_ktx2(&tex, false, &[]).unwrap();
        let u = |at: usize| u32::from_le_bytes(k[at..at + 4].try_into().unwrap());
        let q = |at: usize| u64::from_le_bytes(k[at..at + 8].try_into().unwrap());
        assert_eq!(&k[..12], &KTX2_MAGIC);
        assert_eq!((u(12), u(16), u(20), u(24)), (109, 4, 4, 2));
        assert_eq!((u(36), u(40), u(44)), (1, 2, 0));
        // Level 1 (2×1) is stored before level 0 (4×2), each aligned to 16 bytes.
        let (l0, l1) = (q(80), q(104));
        assert!(l1 < l0 && l0 % 16 == 0 && l1 % 16 == 0);
        assert_eq!((q(88), q(112)), (4 * 2 * 16, 2 * 16));
        // Level 0's first texel is the image's top-left pixel, alpha 1 added.
        let px: Vec<f32> = (0..4)
            .map(|i| f32::from_le_bytes(k[l0 as usize + 4 * i..][..4].try_into().unwrap()))
            .collect();
        assert_eq!(px, vec![0.0, 0.25, 0.5, 1.0]);
        // The DFD: RGBSDA, linear, 16-byte texels, four signed float samples.
        let dfd = u(48) as usize;
        assert_eq!(u(dfd), 92);
        assert_eq!(&k[dfd + 12..dfd + 15], &[1, 1, 1]);
        assert_eq!(k[dfd + 20], 16);
        assert_eq!(k[dfd + 28 + 3], 0xC0);
        assert_eq!(k[dfd + 28 + 3 * 16 + 3], 0xCF);
    }

    #[test]
    fn bad_files_are_refused_with_the_reason() {
        let limits = Limits::default();
        let p = Path::new("x.ktx2");
        let k = encode_ktx2(&chain(8, 8, 4, 2, true), true, &[]).unwrap();
        let err = |b: &[u8]| decode(p, b, &limits).unwrap_err().to_string();
        assert!(err(&k[..k.len() - 3]).contains("truncated"));
        assert!(err(&k[..20]).contains("truncated"));
        let mut z = k.clone();
        z[44..48].copy_from_slice(&1u32.to_le_bytes());
        assert!(err(&z).contains("supercompression"), "{}", err(&z));
        let mut bc = k.clone();
        bc[12..16].copy_from_slice(&145u32.to_le_bytes()); // BC7
        assert!(err(&bc).contains("VkFormat 145"));
        let mut huge = k.clone();
        huge[20..24].copy_from_slice(&(1u32 << 20).to_le_bytes());
        huge[24..28].copy_from_slice(&(1u32 << 20).to_le_bytes());
        assert!(err(&huge).contains("over the limit"));
        let d = encode_dds(&chain(8, 8, 4, 2, false), false).unwrap();
        assert!(err(&d[..d.len() - 1]).contains("truncated"));
        let mut bc = d.clone();
        bc[128..132].copy_from_slice(&71u32.to_le_bytes()); // BC1
        assert!(err(&bc).contains("DXGI format 71"));
        // A level of the wrong size.
        let bad = Texture {
            cube: false,
            levels: vec![ramp(8, 4, 3, 0.0), ramp(3, 2, 3, 0.0)],
        };
        assert!(encode_ktx2(&bad, false, &[])
            .unwrap_err()
            .to_string()
            .contains("level 1 is 3x2"));
    }

    #[test]
    fn orientation_ru_is_turned_to_row_0_at_the_top() {
        let tex = chain(2, 2, 4, 1, false);
        let mut k = encode_ktx2(&tex, false, &[]).unwrap();
        let i = k.windows(3).position(|w| w == b"rd\0").unwrap();
        k[i + 1] = b'u';
        let (back, _) = decode_ktx2(Path::new("x"), &k, &Limits::default()).unwrap();
        let img = &back.levels[0];
        assert_eq!(img.pixel(0, 0), tex.levels[0].pixel(0, 1));
        assert_eq!(img.pixel(1, 1), tex.levels[0].pixel(1, 0));
    }
}
