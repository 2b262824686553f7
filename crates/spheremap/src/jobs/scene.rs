//! What rays see, as one request: [`SceneRequest`] holds the scene (a file or a built-in one),
//! the environment's fields (the map itself is read from a file or handed over as an image),
//! the background, lights and shading options that `spheremap generate` and `preview`, and
//! Python's `Scene.load` and `Scene.builtin`, take — and builds the ray tracer's scene with the
//! core's rules in one place.

use crate::base::error::{Error, Result};
use crate::frame::view::Mat3;
use crate::images::codec::{check_nonfinite, Losses, NonFinite, ReadOptions, WriteOptions};
use crate::images::envmap::{read_env, read_note, write_env, EnvFiles};
use crate::images::format::Format;
use crate::images::Image;
use crate::jobs::source::Source;
use crate::mappings::mapping::Mapping;
use crate::resample::{EnvMap, Progress, IDENTITY};
use crate::trace::generate::{
    generate, EnvSource, GenerateOptions, GenerateSummary, MapRequest, RaySource,
};
use crate::trace::scene::{Builtin, Environment, Light, Scene, Shading};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The prefix of a built-in scene's name where a scene file may be named.
pub const BUILTIN_PREFIX: &str = "builtin:";

/// A scene and what lights it.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneRequest {
    /// A scene file (OBJ + MTL, glTF/GLB) or a built-in scene, `builtin:NAME`; `None`: none
    /// (rays look the environment up directly).
    pub scene: Option<String>,
    /// The built-in mirror ball's reflectance, in [0, 1].
    pub reflectance: f32,
    /// The environment map's mapping, preset, cube layout and view (`src`, …; default its
    /// note, else lat-long).
    #[serde(flatten)]
    pub source: Source,
    /// NaN/Inf in the environment map.
    pub nonfinite: NonFinite,
    /// A constant environment colour (linear RGB) where there is no map; default black, the
    /// demo scene its own sky.
    pub background: Option<[f32; 3]>,
    /// Point lights: position, then intensity.
    pub point_lights: Vec<[f32; 6]>,
    /// Directional lights: the direction the light travels, then its irradiance.
    pub suns: Vec<[f32; 6]>,
    pub shading: Shading,
    /// Mirror bounces followed at most.
    pub max_depth: u32,
    /// Cosine rays per diffuse hit for environment and emitter light (0 = none).
    pub indirect_samples: u32,
    /// Seed of the scene's random rays.
    pub seed: u64,
}

impl Default for SceneRequest {
    fn default() -> Self {
        let options = crate::trace::scene::ShadeOptions::default();
        SceneRequest {
            scene: None,
            reflectance: 0.75,
            source: Source::default(),
            nonfinite: NonFinite::default(),
            background: None,
            point_lights: Vec::new(),
            suns: Vec::new(),
            shading: options.shading,
            max_depth: options.max_depth,
            indirect_samples: options.indirect_samples,
            seed: options.seed,
        }
    }
}

/// An environment map read for a scene: its texels, mapping and the rotation from world
/// directions to its frame.
#[derive(Clone, Debug)]
pub struct SceneEnv {
    pub image: Image,
    pub mapping: Mapping,
    pub rotation: Mat3,
}

impl SceneRequest {
    /// Reads the environment map at `path` by the source fields (its note's defaults, else
    /// lat-long) and the NaN/Inf rule.
    pub fn read_env(&self, path: &str) -> Result<SceneEnv> {
        let note = read_note(path)?;
        let r = self.source.resolve(note.as_ref(), path, Some("latlong"))?;
        let mut image = read_env(path, r.mapping, r.layout, &ReadOptions::default())?;
        check_nonfinite(&mut image, self.nonfinite, path)?;
        self.env_of(image, path)
    }

    /// An environment map given as its texels (a cube map as its face stack) read by the
    /// source fields (default lat-long); `name` names it in errors.
    pub fn env_of(&self, mut image: Image, name: &str) -> Result<SceneEnv> {
        let r = self.source.resolve(None, name, Some("latlong"))?;
        check_nonfinite(&mut image, self.nonfinite, name)?;
        EnvMap::new(r.mapping, &image, name)?;
        Ok(SceneEnv {
            image,
            mapping: r.mapping,
            rotation: r.world_to_src,
        })
    }

