//! Encoded texels that keep the light: BC6H blocks and RGB9E5 packed texels for KTX2 and DDS,
//! UASTC HDR 4x4 and ASTC HDR 6x6 for KTX2, RGBD and RGBM for PNG, with spheremap's own
//! lighting check and repair on top of the encoders.
//!
//! ## Encodings
//!
//! | name | stores | KTX2 `vkFormat` | DDS `DXGI_FORMAT` | range |
//! |---|---|---|---|---|
//! | `float` | RGBA half or float per texel | 97 / 109 | 10 / 2 | ±65,504 (half) / f32 |
//! | `bc6h` | 4×4 blocks of 16 bytes, unsigned half RGB | 143 `BC6H_UFLOAT_BLOCK` | 95 `BC6H_UF16` | 0 … 65,504 |
//! | `rgb9e5` | 32 bits per texel, shared exponent | 123 `E5B9G9R9_UFLOAT_PACK32` | 67 `R9G9B9E5_SHAREDEXP` | 0 … 65,408 |
//! | `uastc-hdr-4x4` | 4×4 blocks of 16 bytes (Basis Universal) | 1000066000 `ASTC_4x4_SFLOAT_BLOCK`, DFD model 167 | – | 0 … 65,216 |
//! | `astc-hdr-6x6` | 6×6 blocks of 16 bytes (Basis Universal) | 1000066004 `ASTC_6x6_SFLOAT_BLOCK`, DFD model 162 | – | 0 … 65,216 |
//!
//! and two HDR packings into 8-bit RGBA PNGs, `rgbd` (Babylon.js) and `rgbm` (three.js).
//!
//! All hold RGB (no alpha: a grey map is written to R, G and B, an alpha channel is dropped
//! with a warning unless it is 1 everywhere) and no negative values.  A texel beyond the range
//! is clamped to it and a negative one to 0, and the light it gained or lost is moved into
//! its neighbours on the same face ([`super::fold`]: the negative lobes that resizing rings
//! beside a sun would otherwise add percents to the power), with a warning that counts the
//! values and states the power each channel changes (0 unless no neighbour could take it);
//! NaN and Inf are refused.
//!
//! ## Keeping the light
//!
//! An encoder minimises a per-texel error; nothing makes it keep a block's radiant power, and
//! on maps with small bright sources the encoders people use lose percents of it.  So the
//! blocks are checked after encoding, and repaired where they leak:
//!
//! 1. Every face of every level is cut into blocks (edge texels repeated to fill the blocks
//!    at the right and bottom edges) and encoded (BC6H: Intel's ISPC encoder, `basic`
//!    preset, through the `intel_tex_2` crate; UASTC HDR 4x4 and ASTC HDR 6x6: Basis
//!    Universal's encoder at its default level, the blocks side by side in images of 256).
//! 2. Each block is decoded (`bcdec_rs`; the pure-Rust `basisu` crate's ASTC decoder, which
//!    `read_texture` reads with) and its power per channel, Σ L·Ω over its texels with
//!    the level's exact texel solid angles Ω (a cube face's, or the 2D map's mapping's from
//!    its note; equal weights when the mapping is not known), compared with the source's.
//! 3. (BC6H) A block whose power differs in a channel by more than [`BLOCK_TOLERANCE`] of the
//!    larger of its own power and the level's mean block power is encoded again, from its
//!    texels scaled per channel by the ratio of the source's power to the decoded power (the
//!    ratio within [½, 2]), and from its texels each scaled by source / decoded; a try is kept
//!    when its power is closer and no channel gets worse.  This repeats up to
//!    [`REPAIR_ROUNDS`] times; a block that a round did not bring closer is not tried again
//!    unless its miss alone breaks the level's tolerance (a sun's block: the one-region
//!    encoder of step 4 would hold it at a larger log error).
//! 4. Where the level then still misses its power by more than [`SURFACE_TOLERANCE`], or a
//!    face of it by more than [`FACE_TOLERANCE`], each face missing by more than
//!    [`SURFACE_TOLERANCE`] has its blocks that miss encoded again to hold their power,
//!    largest misses first.  BC6H: by its one-region modes written here ([`bc6h`]),
//!    endpoints and indices searched for the texels nearest the source in log space among
//!    those that hold the block's power.  UASTC HDR and ASTC HDR: the encoder's block moved
//!    one quantisation step at a time (an endpoint or weight to its neighbouring value, in
//!    the block's own configuration, through the `basisu` crate's ASTC unpacker and packer),
//!    each step the one that removes the most power error per log error added; where that
//!    cannot hold the block, it is encoded again at gains around its power ratio and each
//!    result moved so; where that cannot either, a constant (void-extent) block of its mean
//!    colour where that moves the level's SH9 irradiance by at most [`FLAT_SH_SHARE`]
//!    ([`light_cost`]; a constant block over a sun moves the sun across the block).  That costs texel
//!    accuracy, so a block is taken only while the face's squared log error grows by at most
//!    a share of the encoder's ([`OWN_LOG_SHARE`], [`ASTC_LOG_SHARE`]), unless its miss alone
//!    breaks the face's tolerance.
//! 5. What a block still cannot hold is carried to its neighbours on the same face (within
//!    1, 2, then 4 blocks; each takes at most [`CARRY_SHARE`] of its own power more or less),
//!    and they are encoded again (steps 3 and 4), while the face misses.  Where it still
//!    misses, its blocks that miss are tried once more, a constant ASTC block now taken
//!    wherever it moves the light less than the block as it is.
//!
//! A level that still misses its power by more than [`LEVEL_GOAL`] is written with a warning
//! that states its error per channel.
//!
//! Where every block holds its light, or its neighbours hold it, the level's power and its
//! low-order moments (SH9) hold with it.  A block whose light sits in one texel far brighter
//! than the rest holds it to a part of a percent: BC6H's ten-bit endpoints move in steps of
//! about 3 %, and the block's other texels, whose index the bright one shares in every
//! channel, make up the rest (docs/lighting.md gives the measured misses); ASTC HDR's
//! endpoints, at the precision Basis Universal's configurations give a block of high
//! contrast, move in steps of 3–6 %.  RGB9E5 texels are each rounded to the nearest value the
//! format holds: there is nothing to repair.  [`LevelCompression`] reports, per level, the
//! power error before and after the repair, the blocks repaired and the RMSLE.

use super::fold::fold_into_range;
use super::{bc6h, Image};
use crate::base::error::{Error, Result};
use crate::mappings::mapping::Mapping;
use rayon::prelude::*;
use serde::Serialize;

crate::base::named::named_enum! {
    /// How a texture's texels are encoded (the names `--encode` and Python's `encode=` take).
    #[derive(Default)]
    pub enum Encoding: "encoding" as "encode" {
        /// Half or 32-bit floats, uncompressed.
        #[default]
        Float = "float",
        /// BC6H, unsigned (`BC6H_UF16` / `BC6H_UFLOAT_BLOCK`).
        Bc6h = "bc6h",
        /// RGB9E5, shared exponent (`R9G9B9E5_SHAREDEXP` / `E5B9G9R9_UFLOAT_PACK32`).
        Rgb9e5 = "rgb9e5",
        /// RGBD in an 8-bit RGBA PNG, as Babylon.js's `toRGBD` / `fromRGBD` define it.
        Rgbd = "rgbd",
        /// RGBM in an 8-bit RGBA PNG, as three.js's `RGBMLoader` reads it (range
        /// [`RGBM_RANGE`]).
        Rgbm = "rgbm",
        /// UASTC HDR 4x4 (Basis Universal; KTX2 `VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK`, DFD model
        /// 167).
        UastcHdr4x4 = "uastc-hdr-4x4",
        /// ASTC HDR 6x6 (Basis Universal's encoder; KTX2 `VK_FORMAT_ASTC_6x6_SFLOAT_BLOCK`).
        AstcHdr6x6 = "astc-hdr-6x6",
    }
}

/// A block whose power differs from its source's by more than this (relative, per channel) is
/// encoded again.
pub const BLOCK_TOLERANCE: f64 = 1e-3;
/// The most times a block is encoded again.
pub const REPAIR_ROUNDS: usize = 6;
/// The largest value BC6H's unsigned half holds.
pub const BC6H_MAX: f32 = 65504.0;
/// The largest value RGB9E5 holds: (2⁹ − 1)/2⁹ × 2¹⁶.
pub const RGB9E5_MAX: f32 = 65408.0;
/// The largest value ASTC HDR (and so UASTC HDR) holds.
pub const ASTC_HDR_MAX: f32 = 65216.0;

impl Encoding {
    /// Basis Universal's HDR formats (KTX2 only).
    pub fn is_basis(self) -> bool {
        matches!(self, Encoding::UastcHdr4x4 | Encoding::AstcHdr6x6)
    }

    /// An HDR packing into an 8-bit RGBA PNG (RGBD, RGBM).
    pub fn is_packing(self) -> bool {
        matches!(self, Encoding::Rgbd | Encoding::Rgbm)
    }

    /// The largest value the encoding holds (`None`: float, whose range the half/float
    /// choice sets).
    pub fn range(self) -> Option<f32> {
        match self {
            Encoding::Float => None,
            Encoding::Bc6h => Some(BC6H_MAX),
            Encoding::Rgb9e5 => Some(RGB9E5_MAX),
            Encoding::Rgbd => Some(RGBD_MAX),
            Encoding::Rgbm => Some(RGBM_RANGE),
            Encoding::UastcHdr4x4 | Encoding::AstcHdr6x6 => Some(ASTC_HDR_MAX),
        }
    }
}

/// What encoding one level (all its faces) did to its light.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LevelCompression {
    /// The level's blocks (BC6H) or texels (RGB9E5), all faces.
    pub blocks: usize,
    /// Blocks encoded again to keep their light.
    pub repaired: usize,
    /// The decoded level's power per channel (R, G, B) relative to the level written
    /// (after any range clamp): decoded / source − 1.
    pub power_error: [f64; 3],
    /// The same for the encoder's blocks before the repair.
    pub power_error_unrepaired: [f64; 3],
    /// √mean (ln(1 + x̂) − ln(1 + x))² over the level's texels and channels.
    pub rmsle: f64,
    /// The same for the encoder's blocks before the repair.
    pub rmsle_unrepaired: f64,
    /// Values outside the encoding's range (above it, or negative), clamped to it with their
    /// light moved into their neighbours ([`super::fold`]).
    pub clamped: u64,
    /// The power per channel the clamp changed, relative to the level's: what no neighbour
    /// could take (0 where every value's light was moved).
    pub range_loss: [f64; 3],
}

/// A compressed texture: per level, per face, the encoded bytes; and per level what encoding
/// did.
#[derive(Clone, Debug)]
pub struct Compressed {
    pub encoding: Encoding,
    pub surfaces: Vec<Vec<Vec<u8>>>,
    pub report: Vec<LevelCompression>,
}

