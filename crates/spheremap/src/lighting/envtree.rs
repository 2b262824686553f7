//! The environment as a tree of cube-map texel blocks, for integrating a BRDF lobe against it
//! exactly and fast.
//!
//! Every texel of the map — as up to 32×32 points with the map's bilinear radiance where texels
//! are larger than the tree's leaves, each with its exact solid angle — goes into the leaf of a
//! world-frame cube of face F₀ (a power of two: what the lobe needs, within what the map
//! resolves) that its direction falls in; the faces' leaves are grouped 2×2 into a pyramid up
//! to one node per face.  Each node holds
//!
//! * its **power** Σ L dω and its **solid angle** Σ dω,
//! * the **brightness-weighted centroid** of its points, where its power is evaluated (a sun
//!   inside a large node is evaluated where the sun is), and the Ω-weighted centroid, where
//!   L̄'s share is,
//! * the brightness (mean of the channels) of its residual |Σ (L − L̄) dω| and of its inner
//!   variation, for the error estimate,
//! * its bounding cone (axis and angular radius).
//!
//! An integral ∫ g(l) L(l) dω is then L̄ ∫ g dω (the material's directional albedo) plus
//! Σ [g(dᵢ) Pᵢ − g(oᵢ) L̄ Ωᵢ] over a **cut** of the tree: a node is opened while its estimated
//! error — its inner variation × the lobe's change across it, plus its residual × the lobe's
//! curvature, the lobe's scale being α near its peak, a fraction of the angle to the peak
//! farther out, and the whole node where it straddles the normal's horizon — exceeds a
//! tolerance of the integral.  For a lobe under [`AVERAGE_BELOW`] leaves wide, a leaf that
//! still exceeds it is taken as even radiance, and the lobe is averaged over its area; such a
//! narrow lobe's integral is Σ g P over the cut times the albedo over the cut's own Σ g Ω
//! ([`Cut::integral`]): its steep peak across a few leaves is summed with some error, which
//! the ratio cancels, where L̄ × (albedo − Σ g Ω) would add it at the scale of the map's mean
//! (a dark region under a bright mean lost its whole value to it).  A constant environment
//! integrates to the albedo exactly either way (the white furnace).

use super::brdf::{self, Material};
use crate::base::error::Result;
use crate::mappings::mapping::Mapping;
use crate::resample::EnvMap;
use rayon::prelude::*;

/// How finely a cut resolves the lobe (the tolerances, tuned against brute force).
#[derive(Clone, Copy, Debug)]
pub struct CutRule {
    /// A node is opened while its estimated error exceeds `tol` × the integral's scale
    /// (L̄ × the lobe's albedo).
    pub tol: f64,
    /// Far from the peak the lobe varies on `far` × the angle to the peak.
    pub far: f64,
    /// The largest scale (radians): the cosine's and the broad lobes'.
    pub broad: f64,
}

