//! Prefiltered lighting for engines: the GGX radiance mip chain and the irradiance map.
//!
//! ## What a level holds
//!
//! Level i of L is the environment convolved with the GGX lobe of perceptual roughness rᵢ
//! ([`RoughnessMap`]), at size N >> i.  For `cube`, `octahedral`, `latlong` (and every other
//! mapping but `sphere`) a texel in direction r holds the split-sum prefiltered radiance
//! (Karis 2013, the "LD" term Filament, three.js and Unreal sample), which assumes n = v = r:
//!
//! LD(r) = ∫ L(l) D(h) (r·l)⁺ dω / ∫ D(h) (r·l)⁺ dω,  h = normalize(l + r), α = rᵢ²,
//!
//! the integral importance-sampled estimators (Σ L(lₖ)(n·lₖ) / Σ (n·lₖ), lₖ from D) converge
//! to.  A constant environment gives itself (the white furnace).  Roughness 0 is the
//! environment resampled (`convert`).
//!
//! For `sphere` the n = v assumption is not needed: the view is fixed, so level i is the
//! **exact** GGX MatCap of roughness rᵢ and albedo 1 ([`super::matcap`]), the full BRDF
//! integral L_o(n, v) = ∫ f L (n·l)⁺ dω for the normal n whose mirror direction the texel
//! addresses.  A constant environment of radiance 1 gives the GGX directional albedo E(n·v).
//!
//! A texel holds the lobe's mean over its footprint: where the texel is wider than the lobe
//! (or than about 3°), the level is evaluated on a canvas m times finer and each texel is the
//! solid-angle mean of its m×m children ([`fineness`], [`crate::resample::energy::reduce`]),
//! so the level keeps the power a narrow lobe would otherwise hit or miss at the texel's
//! centre.
//!
//! `irradiance`: one level holding (1/π) ∫ L(l) (n·l)⁺ dω, the radiance a white Lambertian
//! surface of normal n reflects (a constant environment gives itself); for `sphere`, the
//! Lambert MatCap of albedo 1.  Multiply by π for the irradiance E(n).
//!
//! ## Method
//!
//! [`PrefilterMethod::Tree`] (the default) computes each integral on the environment's tree
//! ([`super::envtree`]) with the control variate L̄: LD = L̄ + Σ over a cut of (L − L̄)·k / W(α),
//! k = D(h)(n·l)⁺/4 and W(α) = ∫ k dω its exact integral ([`split_sum_norm`]), to the
//! tolerance ([`DEFAULT_TOLERANCE`]).  The tree's finest face resolves the lobe (16 leaves
//! across α, up to faces of 512; under [`envtree::AVERAGE_BELOW`] leaves, leaves the lobe
//! varies across average it over their area, down to [`MIN_LEAVES_PER_ALPHA`] leaves,
//! α ≈ 0.003, roughness ≈ 0.055), each such integral normalized by its cut's own sum of the
//! lobe ([`envtree::Cut::integral`]).
//! Narrower lobes take 256 visible-normal samples with bilinear lookups, as MatCaps do.  The
//! irradiance level is the cosine integral ([`super::cosine`], face by
//! [`super::cosine::face_for_tolerance`]).
//!
//! [`PrefilterMethod::Sampled`] is filtered importance sampling (Křivánek and Colbert 2008) as
//! Filament's `cmgen` does it: a Hammersley set of the lobe, each sample read trilinearly from
//! the mip of a world-frame cube pyramid whose texel covers its share of the lobe, weighted by
//! n·l and normalized (so the furnace holds); fast, and as blurred as the mips are.

use super::brdf::{self, Material};
use super::envtree::{self, CutRule, EnvTree, Lobe};
use super::matcap::{self, Method, TREE_FACE_CAP};
use crate::base::error::{Error, Result};
use crate::frame::view::Mat3;
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use crate::resample::energy::{reduce, LightCheck, Moments};
use crate::resample::{EnvMap, Outside, Progress, Sampler};
use crate::trace::generate::{generate, GenerateOptions, RaySource};

/// The error each integral of a level may leave, relative to the map's mean radiance, by
/// default: a 256² chain of `park.exr` within 55 dB of 1e-5's in a third of the time.
pub const DEFAULT_TOLERANCE: f64 = 1e-4;

