//! Physically exact MatCaps: the light a lone convex sphere of a material reflects toward an
//! orthographic viewer, baked from an environment map.
//!
//! ## The MatCap layout (a contract)
//!
//! An N×N image, row 0 at the top; texel (i, j) has centre s = (i+½)/N, t = 1 − (j+½)/N;
//! x = 2s − 1, y = 2t − 1; inside the disc the view-space normal is n = (x, y, √(1 − x² − y²)).
//! The viewer is orthographic, v = (0, 0, 1); view space is +X right, +Y up, the eye looking
//! down −Z; `look` / `up` are the world directions of the eye's −Z and +Y (default −Z, +Y).
//! This is the layout of the GL sphere map of the same view (default preset): the texel whose
//! normal is n shows, in a sphere map, the reflection r = 2(n·v)n − v.
//!
//! ## The value of a texel
//!
//! L_o(n, v) = ∫ f(l, v) L(l) max(0, n·l) dω_l, no occlusion, averaged over the texel's
//! footprint with the sample rules of every spheremap output (`samples`, the box filter, the
//! gutter outside the disc): the bake is [`crate::trace::generate`] of a sphere map whose
//! "ray" in direction r returns L_o at n = normalize(r + v).
//!
//! Each integral is computed on the environment's tree ([`super::envtree`]): L̄·E(n·v) (the
//! material's directional albedo times the mean radiance) plus the residual over a cut fine
//! enough for the lobe.  Neighbouring normals (a tile of the grid of normals, 2×2 texels'
//! samples) share one cut opened for all of them ([`EnvTree::group_cut`]), which each sums in
//! vector code ([`envtree::ggx_sums`]).  A GGX lobe narrower than the tree's finest leaves is
//! split: its core by 256 visible-normal samples (Heitz 2018) with bilinear lookups in the
//! source map, its tail on the tree ([`EnvTree::tail`]).  Roughness 0 is the mirror: the bake
//! is then the conversion to the sphere map of the view (`convert --to sphere`), times the
//! albedo.

use super::brdf::{self, Albedo, Material};
use super::envtree::{self, CutRule, EnvTree, Lobe};
use crate::base::error::{Error, Result};
use crate::frame::view::{self, Mat3};
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use crate::resample::{EnvMap, Progress, Sampler};
use crate::trace::generate::{generate, planned_rays, GenerateOptions, RaySource};

/// The finest cube face the tree is built at.
pub const TREE_FACE_CAP: usize = 512;
/// Points of the grid of normals per lobe width (α) across the half-circle of θ from the
/// viewer to the rim (the grid spans 2 × that): `GRID_PER_WIDTH · π / α + 1` points
/// (measured at roughness 0.25 against brute force with a sun: 64.6 dB at 3 per width, 64.3
/// dB at 4, 61.5 dB at 1.5).
const GRID_PER_WIDTH: f64 = 3.0;

/// Points of the grid of normals per side of a tile that shares one cut of the tree.
const TILE: usize = 8;
/// Neighbouring rays (without a grid of normals: 2×2 texels of 4 samples) that share a cut.
const GROUP_RAYS: usize = 16;
/// Visible-normal samples per integral for the core of lobes narrower than the tree resolves.
pub const VNDF_SAMPLES: usize = 256;

/// What to bake (the resolved options of [`MatcapRequest`](super::MatcapRequest)).
#[derive(Clone, Copy, Debug)]
pub struct Bake {
    pub material: Material,
    pub albedo: [f64; 3],
    /// Output size N.
    pub size: usize,
    /// Eye frame → world (columns: the eye's axes in world coordinates).
    pub view: Mat3,
    /// World → the environment map's frame.
    pub world_to_env: Mat3,
    /// Spatial samples, as everywhere (1: the texel centre).
    pub samples: u32,
    pub max_samples: u32,
    pub seed: u64,
    pub outside: crate::resample::Outside,
    pub max_memory: u64,
    pub rule: CutRule,
    /// Integrate on a grid of normals and interpolate ([`NormalTable`]); `None`: where that
    /// takes no more integrals ([`grid_integrals`]) than the samples' own
    /// ([`planned_rays`]).
    pub normal_table: Option<bool>,
}