impl Default for CutRule {
    fn default() -> Self {
        CutRule {
            tol: 1e-5,
            far: 0.25,
            broad: 0.5,
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Node {
    /// Σ L dω and Σ dω: the node's power and solid angle.
    power: [f32; 3],
    omega: f32,
    /// The Ω-weighted centroid (unit): where L̄'s share is evaluated.
    odir: [f32; 3],
    /// |Σ (L − L̄) dω| and the variation inside the node, Σ |L − L̄_node| dω, of the
    /// brightness (the mean of the channels, so no channel is under-weighted).
    abs_res: f32,
    var: f32,
    /// The brightness-weighted centroid (unit): where the power is evaluated.
    dir: [f32; 3],
    /// Bounding cone: axis (unit), the sine of the radius, the radius.
    axis: [f32; 3],
    sin_r: f32,
    rad: f32,
}

struct Level {
    /// Texels per face edge.
    m: usize,
    nodes: Vec<Node>,
}

/// The environment tree (see the module's notes).
pub struct EnvTree {
    /// Finest first.
    levels: Vec<Level>,
    /// L̄ per channel (the map's mean radiance over the sphere).
    pub mean: [f64; 3],
    /// 1 (grey) or 3 (RGB) channels of light.
    pub channels: usize,
    /// The cube's face size F₀.
    pub face: usize,
    cube: Mapping,
}

/// The world-frame cube face a map of `w`×`h` texels is resolved by: the power of two at or above
/// √(w·h/6), within 8..=`cap`.
pub fn face_for(w: usize, h: usize, cap: usize) -> usize {
    let f = ((w as f64 * h as f64) / 6.0).sqrt();
    (f.max(8.0) as usize)
        .next_power_of_two()
        .clamp(8, cap.max(8))
}

/// How many points per texel axis stand for a texel of a `w`×`h` map of `m` in a tree of face
/// `face`: enough that they are at most half a leaf apart (1 to 32: a map coarser than the
/// tree fills every leaf, so that a leaf's radiance is even over it).
fn sub_points(m: Mapping, w: usize, h: usize, face: usize) -> usize {
    let texel = (4.0 * std::f64::consts::PI / (w as f64 * h as f64)).sqrt();
    let _ = m;
    let leaf = std::f64::consts::FRAC_PI_2 / face as f64;
    ((2.0 * texel / leaf).ceil() as usize).clamp(1, 32)
}

/// Leaves across α below which a leaf the lobe varies across is averaged over (narrow lobes on
/// the finest tree a map allows); wider lobes read each leaf at its centroid.
pub const AVERAGE_BELOW: f64 = 8.0;

/// The fewest leaves of the finest tree across α that a GGX lobe is integrated on the tree
/// with (measured against brute force: roughness 0.08, 2.1 leaves of a 512 face, 45 dB;
/// 0.065, 1.4 leaves, 36 dB, still above visible-normal sampling's 24–28 dB); narrower lobes
/// are sampled.
pub const MIN_LEAVES_PER_ALPHA: f64 = 1.0;

/// The cube face that resolves `material`'s lobe (the power of two at or above
/// `FACE_PER_ALPHA`/α), at least 64.
pub const FACE_PER_ALPHA: f64 = 16.0;

/// The cube face that resolves `material`'s lobe (see [`FACE_PER_ALPHA`]).
pub fn face_needed(material: Material) -> usize {
    match material {
        Material::Lambert => 64,
        Material::Ggx { alpha } => ((FACE_PER_ALPHA / alpha.max(1e-9)).min(1e6) as usize)
            .next_power_of_two()
            .max(64),
    }
}

/// The light channels of a map with `c` channels: RGB of RGB(A), else the first (grey).
pub fn light_channels(c: usize) -> usize {
    if c >= 3 {
        3
    } else {
        1
    }
}

/// Every point a tree of face `face` sums: each texel of the map as k×k points (the map's
/// bilinear radiance over its area; k grows until the points are about half a leaf apart, so
/// texels larger than the leaves fill them), with its exact solid angle, put into the leaf of
/// the world-frame cube its direction falls in.  `point(L, d, dω)` makes each point's share
/// (in parallel; L is RGB, or grey in L[0]; d the unit world direction); `add(leaf, share)`
/// sums them in the map's row order, so the sums are the same on any number of threads.
pub(crate) fn sum_points<T: Send>(
    env: &EnvMap,
    world_to_env: [[f64; 3]; 3],
    face: usize,
    point: impl Fn([f64; 3], [f64; 3], f64) -> T + Sync,
    mut add: impl FnMut(usize, T),
) -> Result<()> {
    let cube = Mapping::parse("cube", None)?;
    let (w, h, ch) = (env.width, env.height, env.channels);
    let c = light_channels(ch);
    let m = env.mapping;
    let r = world_to_env;
    let k = sub_points(m, w, h, face);
    let (wk, hk) = (w * k, h * k);
    let sampler = &crate::resample::Sampler::new(env);
    let point = &point;
    let cube = &cube;
    let block = (32 / k).max(1);
    for y0 in (0..h).step_by(block) {
        let parts: Vec<(usize, T)> = (y0 * k..((y0 + block).min(h)) * k)
            .into_par_iter()
            .flat_map_iter(|ys| {
                (0..wk).filter_map(move |xs| {
                    let dw = m.texel_solid_angle(xs, ys, wk, hk);
                    if !(dw > 0.0) {
                        return None;
                    }
                    let uv = [(xs as f64 + 0.5) / wk as f64, (ys as f64 + 0.5) / hk as f64];
                    let d = m.uv_to_dir(uv)?;
                    // The radiance there: the texel itself, or between texels the bilinear
                    // lookup every other spheremap path makes.
                    let mut px = [0f32; 8];
                    if k == 1 {
                        px[..ch].copy_from_slice(&env.data[(ys * w + xs) * ch..][..ch]);
                    } else {
                        sampler.sample(d.map(|v| v as f32), &mut px);
                    }
                    // Map frame → world: the transpose of world → map.
                    let d = brdf::normalize([
                        r[0][0] * d[0] + r[1][0] * d[1] + r[2][0] * d[2],
                        r[0][1] * d[0] + r[1][1] * d[1] + r[2][1] * d[2],
                        r[0][2] * d[0] + r[1][2] * d[1] + r[2][2] * d[2],
                    ]);
                    let [u, v] = cube.dir_to_uv(d);
                    let i = ((u * face as f64) as usize).min(face - 1);
                    let j = ((v * (6 * face) as f64) as usize).min(6 * face - 1);
                    let l = if c == 3 {
                        [px[0] as f64, px[1] as f64, px[2] as f64]
                    } else {
                        [px[0] as f64, 0.0, 0.0]
                    };
                    Some((j * face + i, point(l, d, dw)))
                })
            })
            .collect();
        for (leaf, t) in parts {
            add(leaf, t);
        }
    }
    Ok(())
}

impl EnvTree {
    /// Builds the tree of `env` with leaves on a world-frame cube of face `face`;
    /// `world_to_env` takes world directions to the map's frame.  Every texel of the map is
    /// put, with its exact solid angle, into the leaf its centre's direction falls in: the
    /// tree sums exactly what a brute-force sum over the map's texels sums.
    pub fn build(env: &EnvMap, world_to_env: [[f64; 3]; 3], face: usize) -> Result<EnvTree> {
        let cube = Mapping::parse("cube", None)?;
        let c = light_channels(env.channels);
        let lum = |l: [f64; 3]| brightness(l, c);
        let mut acc = vec![Acc::default(); 6 * face * face];
        sum_points(
            env,
            world_to_env,
            face,
            |l, d, dw| {
                let wt = (lum(l).max(0.0) + 1e-30) * dw;
                Acc {
                    power: l.map(|v| v * dw),
                    wd: [d[0] * wt, d[1] * wt, d[2] * wt],
                    od: [d[0] * dw, d[1] * dw, d[2] * dw],
                    omega: dw,
                    lum: lum(l) * dw,
                    var: 0.0,
                }
            },
            |leaf, a| acc[leaf].add(&a),
        )?;
        let total = acc.iter().fold([0.0; 4], |s, a| {
            [
                s[0] + a.power[0],
                s[1] + a.power[1],
                s[2] + a.power[2],
                s[3] + a.omega,
            ]
        });
        if !total.iter().all(|v| v.is_finite()) || !(total[3] > 0.0) {
            return Err(crate::Error::param(
                "env",
                "its radiance does not sum to a finite value (Inf or NaN in the map)",
            ));
        }
        let mean = [0, 1, 2].map(|k| total[k] / total[3]);
        let mean_lum = lum(mean);
        // Leaves are indexed face·m² + j·m + i, which is the stack's row-major order.
        let mut levels = Vec::new();
        let mut m = face;
        loop {
            levels.push(Level {
                m,
                nodes: finish(&acc, m, &cube, mean_lum),
            });
            if m == 1 {
                break;
            }
            let half = m / 2;
            acc = (0..6 * half * half)
                .into_par_iter()
                .map(|k| {
                    let (f, j, i) = (k / (half * half), (k / half) % half, k % half);
                    let kids = [(0, 0), (0, 1), (1, 0), (1, 1)]
                        .map(|(dj, di)| &acc[f * m * m + (2 * j + dj) * m + 2 * i + di]);
                    let mut r = Acc::default();
                    for ch in kids {
                        r.add(ch);
                    }
                    // The variation between the children's means adds to theirs.
                    if r.omega > 0.0 {
                        let mean = r.lum / r.omega;
                        r.var += kids
                            .iter()
                            .map(|c| (c.lum - c.omega * mean).abs())
                            .sum::<f64>();
                    }
                    r
                })
                .collect();
            m = half;
        }
        Ok(EnvTree {
            levels,
            mean,
            channels: c,
            face,
            cube,
        })
    }

    /// The memory a tree of face `face` takes while it is built (the leaves' sums and every
    /// level's nodes), in bytes.
    pub fn bytes(face: usize) -> u128 {
        let leaves = 6 * face as u128 * face as u128;
        leaves * (std::mem::size_of::<Acc>() as u128 + 2 * std::mem::size_of::<Node>() as u128)
    }

    /// The brightness of L̄: the mean of its channels (its only channel for a grey map).
    pub fn mean_brightness(&self) -> f64 {
        brightness(self.mean, self.channels)
    }

    /// ∫ g(l) (L(l) − L̄) dω for the lobe `q` (add L̄ × the lobe's albedo for ∫ g L dω).
    pub fn residual(&self, q: &Lobe) -> [f64; 3] {
        self.cut(q).residual
    }

    /// The integral of `q` over a cut of the tree (see [`Cut`]).
    pub fn integral(&self, q: &Lobe, albedo: f64) -> [f64; 3] {
        self.cut(q).integral(self.mean, albedo)
    }

    /// The lobe `q` over a cut of the tree: Σ g P − g L̄ Ω and Σ g Ω.
    pub fn cut(&self, q: &Lobe) -> Cut {
        // Start where faces are 4×4 (or the finest level if coarser).
        let start = self.levels.iter().position(|l| l.m <= 4).unwrap_or(0);
        let mut stack: [(u8, u32); 512] = [(0, 0); 512];
        let mut top = 0;
        let n0 = self.levels[start].nodes.len();
        for k in (0..n0).rev() {
            stack[top] = (start as u8, k as u32);
            top += 1;
        }
        let mut acc = [0.0f64; 3];
        let mut weight = 0.0;
        // A lobe fewer than AVERAGE_BELOW leaves wide has its leaves averaged.
        let narrow = match q.material {
            Material::Ggx { alpha } => {
                alpha * self.face as f64 / std::f64::consts::FRAC_PI_2 < AVERAGE_BELOW
            }
            Material::Lambert => false,
        };
        while top > 0 {
            top -= 1;
            let (lv, k) = stack[top];
            let level = &self.levels[lv as usize];
            let node = &level.nodes[k as usize];
            let axis = node.axis.map(|v| v as f64);
            let c = brdf::dot(axis, q.n);
            let (sin_r, rad) = (node.sin_r as f64, node.rad as f64);
            if node.rad < 1.5 && c <= -sin_r {
                continue; // wholly below the horizon
            }
            let dir = node.dir.map(|v| v as f64);
            let g = q.eval(dir);
            let open = lv > 0 && top + 4 <= stack.len();
            if (open || (lv == 0 && narrow))
                && q.error(axis, rad, c.abs() < sin_r, g, node) > q.budget
            {
                if !open {
                    // A leaf the lobe varies across: its radiance is taken as even over it,
                    // so the lobe is averaged over the leaf's area (s×s points) instead of
                    // read at one point.
                    let g = self.leaf_average(q, k as usize);
                    let om = node.omega as f64;
                    weight += g * om;
                    for ch in 0..self.channels {
                        acc[ch] += g * (node.power[ch] as f64 - self.mean[ch] * om);
                    }
                    continue;
                }
                let (m, child) = (level.m, &self.levels[lv as usize - 1]);
                let k = k as usize;
                let (f, j, i) = (k / (m * m), (k / m) % m, k % m);
                let cm = child.m;
                for (dj, di) in [(1, 1), (1, 0), (0, 1), (0, 0)] {
                    stack[top] = (
                        lv - 1,
                        (f * cm * cm + (2 * j + dj) * cm + 2 * i + di) as u32,
                    );
                    top += 1;
                }
                continue;
            }
            // Σ g (L − L̄) dω, each part at its own centroid (first-order exact).
            let go = if node.odir == node.dir {
                g
            } else {
                q.eval(node.odir.map(|v| v as f64))
            };
            if g != 0.0 || go != 0.0 {
                let om = node.omega as f64;
                weight += go * om;
                for ch in 0..self.channels {
                    acc[ch] += g * node.power[ch] as f64 - go * self.mean[ch] * om;
                }
            }
        }
        Cut {
            residual: acc,
            weight,
            narrow,
        }
    }

    /// The lobe `q` averaged over leaf `k` (its face, row and column on the finest level):
    /// s×s points on the face, s from the leaf's size against the lobe's scale (2 to 16).
    fn leaf_average(&self, q: &Lobe, k: usize) -> f64 {
        let m = self.face;
        let (f, j, i) = (k / (m * m), (k / m) % m, k % m);
        let leaf = std::f64::consts::FRAC_PI_2 / m as f64;
        let scale = match q.material {
            Material::Lambert => q.rule.broad,
            Material::Ggx { alpha } => alpha,
        };
        let s = ((8.0 * leaf / scale).ceil() as usize).clamp(2, 16);
        let mut sum = 0.0;
        for b in 0..s {
            for a in 0..s {
                let u = (i as f64 + (a as f64 + 0.5) / s as f64) / m as f64;
                let v = (f as f64 + (j as f64 + (b as f64 + 0.5) / s as f64) / m as f64) / 6.0;
                if let Some(d) = self.cube.uv_to_dir([u, v]) {
                    sum += q.eval(brdf::normalize(d));
                }
            }
        }
        sum / (s * s) as f64
    }
}

/// A lobe g over a cut of the tree.
#[derive(Clone, Copy, Debug)]
pub struct Cut {
    /// Σ over the cut of g P − g L̄ Ω: ∫ g (L − L̄) dω.
    pub residual: [f64; 3],
    /// Σ over the cut of g Ω: the lobe's integral as the cut sums it.
    pub weight: f64,
    /// The lobe was under [`AVERAGE_BELOW`] leaves wide (its leaves averaged).
    pub narrow: bool,
}

impl Cut {
    /// ∫ g L dω, given L̄ and the lobe's exact integral `albedo`: L̄ · albedo + the residual;
    /// for a narrow lobe, Σ g P · albedo / Σ g Ω instead — the cut's sum of the radiance
    /// normalized by its own sum of the lobe, so that the lobe's discretization (its steep
    /// peak across few leaves) cancels rather than being multiplied by L̄ (which for a dark
    /// region under a bright mean is the whole error).  Both are exact for a constant map.
    pub fn integral(&self, mean: [f64; 3], albedo: f64) -> [f64; 3] {
        if self.narrow && self.weight > 0.0 {
            [0, 1, 2].map(|k| (self.residual[k] + mean[k] * self.weight) * albedo / self.weight)
        } else {
            [0, 1, 2].map(|k| mean[k] * albedo + self.residual[k])
        }
    }
}

/// A node's sums while the tree is built (f64).
#[derive(Clone, Copy, Debug, Default)]
struct Acc {
    /// Σ L dω.
    power: [f64; 3],
    wd: [f64; 3],
    od: [f64; 3],
    omega: f64,
    lum: f64,
    var: f64,
}

impl Acc {
    fn add(&mut self, o: &Acc) {
        for q in 0..3 {
            self.power[q] += o.power[q];
            self.wd[q] += o.wd[q];
            self.od[q] += o.od[q];
        }
        self.omega += o.omega;
        self.lum += o.lum;
        self.var += o.var;
    }
}

/// The brightness the tree weighs and estimates errors by: the mean of the channels (each
/// counts alike: a blue sky is not under-weighted), the channel itself for a grey map.
pub(crate) fn brightness(l: [f64; 3], channels: usize) -> f64 {
    if channels == 3 {
        (l[0] + l[1] + l[2]) / 3.0
    } else {
        l[0]
    }
}

/// The bounding cone of texel `k` of a cube of face `m` (the face stack's row-major index):
/// the direction of its centre and the largest angle from it to a corner.
pub(crate) fn cone(cube: &Mapping, m: usize, k: usize) -> ([f64; 3], f64) {
    let (f, j, i) = (k / (m * m), (k / m) % m, k % m);
    let mf = m as f64;
    let eps = 1e-9;
    let uv = |a: f64, b: f64| {
        let u = (a / mf).clamp(eps, 1.0 - eps);
        let v = (f as f64 + (b / mf).clamp(eps, 1.0 - eps)) / 6.0;
        brdf::normalize(cube.uv_to_dir([u, v]).expect("on the cube"))
    };
    let axis = uv(i as f64 + 0.5, j as f64 + 0.5);
    let mut rad: f64 = 0.0;
    for (a, b) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let d = uv(i as f64 + a, j as f64 + b);
        rad = rad.max(brdf::dot(axis, d).clamp(-1.0, 1.0).acos());
    }
    (axis, rad)
}

/// Nodes of a level from their accumulated sums.
fn finish(acc: &[Acc], m: usize, cube: &Mapping, mean_lum: f64) -> Vec<Node> {
    acc.par_iter()
        .enumerate()
        .map(|(k, a)| {
            let (power, wd, od) = (&a.power, &a.wd, &a.od);
            let (axis, rad) = cone(cube, m, k);
            let l = brdf::dot(*wd, *wd).sqrt();
            let dir = if l > 0.0 {
                [wd[0] / l, wd[1] / l, wd[2] / l]
            } else {
                axis
            };
            Node {
                power: power.map(|v| v as f32),
                omega: a.omega as f32,
                odir: {
                    let l = brdf::dot(*od, *od).sqrt();
                    if l > 0.0 {
                        [od[0] / l, od[1] / l, od[2] / l].map(|v| v as f32)
                    } else {
                        axis.map(|v| v as f32)
                    }
                },
                abs_res: (a.lum - mean_lum * a.omega).abs() as f32,
                var: a.var as f32,
                dir: dir.map(|v| v as f32),
                axis: axis.map(|v| v as f32),
                sin_r: rad.sin() as f32,
                rad: rad as f32,
            }
        })
        .collect()
}

/// What a lobe weighs the environment by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// The material's BRDF times the cosine, f(l, v)·(n·l).
    Brdf,
    /// The split-sum prefilter's GGX weight with n = v: D(h)·(n·l)⁺/4 (see
    /// [`super::prefilter`]).
    SplitSum,
}

/// One lobe to integrate: a material seen from `v` at normal `n` (world frame, unit), with the
/// cut rule and the error a node may leave.
pub struct Lobe {
    pub material: Material,
    pub kernel: Kernel,
    pub n: [f64; 3],
    pub v: [f64; 3],
    /// The mirror direction (the GGX lobe's peak; the normal for Lambert).
    peak: [f64; 3],
    rule: CutRule,
    /// A node whose estimated error is over this is opened.
    budget: f64,
}

impl Lobe {
    /// `scale` is the size of the integral (L̄'s brightness × the lobe's albedo): nodes are
    /// opened while their error estimate exceeds `rule.tol` × it.
    pub fn new(material: Material, n: [f64; 3], v: [f64; 3], rule: CutRule, scale: f64) -> Lobe {
        let nv = brdf::dot(n, v);
        let peak = match material {
            Material::Lambert => n,
            Material::Ggx { .. } => [0, 1, 2].map(|k| 2.0 * nv * n[k] - v[k]),
        };
        Lobe {
            material,
            kernel: Kernel::Brdf,
            n,
            v,
            peak,
            rule,
            budget: rule.tol * scale.abs().max(1e-30),
        }
    }