/// Texels per block side.
fn block_side(e: Encoding) -> usize {
    match e {
        Encoding::Bc6h | Encoding::UastcHdr4x4 => 4,
        Encoding::AstcHdr6x6 => 6,
        _ => 1,
    }
}

/// Bytes a `w`×`h` surface takes in encoding `e` (`None` for float).
pub fn surface_bytes(e: Encoding, w: usize, h: usize) -> Option<usize> {
    match e {
        Encoding::Float | Encoding::Rgbd | Encoding::Rgbm => None,
        Encoding::Bc6h => Some(w.div_ceil(4) * h.div_ceil(4) * 16),
        Encoding::Rgb9e5 => Some(w * h * 4),
        Encoding::UastcHdr4x4 => Some(w.div_ceil(4) * h.div_ceil(4) * 16),
        Encoding::AstcHdr6x6 => Some(w.div_ceil(6) * h.div_ceil(6) * 16),
    }
}

/// The solid angle of each texel of a `w`×`h` surface (a cube face when `face`), in rows;
/// equal weights when the mapping is not known.
pub fn texel_weights(mapping: Option<Mapping>, face: bool, w: usize, h: usize) -> Vec<f64> {
    let mut out = vec![0.0; w * h];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                *o = match mapping {
                    _ if face => crate::mappings::cube::texel_solid_angle(x, y, w),
                    Some(m) => m.texel_solid_angle(x, y, w, h),
                    None => 1.0,
                };
            }
        });
    out
}

/// The unit direction of each texel's centre of a `w`×`h` map in `mapping`, or of cube face
/// `face` (GL order), in the map's frame; `None` where the mapping is not known.  Texels off
/// the map: 0.
fn texel_directions(
    mapping: Option<Mapping>,
    face: Option<usize>,
    w: usize,
    h: usize,
) -> Option<Vec<[f64; 3]>> {
    if face.is_none() && mapping.is_none() {
        return None;
    }
    let mut out = vec![[0.0; 3]; w * h];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
                *o = match (face, mapping) {
                    (Some(f), _) => crate::mappings::cube::face_st_to_dir(f, uv[0], uv[1]),
                    (None, Some(m)) => m.uv_to_dir(uv).unwrap_or([0.0; 3]),
                    (None, None) => unreachable!(),
                };
            }
        });
    Some(out)
}

/// How far texels `got` move the light of texels `src` (weights `w`, unit directions `d`):
/// the largest change they can make to the SH9 irradiance of any direction, in units of the
/// mean irradiance of a map of power `power` (the largest channel) — [`moment_bound`] of the
/// change in [`light_moments`].  It counts a change of the block's power (about 1.06 times
/// it) and of where in the block its light sits alike.
fn light_cost(src: &Texels, got: &Texels, w: &[f64], d: &[[f64; 3]], power: &[f64; 3]) -> f64 {
    let (a, b) = (light_moments(got, w, d), light_moments(src, w, d));
    (0..3)
        .filter(|&k| power[k] > 0.0)
        .map(|k| {
            let dm: [f64; 10] = std::array::from_fn(|j| a[k][j] - b[k][j]);
            moment_bound(&dm) / (power[k] / 4.0)
        })
        .fold(0.0, f64::max)
}

/// The light moments of texels (weights `w`, unit directions `d`) per channel: Σ L·Ω times
/// 1, the direction's x, y, z and its products xx, xy, xz, yy, yz, zz.  The SH9 irradiance
/// (the clamped cosine's first three bands) of light p at direction d, seen from n, is
/// p·(3/32 + n·d/2 + 15/32 (n·d)²), so that of light with moments M is
/// 3/32 M₀ + ½ n·M₁ + 15/32 nᵀM₂n, and a level whose moments hold holds its SH9 irradiance.
fn light_moments(t: &Texels, w: &[f64], d: &[[f64; 3]]) -> [[f64; 10]; 3] {
    let mut m = [[0.0; 10]; 3];
    for ((p, &wi), di) in t.iter().zip(w).zip(d) {
        if wi <= 0.0 {
            continue;
        }
        let basis = moment_basis(di);
        for k in 0..3 {
            let l = p[k] as f64 * wi;
            for (mj, bj) in m[k].iter_mut().zip(&basis) {
                *mj += l * bj;
            }
        }
    }
    m
}

fn moment_basis(d: &[f64; 3]) -> [f64; 10] {
    let [x, y, z] = *d;
    [1.0, x, y, z, x * x, x * y, x * z, y * y, y * z, z * z]
}

/// The largest SH9 irradiance change over all directions that a change `dm` of one
/// channel's light moments can make, bounded: 3/32 |ΔM₀| + ½ |ΔM₁| + 15/32 ‖ΔM₂‖_F.
fn moment_bound(dm: &[f64; 10]) -> f64 {
    let m1 = (dm[1] * dm[1] + dm[2] * dm[2] + dm[3] * dm[3]).sqrt();
    let m2 = (dm[4] * dm[4]
        + dm[7] * dm[7]
        + dm[9] * dm[9]
        + 2.0 * (dm[5] * dm[5] + dm[6] * dm[6] + dm[8] * dm[8]))
        .sqrt();
    3.0 / 32.0 * dm[0].abs() + 0.5 * m1 + 15.0 / 32.0 * m2
}

// ---------------------------------------------------------------------------------------------
// RGB9E5 (EXT_texture_shared_exponent's encoding, rounding to nearest).

/// Packs an RGB texel (each in [0, 65408]) into RGB9E5.
pub fn rgb9e5_pack(rgb: [f32; 3]) -> u32 {
    const N: i32 = 9;
    const B: i32 = 15;
    let c = rgb.map(|v| {
        if v > 0.0 {
            (v as f64).min(RGB9E5_MAX as f64)
        } else {
            0.0
        }
    });
    let maxc = c[0].max(c[1]).max(c[2]);
    if maxc <= 0.0 {
        return 0;
    }
    let mut e = (maxc.log2().floor() as i32).max(-B - 1) + 1 + B;
    let scale = |e: i32| (2f64).powi(e - B - N);
    let maxs = (maxc / scale(e) + 0.5).floor();
    if maxs >= (1 << N) as f64 {
        e += 1;
    }
    let m = c.map(|v| ((v / scale(e) + 0.5).floor() as u32).min(511));
    m[0] | (m[1] << 9) | (m[2] << 18) | ((e as u32) << 27)
}

/// Unpacks an RGB9E5 texel.
pub fn rgb9e5_unpack(p: u32) -> [f32; 3] {
    let e = (p >> 27) as i32;
    let s = (2f64).powi(e - 15 - 9);
    [p & 511, (p >> 9) & 511, (p >> 18) & 511].map(|m| (m as f64 * s) as f32)
}

// ---------------------------------------------------------------------------------------------
// RGBD and RGBM: HDR packed into 8-bit RGBA.

/// The largest value RGBD holds (D = 1/255).
pub const RGBD_MAX: f32 = 255.0;
/// The range of RGBM: three.js's `RGBMLoader` default (`maxRange = 7`), recorded in the note.
pub const RGBM_RANGE: f32 = 7.0;

/// Packs linear RGB as Babylon.js's `toRGBD` (its `helperFunctions` shader include): D =
/// clamp(floor(max(255 / max(r, g, b), 1)) / 255, 0, 1), rgb = (rgb · D)^(1/2.2), each stored
/// as the nearest of 256 levels.
pub fn rgbd_pack(rgb: [f32; 3]) -> [u8; 4] {
    let m = rgb[0].max(rgb[1]).max(rgb[2]).max(1e-7) as f64;
    let d = ((255.0 / m).max(1.0).floor() / 255.0).clamp(0.0, 1.0);
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0 + 0.5).floor() as u8;
    let c = rgb.map(|v| q((v.max(0.0) as f64 * d).powf(1.0 / 2.2)));
    [c[0], c[1], c[2], q(d)]
}

/// Babylon.js's `fromRGBD`: rgb^2.2 / D.
pub fn rgbd_unpack(p: [u8; 4]) -> [f32; 3] {
    let d = p[3] as f64 / 255.0;
    if d <= 0.0 {
        return [0.0; 3];
    }
    [0, 1, 2].map(|k| ((p[k] as f64 / 255.0).powf(2.2) / d) as f32)
}

/// Packs linear RGB as three.js's RGBM (the inverse of `RGBMLoader`'s r · a · maxRange): M =
/// ceil(clamp(max(r, g, b) / range, 0, 1) · 255) / 255, rgb / (M · range) to the nearest of 256
/// levels.
pub fn rgbm_pack(rgb: [f32; 3], range: f32) -> [u8; 4] {
    let m = rgb[0].max(rgb[1]).max(rgb[2]).max(0.0) as f64;
    let a = ((m / range as f64).clamp(0.0, 1.0) * 255.0).ceil();
    if a <= 0.0 {
        return [0; 4];
    }
    let scale = a / 255.0 * range as f64;
    let c = rgb.map(|v| ((v.max(0.0) as f64 / scale).clamp(0.0, 1.0) * 255.0 + 0.5).floor() as u8);
    [c[0], c[1], c[2], a as u8]
}

/// `RGBMLoader`'s decoding: r · a · range.
pub fn rgbm_unpack(p: [u8; 4], range: f32) -> [f32; 3] {
    let a = p[3] as f64 / 255.0;
    [0, 1, 2].map(|k| (p[k] as f64 / 255.0 * a * range as f64) as f32)
}

/// Packs an image (RGB, grey or with alpha; alpha is dropped) into 8-bit RGBA with `e` (RGBD
/// or RGBM), clamping each texel to the packing's range; returns the bytes and how many
/// values were clamped (negative, or above the range).
pub fn pack_image(img: &Image, e: Encoding) -> (Vec<u8>, u64) {
    let mut clamped = 0;
    let mut out = Vec::with_capacity(img.width * img.height * 4);
    let max = e.range().expect("a packing");
    for p in img.data.chunks_exact(img.channels) {
        let v = rgb_of(p);
        clamped += v.iter().filter(|x| !(**x >= 0.0 && **x <= max)).count() as u64;
        out.extend(match e {
            Encoding::Rgbd => rgbd_pack(v),
            _ => rgbm_pack(v, RGBM_RANGE),
        });
    }
    (out, clamped)
}

/// The note of a packed PNG: `note` (the map's, if any) with the packing, as `encode=rgbd`
/// or `encode=rgbm rgbm_range=7`.
pub fn packing_note(note: Option<&str>, e: Encoding) -> String {
    let mut t = note.map(|n| format!("{n} ")).unwrap_or_default();
    t += &format!("encode={}", e.name());
    if e == Encoding::Rgbm {
        t += &format!(" rgbm_range={RGBM_RANGE}");
    }
    t
}

/// The packing a PNG's note records, with RGBM's range (its default when not recorded).
pub fn packing_of_note(text: &str) -> Option<(Encoding, f32)> {
    let mut e = None;
    let mut range = RGBM_RANGE;
    for kv in text.split_whitespace() {
        match kv.split_once('=') {
            Some(("encode", v)) => {
                e = Encoding::parse_as(v, "encode")
                    .ok()
                    .filter(|e| e.is_packing())
            }
            Some(("rgbm_range", v)) => {
                range = v.parse().ok().filter(|r: &f32| r.is_finite() && *r > 0.0)?
            }
            _ => {}
        }
    }
    e.map(|e| (e, range))
}