crate::base::named::named_enum! {
    /// How the levels' integrals are computed (the names `--method` takes).
    #[derive(Default)]
    pub enum PrefilterMethod: "method" as "method" {
        /// On the environment's tree, to the tolerance (exact; the default).
        #[default]
        Tree = "tree" | "exact",
        /// Filtered importance sampling as Filament's `cmgen` does it (Křivánek and Colbert
        /// 2008): `lobe_samples` GGX samples per texel, each read from the mip of a
        /// world-frame cube whose texel covers the sample's share of the lobe.  Fast and
        /// approximate.
        Sampled = "sampled" | "fis",
    }
}

pub use super::envtree::MIN_LEAVES_PER_ALPHA;

crate::base::named::named_enum! {
    /// How level i of L is given its roughness (the names `--roughness-map` takes).
    #[derive(Default)]
    pub enum RoughnessMap: "roughness map" as "roughness_map" {
        /// Filament (`cmgen`, and its shader's `perceptualRoughnessToLod`; the default):
        /// lod = i/(L − 1), r = 1 − √(1 − lod), the inverse of lod = r(2 − r); three.js from
        /// r187 too (`PMREMGenerator.lodToRoughness`).
        #[default]
        Filament = "filament",
        /// three.js up to r186 (`roughnessToMip` of its cube-UV PMREM shader): the roughness
        /// three.js reads from a face of 2^m texels, m = log₂ of the level's size; level 0 is
        /// the mirror.
        Threejs = "threejs" | "three",
        /// r = i/(L − 1).
        Linear = "linear",
    }
}

impl RoughnessMap {
    /// The perceptual roughness of level `i` of `levels`, whose size (a cube's face, a
    /// lat-long's height) is `size` texels.
    pub fn roughness(self, i: usize, levels: usize, size: usize) -> f64 {
        if i == 0 {
            return 0.0;
        }
        let lod = i as f64 / (levels.max(2) - 1) as f64;
        match self {
            RoughnessMap::Filament => filament_lod_to_roughness(lod),
            RoughnessMap::Linear => lod.min(1.0),
            RoughnessMap::Threejs => threejs_mip_to_roughness((size.max(1) as f64).log2()),
        }
    }
}

/// Filament's `lodToPerceptualRoughness`: the r with r(2 − r) = lod (lod in 0..=1).
pub fn filament_lod_to_roughness(lod: f64) -> f64 {
    (1.0 - (1.0 - lod.clamp(0.0, 1.0)).sqrt()).clamp(0.0, 1.0)
}

/// three.js's `roughnessToMip` (the mip, log₂ of a face size, its shader reads at roughness
/// `r`; PMREM's constants r0…r6 and m0…m6).
pub fn threejs_roughness_to_mip(r: f64) -> f64 {
    const R: [f64; 5] = [1.0, 0.8, 0.4, 0.305, 0.21];
    const M: [f64; 5] = [-2.0, -1.0, 2.0, 3.0, 4.0];
    for k in 1..5 {
        if r >= R[k] {
            return (R[k - 1] - r) * (M[k] - M[k - 1]) / (R[k - 1] - R[k]) + M[k - 1];
        }
    }
    -2.0 * (1.16 * r).log2()
}

/// The inverse of [`threejs_roughness_to_mip`] (mip ≥ −2; the roughness is 1 at −2).
pub fn threejs_mip_to_roughness(mip: f64) -> f64 {
    const R: [f64; 5] = [1.0, 0.8, 0.4, 0.305, 0.21];
    const M: [f64; 5] = [-2.0, -1.0, 2.0, 3.0, 4.0];
    if mip <= M[0] {
        return 1.0;
    }
    for k in 1..5 {
        if mip <= M[k] {
            return R[k - 1] - (mip - M[k - 1]) * (R[k - 1] - R[k]) / (M[k] - M[k - 1]);
        }
    }
    // mip = −2 log₂(1.16 r) beyond m6.
    (2f64.powf(-mip / 2.0) / 1.16).min(R[4])
}

