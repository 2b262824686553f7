//! A prefilter as one request: [`PrefilterRequest`] holds what `spheremap prefilter`, Python's
//! `prefilter` and a recipe's `prefilter` output take — the output mapping, levels and roughness
//! map, the sampling and the environment's [`Source`] — checks it once
//! ([`PrefilterRequest::resolve`]) and runs [`crate::lighting::prefilter`] on files or on an
//! image in memory.

use crate::base::error::{Error, Result};
use crate::base::limits::default_max_memory;
use crate::images::envmap::{read_note, refuse_overwrite, EnvFiles};
use crate::images::note::MapNote;
use crate::images::Image;
use crate::jobs::env_job::EnvJob;
use crate::jobs::source::{EnvRequest, ResolvedEnv, Source};
use crate::lighting::{envtree, prefilter};
use crate::resample::{EnvMap, Outside, Progress};

/// A prefilter as users name it: `spheremap prefilter` and Python's `prefilter` fill the same
/// fields (serde-readable, unknown keys refused); [`PrefilterRequest::resolve`] checks them.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PrefilterRequest {
    /// The output mapping (`cube`, `octahedral`, `latlong`, `sphere`, …) and its preset.
    pub to: String,
    pub preset: Option<String>,
    /// The cube layout of levels written as images (a `.ktx2`/`.dds` cube holds faces).
    pub layout: Option<String>,
    /// Level 0's size N (cube faces N×N, lat-long 2N×N); default 256, 32 for the irradiance.
    pub size: Option<usize>,
    /// Levels, each half the last's size; default down to 8 texels (6 for 256), 1 for the
    /// irradiance.
    pub levels: Option<usize>,
    /// Level → roughness: `filament`, `threejs` or `linear` ([`prefilter::RoughnessMap`]).
    pub roughness_map: prefilter::RoughnessMap,
    /// One cosine-convolved (Lambert) level instead of the GGX chain.
    pub irradiance: bool,
    /// The output's view: world directions of its −Z and +Y (a sphere map's eye).
    pub look: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    /// Spatial samples per texel (default 1: the texel's centre, or where the texel is wider
    /// than the level's lobe the centres of its children on a finer canvas, whose mean it holds
    /// ([`prefilter::Prefilter::footprint`]); the mirror level 0 takes at least the
    /// conversion's default, 4, filtered over each texel's footprint with its peaks
    /// integrated), the most one may take, the jitter's seed, the gutter rule.
    pub samples: u32,
    pub max_samples: u32,
    pub seed: u64,
    pub outside: Outside,
    /// The error each integral may leave, relative to the map's mean radiance (default
    /// [`prefilter::DEFAULT_TOLERANCE`]): the tree is cut no finer than that.
    pub tolerance: Option<f64>,
    /// `tree` (exact, the default) or `sampled` (filtered importance sampling as Filament's
    /// `cmgen`: fast, approximate) ([`prefilter::PrefilterMethod`]).
    pub method: prefilter::PrefilterMethod,
    /// GGX samples per texel with `sampled` (Filament's default, 1024).
    pub lobe_samples: usize,
    /// The environment, as [`MatcapRequest::source`].
    #[serde(flatten)]
    pub source: Source,
    pub nonfinite: crate::images::codec::NonFinite,
    pub max_memory: Option<u64>,
}

impl Default for PrefilterRequest {
    fn default() -> Self {
        PrefilterRequest {
            to: "cube".into(),
            preset: None,
            layout: None,
            size: None,
            levels: None,
            roughness_map: prefilter::RoughnessMap::Filament,
            irradiance: false,
            look: None,
            up: None,
            samples: 1,
            max_samples: 1024,
            seed: 0,
            outside: Outside::default(),
            tolerance: None,
            method: prefilter::PrefilterMethod::Tree,
            lobe_samples: 1024,
            source: Source::default(),
            nonfinite: Default::default(),
            max_memory: None,
        }
    }
}

/// A [`PrefilterRequest`] checked against its environment.
#[derive(Clone, Debug)]
pub struct ResolvedPrefilter {
    /// The environment: its mapping, cube layout, view and NaN/Inf rule.
    pub env: ResolvedEnv,
    pub layout: Option<crate::images::cube_layout::Layout>,
    pub prefilter: prefilter::Prefilter,
}

/// The report of `spheremap prefilter --json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PrefilterReport {
    pub input: String,
    pub output: Vec<String>,
    pub mapping: String,
    pub size: usize,
    pub irradiance: bool,
    pub roughness_map: &'static str,
    pub samples: u32,
    pub levels: Vec<prefilter::LevelReport>,
    /// The KTX2/DDS texel encoding, and with one other than float, what it did to each
    /// level's light ([`crate::images::compress`]).
    pub encode: crate::images::compress::Encoding,
    pub compression: Option<Vec<crate::images::compress::LevelCompression>>,
    pub seconds: f64,
}

