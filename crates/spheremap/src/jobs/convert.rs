//! A conversion as one request: [`ConvertJob`] holds everything `spheremap convert` and
//! Python's `spheremap.convert` take — the source's and the output's mapping, preset, cube
//! layout and view, the size, the sampling, the limits and the output encoding — by name, as
//! users give them (and as a recipe file spells them: it is serde-readable, unknown keys
//! refused).  The core resolves it once: names checked by their parsers, the defaults a file's
//! note supplies ([`crate::images::note`]), the views turned into the conversion's rotation,
//! the size checked.  It then runs on files ([`ConvertJob::run_files`], the CLI) or on an image in
//! memory ([`ConvertJob::run_image`], Python) and reports what it did ([`ConvertReport`]).
//!
//! The rules, in one place:
//!
//! * **Source**: mapping, preset, cube layout and view by [`Source`]'s rules (`src`,
//!   `src_preset`, `src_layout`, `src_look`, `src_up`, also spelled `from`, `from_preset`, …):
//!   given, else what the input's note records; a file with no mapping either way is an error.
//! * **Output mapping**: `to` (with `preset`); without `to`, the source's mapping (in `preset`
//!   when given), cube layout and view, so that converting a file into another name changes
//!   only its format (the texels are copied).
//! * **Output view**: `look`/`up`, or `yaw`/`pitch`/`roll` (not both); without `to` and
//!   without either, the source's view.
//! * **Size**: `size`, else the source's (a cube face F gives a sphere map of 2F, and N gives
//!   cube faces of N/2: [`crate::images::envmap::default_size`]); checked against
//!   [`crate::base::limits::MAP_SIZE`].

use crate::base::error::{Error, Result};
use crate::base::limits::{check_map_size, default_max_memory};
use crate::frame::view::{self, Mat3};
use crate::images::codec::{Losses, NonFinite, ReadOptions, WriteOptions};
use crate::images::compress::Encoding;
use crate::images::cube_layout::Layout;
use crate::images::envmap::{
    check_nonfinite_env, default_size, read_env_layout, read_note, refuse_overwrite, split_paths,
    write_env_files, EnvReader,
};
use crate::images::format::Format;
use crate::images::note::MapNote;
use crate::images::Image;
use crate::jobs::source::Source;
use crate::mappings::cube::FACE_NAMES;
use crate::mappings::mapping::{name_fields, Mapping};
use crate::resample::energy::{LightCheck, Moments};
use crate::resample::{
    resample, resample_into, EnvMap, Filter, Outside, Precision, Progress, ResampleOptions,
    ResampleReport, Taps, DEFAULT_SAMPLES, IDENTITY,
};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One conversion, as users name it.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConvertJob {
    /// The source: its mapping, preset, cube layout and view (`src`, `src_preset`, …; also
    /// read as `from`, `from_preset`, …).
    #[serde(flatten)]
    pub source: Source,
    /// The output mapping; `None`: the source's (with its preset, layout and view).
    pub to: Option<String>,
    /// The output mapping's preset.
    pub preset: Option<String>,
    /// The output's cube layout (one image); `None`: hcross, or the source's without `to`.
    pub layout: Option<String>,
    /// Output size N (sphere, angular, octahedral N×N; latlong, paraboloid 2N×N; cube faces
    /// N×N); `None`: from the source.
    pub size: Option<usize>,
    /// The output's view: world directions of its eye's −Z and +Y (up defaults to +Y).
    pub look: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    /// The output's view as angles in degrees (instead of look/up): yaw about world +Y (90 =
    /// looking along −X), pitch (90 = looking up), roll about the view axis.
    pub yaw: Option<f64>,
    pub pitch: Option<f64>,
    pub roll: Option<f64>,
    /// Samples per output texel (1: the texel centre only).
    pub samples: u32,
    /// The most samples a texel may take adapting to its footprint.
    pub max_samples: u32,
    /// Reconstruction filter: box, tent, gaussian.
    pub filter: Filter,
    /// How each sample reads the source: bilinear or bicubic.
    pub taps: Taps,
    /// Outside a destination disc: gutter or black.
    pub outside: Outside,
    /// Seed of the sample jitter.
    pub seed: u64,
    /// f32 (fast) or f64 (reference) arithmetic.
    pub precision: Precision,
    /// Keep the light: with samples > 1, the source's brightest texels are integrated exactly
    /// (`resample::peaks`); false leaves the sampled filter alone.
    pub conserve: bool,
    /// Refuse a job needing more memory than this many bytes (`None`: the default,
    /// `$SPHEREMAP_MAX_MEMORY` or 16 GiB).
    pub max_memory: Option<u64>,
    /// NaN/Inf in the source: error, zero or keep.
    pub nonfinite: NonFinite,
    /// LDR files as linear values (no sRGB transfer), read and written.
    pub linear: bool,
    /// 16-bit PNG output.
    pub png16: bool,
    /// EXR output as half floats; `clamp_half` clamps values beyond 65504 instead of refusing.
    pub half: bool,
    pub clamp_half: bool,
    /// KTX2/DDS texel encoding: float, bc6h or rgb9e5 ([`crate::images::compress`]).
    pub encode: Encoding,
    /// KTX2 Zstandard supercompression level (1–22).
    pub zstd: Option<i32>,
    /// Allow an output to overwrite an input.
    pub force: bool,
}