/// How a bake integrated its lobes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The environment's tree.
    Tree,
    /// Narrow GGX lobes: visible-normal samples with bilinear lookups for the core, the tree
    /// for the tail.
    Vndf,
    /// Roughness 0: the sphere map of the view.
    Mirror,
    /// Filtered importance sampling from a cube mip pyramid (`prefilter --method sampled`).
    Sampled,
    /// The cosine integral by the environment's moments (Lambert; [`super::cosine`]).
    Cosine,
}

/// What a bake did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeReport {
    pub method: Method,
    /// The tree's cube face (0 for the mirror).
    pub tree_face: usize,
    /// Lighting integrals computed (one per spatial sample, or, when the bake uses a grid of
    /// normals, one per point of the grid and two per point beyond its rim).
    pub integrals: u64,
    pub max_texel_samples: u32,
}

/// The channels a MatCap of a `c`-channel environment lit with `albedo` has: RGB, or grey
/// when both are grey.
pub fn output_channels(c: usize, albedo: [f64; 3]) -> usize {
    if envtree::light_channels(c) == 1 && albedo[0] == albedo[1] && albedo[1] == albedo[2] {
        1
    } else {
        3
    }
}

/// Bakes the MatCap of `env` (see the module's notes).
pub fn bake(env: &EnvMap, b: &Bake, progress: Option<&Progress>) -> Result<(Image, BakeReport)> {
    crate::base::limits::check_map_size("size", b.size)?;
    let sphere = Mapping::parse("sphere", None)?;
    let out_c = output_channels(env.channels, b.albedo);
    let gen = GenerateOptions {
        samples: b.samples,
        max_samples: b.max_samples,
        filter: crate::resample::Filter::Box,
        outside: b.outside,
        rotation: b.view,
        pos: [0.0; 3],
        seed: b.seed,
        precision: crate::resample::Precision::F32,
        max_memory: b.max_memory,
    };
    let v = [b.view[0][2], b.view[1][2], b.view[2][2]];
    if b.material == (Material::Ggx { alpha: 0.0 }) {
        // The mirror: exactly the conversion to the sphere map of the view.
        let opts = crate::resample::ResampleOptions {
            samples: b.samples,
            max_samples: b.max_samples,
            outside: b.outside,
            rotation: view::mul(&b.world_to_env, &b.view),
            seed: b.seed,
            max_memory: b.max_memory,
            ..Default::default()
        };
        let (map, r) = crate::resample::resample(env, sphere, b.size, b.size, &opts, progress)?;
        let lc = envtree::light_channels(map.channels);
        let mut img = Image::new(b.size, b.size, out_c);
        for (o, p) in img
            .data
            .chunks_exact_mut(out_c)
            .zip(map.data.chunks_exact(map.channels))
        {
            let value = [0, 1, 2].map(|k| p[k.min(map.channels - 1)] as f64);
            put(o, value, lc, b.albedo);
        }
        let report = BakeReport {
            method: Method::Mirror,
            tree_face: 0,
            integrals: r.lookups,
            max_texel_samples: r.max_texel_samples,
        };
        return Ok((img, report));
    }
    if b.material == Material::Lambert {
        // View-independent: albedo/π × E(n), the cosine integral at each sample's normal.
        let face = super::cosine::face_for_tolerance(b.rule.tol);
        let tree = super::cosine::CosineTree::build(env, b.world_to_env, face)?;
        let source = super::cosine::CosineSource {
            tree: &tree,
            normal: |r| normal_of(r, v),
            scale: b.albedo.map(|a| a / std::f64::consts::PI),
            channels: out_c,
        };
        let (img, r) = generate(sphere, b.size, b.size, &source, &gen, progress)?;
        return Ok((img, report(Method::Cosine, face, r)));
    }
    let (method, face) = plan(env, b.material);
    crate::base::limits::check_memory("env", envtree::EnvTree::bytes(face), b.max_memory)?;
    let tree = EnvTree::build(env, b.world_to_env, face)?;
    let mut source = MatcapSource {
        tree: &tree,
        albedo_table: Albedo::new(b.material),
        material: b.material,
        albedo: b.albedo,
        v,
        channels: out_c,
        vndf: (method == Method::Vndf).then(|| (Sampler::new(env), b.world_to_env)),
        rule: b.rule,
        table: None,
        view: b.view,
    };
    let m = NormalTable::size_for(b.material);
    let use_table = match b.normal_table {
        Some(t) => t,
        None => NormalTable::integrals_for(m) <= planned_rays(sphere, b.size, b.size, out_c, &gen)?,
    };
    let mut integrals = 0;
    if use_table {
        let t = NormalTable::build(&source, m, progress);
        integrals = t.integrals;
        source.table = Some(t);
    }
    let (img, r) = generate(sphere, b.size, b.size, &source, &gen, progress)?;
    let mut rep = report(method, face, r);
    if source.table.is_some() {
        rep.integrals = integrals;
    }
    Ok((img, rep))
}