/// The power per channel that `folded` (`img` with its negative values folded,
/// [`super::fold::fold_negatives`]) clamped to `e`'s range holds relative to `img`'s (Σ L·Ω
/// with the texel weights `omega`), minus 1.
pub fn range_loss(img: &Image, omega: &[f64], e: Encoding, folded: &Image) -> [f64; 3] {
    let max = e.range().unwrap_or(f32::MAX);
    let (mut before, mut after) = ([0.0f64; 3], [0.0f64; 3]);
    let c = img.channels;
    for ((p, q), w) in img
        .data
        .chunks_exact(c)
        .zip(folded.data.chunks_exact(c))
        .zip(omega)
    {
        let (v, u) = (rgb_of(p), rgb_of(q));
        for k in 0..3 {
            if v[k].is_finite() {
                before[k] += v[k] as f64 * w;
                after[k] += u[k].clamp(0.0, max) as f64 * w;
            }
        }
    }
    std::array::from_fn(|k| {
        if before[k] != 0.0 {
            after[k] / before[k] - 1.0
        } else {
            0.0
        }
    })
}

/// Unpacks 8-bit RGBA (`rgba`'s values 0..1 as read, alpha last) packed with `e` into RGB.
pub fn unpack_image(rgba: &Image, e: Encoding, rgbm_range: f32) -> Image {
    let mut out = Image::new(rgba.width, rgba.height, 3);
    for (o, p) in out
        .data
        .chunks_exact_mut(3)
        .zip(rgba.data.chunks_exact(rgba.channels))
    {
        let q = |v: f32| (v * 255.0).round().clamp(0.0, 255.0) as u8;
        let b = [q(p[0]), q(p[1]), q(p[2]), q(p[3])];
        o.copy_from_slice(&match e {
            Encoding::Rgbd => rgbd_unpack(b),
            _ => rgbm_unpack(b, rgbm_range),
        });
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Block codecs.

/// A block's texels (row by row) as RGB.
type Texels = Vec<[f32; 3]>;

/// A block to encode holding a power: its source texels and their weights, the power it should
/// hold, its best encoding so far, the error (in `aim`'s units) beyond which it must hold its
/// power whatever its texels cost, and where its texels' directions are known, those and the
/// level's power (so that an encoding may be judged by how far it moves the block's light,
/// [`Ask::light_cost`]); where they are not, whether its surface has [`FLAT_MIN_BLOCKS`]
/// blocks or more.
#[cfg_attr(not(feature = "basisu"), allow(dead_code))]
struct Ask<'a> {
    texels: &'a Texels,
    weights: &'a [f64],
    aim: bc6h::Aim,
    current: &'a [u8],
    must: f64,
    dirs: Option<&'a [[f64; 3]]>,
    level: [f64; 3],
    many_blocks: bool,
    /// Whether its face still misses after the carry: a constant block may then move the
    /// light further than [`FLAT_SH_SHARE`] where it moves it less than the block as it is.
    last_resort: bool,
}

impl Ask<'_> {
    /// How far `got` moves the block's light ([`light_cost`]); `None` where the directions
    /// are not known.
    #[cfg_attr(not(feature = "basisu"), allow(dead_code))]
    fn light_cost(&self, got: &Texels) -> Option<f64> {
        self.dirs
            .map(|d| light_cost(self.texels, got, self.weights, d, &self.level))
    }
}

/// Encodes blocks of `side`×`side` texels (each `side²` RGB values, rows first) into `bytes`
/// per block and gives what each decodes to, as the format's readers decode it.
trait Codec: Sync {
    fn side(&self) -> usize;
    fn bytes(&self) -> usize;
    /// The largest value the format holds.
    fn range(&self) -> f32;
    fn encode(&self, blocks: &[Texels]) -> Result<(Vec<u8>, Vec<Texels>)>;
    /// Blocks encoded to hold their asks' power, and their texels decoded, where the codec
    /// has such an encoder.
    fn holding_power(&self, asks: &[Ask]) -> Vec<Option<(Vec<u8>, Texels)>> {
        vec![None; asks.len()]
    }
    /// How many times the encoder's repair rounds run (each re-encodes the blocks that miss).
    fn rounds(&self) -> usize {
        REPAIR_ROUNDS
    }
    /// Whether [`Codec::holding_power`] judges blocks by where they put the light
    /// ([`Ask::light_cost`]), so that asks need the texels' directions.
    fn weighs_light(&self) -> bool {
        false
    }
    /// The share of the encoder's squared log error over a surface that blocks from
    /// [`Codec::holding_power`] may add to it.
    fn log_share(&self) -> f64 {
        OWN_LOG_SHARE
    }
}

struct Bc6h;

impl Codec for Bc6h {
    fn side(&self) -> usize {
        4
    }
    fn bytes(&self) -> usize {
        16
    }
    fn range(&self) -> f32 {
        BC6H_MAX
    }
    fn encode(&self, blocks: &[Texels]) -> Result<(Vec<u8>, Vec<Texels>)> {
        let bytes = bc6h_encode(blocks, &intel_tex_2::bc6h::basic_settings());
        let decoded = bytes.par_chunks(16).map(bc6h_decode_block).collect();
        Ok((bytes, decoded))
    }
    fn holding_power(&self, asks: &[Ask]) -> Vec<Option<(Vec<u8>, Texels)>> {
        asks.par_iter()
            .map(|a| {
                let (block, _) = bc6h::encode_holding_power(a.texels, a.weights, &a.aim);
                let bytes = block.to_bytes()?;
                Some((bytes.to_vec(), bc6h_decode_block(&bytes)))
            })
            .collect()
    }
}

/// Encodes 4×4 blocks with ISPC's BC6H encoder.
fn bc6h_encode(blocks: &[Texels], settings: &intel_tex_2::bc6h::EncodeSettings) -> Vec<u8> {
    // Blocks side by side in a strip 4 texels high, in chunks encoded in parallel.
    const CHUNK: usize = 64;
    blocks
        .par_chunks(CHUNK)
        .flat_map_iter(|chunk| {
            let n = chunk.len();
            let stride = 4 * n * 8;
            let mut data = vec![0u8; stride * 4];
            for (b, t) in chunk.iter().enumerate() {
                for (i, p) in t.iter().enumerate() {
                    let (x, y) = (4 * b + i % 4, i / 4);
                    let at = y * stride + x * 8;
                    for (k, v) in [p[0], p[1], p[2], 1.0].into_iter().enumerate() {
                        data[at + 2 * k..at + 2 * k + 2]
                            .copy_from_slice(&exr::prelude::f16::from_f32(v).to_le_bytes());
                    }
                }
            }
            let surface = intel_tex_2::RgbaSurface {
                data: &data,
                width: 4 * n as u32,
                height: 4,
                stride: stride as u32,
            };
            intel_tex_2::bc6h::compress_blocks(settings, &surface)
        })
        .collect()
}

/// Decodes one BC6H (unsigned) block into its 16 texels, rows first.
pub fn bc6h_decode_block(block: &[u8]) -> Vec<[f32; 3]> {
    let mut half = [0u16; 48];
    bcdec_rs::bc6h_half(block, &mut half, 12, false);
    half.chunks_exact(3)
        .map(|p| [0, 1, 2].map(|k| exr::prelude::f16::from_bits(p[k]).to_f32()))
        .collect()
}

/// The codec of a block encoding (BC6H, or Basis Universal's UASTC HDR 4x4 and ASTC HDR 6x6
/// where the build has its encoder).
fn codec(what: &str, e: Encoding) -> Result<Box<dyn Codec>> {
    if e.is_basis() {
        basis::codec(what, e)
    } else {
        Ok(Box::new(Bc6h))
    }
}

// ---------------------------------------------------------------------------------------------
// Surfaces.

/// One face of one level as RGB texels, clamped to the encoding's range.
struct Surface {
    w: usize,
    h: usize,
    rgb: Vec<[f32; 3]>,
    omega: Vec<f64>,
    /// Texel directions, where the mapping is known and the codec weighs where blocks put
    /// the light ([`texel_directions`], [`Codec::weighs_light`]).
    dirs: Option<Vec<[f64; 3]>>,
}

/// Per channel power sums, f64.
fn power(rgb: &[[f32; 3]], omega: &[f64]) -> [f64; 3] {
    let mut p = [0.0; 3];
    for (t, w) in rgb.iter().zip(omega) {
        for k in 0..3 {
            p[k] += t[k] as f64 * w;
        }
    }
    p
}

/// Per-channel sums.
fn sum3(v: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    v.fold([0.0; 3], |mut a, p| {
        for k in 0..3 {
            a[k] += p[k];
        }
        a
    })
}

/// The error of `got` against `want`, per channel relative to the larger of `want` and the
/// level's mean block power `mean` (so a block dimmer than the mean may miss by a smaller part
/// of the level's power, never a larger one); the largest over the channels.
fn block_error(got: &[f64; 3], want: &[f64; 3], mean: &[f64; 3]) -> f64 {
    (0..3)
        .filter(|&k| mean[k] > 0.0)
        .map(|k| (got[k] - want[k]).abs() / want[k].max(mean[k]))
        .fold(0.0, f64::max)
}

/// The blocks of a surface (edge texels repeated past its right and bottom edges), with their
/// texels' weights (0 for the repeated ones) and directions (where the surface has them).
struct Blocks {
    texels: Vec<Texels>,
    weights: Vec<Vec<f64>>,
    dirs: Option<Vec<Vec<[f64; 3]>>>,
}

fn blocks_of(s: &Surface, side: usize) -> Blocks {
    let (bx, by) = (s.w.div_ceil(side), s.h.div_ceil(side));
    let mut out = Blocks {
        texels: Vec::with_capacity(bx * by),
        weights: Vec::with_capacity(bx * by),
        dirs: s.dirs.as_ref().map(|_| Vec::with_capacity(bx * by)),
    };
    for j in 0..by {
        for i in 0..bx {
            let mut t = Vec::with_capacity(side * side);
            let mut w = Vec::with_capacity(side * side);
            let mut d = Vec::with_capacity(side * side);
            for y in 0..side {
                for x in 0..side {
                    let (px, py) = (i * side + x, j * side + y);
                    let inside = px < s.w && py < s.h;
                    let at = py.min(s.h - 1) * s.w + px.min(s.w - 1);
                    t.push(s.rgb[at]);
                    w.push(if inside { s.omega[at] } else { 0.0 });
                    if let Some(sd) = &s.dirs {
                        d.push(sd[at]);
                    }
                }
            }
            out.texels.push(t);
            out.weights.push(w);
            if let Some(od) = &mut out.dirs {
                od.push(d);
            }
        }
    }
    out
}

