//! Flags shared by the commands that make a map (`convert`, `generate`): output encoding,
//! limits, NaN policy, overwrite, progress and summary.

use spheremap::images::codec::{NonFinite, WriteOptions};

#[derive(clap::Args, Debug)]
pub struct JobFlags {
    /// EXR output as half floats. A value beyond the half range (65504) is refused, unless
    /// --clamp-half.
    #[arg(long)]
    pub half: bool,
    /// With --half: clamp values beyond 65504 to it instead of refusing them (the --json
    /// summary counts them).
    #[arg(long, requires = "half")]
    pub clamp_half: bool,
    /// 16-bit PNG output.
    #[arg(long)]
    pub png16: bool,
    /// How texels are stored. KTX2/DDS: float (RGBA half with --half, else 32-bit), bc6h
    /// (BC6H_UF16 blocks) or rgb9e5 (shared exponent). KTX2 only: uastc-hdr-4x4 and
    /// astc-hdr-6x6 (Basis Universal; what three.js's KTX2Loader reads; writing them needs a
    /// build with the basisu feature). Each of these keeps each level's light: blocks that
    /// leak are encoded again (the --json summary reports the power per level). PNG: rgbd
    /// (Babylon.js's RGBD, 0..255) or rgbm (three.js's RGBM as its RGBMLoader reads it,
    /// 0..7), 8-bit RGBA with the packing in the note. Values outside the range (bc6h
    /// 0..65504, rgb9e5 0..65408, uastc-hdr-4x4 and astc-hdr-6x6 0..65216; rgbd and rgbm: below
    /// 0) are clamped with their light moved into the texels around them, and a warning naming
    /// the power that still changes; rgbd and rgbm clamp values above their range.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::images::compress::Encoding>())]
    pub encode: spheremap::images::compress::Encoding,
    /// KTX2: supercompress each level with Zstandard at this level (1-22).
    #[arg(long, value_name = "LEVEL", value_parser = clap::value_parser!(i32).range(
        i64::from(*spheremap::images::codec::ZSTD_LEVELS.start())
            ..=i64::from(*spheremap::images::codec::ZSTD_LEVELS.end())
    ))]
    pub zstd: Option<i32>,
    /// Refuse a job that would need more memory than this (bytes, or 512M, 8G, ...; default
    /// $SPHEREMAP_MAX_MEMORY or 16G).
    #[arg(long)]
    pub max_memory: Option<String>,
    /// NaN/Inf values in input images: error (default; names the count and the first pixel),
    /// zero (replace them with 0) or keep.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::images::codec::NonFinite>())]
    pub nonfinite: spheremap::images::codec::NonFinite,
    /// Allow the output to overwrite an input file.
    #[arg(long)]
    pub force: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
}

impl JobFlags {
    /// Refuses (unless --force) an output that is one of the inputs; `{face}` patterns on
    /// either side stand for their six files.
    pub fn refuse_overwrite<I: AsRef<str>, O: AsRef<str>>(
        &self,
        inputs: &[I],
        outputs: &[O],
    ) -> anyhow::Result<()> {
        if self.force {
            return Ok(());
        }
        Ok(spheremap::images::envmap::refuse_overwrite(
            &inputs
                .iter()
                .map(|i| i.as_ref().to_string())
                .collect::<Vec<_>>(),
            &outputs
                .iter()
                .map(|o| o.as_ref().to_string())
                .collect::<Vec<_>>(),
        )?)
    }

    pub fn write_options(&self, linear: bool) -> WriteOptions {
        WriteOptions {
            linear,
            png16: self.png16,
            half: self.half,
            clamp_half: self.clamp_half,
            encode: self.encoding(),
            zstd: self.zstd,
        }
    }

    /// The `--encode` value.
    pub fn encoding(&self) -> spheremap::images::compress::Encoding {
        self.encode
    }

    /// `--max-memory` (absent: the core's default).
    pub fn max_memory(&self) -> anyhow::Result<u64> {
        match &self.max_memory {
            None => Ok(spheremap::base::limits::default_max_memory()),
            Some(s) => Ok(spheremap::base::limits::parse_memory_limit(
                "max-memory",
                s,
            )?),
        }
    }

    pub fn nonfinite(&self) -> anyhow::Result<NonFinite> {
        Ok(self.nonfinite)
    }

    /// Whether to show a progress bar.
    pub fn show_progress(&self) -> bool {
        !self.quiet && !self.json
    }
}

/// A `num_args = 3` flag as an array.
pub fn vec3<T: Copy>(v: &Option<Vec<T>>) -> Option<[T; 3]> {
    v.as_ref().map(|v| [v[0], v[1], v[2]])
}