/// W(α) = ∫ D(h) (n·l)⁺ dω_l / 4 with n = v (h = normalize(l + n)): the split-sum kernel's
/// integral.  With dω_l = 4 (n·h) dω_h and ξ = D's CDF in cos²θ_h, W = ∫₀^{ξc} (2μ²(ξ) − 1) dξ,
/// μ²(ξ) = (1 − ξ)/(1 + aξ), a = α² − 1, ξc = 1/(1 + α²); in closed form
/// W = (2/a)[(α²/a) ln(2α²/(α² + 1)) − ξc] − ξc.  Near α = 1 (|a| < ¼), where the closed form
/// cancels, Gauss–Legendre on the integrand (then smooth: its pole −1/a lies beyond 4).
pub fn split_sum_norm(alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let a = a2 - 1.0;
    let xc = 1.0 / (1.0 + a2);
    if a.abs() >= 0.25 {
        return (2.0 / a) * ((a2 / a) * (2.0 * a2 / (a2 + 1.0)).ln() - xc) - xc;
    }
    let (x, w) = crate::base::quadrature::gauss_legendre(32);
    x.iter()
        .zip(&w)
        .map(|(t, wt)| {
            let xi = 0.5 * xc * (t + 1.0);
            let mu2 = (1.0 - xi) / (1.0 + a * xi);
            wt * 0.5 * xc * (2.0 * mu2 - 1.0)
        })
        .sum()
}

/// What to prefilter (the resolved options of [`super::PrefilterRequest`]).
#[derive(Clone, Copy, Debug)]
pub struct Prefilter {
    pub mapping: Mapping,
    /// Level 0's size N (the mapping's canvas of N).
    pub size: usize,
    pub levels: usize,
    pub map: RoughnessMap,
    /// One cosine-convolved level instead of the GGX chain.
    pub irradiance: bool,
    /// Output frame → world (a turned output; for `sphere`, the view).
    pub view: Mat3,
    /// World → the environment map's frame.
    pub world_to_env: Mat3,
    pub samples: u32,
    pub max_samples: u32,
    pub seed: u64,
    pub outside: Outside,
    pub max_memory: u64,
    pub rule: CutRule,
    pub method: PrefilterMethod,
    /// GGX samples per texel of [`PrefilterMethod::Sampled`].
    pub lobe_samples: usize,
    /// Each texel of a GGX or irradiance level the lobe's mean over its footprint, evaluated
    /// on a finer canvas where the texel is wider than the lobe ([`fineness`]), so that the
    /// level keeps the light (what requests ask); `false`: the lobe at the texel's centre
    /// (what engines that prefilter on the GPU compute), for comparisons.
    pub footprint: bool,
}

/// One level made.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LevelReport {
    pub level: usize,
    pub width: usize,
    pub height: usize,
    /// Perceptual roughness (α = roughness²); `null` for the irradiance.
    pub roughness: Option<f64>,
    /// `tree`, `vndf`, `mirror`, `sampled` or `cosine` (the irradiance).
    pub method: Method,
    /// The environment tree's cube face (0 for the mirror).
    pub tree_face: usize,
    /// Lighting integrals computed.
    pub integrals: u64,
    /// Children per side of each texel: its lobes were evaluated at the m×m children's
    /// centres and averaged by solid angle (1: at the texel itself; see [`fineness`]).
    pub children: usize,
    /// Time the level took (the tree's build included).
    pub seconds: f64,
    /// The light the level holds against the environment's: power per channel (every level:
    /// the kernels are normalized), and for the mirror level the SH9 irradiance.
    pub light: LightCheck,
}

/// The sizes of the levels of `p`.
pub fn level_sizes(p: &Prefilter) -> Vec<(usize, usize)> {
    (0..p.levels)
        .map(|i| p.mapping.canvas((p.size >> i).max(1)))
        .collect()
}

/// The most levels a chain of size `size` has (down to 1 texel).
pub fn max_levels(size: usize) -> usize {
    (usize::BITS - size.max(1).leading_zeros()) as usize
}

/// The default number of levels of a chain of size `size`: down to 8 texels (6 for 256),
/// at least 1.
pub fn default_levels(size: usize) -> usize {
    max_levels(size).saturating_sub(3).max(1)
}