/// What encoding one surface gave.
struct SurfaceOut {
    bytes: Vec<u8>,
    blocks: usize,
    repaired: usize,
    source: [f64; 3],
    unrepaired: [f64; 3],
    decoded: [f64; 3],
    log_sq: f64,
    log_sq_unrepaired: f64,
    values: usize,
}

/// A block encoded by the codec's own encoder: its bytes, texels and power, the squared log
/// error it adds and the miss it removes.
struct OwnTry {
    b: usize,
    bytes: Vec<u8>,
    dec: Texels,
    p: [f64; 3],
    cost: f64,
    gained: f64,
}

/// The blocks of one surface while they are repaired.
struct Repair<'a> {
    c: &'a dyn Codec,
    range: f32,
    /// The level's mean power per block, per channel.
    mean: [f64; 3],
    /// Source texels and their weights, per block.
    blocks: Vec<Texels>,
    weights: Vec<Vec<f64>>,
    /// The blocks' texel directions, where the mapping is known.
    dirs: Option<Vec<Vec<[f64; 3]>>>,
    /// The level's power, per channel (all faces).
    level: [f64; 3],
    /// Whether the face still missed after its carry ([`Ask::last_resort`]).
    last_resort: bool,
    /// The surface's power, per channel.
    source: [f64; 3],
    /// The power each block should hold (its source's, plus what leaky neighbours carried
    /// over).
    target: Vec<[f64; 3]>,
    /// The best block so far: bytes, decoded texels, power, input.
    bytes: Vec<u8>,
    decoded: Vec<Texels>,
    got: Vec<[f64; 3]>,
    best_in: Vec<Texels>,
    /// The last block-gain try: input and power.
    trial_in: Vec<Texels>,
    trial_got: Vec<[f64; 3]>,
    repaired: Vec<bool>,
}

impl Repair<'_> {
    fn error(&self, b: usize, p: &[f64; 3]) -> f64 {
        block_error(p, &self.target[b], &self.mean)
    }

    /// Whether power `p` is closer to block `b`'s target than its best so far: a smaller
    /// largest error, and no channel worse than before (or than the tolerance).
    fn better(&self, b: usize, p: &[f64; 3]) -> bool {
        let (t, old, m) = (&self.target[b], &self.got[b], &self.mean);
        let err = |q: &[f64; 3], k: usize| {
            if m[k] > 0.0 {
                (q[k] - t[k]).abs() / t[k].max(m[k])
            } else {
                0.0
            }
        };
        self.error(b, p) < self.error(b, old)
            && (0..3).all(|k| err(p, k) <= err(old, k).max(BLOCK_TOLERANCE))
    }

    /// Whether block `b`'s miss alone breaks the surface's tolerance.
    fn alone(&self, b: usize) -> bool {
        let n = self.blocks.len() as f64;
        (0..3).any(|k| {
            (self.got[b][k] - self.target[b][k]).abs()
                > SURFACE_TOLERANCE * self.source[k].max(self.mean[k] * n)
        })
    }

    fn scaled(&self, t: &Texels, f: &dyn Fn(usize, usize) -> f64) -> Texels {
        t.iter()
            .enumerate()
            .map(|(i, p)| std::array::from_fn(|k| ((p[k] as f64 * f(i, k)) as f32).min(self.range)))
            .collect()
    }

    /// Encodes the blocks that miss their target again, up to [`REPAIR_ROUNDS`] times.
    fn rounds(&mut self) -> Result<()> {
        let nb = self.c.bytes();
        // A block that a round did not bring closer is not encoded again (the next round's
        // tries would start from nearly the same texels), unless its miss alone breaks the
        // surface's tolerance: such a block (a sun's) would otherwise fall to the one-region
        // encoder, which holds its power at a larger log error.
        let mut stalled = vec![false; self.blocks.len()];
        for _ in 0..self.c.rounds() {
            let bad: Vec<usize> = (0..self.blocks.len())
                .filter(|&b| !stalled[b] && self.error(b, &self.got[b]) > BLOCK_TOLERANCE)
                .collect();
            if bad.is_empty() {
                break;
            }
            // Two tries per block: (1) the last try's texels scaled per channel by the power
            // ratio; (2) the best block's texels each scaled by source / decoded (an encoder
            // that bleeds one texel's colour into its neighbours is fed the opposite), then
            // by the power ratio of the best block.
            let mut inputs: Vec<Texels> = Vec::with_capacity(2 * bad.len());
            for &b in &bad {
                let gain = |got: &[f64; 3], k: usize| {
                    let want = self.target[b][k];
                    if want <= 1e-6 * self.mean[k] {
                        1.0
                    } else if got[k] <= 0.0 {
                        2.0
                    } else {
                        (want / got[k]).clamp(0.5, 2.0)
                    }
                };
                inputs.push(self.scaled(&self.trial_in[b], &|_, k| gain(&self.trial_got[b], k)));
                inputs.push(self.scaled(&self.best_in[b], &|i, k| {
                    let (src, dec) = (self.blocks[b][i][k] as f64, self.decoded[b][i][k] as f64);
                    let t = if dec > 0.0 && src > 0.0 {
                        (src / dec).clamp(0.25, 4.0)
                    } else {
                        1.0
                    };
                    t * gain(&self.got[b], k)
                }));
            }
            let (enc, dec) = self.c.encode(&inputs)?;
            for (i, &b) in bad.iter().enumerate() {
                let mut closer = false;
                self.trial_got[b] = power(&dec[2 * i], &self.weights[b]);
                self.trial_in[b] = inputs[2 * i].clone();
                for j in [2 * i, 2 * i + 1] {
                    let p = power(&dec[j], &self.weights[b]);
                    if self.better(b, &p) {
                        closer = true;
                        self.got[b] = p;
                        self.decoded[b] = dec[j].clone();
                        self.best_in[b] = inputs[j].clone();
                        self.bytes[b * nb..(b + 1) * nb]
                            .copy_from_slice(&enc[j * nb..(j + 1) * nb]);
                        self.repaired[b] = true;
                    }
                }
                stalled[b] = !closer && !self.alone(b);
            }
        }
        Ok(())
    }

    /// Per channel, the surface's power missed (decoded − target) relative to the larger of
    /// its target and its share of the level's (`mean` per block).
    fn surface_miss(&self) -> f64 {
        let n = self.blocks.len() as f64;
        (0..3)
            .filter(|&k| self.mean[k] > 0.0)
            .map(|k| {
                let (got, want): (f64, f64) = (self.got.iter().map(|p| p[k]).sum(), self.source[k]);
                (got - want).abs() / want.max(self.mean[k] * n)
            })
            .fold(0.0, f64::max)
    }

    /// Σ (ln(1 + decoded) − ln(1 + source))² over block `b`'s texels inside the surface.
    fn log_sq(&self, b: usize, decoded: &Texels) -> f64 {
        decoded
            .iter()
            .zip(&self.blocks[b])
            .zip(&self.weights[b])
            .filter(|(_, &w)| w > 0.0)
            .map(|((d, s), _)| {
                (0..3)
                    .map(|k| ((d[k] as f64).ln_1p() - (s[k] as f64).ln_1p()).powi(2))
                    .sum::<f64>()
            })
            .sum()
    }

    /// Blocks that still miss after their rounds encoded by the codec's own encoder that aims
    /// at the power (where it has one: BC6H's one-region modes, which hold a block's power
    /// more closely than a general encoder, its texels often less so), the largest misses
    /// first, until the surface holds its power within [`SURFACE_TOLERANCE`]; a block whose
    /// log error grows is taken only while `budget` (of Σ squared log error) lasts.
    fn own(&mut self, budget: &mut f64) {
        let nb = self.c.bytes();
        let mut bad: Vec<usize> = (0..self.blocks.len())
            .filter(|&b| self.error(b, &self.got[b]) > BLOCK_TOLERANCE)
            .collect();
        let miss = |s: &Self, b: usize| -> f64 {
            (0..3)
                .filter(|&k| s.mean[k] > 0.0)
                .map(|k| (s.got[b][k] - s.target[b][k]).abs() / s.mean[k])
                .fold(0.0, f64::max)
        };
        bad.sort_by(|&a, &b| miss(self, b).total_cmp(&miss(self, a)).then(a.cmp(&b)));
        let n = self.blocks.len() as f64;
        let mut at = 0;
        let mut chunk = 16;
        while at < bad.len() && self.surface_miss() > SURFACE_TOLERANCE {
            let these = &bad[at..(at + chunk).min(bad.len())];
            let asks: Vec<Ask> = these
                .iter()
                .map(|&b| {
                    let scale = std::array::from_fn(|k| {
                        if self.mean[k] > 0.0 {
                            self.target[b][k].max(self.mean[k])
                        } else {
                            0.0
                        }
                    });
                    // The miss (relative to `scale`) at which the block alone breaks the
                    // surface's tolerance.
                    let must = (0..3)
                        .filter(|&k| scale[k] > 0.0)
                        .map(|k| {
                            SURFACE_TOLERANCE * self.source[k].max(self.mean[k] * n) / scale[k]
                        })
                        .fold(f64::INFINITY, f64::min);
                    Ask {
                        texels: &self.blocks[b],
                        weights: &self.weights[b],
                        aim: bc6h::Aim {
                            target: self.target[b],
                            scale,
                            tolerance: BLOCK_TOLERANCE,
                        },
                        current: &self.bytes[b * nb..(b + 1) * nb],
                        must,
                        dirs: self.dirs.as_ref().map(|d| d[b].as_slice()),
                        level: self.level,
                        many_blocks: self.blocks.len() >= FLAT_MIN_BLOCKS,
                        last_resort: self.last_resort,
                    }
                })
                .collect();
            let held = self.c.holding_power(&asks);
            let mut tries: Vec<OwnTry> = these
                .par_iter()
                .zip(held)
                .filter_map(|(&b, held)| {
                    let (bytes, dec) = held?;
                    let p = power(&dec, &self.weights[b]);
                    // Kept when its largest channel error is smaller (the one-region block may trade
                    // a channel's hundredth of a percent for another's percents).
                    if self.error(b, &p) >= self.error(b, &self.got[b]) {
                        return None;
                    }
                    let cost = self.log_sq(b, &dec) - self.log_sq(b, &self.decoded[b]);
                    let gained = miss(self, b)
                        - (0..3)
                            .filter(|&k| self.mean[k] > 0.0)
                            .map(|k| (p[k] - self.target[b][k]).abs() / self.mean[k])
                            .fold(0.0, f64::max);
                    Some(OwnTry {
                        b,
                        bytes,
                        dec,
                        p,
                        cost,
                        gained,
                    })
                })
                .collect();
            // The most power held per log error added first.
            let rate = |t: &OwnTry| t.gained / t.cost.max(1e-12);
            tries.sort_by(|x, y| rate(y).total_cmp(&rate(x)).then(x.b.cmp(&y.b)));
            let mut taken = 0;
            for OwnTry {
                b,
                bytes,
                dec,
                p,
                cost,
                ..
            } in tries
            {
                // A block whose miss alone breaks the surface's tolerance is taken whatever
                // its log error; the others while the budget lasts.
                if cost > 0.0 && !self.alone(b) {
                    if cost > *budget {
                        continue;
                    }
                    *budget -= cost;
                }
                taken += 1;
                self.got[b] = p;
                self.decoded[b] = dec;
                self.bytes[b * nb..(b + 1) * nb].copy_from_slice(&bytes);
                self.repaired[b] = true;
            }
            at += these.len();
            chunk *= 2;
            // Once nothing more is taken, the rest (smaller misses) are not tried.
            if taken == 0 {
                break;
            }
        }
    }

    /// What blocks still miss after their rounds is carried to their neighbours (within
    /// `reach` blocks), shared in proportion to the neighbours' power in that channel and at
    /// most [`CARRY_SHARE`] of it; returns whether anything was carried.
    fn carry(&mut self, bx: usize, reach: usize) -> bool {
        let n = self.blocks.len();
        let by = n / bx;
        let mut carried = false;
        let mut order: Vec<usize> = (0..n)
            .filter(|&b| self.error(b, &self.got[b]) > BLOCK_TOLERANCE)
            .collect();
        order.sort_by(|&a, &b| {
            let d = |b: usize| {
                (0..3)
                    .map(|k| (self.target[b][k] - self.got[b][k]).abs())
                    .sum::<f64>()
            };
            d(b).total_cmp(&d(a)).then(a.cmp(&b))
        });
        for b in order {
            let (i, j) = (b % bx, b / bx);
            let near: Vec<usize> = (j.saturating_sub(reach)..(j + reach + 1).min(by))
                .flat_map(|y| {
                    (i.saturating_sub(reach)..(i + reach + 1).min(bx)).map(move |x| y * bx + x)
                })
                .filter(|&o| o != b)
                .collect();
            for k in 0..3 {
                let miss = self.target[b][k] - self.got[b][k];
                if miss.abs() <= BLOCK_TOLERANCE * self.target[b][k].max(self.mean[k]) {
                    continue;
                }
                let room: f64 = near.iter().map(|&o| self.target[o][k].max(0.0)).sum();
                if room <= 0.0 {
                    continue;
                }
                // What the neighbours can take; the block keeps the rest.
                let moved = miss.clamp(-CARRY_SHARE * room, CARRY_SHARE * room);
                for &o in &near {
                    self.target[o][k] += moved * self.target[o][k].max(0.0) / room;
                }
                self.target[b][k] -= moved;
                carried = true;
            }
        }
        carried
    }
}

