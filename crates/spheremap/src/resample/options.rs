//! What a conversion is asked (the filter, the taps, outside a disc, the precision, the samples
//! and the memory it may take) and what a run reports, shared by the engine's files.

use crate::base::error::{Error, Result};
use crate::base::vec::IDENTITY3 as IDENTITY;
use std::sync::atomic::{AtomicBool, AtomicUsize};

crate::base::named::named_enum! {
    /// Reconstruction filter over the output texel's footprint.
    #[derive(Default)]
    pub enum Filter: "filter" as "filter" {
        /// The 1-texel box: the plain (solid-angle weighted) average over the texel. Default.
        #[default]
        Box = "box",
        /// Tent, radius 1 texel.
        Tent = "tent" | "triangle",
        /// Gaussian, σ = ½ texel, truncated at 1.5 texels.
        Gaussian = "gaussian" | "gauss",
    }
}

impl Filter {
    /// Half-width of the support, in output texels.
    pub(crate) fn radius(self) -> f64 {
        match self {
            Filter::Box => 0.5,
            Filter::Tent => 1.0,
            Filter::Gaussian => 1.5,
        }
    }
    #[inline]
    pub(crate) fn weight(self, d: f64) -> f64 {
        match self {
            Filter::Box => 1.0,
            Filter::Tent => (1.0 - d.abs()).max(0.0),
            Filter::Gaussian => (-2.0 * d * d).exp(),
        }
    }
}

crate::base::named::named_enum! {
    /// How each sample reads the source's texels.
    #[derive(Default)]
    pub enum Taps: "taps" as "taps" {
        /// The 2×2 texels round the sample, bilinearly. Default.
        #[default]
        Bilinear = "bilinear",
        /// The 4×4 texels round the sample, Catmull–Rom bicubic (interpolating: a sample on a
        /// texel centre reads that texel alone), its result clamped per channel to the range of
        /// the 2×2 nearest texels (no ringing, no negative values from positive ones).  Sharper
        /// where destination texels are as small as the source's or smaller; read from the
        /// source itself (a footprint wide enough to read a prefiltered level reads it
        /// bilinearly), and bilinearly where the 4×4 texels are not all on the map (a disc's
        /// rim).  It runs on the generic scalar path: 15–30× slower than bilinear's vectorised
        /// one.
        Bicubic = "bicubic" | "catmull-rom",
    }
}

crate::base::named::named_enum! {
    /// What to write where a destination disc mapping has no direction.
    #[derive(Default)]
    pub enum Outside: "fill" as "outside" {
        /// The radial mirror image across the rim (no dark fringe under GPU filtering).
        /// Default.
        #[default]
        Gutter = "gutter",
        /// Zero; rim texels hold their covered fraction.
        Black = "black",
    }
}

crate::base::named::named_enum! {
    /// Arithmetic of the direction computations.
    #[derive(Default)]
    pub enum Precision: "precision" as "precision" {
        #[default]
        F32 = "f32",
        F64 = "f64",
    }
}

/// Options of [`resample`].
#[derive(Clone, Copy, Debug)]
pub struct ResampleOptions {
    /// Samples per output texel: 1 = one centre lookup; S > 1 = at least S, adaptive.
    pub samples: u32,
    /// The most samples one texel may take when adapting.
    pub max_samples: u32,
    pub filter: Filter,
    /// How each sample reads the source's texels.
    pub taps: Taps,
    pub outside: Outside,
    /// Row-major rotation taking directions in the destination's frame to the source's frame
    /// (its columns are the destination's +X, +Y, +Z axes in source coordinates); see
    /// [`crate::frame::view`].
    pub rotation: [[f64; 3]; 3],
    pub seed: u64,
    pub precision: Precision,
    /// Refuse a job whose estimated allocation is over this many bytes
    /// ([`crate::base::limits::default_max_memory`]).
    pub max_memory: u64,
    /// Keep the light: with `samples > 1`, texels far brighter than the map's mean are split
    /// off and integrated exactly over the output's texels ([`peaks`]), so the output's power
    /// Σ L·dω is the source's.  Default on; off gives the sampled filter alone.
    pub conserve: bool,
}

/// The default sample count (adaptive, at least 4 per texel).
pub const DEFAULT_SAMPLES: u32 = 4;

impl Default for ResampleOptions {
    fn default() -> Self {
        ResampleOptions {
            samples: DEFAULT_SAMPLES,
            max_samples: 1024,
            filter: Filter::Box,
            taps: Taps::Bilinear,
            outside: Outside::Gutter,
            rotation: IDENTITY,
            seed: 0,
            precision: Precision::F32,
            max_memory: crate::base::limits::default_max_memory(),
            conserve: true,
        }
    }
}

/// Shared progress and cancellation: workers add finished rows to `done` and stop early when
/// `cancel` is set (the result is then an error).
#[derive(Debug, Default)]
pub struct Progress {
    pub done: AtomicUsize,
    pub total: AtomicUsize,
    pub cancel: AtomicBool,
}

/// What a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResampleReport {
    /// Source lookups in all.
    pub lookups: u64,
    /// The most samples any texel took.
    pub max_texel_samples: u32,
    /// The conversion was the identity (same mapping and preset, same canvas, no turn): the
    /// texels were copied ([`is_identity`]).
    pub copied: bool,
    /// Source texels integrated exactly as peaks ([`ResampleOptions::conserve`]).
    pub peak_texels: u64,
}

pub(crate) fn check_rotation(r: &[[f64; 3]; 3]) -> Result<()> {
    for i in 0..3 {
        for j in 0..3 {
            let d: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            if !((d - want).abs() < 1e-6) {
                return Err(Error::param(
                    "rotation",
                    "not a rotation (its columns must be orthonormal)",
                ));
            }
        }
    }
    Ok(())
}