/// The token an output name holds for the level number.
pub const LEVEL_TOKEN: &str = "{level}";

impl PrefilterRequest {
    /// The environment's fields.
    pub fn env_request(&self) -> EnvRequest {
        EnvRequest {
            source: self.source.clone(),
            nonfinite: self.nonfinite,
        }
    }

    /// Checks every field; errors name the field.
    pub fn resolve(&self, note: Option<&MapNote>, input: &str) -> Result<ResolvedPrefilter> {
        use crate::mappings::mapping::Mapping;
        let r = self.env_request().resolve(note, input)?;
        let mapping =
            Mapping::parse(&self.to, self.preset.as_deref()).map_err(|e| e.named("to"))?;
        let layout = self
            .layout
            .as_deref()
            .map(crate::images::cube_layout::Layout::parse)
            .transpose()
            .map_err(|e| e.named("layout"))?;
        if layout.is_some() && !matches!(mapping, Mapping::Cube(_)) {
            return Err(Error::param(
                "layout",
                format!(
                    "a cube layout, but the output mapping is {}",
                    mapping.name()
                ),
            ));
        }
        let size = self.size.unwrap_or(if self.irradiance { 32 } else { 256 });
        crate::base::limits::check_map_size("size", size)?;
        let levels = match (self.levels, self.irradiance) {
            (Some(l), true) if l != 1 => {
                return Err(Error::param(
                    "levels",
                    format!("{l}: the irradiance is one level"),
                ))
            }
            (Some(l), _) => l,
            (None, true) => 1,
            (None, false) => prefilter::default_levels(size),
        };
        if levels == 0 || levels > prefilter::max_levels(size) {
            return Err(Error::param(
                "levels",
                format!(
                    "{levels} is out of range 1..={} for size {size}",
                    prefilter::max_levels(size)
                ),
            ));
        }
        crate::base::limits::check_samples(self.samples, self.max_samples)?;
        let view = crate::frame::view::output_view(self.look, self.up, None)?;
        let tolerance = self.tolerance.unwrap_or(prefilter::DEFAULT_TOLERANCE);
        crate::base::limits::check_range(
            "lobe_samples",
            self.lobe_samples,
            1,
            crate::base::limits::LOBE_SAMPLES,
        )?;
        if !(tolerance > 0.0 && tolerance <= 0.1) {
            return Err(Error::param(
                "tolerance",
                format!("{tolerance} is out of range (0, 0.1]"),
            ));
        }
        Ok(ResolvedPrefilter {
            layout,
            prefilter: prefilter::Prefilter {
                mapping,
                size,
                levels,
                map: self.roughness_map,
                irradiance: self.irradiance,
                view,
                world_to_env: r.world_to_env,
                samples: self.samples,
                max_samples: self.max_samples,
                seed: self.seed,
                outside: self.outside,
                max_memory: self.max_memory.unwrap_or_else(default_max_memory),
                rule: envtree::CutRule {
                    tol: tolerance,
                    ..Default::default()
                },
                method: self.method,
                lobe_samples: self.lobe_samples,
                footprint: true,
            },
            env: r,
        })
    }

    /// Prefilters an environment in memory (a cube map as its F×6F face stack): the levels,
    /// level 0 first (a cube's as face stacks).
    pub fn run_image(
        &self,
        image: &Image,
        progress: Option<&Progress>,
    ) -> Result<Vec<(Image, prefilter::LevelReport)>> {
        let r = self.resolve(None, "env")?;
        let env = EnvMap::new(r.env.mapping, image, "env")?;
        prefilter::prefilter(&env, &r.prefilter, progress)
    }

    /// The files `output` names for `levels` levels of `mapping`: one KTX2/DDS texture, one
    /// image per level (`{level}` in the name), or one image for one level.
    pub fn output_files(output: &str, levels: usize, layout_given: bool) -> Result<Vec<String>> {
        let container = crate::images::format::Format::names_container(output);
        if output.contains(LEVEL_TOKEN) {
            Ok((0..levels)
                .map(|i| output.replace(LEVEL_TOKEN, &i.to_string()))
                .collect())
        } else if container {
            if layout_given {
                return Err(Error::param(
                    "layout",
                    format!(
                        "{output}: a .ktx2/.dds texture holds a cube's six faces; a layout \
                         applies to levels written as images ({LEVEL_TOKEN} in the name)"
                    ),
                ));
            }
            Ok(vec![output.to_string()])
        } else if levels == 1 {
            Ok(vec![output.to_string()])
        } else {
            Err(Error::param(
                "output",
                format!(
                    "{output}: {levels} levels need {LEVEL_TOKEN} in the name (one image per \
                     level) or a .ktx2/.dds file (every level in one texture)"
                ),
            ))
        }
    }
}