/// Prefilters `env`: every level, level 0 first.
pub fn prefilter(
    env: &EnvMap,
    p: &Prefilter,
    progress: Option<&Progress>,
) -> Result<Vec<(Image, LevelReport)>> {
    crate::base::limits::check_map_size("size", p.size)?;
    if p.levels == 0 || p.levels > max_levels(p.size) {
        return Err(Error::param(
            "levels",
            format!(
                "{} is out of range 1..={} for size {}",
                p.levels,
                max_levels(p.size),
                p.size
            ),
        ));
    }
    let mut out = Vec::with_capacity(p.levels);
    // The environment's light, for each level's report.
    let source = Moments::of(env, &crate::resample::IDENTITY);
    // One tree at a time, rebuilt when a level needs another face.
    let mut tree: Option<EnvTree> = None;
    let mut pyramid: Option<CubePyramid> = None;
    for (i, (w, h)) in level_sizes(p).into_iter().enumerate() {
        let t0 = std::time::Instant::now();
        let n = (p.size >> i).max(1);
        let roughness = if p.irradiance {
            None
        } else {
            Some(p.map.roughness(i, p.levels, n))
        };
        let material = match roughness {
            None => Material::Lambert,
            Some(r) => Material::Ggx { alpha: r * r },
        };
        // The mirror level is the environment itself, filtered over each texel's footprint
        // like any conversion (with its peaks integrated, so it keeps the light): at least the
        // conversion's default samples.
        let mirror = material == (Material::Ggx { alpha: 0.0 });
        let samples = if mirror {
            p.samples.max(crate::resample::DEFAULT_SAMPLES)
        } else {
            p.samples
        };
        // Lobes evaluated on a finer canvas where the level's texels are wider than they are
        // (mirror and sphere levels have their own footprint rules).
        let m = if mirror || !p.footprint || matches!(p.mapping, Mapping::Sphere(_)) {
            1
        } else {
            fineness(p.mapping, w, h, material)
        };
        let (fw, fh) = (w * m, h * m);
        let gen = GenerateOptions {
            samples: p.samples,
            max_samples: p.max_samples,
            filter: crate::resample::Filter::Box,
            outside: p.outside,
            rotation: p.view,
            pos: [0.0; 3],
            seed: p.seed,
            precision: crate::resample::Precision::F32,
            max_memory: p.max_memory,
        };
        // Each level by its method: (image, method, tree face, integrals).
        let (img, method, tree_face, integrals) = if let Mapping::Sphere(_) = p.mapping {
            let bake = matcap::Bake {
                material,
                albedo: [1.0; 3],
                size: n,
                view: p.view,
                world_to_env: p.world_to_env,
                samples,
                max_samples: p.max_samples,
                seed: p.seed,
                outside: p.outside,
                max_memory: p.max_memory,
                rule: p.rule,
                normal_table: None,
            };
            let (img, r) = matcap::bake(env, &bake, progress)?;
            (img, r.method, r.tree_face, r.integrals)
        } else if mirror {
            // The mirror: the environment resampled.
            let opts = crate::resample::ResampleOptions {
                samples,
                max_samples: p.max_samples,
                outside: p.outside,
                rotation: crate::frame::view::mul(&p.world_to_env, &p.view),
                seed: p.seed,
                max_memory: p.max_memory,
                ..Default::default()
            };
            let (img, r) = crate::resample::resample(env, p.mapping, w, h, &opts, progress)?;
            (img, Method::Mirror, 0, r.lookups)
        } else if material == Material::Lambert && p.method == PrefilterMethod::Tree {
            // The cosine integral by the environment's moments, /π.
            let face = super::cosine::face_for_tolerance(p.rule.tol);
            let tree = super::cosine::CosineTree::build(env, p.world_to_env, face)?;
            let source = super::cosine::CosineSource {
                tree: &tree,
                normal: |d| d,
                scale: [1.0 / std::f64::consts::PI; 3],
                channels: tree.channels,
            };
            let (img, r) = source.generate(p.mapping, fw, fh, &gen, progress)?;
            (reduce(p.mapping, img, m), Method::Cosine, face, r.rays)
        } else if p.method == PrefilterMethod::Sampled {
            if pyramid.is_none() {
                pyramid = Some(CubePyramid::build(env, p, progress)?);
            }
            let pyramid = pyramid.as_ref().expect("built above");
            let source = SampledSource {
                pyramid,
                samples: lobe_samples(material, p.lobe_samples, pyramid.face),
            };
            let (img, r) = generate(p.mapping, fw, fh, &source, &gen, progress)?;
            (reduce(p.mapping, img, m), Method::Sampled, 0, r.rays)
        } else {
            let (method, face) = matcap::plan(env, material);
            if tree.as_ref().map(|t| t.face) != Some(face) {
                drop(tree.take()); // free the last one first
                crate::base::limits::check_memory("env", EnvTree::bytes(face), p.max_memory)?;
                tree = Some(EnvTree::build(env, p.world_to_env, face)?);
            }
            let source = LevelSource {
                tree: tree.as_ref().expect("built above"),
                material,
                norm: match material {
                    Material::Lambert => 1.0,
                    Material::Ggx { alpha } => split_sum_norm(alpha),
                },
                vndf: (method == Method::Vndf).then(|| (Sampler::new(env), p.world_to_env)),
                rule: p.rule,
            };
            let (img, r) = generate(p.mapping, fw, fh, &source, &gen, progress)?;
            (reduce(p.mapping, img, m), method, face, r.rays)
        };
        let light = {
            let level = EnvMap::new(p.mapping, &img, "level")?;
            let rotation = crate::frame::view::mul(&p.world_to_env, &p.view);
            let moments = Moments::of(&level, &rotation);
            if mirror {
                LightCheck::compare(&source, &moments)
            } else {
                LightCheck::power_only(&source, &moments)
            }
        };
        out.push((
            img,
            LevelReport {
                level: i,
                width: w,
                height: h,
                roughness,
                method,
                tree_face,
                integrals,
                children: m,
                seconds: t0.elapsed().as_secs_f64(),
                light,
            },
        ));
    }
    Ok(out)
}