/// The integrals a bake of `material` takes on its grid of normals (the same for every size
/// and sample count).
pub fn grid_integrals(material: Material) -> u64 {
    NormalTable::integrals_for(NormalTable::size_for(material))
}

/// How `material`'s integrals over `env` are computed, and the tree face they use: the tree at
/// the resolution the lobe needs ([`envtree::face_needed`]), up to [`TREE_FACE_CAP`]; a lobe
/// too narrow for that face has its leaves averaged ([`envtree::AVERAGE_BELOW`]) down to
/// [`envtree::MIN_LEAVES_PER_ALPHA`] leaves across α (roughness ≈ 0.055); narrower ones are
/// split between samples and the tree ([`Method::Vndf`]).  Lambert's integrals are the cosine
/// integral's ([`super::cosine`], not planned here; this gives the tree that would serve
/// them).
pub fn plan(env: &EnvMap, material: Material) -> (Method, usize) {
    let src_face = envtree::face_for(env.width, env.height, TREE_FACE_CAP);
    let cap = TREE_FACE_CAP.max(src_face);
    let leaves = |alpha: f64| alpha * cap as f64 / std::f64::consts::FRAC_PI_2;
    let method = match material {
        Material::Ggx { alpha } if leaves(alpha) < envtree::MIN_LEAVES_PER_ALPHA => Method::Vndf,
        _ => Method::Tree,
    };
    (method, envtree::face_needed(material).min(cap))
}

/// L_o on a grid of view-space normals, for bicubic lookups: the hemisphere as the
/// equidistant disc (a, b) = θ/(π/2) · (cos φ, sin φ) (θ the angle to the viewer), M×M points
/// from −1 to 1 plus two on each side (beyond the rim, the line through it: 2 G(1) − G(2 − ρ)).
/// The grid's spacing in θ is a third of the lobe's width (α for GGX; 1 for Lambert), so a
/// Catmull–Rom lookup keeps the integral's accuracy; each grid value is an integral like any
/// other, the points of a tile of [`TILE`]² sharing a cut.
struct NormalTable {
    m: usize,
    /// (m + 4)² values, row-major.
    data: Vec<[f32; 3]>,
    integrals: u64,
}

impl NormalTable {
    const PAD: usize = 2;

    /// The grid size for a material: 3π/α + 1 points across (129 to 1025).
    fn size_for(m: Material) -> usize {
        let width = match m {
            Material::Lambert => 1.0,
            Material::Ggx { alpha } => alpha.min(1.0),
        };
        ((GRID_PER_WIDTH * std::f64::consts::PI / width).ceil() as usize + 1).clamp(129, 1025)
    }

    /// The grid's spacing, for `m` points across the disc.
    fn spacing(m: usize) -> f64 {
        2.0 / (m - 1) as f64
    }

    /// Grid point (i, j) of an `m`-point grid: its (a, b) and ρ = |(a, b)|.
    fn point(m: usize, i: usize, j: usize) -> (f64, f64, f64) {
        let h = Self::spacing(m);
        let a = -1.0 + (i as f64 - Self::PAD as f64) * h;
        let b = -1.0 + (j as f64 - Self::PAD as f64) * h;
        (a, b, a.hypot(b))
    }