impl EnvJob for PrefilterRequest {
    type Report = PrefilterReport;

    /// Reads the environment `input`, prefilters, and writes `output` atomically: every level
    /// in one `.ktx2`/`.dds` texture (a cube's faces, or a 2D mip chain), or one image per
    /// level with `{level}` in the name; each records its mapping and view.
    fn run_files_with(
        &self,
        input: &str,
        output: &str,
        write: &crate::images::codec::WriteOptions,
        force: bool,
        progress: Option<&Progress>,
        read: &mut crate::images::envmap::EnvReader<'_>,
    ) -> Result<(Self::Report, Option<String>)> {
        use crate::images::cube_layout::Layout;
        use crate::images::note::MapNote;
        let t0 = std::time::Instant::now();
        let files = EnvFiles::parse(input);
        let note = read_note(files.first())?;
        let r = self.resolve(note.as_ref(), input)?;
        let p = &r.prefilter;
        let names = Self::output_files(output, p.levels, r.layout.is_some())?;
        let outs: Vec<EnvFiles> = names.iter().map(|n| EnvFiles::parse(n)).collect();
        let all: Vec<String> = outs.iter().flat_map(|o| o.paths()).collect();
        if !force {
            refuse_overwrite(&files.paths(), &all)?;
        }
        for o in &outs {
            o.check_output(p.mapping)?;
        }
        let img = r.env.read(&files, read)?;
        let env = EnvMap::new(r.env.mapping, &img, files.first())?;
        let made = prefilter::prefilter(&env, p, progress)?;
        let cube = matches!(p.mapping, crate::mappings::mapping::Mapping::Cube(_));
        let one_texture =
            !output.contains(LEVEL_TOKEN) && crate::images::format::Format::names_container(output);
        // Nothing is written unless every level can be: a value beyond half's range is found
        // before the first file.
        if write.half
            && !write.clamp_half
            && write.encode == crate::images::compress::Encoding::Float
        {
            for (img, _) in &made {
                let l = crate::images::codec::Losses::of(
                    img,
                    crate::images::format::Format::Exr,
                    write,
                );
                if l.beyond_half > 0 {
                    return Err(crate::images::codec::beyond_half_error(
                        std::path::Path::new(&names[0]),
                        &l,
                    ));
                }
            }
        }
        let mut compression = None;
        let written = if one_texture {
            // One texture with every level.
            let tag = MapNote {
                mapping: p.mapping,
                layout: cube.then_some(Layout::VStrip),
                face: None,
                view: crate::frame::view::as_look_up(&p.view),
            };
            let tex = crate::images::container::Texture {
                cube,
                levels: made.iter().map(|(i, _)| i.clone()).collect(),
            };
            compression = crate::images::codec::write_texture(
                std::path::Path::new(&names[0]),
                &tex,
                write,
                Some(&tag.text()),
            )?;
            names.clone()
        } else {
            let mut w = Vec::new();
            for (o, (img, _)) in outs.iter().zip(&made) {
                w.extend(crate::images::envmap::write_env_files(
                    o, p.mapping, img, r.layout, &p.view, write,
                )?);
            }
            w
        };
        Ok((
            PrefilterReport {
                input: files.label(),
                output: written,
                mapping: p.mapping.name().to_string(),
                size: p.size,
                irradiance: p.irradiance,
                roughness_map: p.map.name(),
                samples: p.samples,
                levels: made.into_iter().map(|(_, l)| l).collect(),
                encode: write.encode,
                compression,
                seconds: t0.elapsed().as_secs_f64(),
            },
            r.env.notice,
        ))
    }
}

impl crate::jobs::Report for PrefilterReport {
    fn lines(&self) -> Vec<String> {
        let r = self;
        let mut o = vec![format!(
            "{} -> {} ({} {}, {} level{}), {:.3} s",
            r.input,
            r.output.join(", "),
            r.mapping,
            if r.irradiance {
                "irradiance"
            } else {
                "GGX radiance"
            },
            r.levels.len(),
            if r.levels.len() == 1 { "" } else { "s" },
            r.seconds
        )];
        for l in &r.levels {
            o.push(format!(
                "  level {}: {}x{} roughness {} ({:?}, {} integrals, {:.3} s)",
                l.level,
                l.width,
                l.height,
                l.roughness.map_or("-".to_string(), |r| format!("{r:.4}")),
                l.method,
                l.integrals,
                l.seconds
            ));
        }
        o
    }
}