/// How many times finer than a `w`×`h` level's canvas its lobes are evaluated, each texel then
/// the solid-angle mean of its m×m children ([`reduce`]): m = the side of the canvas's largest
/// texel (by solid angle: a cube face's centre, a lat-long's equator) over the smaller of the
/// GGX lobe's α and [`FINE_TEXEL`], rounded, so no child anywhere is wider than either.
/// A texel so holds the lobe's mean over its footprint: where a lobe is narrower than the
/// texel, its value at the centre alone hits or misses a small bright source (and the level's
/// power with it), and where the texel spans many degrees it misses the lobe's curvature
/// across it.
fn fineness(mapping: Mapping, w: usize, h: usize, material: Material) -> usize {
    // The side of the canvas's largest texel (a cube face's centre, a lat-long's equator).
    let rows = mapping.texel_rows(w, h);
    let mut row = Vec::with_capacity(w);
    let t = (0..h)
        .map(|y| {
            rows.solid_angles(y, &mut row);
            row.iter().copied().fold(0.0f64, f64::max)
        })
        .fold(0.0f64, f64::max)
        .sqrt();
    let child = match material {
        Material::Ggx { alpha } => alpha.min(FINE_TEXEL),
        Material::Lambert => FINE_TEXEL,
    };
    if child <= 0.0 {
        return 1;
    }
    ((t / child).round() as usize).clamp(1, FINE_MAX)
}

/// The widest child ([`fineness`]), in radians: about 3°.
const FINE_TEXEL: f64 = 0.05;

/// The most children per side of a level's texel ([`fineness`]).
const FINE_MAX: usize = 64;

/// Neighbouring texels (a 4×4 tile) whose lobes share a cut of the tree.
const GROUP_RAYS: usize = 16;

/// A level's texel in direction r: LD(r) (GGX) or the cosine-convolved radiance (Lambert).
struct LevelSource<'a> {
    tree: &'a EnvTree,
    material: Material,
    /// ∫ of the kernel (W(α); 1 for Lambert's (n·l)/π).
    norm: f64,
    vndf: Option<(Sampler<'a>, Mat3)>,
    rule: CutRule,
}