    /// The scene `scene` names (`None` without one), lit by `env` (else the background) and
    /// the lights, with the shading options.
    pub fn build(&self, env: Option<&SceneEnv>) -> Result<Option<Scene>> {
        let Some(name) = &self.scene else {
            if env.is_none() {
                return Err(Error::param(
                    "scene",
                    "give a scene (a file or builtin:demo) and/or an environment map to fire \
                     rays into",
                ));
            }
            return Ok(None);
        };
        let mut scene = match name.strip_prefix(BUILTIN_PREFIX) {
            Some(b) => Builtin::parse_as(b, "scene")?.scene(self.reflectance)?,
            None => Scene::load(Path::new(name))?,
        };
        self.light(&mut scene, env)?;
        Ok(Some(scene))
    }

    /// Lights `scene` as the request says: its environment (`env`, else the background, else
    /// its own — a built-in scene's sky — or black), lights and shading options.
    pub fn light(&self, scene: &mut Scene, env: Option<&SceneEnv>) -> Result<()> {
        let finite = |v: &[f32], field: &str| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(Error::param(
                    field,
                    format!("expected finite numbers, got {v:?}"),
                ))
            }
        };
        scene.environment = match (env, self.background) {
            (Some(_), Some(_)) => {
                return Err(Error::param(
                    "background",
                    "give a background colour or an environment map, not both",
                ))
            }
            (Some(e), None) => Environment::Map {
                image: e.image.clone(),
                mapping: e.mapping,
                rotation: e.rotation,
            },
            (None, Some(c)) => {
                finite(&c, "background")?;
                Environment::Constant(c)
            }
            (None, None) => match &scene.environment {
                Environment::Constant(c) if self.scene.as_deref() == Some("builtin:demo") => {
                    Environment::Constant(*c)
                }
                _ => Environment::Constant([0.0; 3]),
            },
        };
        for l in &self.point_lights {
            finite(l, "point_lights")?;
            scene.lights.push(Light::Point {
                position: [l[0], l[1], l[2]],
                intensity: [l[3], l[4], l[5]],
            });
        }
        for l in &self.suns {
            finite(l, "suns")?;
            if l[..3] == [0.0; 3] {
                return Err(Error::param("suns", "a direction must not be zero"));
            }
            scene.lights.push(Light::Directional {
                direction: [l[0], l[1], l[2]],
                irradiance: [l[3], l[4], l[5]],
            });
        }
        scene.options.shading = self.shading;
        scene.options.max_depth = self.max_depth;
        scene.options.indirect_samples = self.indirect_samples;
        scene.options.seed = self.seed;
        Ok(())
    }
}

/// What rays see, loaded: the scene, and the environment map (what rays leaving the scene see,
/// or without a scene what they look up directly).
pub struct World {
    pub scene: Option<Scene>,
    pub env: Option<SceneEnv>,
}

/// A loaded scene as a ray source.
struct SceneRef<'a>(&'a Scene);

impl RaySource for SceneRef<'_> {
    fn channels(&self) -> usize {
        self.0.channels()
    }
    fn trace(&self, origins: &[[f32; 3]], directions: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        self.0.trace(origins, directions, out)
    }
}

impl World {
    /// The ray source: the scene if there is one, else the environment map.
    pub fn source(&self) -> Box<dyn RaySource + '_> {
        match (&self.scene, &self.env) {
            (Some(s), _) => Box::new(SceneRef(s)),
            (None, Some(e)) => {
                let map = EnvMap {
                    mapping: e.mapping,
                    width: e.image.width,
                    height: e.image.height,
                    channels: e.image.channels,
                    data: &e.image.data,
                };
                Box::new(EnvSource::new(&map, e.rotation))
            }
            _ => unreachable!("SceneRequest::build refuses a world without either"),
        }
    }
}

impl SceneRequest {
    /// Loads what rays see: the scene and the environment map at `env`.
    pub fn load(&self, env: Option<&str>) -> Result<World> {
        let env = env.map(|e| self.read_env(e)).transpose()?;
        let scene = self.build(env.as_ref())?;
        Ok(World { scene, env })
    }