impl Default for ConvertJob {
    fn default() -> Self {
        ConvertJob {
            source: Source::default(),
            to: None,
            preset: None,
            layout: None,
            size: None,
            look: None,
            up: None,
            yaw: None,
            pitch: None,
            roll: None,
            samples: DEFAULT_SAMPLES,
            max_samples: 1024,
            filter: Filter::default(),
            taps: Taps::default(),
            outside: Outside::default(),
            seed: 0,
            precision: Precision::default(),
            conserve: true,
            max_memory: None,
            nonfinite: NonFinite::default(),
            linear: false,
            png16: false,
            half: false,
            clamp_half: false,
            encode: Encoding::Float,
            zstd: None,
            force: false,
        }
    }
}

/// What a conversion did: `spheremap convert --json` prints it, the batch runner records it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConvertReport {
    /// The input as one name (a face pattern or the first of six files), and every input file.
    pub input: String,
    pub inputs: Vec<String>,
    /// The files written.
    pub output: Vec<String>,
    pub from: &'static str,
    pub from_preset: &'static str,
    pub from_look: Option<[f64; 3]>,
    pub from_up: Option<[f64; 3]>,
    pub to: &'static str,
    pub preset: &'static str,
    pub size: usize,
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub samples: u32,
    pub filter: &'static str,
    pub taps: &'static str,
    pub outside: &'static str,
    /// Source lookups in all, and the most samples one texel took.
    pub lookups: u64,
    pub max_texel_samples: u32,
    /// Same mapping, size and view: the texels were copied.
    pub copied: bool,
    /// Source texels integrated exactly as peaks (`conserve`).
    pub peak_texels: u64,
    /// The light the output holds against the source's: power per channel and the SH9
    /// irradiance (before the output format's clipping or half rounding).
    pub light: LightCheck,
    /// The KTX2/DDS texel encoding.
    pub encode: Encoding,
    /// With an encoding other than float: the light of the file as written, read back and
    /// decoded, against the source's (for one output file holding the map as converted).
    pub encoded_light: Option<LightCheck>,
    pub seconds: f64,
    /// Values the output format clipped, and values beyond the half range (clamped with
    /// `clamp_half`).
    pub clipped: u64,
    pub clamped_half: u64,
    /// What the user should hear that did not stop the work (a source mapping that differs
    /// from the file's note).
    pub notice: Option<String>,
}

/// A job resolved: every name parsed, every default filled, the views turned into rotations.
#[derive(Clone, Debug)]
pub struct Resolved {
    pub src: Mapping,
    pub dst: Mapping,
    /// The source's cube layout (given or noted) and the output's (given, or the source's
    /// without `to`: filled in when the source is read).
    pub from_layout: Option<Layout>,
    pub layout: Option<Layout>,
    /// Without `to`: the output keeps the source's mapping, layout and view.
    pub same: bool,
    pub from_look: Option<[f64; 3]>,
    pub from_up: Option<[f64; 3]>,
    /// Destination eye → source eye, and the output's own view (for its note).
    pub rotation: Mat3,
    pub out_view: Mat3,
    pub options: ResampleOptions,
    pub nonfinite: NonFinite,
    pub notice: Option<String>,
}