/// How closely a surface (a face of a level) holds its power, per channel, relative to the
/// larger of its own and its share of the level's, before blocks are given up to BC6H's
/// one-region encoder or their misses are carried to their neighbours.
pub const SURFACE_TOLERANCE: f64 = 2.5e-3;
/// The power every compressed level keeps, relative to the uncompressed level's: a level the
/// repair leaves further off is written with a warning that states its error.
pub const LEVEL_GOAL: f64 = 5e-3;

/// A level whose power holds within [`SURFACE_TOLERANCE`] after the encoder's rounds is left
/// so where no face of it misses by more than this (relative as for [`SURFACE_TOLERANCE`]).
pub const FACE_TOLERANCE: f64 = 2e-2;

/// The share of the encoder's own squared log error (over a surface) that blocks given to
/// BC6H's one-region encoder may add to it: 0.1, i.e. the RMSLE within 5 % of the encoder's.
pub const OWN_LOG_SHARE: f64 = 0.1;

/// As [`OWN_LOG_SHARE`] for UASTC HDR 4x4 and ASTC HDR 6x6, whose blocks hold their power by
/// nudging the encoder's own: 1, i.e. the RMSLE within 1.41× the encoder's (the share that
/// holds every level of the bundled HDRIs' 256² chains within 0.5 %; 0.1 leaves four of them
/// up to 0.95 % off).
pub const ASTC_LOG_SHARE: f64 = 1.0;

/// A block that nothing else holds becomes one constant colour (ASTC's void-extent block,
/// which holds its power to half-float precision) where that moves its light
/// ([`light_cost`]) by at most this, in units of the level's mean SH9 irradiance: a constant
/// block over a small bright source moves the source across the block, on a small face a
/// large part of the sphere.  Where its face still misses its power after the carry, also
/// where it moves the light less than the block as it is (a block that misses its power
/// moves the light too).
pub const FLAT_SH_SHARE: f64 = 1e-3;

/// Where the texels' directions are not known (a 2D texture whose mapping is not recorded),
/// a block may become one constant colour where its surface has this many blocks or more.
pub const FLAT_MIN_BLOCKS: usize = 16;

/// The most a block's target power changes by what leaky neighbours carry over (relative).
pub const CARRY_SHARE: f64 = 0.25;

/// RGB9E5: each texel packed to the nearest representable value (nothing to repair: no texel
/// can hold its light more closely).
fn encode_rgb9e5(s: &Surface) -> SurfaceOut {
    // Per row: the bytes, the source's and the decoded power, the squared log error.
    type Row = (Vec<u8>, [f64; 3], [f64; 3], f64);
    let rows: Vec<Row> = s
        .rgb
        .par_chunks(s.w)
        .zip(s.omega.par_chunks(s.w))
        .map(|(row, om)| {
            let mut bytes = Vec::with_capacity(4 * row.len());
            let (mut src, mut dec, mut sq) = ([0.0; 3], [0.0; 3], 0.0);
            for (t, w) in row.iter().zip(om) {
                let p = rgb9e5_pack(*t);
                bytes.extend(p.to_le_bytes());
                let d = rgb9e5_unpack(p);
                for k in 0..3 {
                    src[k] += t[k] as f64 * w;
                    dec[k] += d[k] as f64 * w;
                    let e = (d[k] as f64).ln_1p() - (t[k] as f64).ln_1p();
                    sq += e * e;
                }
            }
            (bytes, src, dec, sq)
        })
        .collect();
    let mut out = SurfaceOut {
        bytes: Vec::with_capacity(4 * s.rgb.len()),
        blocks: s.rgb.len(),
        repaired: 0,
        source: [0.0; 3],
        unrepaired: [0.0; 3],
        decoded: [0.0; 3],
        log_sq: 0.0,
        log_sq_unrepaired: 0.0,
        values: 3 * s.rgb.len(),
    };
    for (bytes, src, dec, sq) in rows {
        out.bytes.extend(bytes);
        for k in 0..3 {
            out.source[k] += src[k];
            out.decoded[k] += dec[k];
        }
        out.log_sq += sq;
    }
    out.unrepaired = out.decoded;
    out.log_sq_unrepaired = out.log_sq;
    out
}

/// Σ (ln(1 + x̂) − ln(1 + x))² over a `w`×`h` surface's texels and channels (its blocks of
/// `side`, `bx` to a row), and their count.
fn log_error(
    (w, h, side, bx): (usize, usize, usize, usize),
    blocks: &[Texels],
    decoded: &[Texels],
) -> (f64, usize) {
    let (mut sq, mut n) = (0.0, 0usize);
    for (b, t) in decoded.iter().enumerate() {
        for (i, p) in t.iter().enumerate() {
            let (x, y) = ((b % bx) * side + i % side, (b / bx) * side + i / side);
            if x < w && y < h {
                for k in 0..3 {
                    let d = (p[k] as f64).ln_1p() - (blocks[b][i][k] as f64).ln_1p();
                    sq += d * d;
                    n += 1;
                }
            }
        }
    }
    (sq, n)
}

/// A surface encoded, its blocks repaired by the encoder's rounds.
struct Started<'a> {
    r: Repair<'a>,
    shape: (usize, usize, usize, usize),
    unrepaired: [f64; 3],
    log_sq_unrepaired: f64,
    /// What blocks from [`Codec::holding_power`] may still add to the surface's squared log
    /// error.
    budget: f64,
}

fn start_surface<'a>(
    c: &'a dyn Codec,
    s: &Surface,
    mean: [f64; 3],
    level: [f64; 3],
) -> Result<Started<'a>> {
    let side = c.side();
    let Blocks {
        texels: blocks,
        weights,
        dirs,
    } = blocks_of(s, side);
    let n = blocks.len();
    let (bytes, decoded) = c.encode(&blocks)?;
    let want: Vec<[f64; 3]> = blocks
        .iter()
        .zip(&weights)
        .map(|(t, w)| power(t, w))
        .collect();
    let mut r = Repair {
        c,
        range: c.range(),
        mean,
        source: sum3(want.iter().copied()),
        target: want,
        bytes,
        decoded,
        got: Vec::new(),
        best_in: blocks.clone(),
        trial_in: blocks.clone(),
        trial_got: Vec::new(),
        repaired: vec![false; n],
        blocks,
        weights,
        dirs,
        level,
        last_resort: false,
    };
    r.got = r
        .decoded
        .iter()
        .zip(&r.weights)
        .map(|(t, w)| power(t, w))
        .collect();
    r.trial_got = r.got.clone();
    let unrepaired = sum3(r.got.iter().copied());
    let shape = (s.w, s.h, side, s.w.div_ceil(side));
    let log_sq_unrepaired = log_error(shape, &r.blocks, &r.decoded).0;
    // Repair each block by the encoder.
    r.rounds()?;
    Ok(Started {
        budget: c.log_share() * log_sq_unrepaired,
        r,
        shape,
        unrepaired,
        log_sq_unrepaired,
    })
}

/// The rest of a surface's repair where `more` (its level misses): blocks given to the
/// one-region encoder, misses carried to neighbours, near first, while the surface misses.
fn finish_surface(st: &mut Started, more: bool) -> Result<()> {
    let Started {
        r, shape, budget, ..
    } = st;
    if more {
        r.own(budget);
        for reach in [1, 2, 4] {
            if r.surface_miss() <= SURFACE_TOLERANCE || !r.carry(shape.3, reach) {
                break;
            }
            r.rounds()?;
            r.own(budget);
        }
        if r.surface_miss() > SURFACE_TOLERANCE {
            r.last_resort = true;
            r.own(budget);
        }
    }
    Ok(())
}

/// What a surface's encoding gave.
fn surface_out(st: Started) -> SurfaceOut {
    let Started {
        r,
        shape,
        unrepaired,
        log_sq_unrepaired,
        ..
    } = st;
    let (log_sq, values) = log_error(shape, &r.blocks, &r.decoded);
    SurfaceOut {
        blocks: r.blocks.len(),
        repaired: r.repaired.iter().filter(|&&x| x).count(),
        source: r.source,
        unrepaired,
        decoded: sum3(r.got.iter().copied()),
        log_sq,
        log_sq_unrepaired,
        values,
        bytes: r.bytes,
    }
}

/// RGB of a pixel of 1–4 channels.
fn rgb_of(p: &[f32]) -> [f32; 3] {
    match p.len() {
        1 | 2 => [p[0]; 3],
        _ => [p[0], p[1], p[2]],
    }
}