    /// `spheremap generate` on files: the map `map` asks for, made by firing rays from its
    /// position into this scene (and/or the environment map at `env`), written to `output`;
    /// with `faces`, also the six cube faces at that position (in the world's frame, as six
    /// cameras there would take them) into that folder as `{face}.exr`, at that size (default
    /// the map's).  The report.
    pub fn generate_files(
        &self,
        map: &MapRequest,
        env: Option<&str>,
        output: &str,
        faces: Option<(&Path, Option<usize>)>,
        write: &WriteOptions,
        progress: Option<&Progress>,
    ) -> Result<GenerateSummary> {
        let m = map.resolve()?;
        EnvFiles::parse(output).check_output(m.mapping)?;
        let world = self.load(env)?;
        let source = world.source();
        let t0 = std::time::Instant::now();
        let (out, r) = generate(
            m.mapping,
            m.width,
            m.height,
            source.as_ref(),
            &m.options,
            progress,
        )?;
        let seconds = t0.elapsed().as_secs_f64();
        let mut written = write_env(output, m.mapping, &out, m.layout, &m.view, write)?;
        if let Some((dir, size)) = faces {
            let cube = Mapping::parse("cube", None)?;
            let f = size.unwrap_or(map.size);
            crate::base::limits::check_map_size("faces_size", f)?;
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
            let opts = GenerateOptions {
                rotation: IDENTITY,
                ..m.options
            };
            let (faces, _) = generate(cube, f, 6 * f, source.as_ref(), &opts, progress)?;
            let pattern = dir.join("{face}.exr").display().to_string();
            written.extend(write_env(&pattern, cube, &faces, None, &IDENTITY, write)?);
        }
        let losses = Format::from_extension(Path::new(&written[0]))
            .map(|f| Losses::of(&out, f, write))
            .unwrap_or_default();
        let scene = world.scene.as_ref();
        Ok(GenerateSummary {
            scene: self.scene.clone(),
            env: env.map(String::from),
            output: written,
            to: m.mapping.name(),
            preset: m.mapping.preset_name(),
            size: map.size,
            width: out.width,
            height: out.height,
            samples: map.samples,
            filter: map.filter.name(),
            outside: map.outside.name(),
            triangles: scene.map(|s| s.triangle_count()),
            degenerate_triangles: scene.map(|s| s.degenerate_count()),
            lights: scene.map(|s| s.lights.len()),
            rays: r.rays,
            texels_traced: r.texels,
            rays_per_texel: r.rays as f64 / r.texels.max(1) as f64,
            max_texel_samples: r.max_texel_samples,
            seconds,
            rays_per_second: r.rays as f64 / seconds.max(1e-9),
            clipped: losses.clipped,
            clamped_half: losses.beyond_half,
        })
    }
}

impl SceneRequest {
    /// `spheremap preview` on files: what the camera of `preview` sees of this scene (and/or
    /// the environment map at `env`), written to `output`; the report.
    pub fn preview_files(
        &self,
        preview: &crate::trace::camera::PreviewRequest,
        env: Option<&str>,
        output: &str,
        write: &WriteOptions,
        progress: Option<&Progress>,
    ) -> Result<crate::trace::camera::PreviewReport> {
        let cam = preview.camera()?;
        let world = self.load(env)?;
        let source = world.source();
        let t0 = std::time::Instant::now();
        let img = crate::trace::camera::render(
            &cam,
            source.as_ref(),
            preview.samples,
            preview.seed,
            false,
            progress,
        )?;
        let seconds = t0.elapsed().as_secs_f64();
        crate::images::codec::write_image(Path::new(output), &img, write)?;
        let losses = Format::from_extension(Path::new(output))
            .map(|f| Losses::of(&img, f, write))
            .unwrap_or_default();
        Ok(cam.report(output, preview.samples, seconds, losses.into()))
    }
}

impl crate::jobs::Report for GenerateSummary {
    /// A note on zero-area triangles, and the map made.
    fn lines(&self) -> Vec<String> {
        let mut o = Vec::new();
        if let Some(n) = self.degenerate_triangles.filter(|&n| n > 0) {
            o.push(format!(
                "note: {n} degenerate (zero-area) triangles in the scene are ignored"
            ));
        }
        o.push(format!(
            "{} -> {} ({} {}, {}x{}): {} rays ({:.1}/texel), {:.3} s, {:.2} Mrays/s",
            self.scene.as_deref().or(self.env.as_deref()).unwrap_or(""),
            self.output.join(", "),
            self.to,
            self.preset,
            self.width,
            self.height,
            self.rays,
            self.rays_per_texel,
            self.seconds,
            self.rays_per_second / 1e6
        ));
        o
    }
}