    /// The points a lookup can read: ρ within 2√2 spacings of the disc (a lookup inside the
    /// disc reads points up to that far from it; the rest of the square's corners are never
    /// read).
    fn read(m: usize, rho: f64) -> bool {
        rho <= 1.0 + 2.0 * std::f64::consts::SQRT_2 * Self::spacing(m) * (1.0 + 1e-9)
    }

    /// The integrals [`NormalTable::build`] takes for an `m`-point grid: one per point read,
    /// two per point beyond the rim.
    fn integrals_for(m: usize) -> u64 {
        use rayon::prelude::*;
        let side = m + 2 * Self::PAD;
        (0..side)
            .into_par_iter()
            .map(|j| {
                (0..side)
                    .map(|i| Self::point(m, i, j).2)
                    .filter(|&rho| Self::read(m, rho))
                    .map(|rho| 1 + (rho > 1.0) as u64)
                    .sum::<u64>()
            })
            .sum()
    }

    fn build(src: &MatcapSource, m: usize, progress: Option<&Progress>) -> NormalTable {
        use rayon::prelude::*;
        let side = m + 2 * Self::PAD;
        let view = &src.view;
        // The world normal at (ρ, φ) of the equidistant disc.
        let at = |rho: f64, ca: f64, sa: f64| {
            let theta = rho * std::f64::consts::FRAC_PI_2;
            let ne = [theta.sin() * ca, theta.sin() * sa, theta.cos()];
            [0, 1, 2].map(|k| view[k][0] * ne[0] + view[k][1] * ne[1] + view[k][2] * ne[2])
        };
        // Grid point (i, j): its normal, or beyond the rim the two whose line it is on.
        let normals = |i: usize, j: usize| -> ([f64; 3], Option<[f64; 3]>) {
            let (a, b, rho) = Self::point(m, i, j);
            let (ca, sa) = if rho > 0.0 {
                (a / rho, b / rho)
            } else {
                (1.0, 0.0)
            };
            if rho <= 1.0 {
                (at(rho, ca, sa), None)
            } else {
                // Beyond the rim, the line through the rim: 2 G(1) − G(2 − ρ).
                (at(1.0, ca, sa), Some(at((2.0 - rho).max(0.0), ca, sa)))
            }
        };
        // Tiles of TILE×TILE points share one cut of the tree.
        let tiles = side.div_ceil(TILE);
        let integrals = std::sync::atomic::AtomicU64::new(0);
        let parts: Vec<Vec<(usize, [f32; 3])>> = (0..tiles * tiles)
            .into_par_iter()
            .map(|t| {
                let cancelled =
                    progress.is_some_and(|p| p.cancel.load(std::sync::atomic::Ordering::Relaxed));
                let (ty, tx) = (t / tiles, t % tiles);
                let points: Vec<(usize, [f64; 3], Option<[f64; 3]>)> = (ty * TILE
                    ..((ty + 1) * TILE).min(side))
                    .flat_map(|j| (tx * TILE..((tx + 1) * TILE).min(side)).map(move |i| (j, i)))
                    .filter(|&(j, i)| Self::read(m, Self::point(m, i, j).2))
                    .map(|(j, i)| {
                        let (n1, n2) = normals(i, j);
                        (j * side + i, n1, n2)
                    })
                    .collect();
                if cancelled {
                    return points.iter().map(|p| (p.0, [0.0; 3])).collect();
                }
                let list: Vec<[f64; 3]> = points
                    .iter()
                    .flat_map(|p| std::iter::once(p.1).chain(p.2))
                    .collect();
                let values = src.radiances(&list);
                integrals.fetch_add(list.len() as u64, std::sync::atomic::Ordering::Relaxed);
                let mut k = 0;
                points
                    .iter()
                    .map(|p| {
                        let g1 = values[k];
                        k += 1;
                        let v = match p.2 {
                            None => g1,
                            Some(_) => {
                                let g2 = values[k];
                                k += 1;
                                [0, 1, 2].map(|c| 2.0 * g1[c] - g2[c])
                            }
                        };
                        (p.0, v.map(|v| v as f32))
                    })
                    .collect()
            })
            .collect();
        let mut data = vec![[0f32; 3]; side * side];
        for (k, v) in parts.into_iter().flatten() {
            data[k] = v;
        }
        NormalTable {
            m,
            data,
            integrals: integrals.into_inner(),
        }
    }

