//! A MatCap bake as one request: [`MatcapRequest`] holds what `spheremap bake-matcap`,
//! Python's `bake_matcap` and a recipe's `bake-matcap` output take — the material, the view,
//! the sampling and the environment's [`Source`] — checks it once ([`MatcapRequest::resolve`])
//! and runs [`crate::lighting::matcap::bake`] on files or on an image in memory.

use crate::base::error::{Error, Result};
use crate::base::limits::default_max_memory;
use crate::images::envmap::{read_note, refuse_overwrite, EnvFiles};
use crate::images::note::MapNote;
use crate::images::Image;
use crate::jobs::env_job::EnvJob;
use crate::jobs::source::{EnvRequest, ResolvedEnv, Source};
use crate::lighting::brdf::{self, Material};
use crate::lighting::{envtree, matcap};
use crate::resample::{EnvMap, Outside, Progress, DEFAULT_SAMPLES};

/// A MatCap bake as users name it: `spheremap bake-matcap` and Python's `bake_matcap` fill the
/// same fields (serde-readable, unknown keys refused); [`MatcapRequest::resolve`] checks them.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatcapRequest {
    /// `lambert` or `ggx`.
    pub material: brdf::MaterialName,
    /// GGX perceptual roughness in 0..=1 (α = roughness²); 0 is the mirror.
    pub roughness: f64,
    /// Linear RGB albedo; default 0.8 grey for Lambert, white for GGX.
    pub albedo: Option<[f64; 3]>,
    /// Output size N (N×N).
    pub size: usize,
    /// The MatCap's view: world directions of the eye's −Z and +Y.
    pub look: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    /// Spatial samples per texel (1: the centre), the most a texel may take, the jitter's seed,
    /// what goes outside the disc (`gutter` or `black`).
    pub samples: u32,
    pub max_samples: u32,
    pub seed: u64,
    pub outside: Outside,
    /// The environment's mapping, preset and cube layout (default: its note, else lat-long),
    /// and its view when it is not the world's (default: its note's): `src`, `src_preset`, …
    /// (also read as `env_format`, `env_preset`, …).
    #[serde(flatten)]
    pub source: Source,
    /// NaN/Inf in the environment: error, zero or keep.
    pub nonfinite: crate::images::codec::NonFinite,
    /// Refuse a job needing more bytes than this (`None`: the default limit).
    pub max_memory: Option<u64>,
}

impl Default for MatcapRequest {
    fn default() -> Self {
        MatcapRequest {
            material: brdf::MaterialName::Ggx,
            roughness: 0.5,
            albedo: None,
            size: 256,
            look: None,
            up: None,
            samples: DEFAULT_SAMPLES,
            max_samples: 1024,
            seed: 0,
            outside: Outside::default(),
            source: Source::default(),
            nonfinite: Default::default(),
            max_memory: None,
        }
    }
}

/// A [`MatcapRequest`] checked against its environment.
#[derive(Clone, Debug)]
pub struct ResolvedMatcap {
    /// The environment: its mapping, cube layout, view and NaN/Inf rule.
    pub env: ResolvedEnv,
    pub bake: matcap::Bake,
}

/// The report of `spheremap bake-matcap --json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MatcapReport {
    pub input: String,
    pub output: Vec<String>,
    pub material: &'static str,
    pub roughness: f64,
    pub albedo: [f64; 3],
    pub size: usize,
    pub channels: usize,
    pub samples: u32,
    /// How the lobes were integrated: `tree`, `vndf`, `mirror` or `cosine` (Lambert).
    pub method: matcap::Method,
    /// The environment tree's cube face (0 for the mirror).
    pub tree_face: usize,
    /// Lighting integrals computed (one per spatial sample, or per point of the grid of normals).
    pub integrals: u64,
    pub max_texel_samples: u32,
    pub seconds: f64,
}

impl MatcapRequest {
    /// The environment's fields.
    pub fn env_request(&self) -> EnvRequest {
        EnvRequest {
            source: self.source.clone(),
            nonfinite: self.nonfinite,
        }
    }