impl RaySource for LevelSource<'_> {
    fn channels(&self) -> usize {
        self.tree.channels
    }
    fn rows_per_call(&self) -> usize {
        // Tiles of 4×4 texels share cuts.
        4
    }
    fn trace(&self, _: &[[f32; 3]], dirs: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        let c = self.tree.channels;
        let scale = self.tree.mean_brightness() * self.norm;
        if let (Material::Ggx { alpha }, None) = (self.material, &self.vndf) {
            // Neighbours share a cut of the tree: the texels of a few rows in 4×4 tiles (the
            // order of a Z-order curve on the cube).
            let shared = envtree::Shared {
                alpha,
                kernel: envtree::Kernel::SplitSum,
                v: [0.0; 3],
                rule: self.rule,
            };
            let rs: Vec<[f64; 3]> = dirs
                .iter()
                .map(|d| crate::base::vec::normalize(d.map(|v| v as f64)))
                .collect();
            let order = envtree::spatial_order(&rs);
            for idx in order.chunks(GROUP_RAYS) {
                let ns: Vec<[f64; 3]> = idx.iter().map(|&i| rs[i as usize]).collect();
                let values = self.tree.shared_integrals(&shared, &ns, |_| self.norm);
                for (value, &i) in values.iter().zip(idx) {
                    for k in 0..c {
                        out[i as usize * c + k] = (value[k] / self.norm) as f32;
                    }
                }
            }
            return Ok(());
        }
        for (d, o) in dirs.iter().zip(out.chunks_exact_mut(c)) {
            let r = crate::base::vec::normalize(d.map(|v| v as f64));
            let value = match (self.material, &self.vndf) {
                (Material::Ggx { alpha }, Some((sampler, rot))) => {
                    // Samples from D(h)(n·h) about n = v = r have density D/4 in l: the
                    // kernel over it is n·l.  They take the lobe's core, the tree its tail
                    // (as for a MatCap).
                    let radius = envtree::core_radius(alpha, self.tree.face);
                    let (res, w_core) = matcap::vndf_residual(
                        sampler,
                        rot,
                        alpha,
                        r,
                        r,
                        [0.0; 3],
                        r,
                        Some((r, radius.cos())),
                        |mu_l| mu_l,
                    );
                    let lobe = Lobe::split_sum(alpha, r, self.rule, scale);
                    let tail = self.tree.tail(&lobe, radius, self.norm - w_core);
                    [0, 1, 2].map(|k| tail[k] + res[k])
                }
                (Material::Ggx { alpha }, None) => self
                    .tree
                    .integral(&Lobe::split_sum(alpha, r, self.rule, scale), self.norm),
                (Material::Lambert, _) => self.tree.integral(
                    &Lobe::new(Material::Lambert, r, r, self.rule, scale),
                    self.norm,
                ),
            };
            for k in 0..c {
                o[k] = (value[k] / self.norm) as f32;
            }
        }
        Ok(())
    }
}

/// A world-frame cube of the environment and its mips (each face's 2×2 averages), for
/// filtered importance sampling.
struct CubePyramid {
    /// Level k: faces of `face >> k`, the six stacked, RGB.
    levels: Vec<Vec<[f32; 3]>>,
    face: usize,
    channels: usize,
}

impl CubePyramid {
    /// The environment resampled (exactly, as `convert`) onto a world-frame cube of the face
    /// that resolves it (up to 512), then halved down to 1×1 faces.
    fn build(env: &EnvMap, p: &Prefilter, progress: Option<&Progress>) -> Result<CubePyramid> {
        let face = envtree::face_for(env.width, env.height, TREE_FACE_CAP);
        let cube = Mapping::parse("cube", None)?;
        let opts = crate::resample::ResampleOptions {
            samples: 1,
            rotation: p.world_to_env,
            max_memory: p.max_memory,
            ..Default::default()
        };
        let (img, _) = crate::resample::resample(env, cube, face, 6 * face, &opts, progress)?;
        let c = img.channels;
        let channels = envtree::light_channels(c);
        let mut level: Vec<[f32; 3]> = img
            .data
            .chunks_exact(c)
            .map(|px| {
                if channels == 3 {
                    [px[0], px[1], px[2]]
                } else {
                    [px[0]; 3]
                }
            })
            .collect();
        let mut levels = Vec::new();
        let mut f = face;
        loop {
            let next = (f > 1).then(|| {
                let h = f / 2;
                let mut out = vec![[0f32; 3]; 6 * h * h];
                for fc in 0..6 {
                    for y in 0..h {
                        for x in 0..h {
                            let at = |dx: usize, dy: usize| {
                                level[fc * f * f + (2 * y + dy) * f + 2 * x + dx]
                            };
                            let q = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
                            out[fc * h * h + y * h + x] =
                                [0, 1, 2].map(|k| 0.25 * (q[0][k] + q[1][k] + q[2][k] + q[3][k]));
                        }
                    }
                }
                out
            });
            levels.push(std::mem::take(&mut level));
            match next {
                Some(n) => {
                    level = n;
                    f /= 2;
                }
                None => break,
            }
        }
        Ok(CubePyramid {
            levels,
            face,
            channels,
        })
    }

