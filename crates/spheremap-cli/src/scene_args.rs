//! The flags that describe what rays see — a scene file or built-in scene, an environment
//! map, lights, shading — shared by `generate` (a map from a point) and `preview` (a photo
//! through a camera): they fill the core's `jobs::scene::SceneRequest`.

use crate::job::{vec3, JobFlags};
use spheremap::images::codec::NonFinite;
use spheremap::jobs::scene::SceneRequest;
use spheremap::trace::scene::Shading;

/// A scene request's error as the flags name it (`--sun`, `--point-light`, `--scene`, …).
pub fn flag_error(e: spheremap::Error) -> anyhow::Error {
    crate::flag_error(
        e.renamed("suns", "sun")
            .renamed("point_lights", "point_light"),
    )
}

#[derive(clap::Args, Debug)]
pub struct SceneArgs {
    /// Scene file: OBJ (+MTL) or glTF 2.0 (.gltf/.glb); or a built-in scene: builtin:demo,
    /// builtin:octants (inside a sphere whose octants glow in 8 colours), builtin:mirror-ball
    /// (a chrome ball of radius 1 at the origin, reflectance 0.75).
    #[arg(long)]
    pub scene: Option<String>,
    /// Environment map: what rays leaving the scene see (and the light it casts); without
    /// --scene, the rays look it up directly (e.g. six cube faces taken around the point:
    /// 'faces_{face}.exr' --from cube).
    #[arg(long)]
    pub env: Option<String>,
    #[command(flatten)]
    source: crate::source_args::SourceArgs,
    /// Constant environment colour (linear RGB) when there is no --env; default black.
    #[arg(long, num_args = 3, value_names = ["R", "G", "B"], allow_negative_numbers = true)]
    background: Option<Vec<f32>>,
    /// A point light: position and intensity (repeatable).
    #[arg(long, num_args = 6, value_names = ["X", "Y", "Z", "R", "G", "B"], allow_negative_numbers = true, action = clap::ArgAction::Append)]
    point_light: Vec<f32>,
    /// A directional light: the direction the light travels and its irradiance (repeatable).
    #[arg(long, num_args = 6, value_names = ["DX", "DY", "DZ", "R", "G", "B"], allow_negative_numbers = true, action = clap::ArgAction::Append)]
    sun: Vec<f32>,
    /// full (emission, lights with shadows, environment light, mirrors; default) or emission
    /// (the emitted colour of the first surface hit only).
    #[arg(long, default_value_t, value_parser = crate::names::typed::<Shading>())]
    shading: Shading,
    /// Mirror bounces followed at most.
    #[arg(long, default_value_t = SceneRequest::default().max_depth)]
    max_depth: u32,
    /// Cosine rays per diffuse hit for environment and emitter light (0 = none).
    #[arg(long, default_value_t = SceneRequest::default().indirect_samples)]
    indirect_samples: u32,
}

impl SceneArgs {
    /// The core's scene request for these flags.
    pub fn request(&self, nonfinite: NonFinite, seed: u64) -> SceneRequest {
        let sixes = |v: &[f32]| -> Vec<[f32; 6]> {
            v.chunks_exact(6)
                .map(|l| std::array::from_fn(|i| l[i]))
                .collect()
        };
        SceneRequest {
            scene: self.scene.clone(),
            source: self.source.source(),
            nonfinite,
            background: vec3(&self.background),
            point_lights: sixes(&self.point_light),
            suns: sixes(&self.sun),
            shading: self.shading,
            max_depth: self.max_depth,
            indirect_samples: self.indirect_samples,
            seed,
            ..Default::default()
        }
    }

    /// Refuses (unless --force) outputs that would overwrite the scene or the map.
    pub fn refuse_overwrite(&self, job: &JobFlags, outputs: &[String]) -> anyhow::Result<()> {
        let inputs: Vec<&String> = self.scene.iter().chain(&self.env).collect();
        job.refuse_overwrite(&inputs, outputs)
    }
}