impl ConvertJob {
    /// Resolves the job for a source that records `note` (`None` for an image in memory or a
    /// file without one); `input` names the source in errors.
    pub fn resolve(&self, note: Option<&MapNote>, input: &str) -> Result<Resolved> {
        crate::base::limits::check_samples(self.samples, self.max_samples)?;
        let source = self.source.resolve(note, input, None)?;
        let src = source.mapping;
        let same = self.to.is_none();
        let dst = match &self.to {
            Some(to) => Mapping::parse(to, self.preset.as_deref())
                .map_err(|e| name_fields(e, "to", "preset"))?,
            None => match self.preset.as_deref() {
                Some(p) => Mapping::parse(src.name(), Some(p)).map_err(|e| e.named("preset"))?,
                None => src,
            },
        };
        let layout = self.layout.as_deref().map(Layout::parse).transpose()?;
        let ypr = self.yaw_pitch_roll();
        let (from_look, from_up) = (source.look, source.up);
        // Without `to` and an output view, the output keeps the source's view.
        let (look, up) = match (same && self.look.is_none() && ypr.is_none(), from_look) {
            (true, Some(l)) => (Some(l), from_up),
            _ => (self.look, self.up),
        };
        let rotation = view::conversion_rotation(look, up, ypr, from_look, from_up)?;
        let out_view = view::output_view(look, up, ypr)?;
        let options = ResampleOptions {
            samples: self.samples,
            max_samples: self.max_samples,
            filter: self.filter,
            taps: self.taps,
            outside: self.outside,
            rotation,
            seed: self.seed,
            precision: self.precision,
            max_memory: self.max_memory.unwrap_or_else(default_max_memory),
            conserve: self.conserve,
        };
        Ok(Resolved {
            src,
            dst,
            from_layout: source.layout,
            layout,
            same,
            from_look,
            from_up,
            rotation,
            out_view,
            options,
            nonfinite: self.nonfinite,
            notice: source.notice,
        })
    }

    /// The output angles, when any is given (the others 0).
    pub fn yaw_pitch_roll(&self) -> Option<[f64; 3]> {
        (self.yaw.is_some() || self.pitch.is_some() || self.roll.is_some()).then(|| {
            [
                self.yaw.unwrap_or(0.0),
                self.pitch.unwrap_or(0.0),
                self.roll.unwrap_or(0.0),
            ]
        })
    }

    /// The output size for a source of size `src_n` (`size`, else the source's), checked.
    pub fn size_for(&self, r: &Resolved, src_n: usize) -> Result<usize> {
        check_map_size(
            "size",
            self.size
                .unwrap_or_else(|| default_size(r.src, src_n, r.dst)),
        )
    }

    /// The write options of the output.
    pub fn write_options(&self) -> WriteOptions {
        WriteOptions {
            linear: self.linear,
            png16: self.png16,
            half: self.half,
            clamp_half: self.clamp_half,
            encode: self.encode,
            zstd: self.zstd,
        }
    }

    /// Converts an image in memory: `image` holds the source (a cube map as its face stack,
    /// F × 6F, GL order).  Into `out` when given (it must hold the output's width × height ×
    /// channels), else into a new image, returned.
    pub fn run_image(
        &self,
        image: &Image,
        progress: Option<&Progress>,
        out: Option<&mut [f32]>,
    ) -> Result<(Option<Image>, Resolved, ResampleReport)> {
        let r = self.resolve(None, "image")?;
        let n = self.size_for(&r, r.src.check_input(image.width, image.height, "image")?)?;
        let (w, h) = r.dst.canvas(n);
        let env = EnvMap {
            mapping: r.src,
            width: image.width,
            height: image.height,
            channels: image.channels,
            data: &image.data,
        };
        match out {
            Some(buf) => {
                let report = resample_into(&env, r.dst, w, h, &r.options, progress, buf)?;
                Ok((None, r, report))
            }
            None => {
                let (img, report) = resample(&env, r.dst, w, h, &r.options, progress)?;
                Ok((Some(img), r, report))
            }
        }
    }

    /// Converts files: `paths` are the input then the output, each one image or a face
    /// pattern, or six cube-face files one by one (so 2, 7 or 12 paths).  Reads, converts and
    /// writes atomically; refuses an output that is an input unless `force`.
    pub fn run_files(
        &self,
        paths: &[String],
        progress: Option<&Progress>,
    ) -> Result<ConvertReport> {
        self.run_files_with(paths, progress, &mut read_env_layout)
    }

