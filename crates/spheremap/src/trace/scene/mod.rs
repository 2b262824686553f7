//! A small ray tracer: triangle scenes (OBJ + MTL, glTF 2.0, or built in code) behind a BVH
//! (obvhs' compressed wide BVH8), usable as the generator's `fire_ray`.
//!
//! ## What colour a ray returns (`Shading::Full`, the default)
//!
//! A ray that hits nothing returns the **environment** in its direction (a constant colour or
//! an environment map).  A ray that hits a triangle returns, at the hit point `p` with the
//! shading normal `n` turned to face the ray:
//!
//! ```text
//!   L = E                                     emission (OBJ Ke, glTF emissiveFactor × strength)
//!     + ρ/π · Σ_lights  V · I · max(0, n·l)   direct light, ρ = diffuse colour × texture:
//!                                               point light: I = intensity / d², l toward it;
//!                                               directional: I = irradiance, l = −direction;
//!                                               V = 1 if the shadow ray reaches the light
//!     + S·(s+8)/(8π) · Σ_lights V · I · max(0, n·h)^s · max(0, n·l)
//!                                             highlights of the lights (normalised
//!                                               Blinn–Phong; S = specular colour, s = its
//!                                               exponent, h = normalize(l + v); lights only,
//!                                               not the environment)
//!     + ρ · (1/K) Σ_k L_e(ω_k)                environment and emitters seen by K cosine-
//!                                               distributed rays (K = indirect_samples): the
//!                                               emission of what they hit, else the environment
//!     + M · L(reflected ray)                  perfect mirror, M = mirror colour, up to
//!                                               max_depth bounces (then 0)
//! ```
//!
//! An **unlit** material (MTL `illum 0`, glTF `KHR_materials_unlit`) returns `L = E + ρ`
//! whatever the lights, the environment and its neighbours.
//!
//! There is no multiple diffuse inter-reflection (light bounces once off a diffuse surface).
//! The cosine rays are deterministic: their random numbers are a hash of the incoming ray's
//! bits and the seed, so a scene traced twice gives the same image.
//!
//! **An emission-only scene gives exactly the emitted colour of the first surface hit**: with
//! no lights, a black environment and materials without diffuse or mirror colour every term
//! but `E` is 0 — and [`Shading::Emission`] returns `E` of the first hit (the environment on a
//! miss) whatever the materials say; that mode is what is compared with other renderers.
//!
//! ## Units and frames
//!
//! World is right-handed, Y up.  Colours are linear; a point light's intensity is radiant
//! intensity (glTF candela taken as is), a directional light's irradiance glTF lux as is.
//! Texture coordinates are stored with v = 0 at the top row of the image (glTF's convention;
//! OBJ `vt`, whose v = 0 is the bottom, is flipped on load); textures repeat.

mod builtin;
mod load;

pub use builtin::{
    demo_scene, floor_scene, mirror_ball_scene, octant_colour, octant_sphere_scene, Builtin,
};

use crate::base::error::{Error, Result};
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use crate::resample::{EnvMap, Sampler};
use crate::trace::generate::RaySource;
use glam::{Vec3, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};

/// A surface's response (see the module docs for how each term enters).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub emission: [f32; 3],
    pub diffuse: [f32; 3],
    /// Index into the scene's textures; multiplies `diffuse`.
    pub diffuse_texture: Option<usize>,
    /// Perfect mirror reflectance (0 = none).
    pub mirror: [f32; 3],
    /// Colour of the lights' highlights (normalised Blinn–Phong; 0 = none).
    pub specular: [f32; 3],
    /// The highlights' exponent (MTL `Ns`).
    pub shininess: f32,
    /// Lit by nothing: the surface shows `emission + diffuse × texture` whatever the lights,
    /// environment and neighbours (MTL `illum 0`, glTF `KHR_materials_unlit`).
    pub unlit: bool,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: String::new(),
            emission: [0.0; 3],
            diffuse: [0.8; 3],
            diffuse_texture: None,
            mirror: [0.0; 3],
            specular: [0.0; 3],
            shininess: 0.0,
            unlit: false,
        }
    }
}