impl crate::jobs::Report for crate::trace::camera::PreviewReport {
    fn lines(&self) -> Vec<String> {
        vec![format!(
            "-> {} ({}x{}, {} rays/pixel): {:.3} s",
            self.output, self.width, self.height, self.samples, self.seconds
        )]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(scene: &str) -> SceneRequest {
        SceneRequest {
            scene: Some(scene.into()),
            ..Default::default()
        }
    }

    #[test]
    fn a_built_in_scene_keeps_its_sky_unless_told_and_takes_the_lights_and_options() {
        let demo = request("builtin:demo").build(None).unwrap().unwrap();
        let own = match crate::trace::scene::Builtin::Demo
            .scene(0.75)
            .unwrap()
            .environment
        {
            Environment::Constant(c) => c,
            _ => unreachable!("the demo's sky is a colour"),
        };
        assert!(matches!(demo.environment, Environment::Constant(c) if c == own));
        let r = SceneRequest {
            background: Some([0.5, 0.25, 1.0]),
            point_lights: vec![[0.0, 2.0, 0.0, 1.0, 1.0, 1.0]],
            suns: vec![[0.0, -1.0, 0.0, 3.0, 3.0, 3.0]],
            max_depth: 2,
            seed: 7,
            ..request("builtin:octants")
        };
        let s = r.build(None).unwrap().unwrap();
        assert!(matches!(
            s.environment,
            Environment::Constant([0.5, 0.25, 1.0])
        ));
        assert_eq!(s.lights.len(), 2);
        assert_eq!((s.options.max_depth, s.options.seed), (2, 7));
    }

    #[test]
    fn a_map_and_its_cube_faces_are_generated_written_and_reported() {
        use crate::jobs::Report;
        let dir = std::env::temp_dir().join(format!("spheremap-generate-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("octants.exr");
        let map = MapRequest {
            size: 8,
            samples: 1,
            ..Default::default()
        };
        let r = request("builtin:octants")
            .generate_files(
                &map,
                None,
                out.to_str().unwrap(),
                Some((&dir.join("faces"), Some(4))),
                &WriteOptions::default(),
                None,
            )
            .unwrap();
        assert_eq!((r.width, r.height, r.output.len()), (8, 8, 7));
        // One ray per texel whose centre is on the disc (52 of an 8×8 sphere map).
        assert_eq!((r.rays, r.texels_traced), (52, 52));
        assert!(dir.join("faces").join("px.exr").is_file() && out.is_file());
        assert!(r.lines().last().unwrap().starts_with("builtin:octants -> "));
        let photo = dir.join("look.exr");
        let preview = crate::trace::camera::PreviewRequest {
            eye: Some([0.0; 3]),
            target: Some([0.0, 0.0, -1.0]),
            width: 8,
            height: 6,
            samples: 1,
            ..Default::default()
        };
        let p = request("builtin:octants")
            .preview_files(
                &preview,
                None,
                photo.to_str().unwrap(),
                &WriteOptions::default(),
                None,
            )
            .unwrap();
        assert_eq!((p.width, p.height, p.samples), (8, 6, 1));
        assert!(photo.is_file() && p.lines()[0].starts_with(&format!("-> {}", photo.display())));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn mistakes_are_refused_naming_the_field() {
        let e = |r: SceneRequest, env: Option<&SceneEnv>| match r.build(env) {
            Ok(_) => panic!("taken"),
            Err(e) => e.to_string(),
        };
        assert!(e(SceneRequest::default(), None).starts_with("scene: give a scene"));
        assert!(e(request("builtin:nope"), None).starts_with("scene: unknown built-in scene"));
        let bad = SceneRequest {
            reflectance: 2.0,
            ..request("builtin:mirror-ball")
        };
        assert!(e(bad, None).starts_with("reflectance: "));
        let sun = SceneRequest {
            suns: vec![[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]],
            ..request("builtin:octants")
        };
        assert!(e(sun, None).starts_with("suns: "));
        let env = SceneRequest::default()
            .env_of(Image::new(8, 4, 3), "sky")
            .unwrap();
        let both = SceneRequest {
            background: Some([1.0; 3]),
            ..request("builtin:octants")
        };
        assert!(e(both, Some(&env)).starts_with("background: "));
        // An environment alone is a ray source: no scene is built.
        assert!(SceneRequest::default().build(Some(&env)).unwrap().is_none());
    }
}