/// Encodes a texture's levels (level 0 first; a cube's as its face stacks) in `e` (not
/// `Float`), keeping the light; `mapping` is the 2D map's mapping (for its texel solid angles;
/// `None`: equal weights).  `what` names the output in messages and warnings.
pub fn compress(
    what: &str,
    levels: &[Image],
    cube: bool,
    e: Encoding,
    mapping: Option<Mapping>,
) -> Result<Compressed> {
    let range = e.range().expect("a compressed encoding");
    let c = match e {
        Encoding::Rgb9e5 => None,
        _ => Some(codec(what, e)?),
    };
    let nf = if cube { 6 } else { 1 };
    let mut surfaces = Vec::with_capacity(levels.len());
    let mut report = Vec::with_capacity(levels.len());
    let mut alpha_dropped = false;
    for (li, level) in levels.iter().enumerate() {
        let (w, h) = (level.width, level.height / nf);
        let omega = texel_weights(if cube { None } else { mapping }, cube, w, h);
        // Texel directions, for a codec that judges blocks by where they put the light.
        let weighs = c.as_ref().is_some_and(|c| c.weighs_light());
        let dirs = |f: usize| {
            weighs
                .then(|| {
                    texel_directions(if cube { None } else { mapping }, cube.then_some(f), w, h)
                })
                .flatten()
        };
        let ch = level.channels;
        // The faces as RGB, folded into the range; what the fold could not keep.
        let mut faces = Vec::with_capacity(nf);
        let mut clamped = 0u64;
        let (mut before, mut after) = ([0.0f64; 3], [0.0f64; 3]);
        for f in 0..nf {
            let px = &level.data[f * w * h * ch..(f + 1) * w * h * ch];
            let mut rgb = Vec::with_capacity(w * h);
            for (i, p) in px.chunks_exact(ch).enumerate() {
                if p.iter().any(|v| !v.is_finite()) {
                    return Err(Error::param(
                        what,
                        format!(
                            "level {li} holds NaN or Inf (at texel {} of face {f}); {} \
                             cannot encode them",
                            i,
                            e.name()
                        ),
                    ));
                }
                if (ch == 2 || ch == 4) && p[ch - 1] != 1.0 {
                    alpha_dropped = true;
                }
                let v = rgb_of(p);
                for k in 0..3 {
                    before[k] += v[k] as f64 * omega[i];
                }
                rgb.push(v);
            }
            // Values outside the range: their light moved into their neighbours.
            clamped += fold_into_range(&mut rgb, &omega, w, h, range).values;
            for (t, om) in rgb.iter().zip(&omega) {
                for k in 0..3 {
                    after[k] += t[k] as f64 * om;
                }
            }
            faces.push(Surface {
                w,
                h,
                rgb,
                omega: omega.clone(),
                dirs: dirs(f),
            });
        }
        let rel = |a: f64, b: f64| if b != 0.0 { a / b - 1.0 } else { 0.0 };
        let range_loss: [f64; 3] = std::array::from_fn(|k| rel(after[k], before[k]));
        if clamped > 0 {
            crate::base::error::warn(&format!(
                "{what}: level {li}: {clamped} value{} outside {}'s range [0, {range}] \
                 clamped to it, their light moved into their neighbours; the level's power \
                 changes by {:+.4} % (R), {:+.4} % (G), {:+.4} % (B)",
                if clamped == 1 { "" } else { "s" },
                e.name(),
                100.0 * range_loss[0],
                100.0 * range_loss[1],
                100.0 * range_loss[2]
            ));
        }
        let nblocks = (w.div_ceil(block_side(e)) * h.div_ceil(block_side(e)) * nf) as f64;
        let mean = after.map(|p| p / nblocks);
        let outs: Vec<SurfaceOut> = if let Some(c) = &c {
            // Every face encoded and its blocks repaired by the encoder; where the level then
            // holds its power within SURFACE_TOLERANCE and no face misses by more than
            // FACE_TOLERANCE, it stays so (the encoder's texels are closer); otherwise every
            // face goes on to the one-region encoder and the carry.
            let started = faces
                .iter()
                .map(|s| start_surface(c.as_ref(), s, mean, after))
                .collect::<Result<Vec<Started>>>()?;
            let level_miss = (0..3)
                .filter(|&k| after[k] > 0.0)
                .map(|k| {
                    let got: f64 = started
                        .iter()
                        .flat_map(|st| st.r.got.iter().map(|p| p[k]))
                        .sum();
                    (got / after[k] - 1.0).abs()
                })
                .fold(0.0, f64::max);
            let more = level_miss > SURFACE_TOLERANCE
                || started
                    .iter()
                    .any(|st| st.r.surface_miss() > FACE_TOLERANCE);
            let mut started = started;
            for st in started.iter_mut() {
                finish_surface(st, more)?;
            }
            started.into_iter().map(surface_out).collect()
        } else {
            faces.iter().map(encode_rgb9e5).collect()
        };
        let total = |f: fn(&SurfaceOut) -> [f64; 3]| sum3(outs.iter().map(f));
        let (src, unrep, dec) = (
            total(|o| o.source),
            total(|o| o.unrepaired),
            total(|o| o.decoded),
        );
        let values: usize = outs.iter().map(|o| o.values).sum();
        let miss: [f64; 3] = std::array::from_fn(|k| rel(dec[k], src[k]));
        if miss.iter().any(|m| m.abs() > LEVEL_GOAL) {
            crate::base::error::warn(&format!(
                "{what}: level {li}: {} keeps this level's power only to {:+.2} % (R), \
                 {:+.2} % (G), {:+.2} % (B), beyond ±{} %: a block holds a source too small \
                 and bright for the format's endpoints{}",
                e.name(),
                100.0 * miss[0],
                100.0 * miss[1],
                100.0 * miss[2],
                100.0 * LEVEL_GOAL,
                if e == Encoding::AstcHdr6x6 {
                    "; uastc-hdr-4x4 or bc6h keep it"
                } else {
                    ""
                }
            ));
        }
        report.push(LevelCompression {
            blocks: outs.iter().map(|o| o.blocks).sum(),
            repaired: outs.iter().map(|o| o.repaired).sum(),
            power_error: std::array::from_fn(|k| rel(dec[k], src[k])),
            power_error_unrepaired: std::array::from_fn(|k| rel(unrep[k], src[k])),
            rmsle: (outs.iter().map(|o| o.log_sq).sum::<f64>() / values.max(1) as f64).sqrt(),
            rmsle_unrepaired: (outs.iter().map(|o| o.log_sq_unrepaired).sum::<f64>()
                / values.max(1) as f64)
                .sqrt(),
            clamped,
            range_loss,
        });
        surfaces.push(outs.into_iter().map(|o| o.bytes).collect());
    }
    if alpha_dropped {
        crate::base::error::warn(&format!(
            "{what}: {} holds no alpha; the alpha channel is dropped",
            e.name()
        ));
    }
    Ok(Compressed {
        encoding: e,
        surfaces,
        report,
    })
}

/// Decodes a `w`×`h` surface of BC6H or RGB9E5 (3 channels, RGB).
pub fn decode_surface(e: Encoding, bytes: &[u8], w: usize, h: usize) -> Image {
    let (side, nb) = match e {
        Encoding::Rgb9e5 => (1, 4),
        _ => (4, 16),
    };
    let decode = |b: &[u8]| -> Texels {
        match e {
            Encoding::Rgb9e5 => vec![rgb9e5_unpack(u32::from_le_bytes(
                b[..4].try_into().expect("4 bytes"),
            ))],
            _ => bc6h_decode_block(b),
        }
    };
    let (bx, by) = (w.div_ceil(side), h.div_ceil(side));
    let mut img = Image::new(w, h, 3);
    let rows: Vec<Vec<Texels>> = (0..by)
        .into_par_iter()
        .map(|j| {
            (0..bx)
                .map(|i| decode(&bytes[(j * bx + i) * nb..(j * bx + i + 1) * nb]))
                .collect()
        })
        .collect();
    for (j, row) in rows.iter().enumerate() {
        for (i, t) in row.iter().enumerate() {
            for (k, p) in t.iter().enumerate() {
                let (x, y) = (i * side + k % side, j * side + k / side);
                if x < w && y < h {
                    img.pixel_mut(x, y).copy_from_slice(p);
                }
            }
        }
    }
    img
}

/// UASTC HDR 4x4 and ASTC HDR 6x6: encoded by Basis Universal's encoder (feature `basisu`),
/// read by the pure-Rust Basis Universal transcoder.
pub mod basis {
    use super::Encoding;
    #[cfg(feature = "basisu")]
    use super::Texels;
    use crate::base::error::{Error, Result};
    use crate::images::Image;

    /// KTX2's `vkFormat` of each: `VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK`, `..._6x6_...`.
    pub fn vk_format(e: Encoding) -> u32 {
        match e {
            Encoding::UastcHdr4x4 => 1_000_066_000,
            _ => 1_000_066_004,
        }
    }

    /// The data format descriptor Basis Universal writes for each (its total size first):
    /// UASTC HDR 4x4 (model 167, one unsigned float sample) and ASTC 6x6 (model 162, one
    /// signed float sample), BT.709, linear, 16 bytes per block.
    pub fn dfd(e: Encoding) -> Vec<u8> {
        let (model, dim, channel, lower) = match e {
            Encoding::UastcHdr4x4 => (167u8, 3u8, 0x80u8, 0u32),
            _ => (162, 5, 0xC0, 0xBF80_0000),
        };
        let mut d = Vec::with_capacity(44);
        d.extend(44u32.to_le_bytes());
        d.extend(0u32.to_le_bytes());
        d.extend(2u16.to_le_bytes());
        d.extend(40u16.to_le_bytes());
        d.extend([model, 1, 1, 0, dim, dim, 0, 0, 16, 0, 0, 0, 0, 0, 0, 0]);
        d.extend(0u16.to_le_bytes());
        d.extend([127, channel, 0, 0, 0, 0]);
        d.extend(lower.to_le_bytes());
        d.extend(0x3F80_0000u32.to_le_bytes());
        d
    }

    /// Decodes every level of a UASTC HDR / ASTC HDR KTX2 file (its faces stacked) to RGB.
    pub fn decode_ktx2(path: &std::path::Path, bytes: &[u8]) -> Result<Vec<Image>> {
        let bad = |m: String| Error::data(path, format!("cannot decode KTX2: {m}"));
        let t = basisu::Transcoder::new(bytes).map_err(|e| bad(format!("{e:?}")))?;
        let faces = t.face_count().max(1);
        let (w0, h0) = t.base_dimensions();
        let mut levels = Vec::new();
        for level in 0..t.level_count() {
            let (w, h) = (
                ((w0 >> level).max(1)) as usize,
                ((h0 >> level).max(1)) as usize,
            );
            let mut img = Image::new(w, h * faces as usize, 3);
            for f in 0..faces {
                let px = t
                    .transcode_image(
                        level,
                        0,
                        f,
                        basisu::TargetFormat::RgbaHalf,
                        basisu::DecodeFlags::NONE,
                    )
                    .map_err(|e| bad(format!("level {level} face {f}: {e:?}")))?;
                if px.len() != w * h * 8 {
                    return Err(bad(format!(
                        "level {level} transcodes to {} bytes",
                        px.len()
                    )));
                }
                let out = &mut img.data[f as usize * w * h * 3..(f as usize + 1) * w * h * 3];
                for (o, p) in out.chunks_exact_mut(3).zip(px.chunks_exact(8)) {
                    for k in 0..3 {
                        o[k] = exr::prelude::f16::from_le_bytes([p[2 * k], p[2 * k + 1]]).to_f32();
                    }
                }
            }
            levels.push(img);
        }
        Ok(levels)
    }