/// Lights with shadows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Point {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    /// Light from infinitely far away, travelling along `direction`.
    Directional {
        direction: [f32; 3],
        irradiance: [f32; 3],
    },
}

/// What rays that leave the scene see.
#[derive(Clone, Debug)]
pub enum Environment {
    Constant([f32; 3]),
    /// An environment map; `rotation` takes world directions to the map's frame.
    Map {
        image: Image,
        mapping: Mapping,
        rotation: [[f64; 3]; 3],
    },
}

crate::base::named::named_enum! {
    /// How rays are shaded.
    #[derive(Default)]
    pub enum Shading: "shading" as "shading" {
        /// Emission, direct light, environment light, mirrors (module docs).
        #[default]
        Full = "full",
        /// Only the emission of the first surface hit (the environment on a miss).
        Emission = "emission",
    }
}

#[derive(Clone, Copy, Debug)]
pub struct ShadeOptions {
    pub shading: Shading,
    /// Mirror bounces followed at most.
    pub max_depth: u32,
    /// Cosine-distributed rays per diffuse hit for environment and emitter light (0 = none).
    pub indirect_samples: u32,
    pub seed: u64,
}

impl Default for ShadeOptions {
    fn default() -> Self {
        ShadeOptions {
            shading: Shading::Full,
            max_depth: 8,
            indirect_samples: 1,
            seed: 0,
        }
    }
}

/// A triangle as the intersector wants it: a vertex, two edges and their cross product.
#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    n: Vec3A,
}

use crate::base::limits::SCENE_COORDINATE as MAX_COORDINATE;

/// Barycentric tolerance of the intersector: triangles overlap their neighbours by this much
/// (relative) so rays through shared edges cannot slip between them.
const EDGE_EPS: f32 = 2e-6;

impl Tri {
    fn new(v0: Vec3A, v1: Vec3A, v2: Vec3A) -> Self {
        let (e1, e2) = (v1 - v0, v2 - v0);
        Tri {
            v0,
            e1,
            e2,
            n: e1.cross(e2),
        }
    }

    /// Möller–Trumbore by Cramer's rule with the normal precomputed: for o + t·d = v0 + u·e1 +
    /// v·e2 and s = o − v0, det = −d·n, t = s·n / det, and with q = d × s, u = −e2·q / det,
    /// v = e1·q / det.  The distance is tested first (most candidates in a leaf lie beyond the
    /// closest hit so far).  `f32::INFINITY` on a miss.
    #[inline(always)]
    fn intersect(&self, ray: &Ray) -> f32 {
        let det = -ray.direction.dot(self.n);
        let s = ray.origin - self.v0;
        let inv = 1.0 / det;
        let t = s.dot(self.n) * inv;
        // NaN (det = 0) fails both comparisons.
        if !(t > ray.tmin && t < ray.tmax) {
            return f32::INFINITY;
        }
        let q = ray.direction.cross(s);
        let u = -self.e2.dot(q) * inv;
        let v = self.e1.dot(q) * inv;
        if u < -EDGE_EPS || v < -EDGE_EPS || u + v > 1.0 + EDGE_EPS {
            return f32::INFINITY;
        }
        t
    }

    fn barycentric(&self, o: Vec3A, d: Vec3A) -> (f32, f32) {
        let p = d.cross(self.e2);
        let inv = 1.0 / self.e1.dot(p);
        let s = o - self.v0;
        let q = s.cross(self.e1);
        (s.dot(p) * inv, d.dot(q) * inv)
    }
}

/// Per input triangle: what shading needs.
#[derive(Clone, Copy, Debug)]
struct TriInfo {
    material: u32,
    /// Vertex normals (zero = use the geometric normal).
    normals: [[f32; 3]; 3],
    uvs: [[f32; 2]; 3],
}