    /// Catmull–Rom at view-space normal `ne` (unit, ne.z ≥ 0).
    fn lookup(&self, ne: [f64; 3]) -> [f64; 3] {
        let theta = ne[2]
            .clamp(-1.0, 1.0)
            .acos()
            .min(std::f64::consts::FRAC_PI_2);
        let s = (ne[0] * ne[0] + ne[1] * ne[1]).sqrt();
        let (ca, sa) = if s > 0.0 {
            (ne[0] / s, ne[1] / s)
        } else {
            (1.0, 0.0)
        };
        let rho = theta / std::f64::consts::FRAC_PI_2;
        let h = Self::spacing(self.m);
        let fx = (rho * ca + 1.0) / h + Self::PAD as f64;
        let fy = (rho * sa + 1.0) / h + Self::PAD as f64;
        let side = self.m + 2 * Self::PAD;
        let (ix, iy) = (fx.floor() as isize, fy.floor() as isize);
        let (tx, ty) = (fx - ix as f64, fy - iy as f64);
        let w = |t: f64| {
            [
                0.5 * (-t + 2.0 * t * t - t * t * t),
                0.5 * (2.0 - 5.0 * t * t + 3.0 * t * t * t),
                0.5 * (t + 4.0 * t * t - 3.0 * t * t * t),
                0.5 * (-t * t + t * t * t),
            ]
        };
        let (wx, wy) = (w(tx), w(ty));
        let mut out = [0.0; 3];
        for (dj, wj) in wy.iter().enumerate() {
            let y = (iy - 1 + dj as isize).clamp(0, side as isize - 1) as usize;
            for (di, wi) in wx.iter().enumerate() {
                let x = (ix - 1 + di as isize).clamp(0, side as isize - 1) as usize;
                let v = &self.data[y * side + x];
                for k in 0..3 {
                    out[k] += wi * wj * v[k] as f64;
                }
            }
        }
        out
    }
}

fn report(method: Method, face: usize, r: crate::trace::generate::GenerateReport) -> BakeReport {
    BakeReport {
        method,
        tree_face: face,
        integrals: r.rays,
        max_texel_samples: r.max_texel_samples,
    }
}

/// The normal whose mirror direction for viewer `v` is `r`: normalize(r + v) (at r = −v, the
/// rim, a normal perpendicular to v).
#[inline]
pub fn normal_of(r: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    let s = [r[0] + v[0], r[1] + v[1], r[2] + v[2]];
    let l = crate::base::vec::dot(s, s).sqrt();
    if l > 1e-12 {
        [s[0] / l, s[1] / l, s[2] / l]
    } else {
        brdf::tangent_frame(v).0
    }
}

fn put(out: &mut [f32], value: [f64; 3], light_c: usize, albedo: [f64; 3]) {
    if out.len() == 1 {
        out[0] = (value[0] * albedo[0]) as f32;
    } else {
        for k in 0..3 {
            let v = if light_c == 3 { value[k] } else { value[0] };
            out[k] = (v * albedo[k]) as f32;
        }
    }
}

/// The lit sphere: direction r → L_o at n = normalize(r + v).
struct MatcapSource<'a> {
    tree: &'a EnvTree,
    albedo_table: Albedo,
    material: Material,
    albedo: [f64; 3],
    v: [f64; 3],
    channels: usize,
    /// Narrow lobes: the source map and world → its frame.
    vndf: Option<(Sampler<'a>, Mat3)>,
    rule: CutRule,
    /// The integrals on a grid of normals, when the bake uses one.
    table: Option<NormalTable>,
    /// Eye → world.
    view: Mat3,
}