    /// Checks every field; errors name the field.  `note` is what the environment's file
    /// records (`None` for an array), `input` names it.
    pub fn resolve(&self, note: Option<&MapNote>, input: &str) -> Result<ResolvedMatcap> {
        let r = self.env_request().resolve(note, input)?;
        let material = Material::of(self.material, self.roughness)?;
        if material == Material::Lambert && !(0.0..=1.0).contains(&self.roughness) {
            return Err(Error::param(
                "roughness",
                format!("{} is out of range 0..=1", self.roughness),
            ));
        }
        let albedo = matcap::check_albedo(self.albedo.unwrap_or(material.default_albedo()))?;
        crate::base::limits::check_map_size("size", self.size)?;
        crate::base::limits::check_samples(self.samples, self.max_samples)?;
        let view = crate::frame::view::output_view(self.look, self.up, None)?;
        let world_to_env = r.world_to_env;
        Ok(ResolvedMatcap {
            bake: matcap::Bake {
                material,
                albedo,
                size: self.size,
                view,
                world_to_env,
                samples: self.samples,
                max_samples: self.max_samples,
                seed: self.seed,
                outside: self.outside,
                max_memory: self.max_memory.unwrap_or_else(default_max_memory),
                rule: envtree::CutRule::default(),
                normal_table: None,
            },
            env: r,
        })
    }

    /// Bakes from an environment in memory (a cube map as its F×6F face stack).
    pub fn run_image(
        &self,
        image: &Image,
        progress: Option<&Progress>,
    ) -> Result<(Image, matcap::BakeReport)> {
        let r = self.resolve(None, "env")?;
        let env = EnvMap::new(r.env.mapping, image, "env")?;
        matcap::bake(&env, &r.bake, progress)
    }
}

impl EnvJob for MatcapRequest {
    type Report = MatcapReport;

    /// Reads the environment `input` (one image, a face pattern), bakes, and writes `output`
    /// atomically with a sphere-map note of the view (the MatCap of a mirror is the sphere map;
    /// of any material, the map of its reflected light addressed by reflection).
    fn run_files_with(
        &self,
        input: &str,
        output: &str,
        write: &crate::images::codec::WriteOptions,
        force: bool,
        progress: Option<&Progress>,
        read: &mut crate::images::envmap::EnvReader<'_>,
    ) -> Result<(Self::Report, Option<String>)> {
        let t0 = std::time::Instant::now();
        let files = EnvFiles::parse(input);
        let note = read_note(files.first())?;
        let r = self.resolve(note.as_ref(), input)?;
        let out = EnvFiles::parse(output);
        if !force {
            refuse_overwrite(&files.paths(), &out.paths())?;
        }
        let sphere = crate::mappings::mapping::Mapping::parse("sphere", None)?;
        out.check_output(sphere)?;
        let img = r.env.read(&files, read)?;
        let env = EnvMap::new(r.env.mapping, &img, files.first())?;
        let (map, rep) = matcap::bake(&env, &r.bake, progress)?;
        let written =
            crate::images::envmap::write_env_files(&out, sphere, &map, None, &r.bake.view, write)?;
        Ok((
            MatcapReport {
                input: files.label(),
                output: written,
                material: r.bake.material.name(),
                roughness: self.roughness,
                albedo: r.bake.albedo,
                size: self.size,
                channels: map.channels,
                samples: self.samples,
                method: rep.method,
                tree_face: rep.tree_face,
                integrals: rep.integrals,
                max_texel_samples: rep.max_texel_samples,
                seconds: t0.elapsed().as_secs_f64(),
            },
            r.env.notice,
        ))
    }
}

impl crate::jobs::Report for MatcapReport {
    fn lines(&self) -> Vec<String> {
        let r = self;
        vec![format!(
            "{} -> {} ({} roughness {}, {}x{}): {} integrals ({:?}), {:.3} s",
            r.input,
            r.output.join(", "),
            r.material,
            r.roughness,
            r.size,
            r.size,
            r.integrals,
            r.method,
            r.seconds
        )]
    }
}