    /// Basis Universal's encoder for UASTC HDR 4x4 or ASTC HDR 6x6, its blocks decoded by
    /// the pure-Rust transcoder (what `read_texture` and `info` read).
    #[cfg(feature = "basisu")]
    struct Basis(Encoding);

    /// Blocks encoded in one call of Basis Universal's encoder, side by side in rows of
    /// [`ROW`] (an ASTC block decodes on its own, so its bytes hold wherever it is placed).
    #[cfg(feature = "basisu")]
    const CHUNK: usize = 256;
    #[cfg(feature = "basisu")]
    const ROW: usize = 16;

    #[cfg(feature = "basisu")]
    impl Basis {
        fn encode_chunk(&self, blocks: &[Texels]) -> Result<(Vec<u8>, Vec<Texels>)> {
            use basisu_c_sys::extra::{
                types, BasisuEncoder, BasisuEncoderParams, SourceImage, SourceImageFormat,
            };
            let side = super::block_side(self.0);
            let (cols, rows) = (blocks.len().min(ROW), blocks.len().div_ceil(ROW));
            let (w, h) = (cols * side, rows * side);
            let mut data = vec![0u8; w * h * 16];
            for (b, t) in blocks.iter().enumerate() {
                let (bx, by) = (b % ROW, b / ROW);
                for (i, p) in t.iter().enumerate() {
                    let (x, y) = (bx * side + i % side, by * side + i / side);
                    let at = (y * w + x) * 16;
                    for (k, v) in [p[0], p[1], p[2], 1.0].into_iter().enumerate() {
                        // Rounded to half floats, the encoder's own precision (its ASTC HDR
                        // 6x6 path asserts that its fast float-to-half conversion agrees with
                        // the exact one, which fails on some floats between two halves).
                        let v = if v > 0.0 {
                            exr::prelude::f16::from_f32(v).to_f32()
                        } else {
                            0.0
                        };
                        data[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
                    }
                }
            }
            let fail = |x: String| Error::param("encode", format!("Basis Universal: {x}"));
            let mut enc = BasisuEncoder::new();
            enc.set_image(SourceImage {
                data: &data,
                format: SourceImageFormat::Rgba32Float,
                size: types::Extent3d {
                    width: w as u32,
                    height: h as u32,
                    depth_or_array_layers: 1,
                },
            })
            .map_err(|x| fail(x.to_string()))?;
            let format = match self.0 {
                Encoding::UastcHdr4x4 => basisu_c_sys::BasisTextureFormat::UastcHdr4x4,
                _ => basisu_c_sys::BasisTextureFormat::AstcHdr6x6,
            };
            let mut params = BasisuEncoderParams::new_with_linear_defaults(format);
            if self.0 == Encoding::UastcHdr4x4 {
                // UASTC HDR 4x4 has no quality parameter (no RDO): the codec's own settings.
                // (Effort 2 is Basis Universal's default level, 1 of 0–4.)
                params.quality_level = -1;
            }
            // One thread per call: the chunks run in parallel.
            let params = params
                .with_tex_type(types::TextureViewDimension::D2)
                .with_removed_flags(
                    basisu_c_sys::common::BU_COMP_FLAGS_KTX2_UASTC_ZSTD
                        | basisu_c_sys::common::BU_COMP_FLAGS_THREADED,
                );
            let ktx2 = enc.compress(params).map_err(|x| fail(x.to_string()))?;
            let q = |at: usize| {
                ktx2.get(at..at + 8)
                    .map(|b| u64::from_le_bytes(b.try_into().expect("8")) as usize)
                    .ok_or_else(|| fail("a KTX2 shorter than its header".into()))
            };
            let (at, len) = (q(80)?, q(88)?);
            let n = cols * rows;
            if len != n * 16 || ktx2.len() < at + len {
                return Err(fail(format!("{len} bytes for {n} blocks")));
            }
            let level = &ktx2[at..at + len];
            let img = decode_ktx2(std::path::Path::new("basisu"), &ktx2)?
                .into_iter()
                .next()
                .ok_or_else(|| fail("no level".into()))?;
            let mut bytes = Vec::with_capacity(16 * blocks.len());
            let mut decoded = Vec::with_capacity(blocks.len());
            for b in 0..blocks.len() {
                let (bx, by) = (b % ROW, b / ROW);
                bytes.extend_from_slice(&level[16 * (by * cols + bx)..16 * (by * cols + bx + 1)]);
                decoded.push(
                    (0..side * side)
                        .map(|i| {
                            let (x, y) = (bx * side + i % side, by * side + i / side);
                            let p = img.pixel(x, y);
                            [p[0], p[1], p[2]]
                        })
                        .collect(),
                );
            }
            Ok((bytes, decoded))
        }
    }

    #[cfg(feature = "basisu")]
    impl super::Codec for Basis {
        fn side(&self) -> usize {
            super::block_side(self.0)
        }
        fn bytes(&self) -> usize {
            16
        }
        fn range(&self) -> f32 {
            super::ASTC_HDR_MAX
        }
        /// Each block nudged from the encoder's; those that then miss by more than their
        /// `must` encoded again (all in one batch) at gains around their power ratio and each
        /// of those nudged; those that miss still, the constant block of their mean colour
        /// where it holds more closely.
        fn holding_power(&self, asks: &[super::Ask]) -> Vec<Option<(Vec<u8>, Texels)>> {
            use rayon::prelude::*;
            let side = super::block_side(self.0) as u32;
            let short = |t: &Option<AstcTry>, a: &super::Ask| {
                t.as_ref().is_none_or(|t| t.2 > a.aim.tolerance.max(a.must))
            };
            let mut best: Vec<Option<AstcTry>> = asks
                .par_iter()
                .map(|a| {
                    let start: &[u8; 16] = a.current.try_into().ok()?;
                    // A constant block stays one, at the colour that holds the power.
                    let log = basisu::astc::unpack::unpack_block(start, side, side)?;
                    if log.solid_color_flag_hdr || log.solid_color_flag_ldr {
                        return astc_solid(a.texels, a.weights, &a.aim, side);
                    }
                    astc_nudge(a.texels, a.weights, &a.aim, start, side)
                })
                .collect();
            let again: Vec<usize> = (0..asks.len())
                .filter(|&i| short(&best[i], &asks[i]))
                .collect();
            let inputs: Vec<Texels> = again
                .iter()
                .flat_map(|&i| {
                    let a = &asks[i];
                    let src = super::power(a.texels, a.weights);
                    let ratio: [f64; 3] = std::array::from_fn(|k| {
                        if src[k] > 0.0 {
                            a.aim.target[k] / src[k]
                        } else {
                            1.0
                        }
                    });
                    REENCODE_GAINS.iter().map(move |g| {
                        a.texels
                            .iter()
                            .map(|p| {
                                std::array::from_fn(|k| {
                                    ((p[k] as f64 * ratio[k] * g) as f32).min(super::ASTC_HDR_MAX)
                                })
                            })
                            .collect()
                    })
                })
                .collect();
            if let Ok((bytes, _)) = super::Codec::encode(self, &inputs) {
                let per = 16 * REENCODE_GAINS.len();
                let found: Vec<Option<AstcTry>> = again
                    .par_iter()
                    .zip(bytes.par_chunks(per))
                    .map(|(&i, chunk)| {
                        let a = &asks[i];
                        let mut b: Option<AstcTry> = None;
                        for blk in chunk.chunks_exact(16) {
                            let t =
                                astc_nudge(a.texels, a.weights, &a.aim, blk.try_into().ok()?, side);
                            if let Some(t) = t {
                                if b.as_ref().is_none_or(|b| (t.2, t.3) < (b.2, b.3)) {
                                    b = Some(t);
                                }
                            }
                        }
                        b
                    })
                    .collect();
                for (&i, t) in again.iter().zip(found) {
                    if let Some(t) = t {
                        if best[i].as_ref().is_none_or(|b| (t.2, t.3) < (b.2, b.3)) {
                            best[i] = Some(t);
                        }
                    }
                }
            }
            best.into_iter()
                .zip(asks)
                .map(|(mut b, a)| {
                    // A constant block moves a small bright source across the block: only
                    // where that moves the light less than the block as it is.
                    if short(&b, a) {
                        if let Some(t) = astc_solid(a.texels, a.weights, &a.aim, side) {
                            let flat = match &b {
                                None => true,
                                Some(b) => {
                                    t.2 < b.2
                                        && match (a.light_cost(&t.1), a.light_cost(&b.1)) {
                                            (Some(f), Some(k)) => {
                                                f <= super::FLAT_SH_SHARE
                                                    || (a.last_resort && f < k)
                                            }
                                            _ => a.many_blocks,
                                        }
                                }
                            };
                            if flat {
                                b = Some(t);
                            }
                        }
                    }
                    b.map(|(bytes, dec, _, _)| (bytes, dec))
                })
                .collect()
        }
        /// None: a call of the encoder costs more than the nudges that replace its rounds.
        fn rounds(&self) -> usize {
            0
        }
        /// Constant blocks are taken by where they put the light.
        fn weighs_light(&self) -> bool {
            true
        }
        fn log_share(&self) -> f64 {
            super::ASTC_LOG_SHARE
        }
        fn encode(&self, blocks: &[Texels]) -> Result<(Vec<u8>, Vec<Texels>)> {
            use rayon::prelude::*;
            let parts = blocks
                .par_chunks(CHUNK)
                .map(|c| self.encode_chunk(c))
                .collect::<Result<Vec<_>>>()?;
            let mut out = (Vec::new(), Vec::new());
            for (b, d) in parts {
                out.0.extend(b);
                out.1.extend(d);
            }
            Ok(out)
        }
    }

    /// The most texels an ASTC block of these formats holds (6×6).
    #[cfg(feature = "basisu")]
    const MAX_TEXELS: usize = 36;

    /// An ASTC block's texels as half floats (RGB), by the pure-Rust transcoder's decoder;
    /// `None` for a block it rejects.
    #[cfg(feature = "basisu")]
    fn astc_halves(
        log: &basisu::astc::unpack::LogAstcBlock,
        side: u32,
    ) -> Option<[[u16; 4]; MAX_TEXELS]> {
        let mut out = [[0u16; 4]; MAX_TEXELS];
        basisu::astc::decode::decode_block_hdr16(log, side, side, &mut out)?;
        Some(out)
    }