    /// The split-sum prefilter's lobe about `r` (n = v = r): D(h)·(n·l)⁺/4, h = normalize(l + r);
    /// `scale` as for [`Lobe::new`].
    pub fn split_sum(alpha: f64, r: [f64; 3], rule: CutRule, scale: f64) -> Lobe {
        Lobe {
            kernel: Kernel::SplitSum,
            ..Lobe::new(Material::Ggx { alpha }, r, r, rule, scale)
        }
    }

    #[inline(always)]
    pub fn eval(&self, l: [f64; 3]) -> f64 {
        if self.kernel == Kernel::SplitSum {
            return self.split_sum_eval(l);
        }
        brdf::eval_cos(self.material, self.n, self.v, l)
    }

    /// D(h)·(n·l)⁺/4 with n = v, h = normalize(l + n).
    #[inline(never)]
    fn split_sum_eval(&self, l: [f64; 3]) -> f64 {
        let Material::Ggx { alpha } = self.material else {
            return 0.0;
        };
        let c = brdf::dot(self.n, l);
        if !(c > 0.0) {
            return 0.0;
        }
        // n·h for h = normalize(l + n): √((1 + c)/2).
        brdf::ggx_d(alpha, ((1.0 + c) * 0.5).sqrt()) * c * 0.25
    }