    /// Bilinear within face `fc` at (s, t) (edges clamped), mip `k`.
    #[inline(always)]
    fn texel(&self, k: usize, fc: usize, s: f32, t: f32) -> [f32; 3] {
        let f = (self.face >> k).max(1);
        let (x, y) = (s * f as f32 - 0.5, t * f as f32 - 0.5);
        // x, y ≥ −0.5 (s, t in [0, 1]): floor by truncation of x + 1 (no libm call).
        let (xi, yi) = ((x + 1.0) as i32 - 1, (y + 1.0) as i32 - 1);
        let (tx, ty) = (x - xi as f32, y - yi as f32);
        let last = f as i32 - 1;
        let cl = |v: i32| v.clamp(0, last) as usize;
        let (xa, xb, ya, yb) = (cl(xi), cl(xi + 1), cl(yi), cl(yi + 1));
        let lv = &self.levels[k];
        let base = fc * f * f;
        let (a, b) = (lv[base + ya * f + xa], lv[base + ya * f + xb]);
        let (c, e) = (lv[base + yb * f + xa], lv[base + yb * f + xb]);
        let (w00, w10) = ((1.0 - tx) * (1.0 - ty), tx * (1.0 - ty));
        let (w01, w11) = ((1.0 - tx) * ty, tx * ty);
        [
            w00 * a[0] + w10 * b[0] + w01 * c[0] + w11 * e[0],
            w00 * a[1] + w10 * b[1] + w01 * c[1] + w11 * e[1],
            w00 * a[2] + w10 * b[2] + w01 * c[2] + w11 * e[2],
        ]
    }

    /// Trilinear in direction `d` at fractional mip `lod`.
    #[inline(always)]
    fn sample(&self, d: [f32; 3], lod: f32) -> [f32; 3] {
        let lod = lod.clamp(0.0, (self.levels.len() - 1) as f32);
        let k = lod as usize;
        let t = lod - k as f32;
        let (fc, s, tt) = crate::mappings::cube::dir_to_face_st(d);
        let a = self.texel(k, fc, s, tt);
        if t == 0.0 {
            return a;
        }
        let b = self.texel(k + 1, fc, s, tt);
        [
            a[0] + t * (b[0] - a[0]),
            a[1] + t * (b[1] - a[1]),
            a[2] + t * (b[2] - a[2]),
        ]
    }
}

/// One sample of a level's lobe, in the frame of n = v (z up): l, its weight n·l, the mip it
/// is read from.
struct LobeSample {
    l: [f32; 3],
    nl: f32,
    lod: f32,
}

/// A level's lobe samples (those above the horizon) and the sum of their weights.
struct LobeSet {
    samples: Vec<LobeSample>,
    weight: f64,
}

/// The Hammersley set of `n` samples of `material`'s lobe about z (the split-sum's D(h) with
/// n = v, or the cosine) with their densities; each is read from the mip whose texel covers its
/// share of the lobe, lod = ½ log₂(Ω_s / Ω_p) + 1 with Ω_s = 1/(n·pdf) and Ω_p a level-0
/// texel of the pyramid (Filament's rule).
fn lobe_samples(material: Material, n: usize, face: usize) -> LobeSet {
    let omega_p = 4.0 * std::f64::consts::PI / (6.0 * face as f64 * face as f64);
    let samples: Vec<LobeSample> = (0..n)
        .filter_map(|i| {
            let u1 = (i as f64 + 0.5) / n as f64;
            let u2 = (i as u32).reverse_bits() as f64 / 4294967296.0;
            let phi = 2.0 * std::f64::consts::PI * u2;
            let (l, pdf) = match material {
                Material::Ggx { alpha } => {
                    // cos²θ_h from D's CDF; l = reflect(z about h).
                    let a2 = alpha * alpha;
                    let c2 = (1.0 - u1) / (1.0 + (a2 - 1.0) * u1);
                    let (ch, sh) = (c2.sqrt(), (1.0 - c2).max(0.0).sqrt());
                    let h = [sh * phi.cos(), sh * phi.sin(), ch];
                    let l = [2.0 * ch * h[0], 2.0 * ch * h[1], 2.0 * ch * ch - 1.0];
                    (l, brdf::ggx_d(alpha, ch) / 4.0)
                }
                Material::Lambert => {
                    let (c, s) = ((1.0 - u1).sqrt(), u1.sqrt());
                    ([s * phi.cos(), s * phi.sin(), c], c / std::f64::consts::PI)
                }
            };
            let omega_s = 1.0 / (n as f64 * pdf.max(1e-300));
            let lod = (0.5 * (omega_s / omega_p).log2() + 1.0).max(0.0);
            (l[2] > 0.0).then_some(LobeSample {
                l: l.map(|v| v as f32),
                nl: l[2] as f32,
                lod: lod as f32,
            })
        })
        .collect();
    let weight = samples.iter().map(|s| s.nl as f64).sum::<f64>().max(1e-300);
    LobeSet { samples, weight }
}