    /// Each half float's value and ln(1 + value) (0 for negative, infinite and NaN ones,
    /// which these blocks do not decode to), indexed by its bits.
    #[cfg(feature = "basisu")]
    fn half_table() -> &'static [(f64, f64)] {
        static TABLE: std::sync::OnceLock<Vec<(f64, f64)>> = std::sync::OnceLock::new();
        TABLE.get_or_init(|| {
            (0..=u16::MAX)
                .map(|b| {
                    let v = exr::prelude::f16::from_bits(b).to_f32() as f64;
                    let v = if v.is_finite() { v.max(0.0) } else { 0.0 };
                    (v, v.ln_1p())
                })
                .collect()
        })
    }

    /// A block's texels as RGB.
    #[cfg(feature = "basisu")]
    fn astc_rgb(h: &[[u16; 4]; MAX_TEXELS], n: usize) -> Texels {
        h[..n]
            .iter()
            .map(|p| [0, 1, 2].map(|k| exr::prelude::f16::from_bits(p[k]).to_f32()))
            .collect()
    }

    /// What a block is measured against: the source texels' ln(1 + x), their weights, the aim.
    #[cfg(feature = "basisu")]
    struct AstcGoal<'a> {
        ln_src: Vec<[f64; 3]>,
        weights: &'a [f64],
        aim: &'a super::bc6h::Aim,
    }

    #[cfg(feature = "basisu")]
    impl<'a> AstcGoal<'a> {
        fn new(texels: &Texels, weights: &'a [f64], aim: &'a super::bc6h::Aim) -> Self {
            AstcGoal {
                ln_src: texels
                    .iter()
                    .map(|p| p.map(|v| (v as f64).ln_1p()))
                    .collect(),
                weights,
                aim,
            }
        }

        /// The block's power error against the aim (the largest channel's, in the aim's
        /// units) and its squared log error against the source.
        fn errors(&self, h: &[[u16; 4]; MAX_TEXELS]) -> (f64, f64) {
            let t = half_table();
            let (mut p, mut l) = ([0.0f64; 3], 0.0);
            for ((d, s), &w) in h.iter().zip(&self.ln_src).zip(self.weights) {
                if w > 0.0 {
                    for k in 0..3 {
                        let (v, ln) = t[d[k] as usize];
                        p[k] += v * w;
                        l += (ln - s[k]) * (ln - s[k]);
                    }
                }
            }
            let aim = self.aim;
            let e = (0..3)
                .filter(|&k| aim.scale[k] > 0.0)
                .map(|k| (p[k] - aim.target[k]).abs() / aim.scale[k])
                .fold(0.0, f64::max);
            (e, l)
        }
    }

    /// An ASTC block, its texels, power error and squared log error.
    #[cfg(feature = "basisu")]
    type AstcTry = (Vec<u8>, Texels, f64, f64);

    /// The block `start` moved one quantisation step at a time (an endpoint or weight symbol
    /// to its neighbour in value), each step the one that removes the most power error per
    /// log error added, then, once within `aim`'s tolerance, the one that removes the most
    /// log error; the block keeps the configuration the encoder chose (UASTC HDR 4x4's subset
    /// of ASTC).  `None` for a constant (void-extent) block.
    #[cfg(feature = "basisu")]
    fn astc_nudge(
        texels: &Texels,
        weights: &[f64],
        aim: &super::bc6h::Aim,
        start: &[u8; 16],
        side: u32,
    ) -> Option<AstcTry> {
        use basisu::astc::{dequant, pack, unpack};
        let mut log = unpack::unpack_block(start, side, side)?;
        if log.solid_color_flag_hdr || log.solid_color_flag_ldr {
            return None;
        }
        // Each range's symbols in the order of their values.
        let order = |levels: u32, value: &dyn Fn(u32) -> u32| -> Vec<u8> {
            let mut v: Vec<u8> = (0..levels.min(256)).map(|x| x as u8).collect();
            v.sort_by_key(|&x| (value(x as u32), x));
            v
        };
        let (er, wr) = (log.endpoint_ise_range, log.weight_ise_range);
        let e_order = order(unpack::ise_levels(er), &|x| {
            dequant::dequant_bise_endpoint(x, er)
        });
        let w_order = order(unpack::ise_levels(wr), &|x| {
            dequant::dequant_bise_weight(x, wr)
        });
        let n_end: usize = log.color_endpoint_modes[..log.num_partitions as usize]
            .iter()
            .map(|&c| ((c as usize >> 2) + 1) * 2)
            .sum();
        let n_w = (log.grid_width * log.grid_height) as usize * if log.dual_plane { 2 } else { 1 };
        let goal = AstcGoal::new(texels, weights, aim);
        let mut dec = astc_halves(&log, side)?;
        let (mut e, mut l) = goal.errors(&dec);
        for _ in 0..NUDGES {
            let mut step: Option<(unpack::LogAstcBlock, [[u16; 4]; MAX_TEXELS], f64, f64)> = None;
            let slots = (0..n_end)
                .map(|i| (true, i))
                .chain((0..n_w).map(|i| (false, i)));
            for (is_end, i) in slots {
                let (ord, sym) = if is_end {
                    (&e_order, log.endpoints[i])
                } else {
                    (&w_order, log.weights[i])
                };
                let at = ord.iter().position(|&x| x == sym)?;
                for to in [at.wrapping_sub(1), at + 1] {
                    let Some(&v) = ord.get(to) else { continue };
                    let mut t = log;
                    if is_end {
                        t.endpoints[i] = v;
                    } else {
                        t.weights[i] = v;
                    }
                    let Some(d) = astc_halves(&t, side) else {
                        continue;
                    };
                    let (te, tl) = goal.errors(&d);
                    let rate = |te: f64, tl: f64| (e - te) / (tl - l).max(1e-9);
                    let outside = e > aim.tolerance;
                    let gain = if outside {
                        te < e
                    } else {
                        te <= aim.tolerance && tl < l
                    };
                    let first = match &step {
                        None => true,
                        Some((_, _, se, sl)) if outside => rate(te, tl) > rate(*se, *sl),
                        Some((_, _, _, sl)) => tl < *sl,
                    };
                    if gain && first {
                        step = Some((t, d, te, tl));
                    }
                }
            }
            match step {
                Some((t, d, te, tl)) => (log, dec, e, l) = (t, d, te, tl),
                None => break,
            }
        }
        let bytes = pack::pack_astc_block(&log)?;
        // The packed block must decode as searched.
        let back = unpack::unpack_block(&bytes, side, side)?;
        let n = (side * side) as usize;
        (astc_halves(&back, side)?[..n] == dec[..n])
            .then(|| (bytes.to_vec(), astc_rgb(&dec, n), e, l))
    }

    /// The constant (void-extent) block of the block's mean colour, its half floats moved a
    /// step where that holds `aim`'s power more closely: it holds the power to half-float
    /// precision whatever the texels.
    #[cfg(feature = "basisu")]
    fn astc_solid(
        texels: &Texels,
        weights: &[f64],
        aim: &super::bc6h::Aim,
        side: u32,
    ) -> Option<AstcTry> {
        use basisu::astc::{pack, unpack};
        let area: f64 = weights.iter().sum();
        if area <= 0.0 {
            return None;
        }
        let f16 = |v: f64| exr::prelude::f16::from_f32(v as f32).to_bits();
        let mut h: [u16; 3] = std::array::from_fn(|k| f16(aim.target[k].max(0.0) / area));
        for k in 0..3 {
            let val = |b: u16| exr::prelude::f16::from_bits(b).to_f32() as f64 * area;
            for c in [h[k].wrapping_sub(1), h[k] + 1] {
                if c < 0x7C00 && (val(c) - aim.target[k]).abs() < (val(h[k]) - aim.target[k]).abs()
                {
                    h[k] = c;
                }
            }
        }
        let solid = pack::pack_void_extent_hdr(h[0], h[1], h[2], 0x3C00);
        let dec = astc_halves(&unpack::unpack_block(&solid, side, side)?, side)?;
        let (e, l) = AstcGoal::new(texels, weights, aim).errors(&dec);
        Some((solid.to_vec(), astc_rgb(&dec, (side * side) as usize), e, l))
    }

    /// The most steps [`astc_nudge`] takes.
    #[cfg(feature = "basisu")]
    const NUDGES: usize = 48;

    /// Gains (on the power ratio) a block that nudging cannot hold is encoded again with.
    #[cfg(feature = "basisu")]
    const REENCODE_GAINS: [f64; 8] = [0.8, 0.9, 0.95, 1.0, 1.05, 1.1, 1.2, 1.4];

    /// The codec of `e`, a Basis Universal format.
    #[cfg(feature = "basisu")]
    pub(super) fn codec(_what: &str, e: Encoding) -> Result<Box<dyn super::Codec>> {
        basisu_c_sys::extra::basisu_encoder_init();
        Ok(Box::new(Basis(e)))
    }

    /// Without the `basisu` feature: an error naming what is missing.
    #[cfg(not(feature = "basisu"))]
    pub(super) fn codec(what: &str, e: Encoding) -> Result<Box<dyn super::Codec>> {
        Err(Error::unsupported(
            format!("{what}: --encode {}", e.name()),
            "this build has no Basis Universal encoder: build spheremap with the `basisu` \
             feature (cargo build --features basisu; it needs libclang, Debian's libclang-dev)",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb9e5_holds_exact_values_and_rounds_to_nearest() {
        for v in [
            [0.0, 0.0, 0.0],
            [1.0, 0.5, 0.25],
            [65408.0, 1.0, 0.0],
            [3.0, 2.0, 1.0],
        ] {
            let back = rgb9e5_unpack(rgb9e5_pack(v));
            for k in 0..3 {
                assert!((back[k] - v[k]).abs() <= v[0].max(v[1]).max(v[2]) / 512.0);
            }
        }
        assert_eq!(
            rgb9e5_unpack(rgb9e5_pack([1.0, 0.5, 0.25])),
            [1.0, 0.5, 0.25]
        );
        // The EXT_texture_shared_exponent bit layout: R in bits 0-8, exponent in 27-31.
        // 1.0 = 256 × 2^(16 - 15 - 9).
        assert_eq!(rgb9e5_pack([1.0, 0.0, 0.0]), 256 | (16 << 27));
        assert_eq!(rgb9e5_unpack(rgb9e5_pack([1e9, 0.0, 0.0]))[0], RGB9E5_MAX);
        // Rounding up past 511 takes the next exponent.
        assert_eq!(rgb9e5_unpack(rgb9e5_pack([1.999, 0.0, 0.0]))[0], 2.0);
    }

    #[test]
    fn names_round_trip() {
        for e in Encoding::ALL {
            assert_eq!(Encoding::parse_as(e.name(), "encode").unwrap(), e);
        }
        assert!(Encoding::parse_as("bc7", "--encode")
            .unwrap_err()
            .to_string()
            .contains("float, bc6h, rgb9e5"));
    }
}