/// One triangle for [`SceneBuilder::add_triangle`].
#[derive(Clone, Copy, Debug, Default)]
pub struct TriangleInput {
    pub positions: [[f32; 3]; 3],
    pub normals: Option<[[f32; 3]; 3]>,
    /// v = 0 is the top row of the texture.
    pub uvs: Option<[[f32; 2]; 3]>,
    pub material: u32,
}

/// An analytic sphere (exact, unlike a tessellated one: a mirror ball for photo tests, a
/// camera body that occludes).  Its shading normal is the true normal; it has no texture
/// coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre: [f32; 3],
    pub radius: f32,
    pub material: u32,
}

impl Sphere {
    /// The nearest positive distance along the unit ray `o + t d` (`INFINITY` on a miss).
    /// Uses the geometric form (`h` = the ray's closest approach) which keeps its precision
    /// when the sphere is far from the origin of the ray.
    fn intersect(&self, o: Vec3A, d: Vec3A, tmax: f32) -> f32 {
        let oc = o - Vec3A::from(self.centre);
        let b = oc.dot(d);
        let h = oc - d * b;
        let disc = self.radius * self.radius - h.length_squared();
        if disc < 0.0 {
            return f32::INFINITY;
        }
        let q = disc.sqrt();
        for t in [-b - q, -b + q] {
            if t > 0.0 && t < tmax {
                return t;
            }
        }
        f32::INFINITY
    }
}

/// Collects geometry, materials, textures and lights; [`SceneBuilder::build`] makes the BVH.
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    tris: Vec<TriangleInput>,
    spheres: Vec<Sphere>,
    pub materials: Vec<Material>,
    pub textures: Vec<Image>,
    pub lights: Vec<Light>,
}