    /// The error of evaluating a node (cone `axis`, radius `rad`) at its representative
    /// direction, where the lobe is `g`: the node's inner variation × the lobe's change across
    /// it (first order) plus its residual × the lobe's curvature (second order); the lobe's
    /// largest value in the node is taken where the node comes nearest the peak.
    #[inline]
    fn error(&self, axis: [f64; 3], rad: f64, straddles: bool, g: f64, node: &Node) -> f64 {
        let cos_t = brdf::dot(axis, self.peak).clamp(-1.0, 1.0);
        let theta = cos_t.acos();
        let near = (theta - rad).max(0.0);
        let g_max = if near == 0.0 {
            self.eval(self.peak).max(g)
        } else {
            // The node's point nearest the peak: the axis turned toward it by `rad`.
            let s = theta.sin().max(1e-12);
            let (a, b) = ((theta - rad).sin() / s, rad.sin() / s);
            let d = [0, 1, 2].map(|k| a * axis[k] + b * self.peak[k]);
            self.eval(d).max(g)
        };
        if g_max == 0.0 {
            return 0.0;
        }
        let scale = match self.material {
            Material::Lambert => self.rule.broad,
            Material::Ggx { alpha } => alpha.max(self.rule.far * near).min(self.rule.broad),
        };
        let x = if straddles {
            1.0
        } else {
            (rad / scale).min(1.0)
        };
        g_max * (node.var as f64 * x + node.abs_res as f64 * x * x)
    }
}