    /// [`ConvertJob::run_files`] with the source read by `read`.
    pub fn run_files_with(
        &self,
        paths: &[String],
        progress: Option<&Progress>,
        read: &mut EnvReader<'_>,
    ) -> Result<ConvertReport> {
        let t0 = std::time::Instant::now();
        let first = paths
            .first()
            .ok_or_else(|| Error::param("paths", "expected IN and OUT"))?;
        let note = read_note(first)?;
        let r = self.resolve(note.as_ref(), first)?;
        let (input, output) = split_paths(
            paths,
            matches!(r.src, Mapping::Cube(_)),
            matches!(r.dst, Mapping::Cube(_)),
        )?;
        if let (Some(f), crate::images::envmap::EnvFiles::One(p)) =
            (note.as_ref().and_then(|t| t.face), &input)
        {
            if matches!(r.src, Mapping::Cube(_)) {
                return Err(Error::data(
                    p,
                    format!(
                        "one face ({}) of a cube map of six files; give all six, or a pattern \
                         such as 'sky_{{face}}.exr'",
                        FACE_NAMES[f]
                    ),
                ));
            }
        }
        if !self.force {
            refuse_overwrite(&input.paths(), &output.paths())?;
        }
        output.check_output(r.dst)?;
        let ropts = ReadOptions {
            linear: self.linear,
            ..Default::default()
        };
        let (mut img, in_layout) = read(&input, r.src, r.from_layout, &ropts)?;
        let layout = r.layout.or(if r.same { in_layout } else { None });
        check_nonfinite_env(&mut img, &input, r.nonfinite)?;
        let env = EnvMap::new(r.src, &img, input.first())?;
        let n = self.size_for(&r, r.src.size_of(img.width, img.height, input.first())?)?;
        let (w, h) = r.dst.canvas(n);
        let (out, report) = resample(&env, r.dst, w, h, &r.options, progress)?;
        let source = Moments::of(&env, &IDENTITY);
        let light = LightCheck::compare(
            &source,
            &Moments::of(&EnvMap::new(r.dst, &out, "output")?, &r.rotation),
        );
        let wopts = self.write_options();
        let written = write_env_files(&output, r.dst, &out, layout, &r.out_view, &wopts)?;
        // Encoded texels: the light of the file as written, decoded.
        let encoded_light = match (wopts.encode, written.as_slice()) {
            (Encoding::Float, _) => None,
            (e, [one]) => {
                let back = if e.is_packing() {
                    crate::images::codec::read_image(Path::new(one), &ropts)?
                } else {
                    crate::images::codec::read_texture(Path::new(one), &ropts)?
                        .levels
                        .swap_remove(0)
                };
                (back.width == out.width && back.height == out.height)
                    .then(|| {
                        EnvMap::new(r.dst, &back, one)
                            .map(|m| LightCheck::compare(&source, &Moments::of(&m, &r.rotation)))
                    })
                    .transpose()?
            }
            _ => None,
        };
        let losses = Format::from_extension(Path::new(&written[0]))
            .map(|f| Losses::of(&out, f, &wopts))
            .unwrap_or_default();
        Ok(ConvertReport {
            input: input.label(),
            inputs: input.paths(),
            output: written,
            from: r.src.name(),
            from_preset: r.src.preset_name(),
            from_look: r.from_look,
            from_up: r.from_up,
            to: r.dst.name(),
            preset: r.dst.preset_name(),
            size: n,
            width: w,
            height: h,
            channels: out.channels,
            samples: self.samples,
            filter: r.options.filter.name(),
            taps: r.options.taps.name(),
            outside: r.options.outside.name(),
            lookups: report.lookups,
            max_texel_samples: report.max_texel_samples,
            copied: report.copied,
            peak_texels: report.peak_texels,
            light,
            encode: wopts.encode,
            encoded_light,
            seconds: t0.elapsed().as_secs_f64(),
            clipped: losses.clipped,
            clamped_half: losses.beyond_half,
            notice: r.notice,
        })
    }
}

impl crate::jobs::Report for ConvertReport {
    fn lines(&self) -> Vec<String> {
        let r = self;
        vec![if r.copied {
            format!(
                "{} ({} {}) -> {} ({}x{}): the same mapping, size and view: texels copied, \
                 {:.3} s",
                r.input,
                r.from,
                r.from_preset,
                r.output.join(", "),
                r.width,
                r.height,
                r.seconds
            )
        } else {
            format!(
                "{} ({} {}) -> {} ({} {}, {}x{}): {:.1} lookups/texel, power {:+.3} %, {:.3} s",
                r.input,
                r.from,
                r.from_preset,
                r.output.join(", "),
                r.to,
                r.preset,
                r.width,
                r.height,
                r.lookups as f64 / (r.width * r.height) as f64,
                100.0 * r.light.worst_signed_power_error(),
                r.seconds
            )
        }]
    }
}
