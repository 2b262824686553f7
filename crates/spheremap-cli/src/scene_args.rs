//! The flags that describe what rays see — a scene file or built-in scene, an environment
//! map, lights, shading — shared by `generate` (a map from a point) and `preview` (a photo
//! through a camera).

use crate::job::{vec3, JobFlags};
use anyhow::bail;
use spheremap::frame::view::Mat3;
use spheremap::images::codec::{check_nonfinite, ReadOptions};
use spheremap::images::envmap::read_env;
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::EnvMap;
use spheremap::trace::generate::{EnvSource, RaySource};
use spheremap::trace::scene::{self, Environment, Light, Scene, Shading};
use std::path::Path;

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
    #[arg(long, default_value_t = 8)]
    max_depth: u32,
    /// Cosine rays per diffuse hit for environment and emitter light (0 = none).
    #[arg(long, default_value_t = 1)]
    indirect_samples: u32,
}

/// What the rays see, loaded.
pub struct World {
    pub scene: Option<Scene>,
    /// The environment map, its mapping and the rotation from world directions to its frame.
    pub env: Option<(Image, Mapping, Mat3)>,
}

impl World {
    /// The ray source: the scene if there is one, else the environment map.
    pub fn source(&self) -> Box<dyn RaySource + '_> {
        match (&self.scene, &self.env) {
            (Some(s), _) => Box::new(SceneRef(s)),
            (None, Some((img, mapping, rotation))) => {
                let map = EnvMap {
                    mapping: *mapping,
                    width: img.width,
                    height: img.height,
                    channels: img.channels,
                    data: &img.data,
                };
                Box::new(EnvSource::new(&map, *rotation))
            }
            _ => unreachable!("checked on load"),
        }
    }
}

struct SceneRef<'a>(&'a Scene);

impl RaySource for SceneRef<'_> {
    fn channels(&self) -> usize {
        self.0.channels()
    }
    fn trace(
        &self,
        origins: &[[f32; 3]],
        directions: &[[f32; 3]],
        out: &mut [f32],
    ) -> spheremap::Result<()> {
        self.0.trace(origins, directions, out)
    }
}

/// Loads --scene (a file or builtin:NAME).
fn load_scene(name: &str) -> anyhow::Result<Scene> {
    Ok(match name.strip_prefix("builtin:") {
        Some(b) => scene::Builtin::parse_as(b, "--scene")?.scene(0.75)?,
        None => Scene::load(Path::new(name))?,
    })
}

impl SceneArgs {
    /// Loads the scene and/or the environment map; refuses outputs that would overwrite them.
    pub fn load(&self, job: &JobFlags, seed: u64, outputs: &[String]) -> anyhow::Result<World> {
        let shading = self.shading;
        if self.scene.is_none() && self.env.is_none() {
            bail!("give --scene FILE (or builtin:demo) and/or --env MAP to fire rays into");
        }
        let inputs: Vec<&String> = self.scene.iter().chain(&self.env).collect();
        job.refuse_overwrite(&inputs, outputs)?;
        let env: Option<(Image, Mapping, Mat3)> = match &self.env {
            Some(e) => {
                let (m, l, rotation) = self.source.read_as(e, "latlong")?;
                let mut img = read_env(e, m, l, &ReadOptions::default())?;
                check_nonfinite(&mut img, job.nonfinite()?, e)?;
                EnvMap::new(m, &img, e)?;
                Some((img, m, rotation))
            }
            None => None,
        };
        let scene = match &self.scene {
            Some(s) => {
                let mut sc = load_scene(s)?;
                sc.environment = match &env {
                    Some((img, m, rotation)) => Environment::Map {
                        image: img.clone(),
                        mapping: *m,
                        rotation: *rotation,
                    },
                    None => Environment::Constant(match vec3(&self.background) {
                        Some(c) => c,
                        None if s == "builtin:demo" => match &sc.environment {
                            Environment::Constant(c) => *c,
                            _ => [0.0; 3],
                        },
                        None => [0.0; 3],
                    }),
                };
                for l in self.point_light.chunks_exact(6) {
                    sc.lights.push(Light::Point {
                        position: [l[0], l[1], l[2]],
                        intensity: [l[3], l[4], l[5]],
                    });
                }
                for l in self.sun.chunks_exact(6) {
                    sc.lights.push(Light::Directional {
                        direction: [l[0], l[1], l[2]],
                        irradiance: [l[3], l[4], l[5]],
                    });
                }
                sc.options.shading = shading;
                sc.options.max_depth = self.max_depth;
                sc.options.indirect_samples = self.indirect_samples;
                sc.options.seed = seed;
                Some(sc)
            }
            None => None,
        };
        Ok(World { scene, env })
    }
}