impl SceneBuilder {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn add_material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }
    pub fn add_texture(&mut self, img: Image) -> usize {
        self.textures.push(img);
        self.textures.len() - 1
    }
    pub fn add_light(&mut self, l: Light) {
        self.lights.push(l);
    }
    pub fn add_triangle(&mut self, t: TriangleInput) {
        self.tris.push(t);
    }
    /// An analytic sphere.
    pub fn add_sphere(&mut self, centre: [f32; 3], radius: f32, material: u32) {
        self.spheres.push(Sphere {
            centre,
            radius,
            material,
        });
    }
    /// An indexed mesh; `normals` and `uvs` per vertex when given.
    pub fn add_mesh(
        &mut self,
        positions: &[[f32; 3]],
        normals: Option<&[[f32; 3]]>,
        uvs: Option<&[[f32; 2]]>,
        triangles: &[[u32; 3]],
        material: u32,
    ) {
        for t in triangles {
            let i = t.map(|k| k as usize);
            self.tris.push(TriangleInput {
                positions: i.map(|k| positions[k]),
                normals: normals.map(|n| i.map(|k| n[k])),
                uvs: uvs.map(|u| i.map(|k| u[k])),
                material,
            });
        }
    }
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Checks the data and builds the BVH (`what` names the source in errors).
    pub fn build(self, environment: Environment, what: &str) -> Result<Scene> {
        if self.tris.is_empty() && self.spheres.is_empty() {
            return Err(Error::data(what, "the scene has no triangles"));
        }
        for (i, s) in self.spheres.iter().enumerate() {
            let ok = s.centre.iter().all(|v| v.abs() <= MAX_COORDINATE)
                && s.radius > 0.0
                && s.radius <= MAX_COORDINATE;
            if !ok {
                return Err(Error::data(
                    what,
                    format!("sphere {i}: centre must be finite and radius positive"),
                ));
            }
            if s.material as usize >= self.materials.len() {
                return Err(Error::data(
                    what,
                    format!(
                        "sphere {i} names material {} of {}",
                        s.material,
                        self.materials.len()
                    ),
                ));
            }
        }
        if self.materials.is_empty() {
            return Err(Error::data(what, "the scene has no materials"));
        }
        for (i, t) in self.tris.iter().enumerate() {
            if t.positions.iter().flatten().any(|v| !v.is_finite()) {
                return Err(Error::data(
                    what,
                    format!("triangle {i} has a non-finite vertex"),
                ));
            }
            // Beyond this, f32 tracing is meaningless and the BVH builder's arithmetic
            // overflows (found by the fuzzer: obvhs panics on coordinates near 1e33).
            if t.positions
                .iter()
                .flatten()
                .any(|v| v.abs() > MAX_COORDINATE)
            {
                return Err(Error::limit(
                    what,
                    format!("triangle {i} has a vertex coordinate beyond ±{MAX_COORDINATE:e}"),
                ));
            }
            if t.material as usize >= self.materials.len() {
                return Err(Error::data(
                    what,
                    format!(
                        "triangle {i} names material {} of {}",
                        t.material,
                        self.materials.len()
                    ),
                ));
            }
        }
        for m in &self.materials {
            if m.diffuse_texture.is_some_and(|k| k >= self.textures.len()) {
                return Err(Error::data(
                    what,
                    format!("material {:?}: no such texture", m.name),
                ));
            }
        }
        let prims: Vec<obvhs::triangle::Triangle> = self
            .tris
            .iter()
            .map(|t| {
                let [a, b, c] = t.positions.map(Vec3A::from);
                obvhs::triangle::Triangle {
                    v0: a,
                    v1: b,
                    v2: c,
                }
            })
            .collect();
        // Any other panic of the builder on strange geometry becomes an error.  A scene of
        // spheres only has no BVH.
        let bvh = if prims.is_empty() {
            None
        } else {
            Some(crate::base::error::guard_parser(
                std::path::Path::new(what),
                "scene geometry",
                || {
                    Ok(obvhs::cwbvh::builder::build_cwbvh_from_tris(
                        &prims,
                        obvhs::BvhBuildParams::medium_build(),
                        &mut std::time::Duration::default(),
                    ))
                },
            )?)
        };
        let order = bvh
            .as_ref()
            .map(|b| b.primitive_indices.clone())
            .unwrap_or_default();
        // Triangles in the BVH's leaf order, so traversal reads them sequentially.
        let tris = order
            .iter()
            .map(|&i| {
                let t = &prims[i as usize];
                Tri::new(t.v0, t.v1, t.v2)
            })
            .collect();
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for p in self.tris.iter().flat_map(|t| t.positions) {
            lo = lo.min(Vec3::from(p));
            hi = hi.max(Vec3::from(p));
        }
        for s in &self.spheres {
            lo = lo.min(Vec3::from(s.centre) - s.radius);
            hi = hi.max(Vec3::from(s.centre) + s.radius);
        }
        let info = self
            .tris
            .iter()
            .map(|t| TriInfo {
                material: t.material,
                normals: t
                    .normals
                    .filter(|n| n.iter().flatten().all(|v| v.is_finite()))
                    .unwrap_or([[0.0; 3]; 3]),
                uvs: t.uvs.unwrap_or([[0.0; 2]; 3]),
            })
            .collect();
        let extent = (hi - lo)
            .max_element()
            .max(hi.abs().max(lo.abs()).max_element());
        // Zero-area triangles are kept (they are never hit) and counted for the report.
        let degenerate = self
            .tris
            .iter()
            .filter(|t| {
                let [a, b, c] = t.positions.map(Vec3::from);
                (b - a).cross(c - a).length_squared() == 0.0
            })
            .count();
        Ok(Scene {
            tris,
            slot_to_tri: order,
            info,
            bvh,
            spheres: self.spheres,
            materials: self.materials,
            textures: self.textures,
            lights: self.lights,
            environment,
            options: ShadeOptions::default(),
            eps: (extent * 1e-5).max(1e-6),
            bounds: (lo.to_array(), hi.to_array()),
            degenerate,
        })
    }
}

/// A scene ready to trace.
pub struct Scene {
    tris: Vec<Tri>,
    slot_to_tri: Vec<u32>,
    info: Vec<TriInfo>,
    bvh: Option<CwBvh>,
    spheres: Vec<Sphere>,
    pub materials: Vec<Material>,
    pub textures: Vec<Image>,
    pub lights: Vec<Light>,
    pub environment: Environment,
    pub options: ShadeOptions,
    /// Offset of secondary ray origins along the normal (scene-size relative).
    eps: f32,
    bounds: ([f32; 3], [f32; 3]),
    degenerate: usize,
}