/// A level's texel by filtered importance sampling.
struct SampledSource<'a> {
    pyramid: &'a CubePyramid,
    samples: LobeSet,
}

impl RaySource for SampledSource<'_> {
    fn channels(&self) -> usize {
        self.pyramid.channels
    }
    fn trace(&self, _: &[[f32; 3]], dirs: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        let c = self.pyramid.channels;
        let set = &self.samples;
        for (d, o) in dirs.iter().zip(out.chunks_exact_mut(c)) {
            let r = crate::base::vec::normalize(d.map(|v| v as f64));
            let (t, b) = brdf::tangent_frame(r);
            let (t, b, r) = (
                t.map(|v| v as f32),
                b.map(|v| v as f32),
                r.map(|v| v as f32),
            );
            let mut acc = [0.0f64; 3];
            for smp in &set.samples {
                let [x, y, z] = smp.l;
                let l = [
                    x * t[0] + y * b[0] + z * r[0],
                    x * t[1] + y * b[1] + z * r[1],
                    x * t[2] + y * b[2] + z * r[2],
                ];
                let v = self.pyramid.sample(l, smp.lod);
                for k in 0..3 {
                    acc[k] += (v[k] * smp.nl) as f64;
                }
            }
            for k in 0..c {
                o[k] = (acc[k] / set.weight) as f32;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_sum_norm_matches_a_fine_quadrature_and_its_limits() {
        // α = 1: D = 1/π, W = ∫ (n·l)/(4π) dω = 1/4.
        assert!((split_sum_norm(1.0) - 0.25).abs() < 1e-14);
        // Against a midpoint rule of the ξ integral with many points (both branches).
        for alpha in [0.005f64, 0.05, 0.2, 0.5, 0.8, 0.9, 1.0] {
            let a2 = alpha * alpha;
            let xc = 1.0 / (1.0 + a2);
            let n = 400_000;
            let fine: f64 = (0..n)
                .map(|i| {
                    let xi = xc * (i as f64 + 0.5) / n as f64;
                    let mu2 = (1.0 - xi) / (1.0 + (a2 - 1.0) * xi);
                    (2.0 * mu2 - 1.0) * xc / n as f64
                })
                .sum();
            let w = split_sum_norm(alpha);
            assert!((w - fine).abs() < 1e-7, "{alpha}: {w} vs {fine}");
        }
        // α → 0: a delta at n, where n·l = 1.
        assert!((split_sum_norm(1e-4) - 1.0).abs() < 1e-6);
        // Continuous across the branch change.
        let (lo, hi) = (
            split_sum_norm(0.75f64.sqrt() - 1e-9),
            split_sum_norm(0.75f64.sqrt() + 1e-9),
        );
        assert!((lo - hi).abs() < 1e-9);
    }

    #[test]
    fn roughness_maps_are_pinned() {
        // Filament: lod = r(2 − r) inverted, 6 levels.
        let f: Vec<f64> = (0..6)
            .map(|i| RoughnessMap::Filament.roughness(i, 6, 256 >> i))
            .collect();
        for (i, r) in f.iter().enumerate() {
            assert!((r * (2.0 - r) - i as f64 / 5.0).abs() < 1e-12);
        }
        assert_eq!(f[5], 1.0);
        // three.js: the inverse of roughnessToMip at log2 of the level's size.
        for r in [0.05, 0.1, 0.21, 0.25, 0.305, 0.35, 0.4, 0.6, 0.8, 0.9, 1.0] {
            let m = threejs_roughness_to_mip(r);
            assert!((threejs_mip_to_roughness(m) - r).abs() < 1e-12, "{r}");
        }
        assert!(
            (RoughnessMap::Threejs.roughness(1, 6, 128) - 2f64.powf(-3.5) / 1.16).abs() < 1e-15
        );
        assert!((RoughnessMap::Threejs.roughness(4, 6, 16) - 0.21).abs() < 1e-12);
        assert_eq!(RoughnessMap::Linear.roughness(2, 5, 64), 0.5);
        assert_eq!(default_levels(256), 6);
        assert_eq!(default_levels(4), 1);
    }
}