impl MatcapSource<'_> {
    /// L_o at each of `ns`, neighbouring normals (before the albedo): one cut of the tree for
    /// all of them where the lobe allows ([`EnvTree::group_cut`]), else each by itself.
    fn radiances(&self, ns: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let each = || {
            ns.iter()
                .map(|&n| {
                    let nv = crate::base::vec::dot(n, self.v);
                    let r = [0, 1, 2].map(|k| 2.0 * nv * n[k] - self.v[k]);
                    self.radiance(n, r)
                })
                .collect()
        };
        let Material::Ggx { alpha } = self.material else {
            return each();
        };
        if self.vndf.is_some() || ns.len() < 2 {
            return each();
        }
        let shared = envtree::Shared {
            alpha,
            kernel: envtree::Kernel::Brdf,
            v: self.v,
            rule: self.rule,
        };
        self.tree.shared_integrals(&shared, ns, |n| {
            self.albedo_table
                .at(crate::base::vec::dot(n, self.v).clamp(0.0, 1.0))
        })
    }

    /// L_o at normal `n` (before the albedo).
    fn radiance(&self, n: [f64; 3], r: [f64; 3]) -> [f64; 3] {
        let mu = crate::base::vec::dot(n, self.v).clamp(0.0, 1.0);
        let e = self.albedo_table.at(mu);
        match (&self.vndf, self.material) {
            (Some((sampler, rot)), Material::Ggx { alpha }) => {
                // Each sample's weight G₂/G₁(v): the visible-normal pdf holds G₁(v).
                let lambda_v =
                    brdf::smith_lambda(alpha, crate::base::vec::dot(self.v, n).max(1e-6));
                let w =
                    |mu_l| (1.0 + lambda_v) / (1.0 + lambda_v + brdf::smith_lambda(alpha, mu_l));
                // The lobe's core by samples, its tail on the tree, each over L itself; the
                // tail is the lobe's albedo less the samples' share of it ([`EnvTree::tail`]).
                let nv = crate::base::vec::dot(n, self.v);
                let peak = [0, 1, 2].map(|k| 2.0 * nv * n[k] - self.v[k]);
                let radius = envtree::core_radius(alpha, self.tree.face);
                let core = Some((peak, radius.cos()));
                let (res, w_core) =
                    vndf_residual(sampler, rot, alpha, n, self.v, [0.0; 3], r, core, w);
                let scale = self.tree.mean_brightness() * e;
                let lobe = Lobe::new(self.material, n, self.v, self.rule, scale);
                let tail = self.tree.tail(&lobe, radius, e - w_core);
                [0, 1, 2].map(|k| res[k] + tail[k])
            }
            _ => self.tree.integral(
                &Lobe::new(
                    self.material,
                    n,
                    self.v,
                    self.rule,
                    self.tree.mean_brightness() * e,
                ),
                e,
            ),
        }
    }
}

impl RaySource for MatcapSource<'_> {
    fn channels(&self) -> usize {
        self.channels
    }
    fn rows_per_call(&self) -> usize {
        // Tiles of texels share cuts.
        4
    }
    fn trace(&self, _: &[[f32; 3]], dirs: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        let normal =
            |d: &[f32; 3]| normal_of(crate::base::vec::normalize(d.map(|v| v as f64)), self.v);
        if let Some(t) = &self.table {
            for (d, o) in dirs.iter().zip(out.chunks_exact_mut(self.channels)) {
                let n = normal(d);
                // World → eye: the view's transpose.
                let vw = &self.view;
                let ne = [0, 1, 2].map(|k| vw[0][k] * n[0] + vw[1][k] * n[1] + vw[2][k] * n[2]);
                put(o, t.lookup(ne), self.tree.channels, self.albedo);
            }
            return Ok(());
        }
        // Neighbouring normals share a cut: the rays of a few rows, in the order of a Z-order
        // curve on the cube of normals.
        let normals: Vec<[f64; 3]> = dirs.iter().map(normal).collect();
        let c = self.channels;
        for idx in envtree::spatial_order(&normals).chunks(GROUP_RAYS) {
            let ns: Vec<[f64; 3]> = idx.iter().map(|&i| normals[i as usize]).collect();
            for (value, &i) in self.radiances(&ns).into_iter().zip(idx) {
                put(
                    &mut out[i as usize * c..][..c],
                    value,
                    self.tree.channels,
                    self.albedo,
                );
            }
        }
        Ok(())
    }
}