/// What a ray hit.
#[derive(Clone, Copy)]
enum Prim {
    /// A triangle's BVH slot.
    Tri(usize),
    /// An index into `spheres`.
    Sphere(usize),
}

/// A hit: the primitive and the distance.
struct Hit {
    prim: Prim,
    t: f32,
}

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.info.len()
    }

    /// Triangles of zero area (kept, never hit; reported by the front ends).
    pub fn degenerate_count(&self) -> usize {
        self.degenerate
    }

    /// The axis-aligned bounds of the geometry (min, max).
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        self.bounds
    }

    /// A ray for obvhs.  Negative zeros in the direction are made positive: the traversal
    /// takes the octant from the sign bits and misses with a −0 component (seen with the
    /// light direction −(0, −1, 0) = (−0, 1, −0)).
    fn ray(o: Vec3A, d: Vec3A, tmax: f32) -> Ray {
        Ray::new(o, d + Vec3A::ZERO, 0.0, tmax)
    }

    fn closest(&self, o: Vec3A, d: Vec3A, tmax: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        if let Some(bvh) = &self.bvh {
            let ray = Self::ray(o, d, tmax);
            let mut hit = RayHit::none();
            if bvh.ray_traverse(ray, &mut hit, |r, id| self.tris[id].intersect(r)) {
                best = Some(Hit {
                    prim: Prim::Tri(hit.primitive_id as usize),
                    t: hit.t,
                });
            }
        }
        // Spheres are few (a ball, a camera): a plain loop.
        for (i, s) in self.spheres.iter().enumerate() {
            let t = s.intersect(o, d, best.as_ref().map_or(tmax, |h| h.t));
            if t.is_finite() {
                best = Some(Hit {
                    prim: Prim::Sphere(i),
                    t,
                });
            }
        }
        best
    }

    fn unoccluded(&self, o: Vec3A, d: Vec3A, tmax: f32) -> bool {
        if self
            .spheres
            .iter()
            .any(|s| s.intersect(o, d, tmax).is_finite())
        {
            return false;
        }
        self.bvh.as_ref().is_none_or(|bvh| {
            bvh.ray_traverse_miss(Self::ray(o, d, tmax), |r, id| self.tris[id].intersect(r))
        })
    }

    fn material_of(&self, prim: Prim) -> &Material {
        let m = match prim {
            Prim::Tri(slot) => self.info[self.slot_to_tri[slot] as usize].material,
            Prim::Sphere(i) => self.spheres[i].material,
        };
        &self.materials[m as usize]
    }

    /// At a hit: the geometric normal, the shading normal (may face either way) and the
    /// texture coordinates.
    fn surface(&self, hit: &Hit, o: Vec3A, d: Vec3A) -> (Vec3A, Vec3A, [f32; 2]) {
        match hit.prim {
            Prim::Sphere(i) => {
                let s = &self.spheres[i];
                let n = ((o + d * hit.t - Vec3A::from(s.centre)) / s.radius).normalize_or_zero();
                (n, n, [0.0; 2])
            }
            Prim::Tri(slot) => {
                let info = &self.info[self.slot_to_tri[slot] as usize];
                let tri = &self.tris[slot];
                let (u, v) = tri.barycentric(o, d);
                let w = 1.0 - u - v;
                let ns = Vec3A::from(info.normals[0]) * w
                    + Vec3A::from(info.normals[1]) * u
                    + Vec3A::from(info.normals[2]) * v;
                let uv =
                    [0, 1].map(|c| w * info.uvs[0][c] + u * info.uvs[1][c] + v * info.uvs[2][c]);
                (tri.n.normalize_or_zero(), ns, uv)
            }
        }
    }

    /// The closest hit's distance along a ray (`None` on a miss): for tests and tools.
    pub fn intersect(&self, origin: [f32; 3], direction: [f32; 3]) -> Option<f32> {
        self.closest(origin.into(), direction.into(), f32::INFINITY)
            .map(|h| h.t)
    }

    fn environment_radiance(&self, d: Vec3A) -> [f32; 3] {
        match &self.environment {
            Environment::Constant(c) => *c,
            Environment::Map {
                image,
                mapping,
                rotation,
            } => {
                let r = rotation;
                let v = [0, 1, 2].map(|i| {
                    (r[i][0] * d.x as f64 + r[i][1] * d.y as f64 + r[i][2] * d.z as f64) as f32
                });
                let env = EnvMap {
                    mapping: *mapping,
                    width: image.width,
                    height: image.height,
                    channels: image.channels,
                    data: &image.data,
                };
                let mut px = [0f32; 4];
                Sampler::new(&env).sample(v, &mut px);
                match image.channels {
                    1 | 2 => [px[0]; 3],
                    _ => [px[0], px[1], px[2]],
                }
            }
        }
    }

    /// The radiance arriving at `o` from direction `-d` (see the module docs).
    pub fn radiance(&self, o: [f32; 3], d: [f32; 3]) -> [f32; 3] {
        let d = Vec3A::from(d).normalize_or_zero();
        if d == Vec3A::ZERO {
            return [0.0; 3];
        }
        self.trace_ray(Vec3A::from(o), d, 0).to_array()
    }

    /// Each light that reaches the surface at `hit_point` (normal `n`; shadow rays start at `p`)
    /// from above it: its direction from the surface and the irradiance it brings, I·max(0, n·l).
    fn lights_at(
        &self,
        hit_point: Vec3A,
        p: Vec3A,
        n: Vec3A,
    ) -> impl Iterator<Item = (Vec3A, Vec3)> + '_ {
        self.lights.iter().filter_map(move |light| match *light {
            Light::Point {
                position,
                intensity,
            } => {
                // Geometry from the hit point itself; the offset only starts the shadow ray.
                let to = Vec3A::from(position) - hit_point;
                let dist = to.length();
                let cos = n.dot(to) / dist;
                (cos > 0.0 && self.unoccluded(p, to / dist, dist * (1.0 - 1e-4)))
                    .then(|| (to / dist, Vec3::from(intensity) * (cos / (dist * dist))))
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                let l_dir = -Vec3A::from(direction).normalize_or_zero();
                let cos = n.dot(l_dir);
                (cos > 0.0 && self.unoccluded(p, l_dir, f32::INFINITY))
                    .then(|| (l_dir, Vec3::from(irradiance) * cos))
            }
        })
    }

    fn trace_ray(&self, o: Vec3A, d: Vec3A, depth: u32) -> Vec3 {
        let Some(hit) = self.closest(o, d, f32::INFINITY) else {
            return Vec3::from(self.environment_radiance(d));
        };
        let m = self.material_of(hit.prim);
        let mut l = Vec3::from(m.emission);
        if self.options.shading == Shading::Emission {
            return l;
        }
        let (ng, ns, uv) = self.surface(&hit, o, d);
        let mut n = if ns.length_squared() > 1e-12 {
            ns.normalize()
        } else {
            ng
        };
        if n.dot(d) > 0.0 {
            n = -n;
        }
        // Secondary rays leave from the side the ray came from.
        let side = if ng.dot(d) > 0.0 { -ng } else { ng };
        let hit_point = o + d * hit.t;
        let p = hit_point + side * self.eps;
        let mut albedo = Vec3::from(m.diffuse);
        if let Some(k) = m.diffuse_texture {
            albedo *= Vec3::from(sample_texture(&self.textures[k], uv));
        }
        if m.unlit {
            return l + albedo;
        }
        let specular = Vec3::from(m.specular);
        if specular.max_element() > 0.0 {
            // Normalised Blinn–Phong: S (s + 8)/(8π) (n·h)^s, times the light's irradiance.
            let s = m.shininess.max(0.0);
            let norm = (s + 8.0) / (8.0 * std::f32::consts::PI);
            let mut e = Vec3::ZERO;
            for (l_dir, irradiance) in self.lights_at(hit_point, p, n) {
                let h = (l_dir - d).normalize_or_zero();
                e += irradiance * n.dot(h).max(0.0).powf(s);
            }
            l += specular * e * norm;
        }
        if albedo.max_element() > 0.0 {
            let mut e = Vec3::ZERO;
            for (_, irradiance) in self.lights_at(hit_point, p, n) {
                e += irradiance;
            }
            l += albedo * e * std::f32::consts::FRAC_1_PI;
            let k = self.options.indirect_samples;
            if k > 0 {
                let mut sum = Vec3::ZERO;
                for i in 0..k {
                    let (r1, r2) = ray_random(self.options.seed, o, d, depth, i);
                    let q = cosine_direction(n, r1, r2);
                    sum += match self.closest(p, q, f32::INFINITY) {
                        Some(h) => Vec3::from(self.material_of(h.prim).emission),
                        None => Vec3::from(self.environment_radiance(q)),
                    };
                }
                l += albedo * sum / k as f32;
            }
        }
        let mirror = Vec3::from(m.mirror);
        if mirror.max_element() > 0.0 && depth < self.options.max_depth {
            let r = d - n * (2.0 * d.dot(n));
            l += mirror * self.trace_ray(p, r.normalize(), depth + 1);
        }
        l
    }
}