/// Σ (L(lᵢ) − L̄) w(n·lᵢ) / N over N visible-normal samples lᵢ (GGX α seen from `v` at normal
/// `n`, world frame; `rot` takes world directions to the map's): the residual of a narrow GGX
/// lobe (`mean` L̄; zero for the integral itself), `weight` the lobe over the sampling density.
/// With `core` = (the lobe's peak, cos θ) only the samples within θ of the peak count (the
/// rest of the lobe is the tree's, [`EnvTree::tail`]).  Also returns Σ w / N over the samples
/// that count (the lobe's integral over them).  The points are a Hammersley set, turned per
/// integral by a hash of `key`.
#[allow(clippy::too_many_arguments)]
pub(super) fn vndf_residual(
    sampler: &Sampler,
    rot: &Mat3,
    alpha: f64,
    n: [f64; 3],
    v: [f64; 3],
    mean: [f64; 3],
    key: [f64; 3],
    core: Option<([f64; 3], f64)>,
    weight: impl Fn(f64) -> f64,
) -> ([f64; 3], f64) {
    let (t, b) = brdf::tangent_frame(n);
    let vl = [
        crate::base::vec::dot(v, t),
        crate::base::vec::dot(v, b),
        crate::base::vec::dot(v, n).max(1e-6),
    ];
    let lc = envtree::light_channels(sampler.channels());
    let h = key.iter().fold(0x9E37_79B9u32, |h, &k| {
        (h ^ (k as f32).to_bits()).wrapping_mul(0x85EB_CA6B)
    });
    let shift = (h >> 8) as f64 / (1u32 << 24) as f64;
    let mut acc = [0.0f64; 3];
    let mut sum_w = 0.0;
    let mut px = [0f32; 4];
    for i in 0..VNDF_SAMPLES {
        let u1 = (i as f64 + 0.5) / VNDF_SAMPLES as f64;
        let u2 = ((i as u32).reverse_bits() as f64 / 4294967296.0 + shift).fract();
        let m = brdf::sample_vndf(alpha, vl, u1, u2);
        let vh = crate::base::vec::dot(vl, m);
        let ll = [0, 1, 2].map(|k| 2.0 * vh * m[k] - vl[k]);
        if !(ll[2] > 0.0) {
            continue;
        }
        let w = weight(ll[2]);
        let l = [0, 1, 2].map(|k| ll[0] * t[k] + ll[1] * b[k] + ll[2] * n[k]);
        if let Some((peak, cos_core)) = core {
            if crate::base::vec::dot(l, peak) < cos_core {
                continue;
            }
        }
        let e = [0, 1, 2].map(|i| (rot[i][0] * l[0] + rot[i][1] * l[1] + rot[i][2] * l[2]) as f32);
        sampler.sample(e, &mut px);
        for k in 0..lc {
            acc[k] += (px[k] as f64 - mean[k]) * w;
        }
        sum_w += w;
    }
    let n = VNDF_SAMPLES as f64;
    (acc.map(|a| a / n), sum_w / n)
}

/// Checks an albedo: three finite values ≥ 0.
pub fn check_albedo(a: [f64; 3]) -> Result<[f64; 3]> {
    if a.iter().all(|v| v.is_finite() && *v >= 0.0) {
        Ok(a)
    } else {
        Err(Error::param(
            "albedo",
            format!("{a:?}: three finite values of at least 0 are expected"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plan_trees_lobes_down_to_one_leaf_of_a_512_face() {
        let m = Mapping::parse("latlong", None).unwrap();
        let img = Image::new(512, 256, 3);
        let env = EnvMap::new(m, &img, "env").unwrap();
        let ggx = |r: f64| Material::Ggx { alpha: r * r };
        assert_eq!(plan(&env, Material::Lambert), (Method::Tree, 64));
        assert_eq!(plan(&env, ggx(0.5)), (Method::Tree, 64));
        assert_eq!(plan(&env, ggx(0.25)), (Method::Tree, 256));
        // 16/α wants a 1024 face; the 512 face holds 7.3 leaves across α: averaged leaves.
        assert_eq!(plan(&env, ggx(0.15)), (Method::Tree, 512));
        assert_eq!(plan(&env, ggx(0.1)), (Method::Tree, 512));
        assert_eq!(plan(&env, ggx(0.06)), (Method::Tree, 512));
        // Under 1 leaf across α (roughness 0.055): visible-normal samples.
        assert_eq!(plan(&env, ggx(0.05)).0, Method::Vndf);
    }
}