impl RaySource for Scene {
    fn channels(&self) -> usize {
        3
    }
    fn trace(&self, origins: &[[f32; 3]], directions: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        for ((o, d), px) in origins.iter().zip(directions).zip(out.chunks_exact_mut(3)) {
            px.copy_from_slice(&self.radiance(*o, *d));
        }
        Ok(())
    }
}

/// Bilinear, repeating, texel centres at i + ½, v = 0 at the top row; RGB (grey for 1–2
/// channels).
fn sample_texture(img: &Image, uv: [f32; 2]) -> [f32; 3] {
    let (w, h) = (img.width as isize, img.height as isize);
    let x = uv[0].rem_euclid(1.0) * w as f32 - 0.5;
    let y = uv[1].rem_euclid(1.0) * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (ax, ay) = (x - x0, y - y0);
    let mut out = [0f32; 3];
    for (dx, dy, wt) in [
        (0, 0, (1.0 - ax) * (1.0 - ay)),
        (1, 0, ax * (1.0 - ay)),
        (0, 1, (1.0 - ax) * ay),
        (1, 1, ax * ay),
    ] {
        let xi = (x0 as isize + dx).rem_euclid(w) as usize;
        let yi = (y0 as isize + dy).rem_euclid(h) as usize;
        let px = img.pixel(xi, yi);
        for c in 0..3 {
            out[c] += wt * if img.channels >= 3 { px[c] } else { px[0] };
        }
    }
    out
}

/// Two numbers in [0,1) from the bits of a ray, the bounce and the sample (SplitMix64).
fn ray_random(seed: u64, o: Vec3A, d: Vec3A, depth: u32, k: u32) -> (f32, f32) {
    let mut z = seed ^ ((depth as u64) << 32 | k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for v in [o.x, o.y, o.z, d.x, d.y, d.z] {
        z = (z ^ v.to_bits() as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z ^= z >> 29;
    }
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (
        (z >> 40) as f32 / (1u64 << 24) as f32,
        ((z >> 16) & 0xFF_FFFF) as f32 / (1u64 << 24) as f32,
    )
}

/// A cosine-distributed direction about `n` (Malley: uniform disc point lifted to the
/// hemisphere).
fn cosine_direction(n: Vec3A, r1: f32, r2: f32) -> Vec3A {
    let (b1, b2) = Vec3::from(n).any_orthonormal_pair();
    let r = r1.sqrt();
    let phi = std::f32::consts::TAU * r2;
    let (x, y) = (r * phi.cos(), r * phi.sin());
    let z = (1.0 - r1).max(0.0).sqrt();
    (Vec3A::from(b1) * x + Vec3A::from(b2) * y + n * z).normalize()
}
