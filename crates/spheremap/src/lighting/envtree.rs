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
/// with; narrower lobes are split, their core sampled, their tail on the tree
/// ([`EnvTree::tail`]).  Measured against a brute-force sum that resolves the lobe, on maps
/// with a one-texel sun: roughness 0.08 (2.1 leaves of a 512 face) 66–68 dB, 0.065 (1.4
/// leaves) 65–66 dB, and at 0.05 (0.8 leaves) the split 58–71 dB, the tree 62–65 dB at 2.5×
/// the time.
pub const MIN_LEAVES_PER_ALPHA: f64 = 1.0;

/// The core of a narrow lobe that visible-normal samples cover, in units of α: the rest, its
/// tail, is summed on the tree ([`EnvTree::tail`]).  (At roughness 0.05 on a studio map with
/// small bright softboxes and a sun: 58 dB, against 31 dB for samples over the whole lobe.)
pub const CORE_PER_ALPHA: f64 = 8.0;

/// The radius (radians) about a GGX lobe's peak that visible-normal samples cover for a tree
/// of face `face`: [`CORE_PER_ALPHA`] × α, and at least two of its leaves.
pub fn core_radius(alpha: f64, face: usize) -> f64 {
    (CORE_PER_ALPHA * alpha).max(2.0 * std::f64::consts::FRAC_PI_2 / face as f64)
}

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

pub use crate::resample::energy::light_channels;

/// Every point a tree of leaves of face `leaf_face` sums: each texel of the map as k×k points
/// (the map's bilinear radiance over its area; k grows until the points are about half such a
/// leaf apart, so texels larger than the leaves fill them), with its exact solid angle, put
/// into the cell of the world-frame cube of face `face` (`leaf_face` or finer) its direction
/// falls in.  `point(L, d, dω)` makes each point's share
/// (in parallel; L is RGB, or grey in L[0]; d the unit world direction); `merge(a, b)` may
/// fold share b into a, the share of the point before it on the same row and in the same
/// leaf (returning false where it does not); `add(leaf, share)` sums what is left in the
/// map's row order, so the sums are the same on any number of threads.
pub(crate) fn sum_points<T: Send>(
    env: &EnvMap,
    world_to_env: [[f64; 3]; 3],
    leaf_face: usize,
    face: usize,
    point: impl Fn([f64; 3], [f64; 3], f64) -> T + Sync,
    merge: impl Fn(&mut T, &T) -> bool + Sync,
    mut add: impl FnMut(usize, T),
) -> Result<()> {
    let cube = Mapping::parse("cube", None)?;
    let (w, h, ch) = (env.width, env.height, env.channels);
    let c = light_channels(ch);
    let m = env.mapping;
    let r = world_to_env;
    let k = sub_points(m, w, h, leaf_face);
    let (wk, hk) = (w * k, h * k);
    let sampler = &crate::resample::Sampler::new(env);
    let point = &point;
    let cube = &cube;
    let block = (32 / k).max(1);
    let texels = &m.texel_rows(wk, hk);
    for y0 in (0..h).step_by(block) {
        let parts: Vec<Vec<(usize, T)>> = (y0 * k..((y0 + block).min(h)) * k)
            .into_par_iter()
            .map(|ys| {
                let mut row: Vec<(usize, T)> = Vec::new();
                let mut cells = Vec::with_capacity(wk);
                texels.row(ys, &mut cells);
                for (xs, &(dw, d)) in cells.iter().enumerate() {
                    if !(dw > 0.0) {
                        continue;
                    }
                    let Some(d) = d else {
                        continue;
                    };
                    // The radiance there: the texel itself, or between texels the bilinear
                    // lookup every other spheremap path makes.
                    let mut px = [0f32; 8];
                    if k == 1 {
                        px[..ch].copy_from_slice(&env.data[(ys * w + xs) * ch..][..ch]);
                    } else {
                        sampler.sample(d.map(|v| v as f32), &mut px);
                    }
                    // Map frame → world: the transpose of world → map.
                    let d = crate::base::vec::normalize([
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
                    let leaf = j * face + i;
                    let t = point(l, d, dw);
                    if let Some(last) = row.last_mut() {
                        if last.0 == leaf && merge(&mut last.1, &t) {
                            continue;
                        }
                    }
                    row.push((leaf, t));
                }
                row
            })
            .collect();
        for (leaf, t) in parts.into_iter().flatten() {
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
            |a, b| {
                a.add(b);
                true
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
            return Err(crate::base::error::Error::param(
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

    /// ∫ g(l) L(l) dω over the directions more than `core` radians from the lobe's peak (its
    /// tail), given the lobe's own integral there (`albedo`): the cut's Σ g L dω times it over
    /// the cut's Σ g dω, as for a narrow lobe's whole cut ([`Cut::integral`]), so that the
    /// lobe's discretization cancels.  The tail is the part of a narrow lobe that
    /// visible-normal samples, which gather at the peak, leave to a few samples (a small
    /// bright source off the peak); the caller integrates the core ([`core_radius`]).
    pub fn tail(&self, q: &Lobe, core: f64, albedo: f64) -> [f64; 3] {
        let c = self.cut(&Lobe { core, ..*q });
        let sum = [0, 1, 2].map(|k| c.residual[k] + self.mean[k] * c.weight);
        if c.weight > 0.0 {
            sum.map(|v| v * albedo.max(0.0) / c.weight)
        } else {
            sum
        }
    }

    /// The integral of `q` over a cut of the tree (see [`Cut`]).
    pub fn integral(&self, q: &Lobe, albedo: f64) -> [f64; 3] {
        self.cut(q).integral(self.mean, albedo)
    }

    /// Whether `material`'s lobe is under [`AVERAGE_BELOW`] leaves wide (its leaves averaged).
    pub fn narrow(&self, material: Material) -> bool {
        match material {
            Material::Ggx { alpha } => {
                alpha * self.face as f64 / std::f64::consts::FRAC_PI_2 < AVERAGE_BELOW
            }
            Material::Lambert => false,
        }
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
        let narrow = self.narrow(q.material);
        while top > 0 {
            top -= 1;
            let (lv, k) = stack[top];
            let level = &self.levels[lv as usize];
            let node = &level.nodes[k as usize];
            let axis = node.axis.map(|v| v as f64);
            let c = crate::base::vec::dot(axis, q.n);
            let (sin_r, rad) = (node.sin_r as f64, node.rad as f64);
            if node.rad < 1.5 && c <= -sin_r {
                continue; // wholly below the horizon
            }
            let dir = node.dir.map(|v| v as f64);
            let open = lv > 0 && top + 4 <= stack.len();
            // A core left to the caller ([`EnvTree::tail`]): nodes wholly in it are
            // skipped, nodes across its edge opened, leaves in it by their centroid.
            let mut in_core = false;
            if q.core > 0.0 {
                let t = crate::base::vec::dot(axis, q.peak).clamp(-1.0, 1.0).acos();
                if t + rad <= q.core {
                    continue;
                }
                in_core = t - rad < q.core;
                if in_core && !open {
                    if crate::base::vec::dot(dir, q.peak) >= q.core.cos() {
                        continue;
                    }
                    in_core = false;
                }
            }
            let g = q.eval(dir);
            if in_core
                || (open || (lv == 0 && narrow))
                    && q.error(axis, rad, sin_r, (0.0, 0.0, 1.0), c.abs() < sin_r, g, node)
                        > q.budget
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

    /// The cut that serves every GGX lobe seen from `q.v` whose normal lies within `spread`
    /// (radians) of `q.n`, in `out` (cleared first): a node is opened while, for the lobe of
    /// `q.n`, its error estimate with the peak widened to the cone the group's peaks lie in
    /// (2 × `spread`: the mirror direction turns at most twice as fast as the normal)
    /// exceeds `q`'s budget, or while it straddles the horizon of any of the normals.  A
    /// narrow lobe's leaf that still exceeds it goes in as the points [`EnvTree::cut`]
    /// averages the lobe over, each with an equal share of the leaf.  Each lobe's integral is
    /// then [`ggx_sums`] over the nodes.
    pub fn group_cut(&self, q: &Lobe, spread: f64, out: &mut CutNodes) {
        out.clear();
        // The sine and cosine of the spread, which every node's horizon test takes (its sine
        // is also the lobe's slack), and of twice it (the peaks).
        let (sin_s, cos_s) = spread.min(std::f64::consts::FRAC_PI_2).sin_cos();
        let peaks = 2.0 * spread;
        let (sin_p, cos_p) = peaks.sin_cos();
        let q = &Lobe { slack: sin_s, ..*q }.bounded();
        let start = self.levels.iter().position(|l| l.m <= 4).unwrap_or(0);
        let mut stack: [(u8, u32); 512] = [(0, 0); 512];
        let mut top = 0;
        for k in (0..self.levels[start].nodes.len()).rev() {
            stack[top] = (start as u8, k as u32);
            top += 1;
        }
        let v = q.v;
        let narrow = self.narrow(q.material);
        let mut points = Vec::new();
        while top > 0 {
            top -= 1;
            let (lv, k) = stack[top];
            let level = &self.levels[lv as usize];
            let node = &level.nodes[k as usize];
            let axis = node.axis.map(|v| v as f64);
            let c = crate::base::vec::dot(axis, q.n);
            let (sin_r, rad) = (node.sin_r as f64, node.rad as f64);
            // The node's cone widened by the group's normals, for the horizons: sin(rad +
            // spread), 1 from π/2 on.
            let wide = rad + spread;
            let sin_w = if wide >= std::f64::consts::FRAC_PI_2 {
                1.0
            } else {
                sin_r * cos_s + (1.0 - sin_r * sin_r).max(0.0).sqrt() * sin_s
            };
            if wide < 1.5 && c <= -sin_w {
                continue; // wholly below every normal's horizon
            }
            let open = lv > 0 && top + 4 <= stack.len();
            // The lobe at the node's direction, which the error bounds from below: only where
            // the node is tested, and not for the split sum, whose bound (its D and cosine at
            // the node's point nearest the peak, the cosine raised by the slack) is never
            // below it.
            let g = || match q.kernel {
                Kernel::SplitSum => 0.0,
                Kernel::Brdf => q.eval(node.dir.map(|v| v as f64)),
            };
            if (open || (lv == 0 && narrow))
                && q.error(
                    axis,
                    rad,
                    sin_r,
                    (peaks, sin_p, cos_p),
                    c.abs() < sin_w,
                    g(),
                    node,
                ) > q.budget
            {
                if !open {
                    // A leaf the lobes vary across: its radiance even over it, as s×s
                    // points of equal shares (the lobe averaged over its area, as in a cut).
                    let s = self.leaf_points(q, k as usize, &mut points);
                    let share = 1.0 / (s * s) as f32;
                    let power = node.power.map(|p| p * share);
                    let omega = node.omega * share;
                    for d in &points {
                        let d = d.map(|x| x as f32);
                        out.push_point(d, power, omega, v);
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
            out.push(node, v);
        }
        out.pad();
    }

    /// The lobe `q` averaged over leaf `k` (its face, row and column on the finest level):
    /// the mean over [`EnvTree::leaf_points`].
    fn leaf_average(&self, q: &Lobe, k: usize) -> f64 {
        LEAF_POINTS.with_borrow_mut(|points| {
            let s = self.leaf_points(q, k, points);
            points.iter().map(|&d| q.eval(d)).sum::<f64>() / (s * s) as f64
        })
    }

    /// The s×s points a narrow lobe is averaged over in leaf `k`, evenly spaced on its face
    /// (`points`, cleared first), s from the leaf's size against the lobe's scale (2 to 16);
    /// returns s.
    fn leaf_points(&self, q: &Lobe, k: usize, points: &mut Vec<[f64; 3]>) -> usize {
        let m = self.face;
        let leaf = std::f64::consts::FRAC_PI_2 / m as f64;
        let scale = match q.material {
            Material::Lambert => q.rule.broad,
            Material::Ggx { alpha } => {
                // Away from the peak the lobe varies on `far` × the angle to it (from the
                // leaf's axis, its centre's direction).
                let c = self.levels[0].nodes[k].axis.map(|v| v as f64);
                let near = (acos_approx(crate::base::vec::dot(c, q.peak).clamp(-1.0, 1.0)) - leaf)
                    .max(0.0);
                alpha.max(q.rule.far * near).min(q.rule.broad)
            }
        };
        let s = ((8.0 * leaf / scale).ceil() as usize).clamp(2, 16);
        leaf_grid(&self.cube, m, k, s, points);
        s
    }
}

/// The s×s points evenly spaced on leaf `k` of a tree of face `m` on `cube` (row by row, into
/// `points`, cleared first): the directions `cube.uv_to_dir` gives at their centres.
fn leaf_grid(cube: &Mapping, m: usize, k: usize, s: usize, points: &mut Vec<[f64; 3]>) {
    let (f, j, i) = (k / (m * m), (k / m) % m, k % m);
    points.clear();
    // On the face's plane the points are p₀ + a·Δs + b·Δt (the cube's face table is
    // affine in (s, t)), turned into the world by the cube's frame and normalized: what
    // `uv_to_dir` gives at each, with a few products instead of its table and two roots.
    let world = |p: [f64; 3]| cube_to_world(cube, p);
    let step = 1.0 / (m * s) as f64;
    let (s0, t0) = (
        (i as f64 + 0.5 / s as f64) / m as f64,
        (j as f64 + 0.5 / s as f64) / m as f64,
    );
    let p0 = crate::mappings::cube::face_st_to_point(f, s0, t0);
    let ps = crate::mappings::cube::face_st_to_point(f, s0 + step, t0);
    let pt = crate::mappings::cube::face_st_to_point(f, s0, t0 + step);
    let o = world(p0);
    let ds = world([0, 1, 2].map(|c| ps[c] - p0[c]));
    let dt = world([0, 1, 2].map(|c| pt[c] - p0[c]));
    for b in 0..s {
        let rb = [0, 1, 2].map(|c| o[c] + b as f64 * dt[c]);
        for a in 0..s {
            let p = [0, 1, 2].map(|c| rb[c] + a as f64 * ds[c]);
            points.push(crate::base::vec::normalize(p));
        }
    }
}

thread_local! {
    static LEAF_POINTS: std::cell::RefCell<Vec<[f64; 3]>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// GGX lobes of one kind that neighbouring normals share cuts of the tree for
/// ([`EnvTree::shared_integrals`]).
#[derive(Clone, Copy, Debug)]
pub struct Shared {
    pub alpha: f64,
    /// [`Kernel::Brdf`] seen from `v` (a MatCap), or [`Kernel::SplitSum`] about each normal.
    pub kernel: Kernel,
    pub v: [f64; 3],
    pub rule: CutRule,
}

/// A key whose order keeps neighbouring directions together: the cube face of `n`, then the
/// Morton (Z-order) code of its position on the face in 2¹⁶ steps, so that the 4×4 texel
/// tiles of a cube face of any power-of-two size follow one another.
pub(crate) fn spatial_key(n: [f64; 3]) -> u64 {
    let a = n.map(f64::abs);
    let axis = major_axis(n);
    let m = a[axis].max(f64::MIN_POSITIVE);
    let face = 2 * axis as u64 + (n[axis] < 0.0) as u64;
    let q = |v: f64| (((v / m).clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0) as u32;
    let (u, v) = (q(n[(axis + 1) % 3]), q(n[(axis + 2) % 3]));
    let spread = |x: u32| {
        let mut x = x as u64 & 0xffff;
        x = (x | (x << 8)) & 0x00ff_00ff;
        x = (x | (x << 4)) & 0x0f0f_0f0f;
        x = (x | (x << 2)) & 0x3333_3333;
        (x | (x << 1)) & 0x5555_5555
    };
    (face << 32) | (spread(v) << 1) | spread(u)
}

/// The axis of `n`'s largest component (the lowest of equals): the cube face `n` falls on.
pub(crate) fn major_axis(n: [f64; 3]) -> usize {
    let a = n.map(f64::abs);
    if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    }
}

/// The indices of `ns` in the order of [`spatial_key`]: groups of consecutive ones are
/// neighbours.
pub(crate) fn spatial_order(ns: &[[f64; 3]]) -> Vec<u32> {
    let mut order: Vec<u32> = (0..ns.len() as u32).collect();
    order.sort_by_cached_key(|&i| spatial_key(ns[i as usize]));
    order
}

/// The widest group of normals that shares a cut, in lobe widths (α) from their mean: a tile
/// of a MatCap's grid of normals (spaced α/3) is about 1.6 α; a 4×4 tile of the 128² level of
/// a prefiltered chain (roughness 0.106) about 2.3 α.  (That level of `park.exr`'s chain: 5.8 s
/// with groups of at most 2 α, 4.4 s with 4 α, at the same accuracy.)
const GROUP_SPREAD_PER_ALPHA: f64 = 4.0;
/// The widest group of normals that shares a cut (radians from their mean).
const MAX_GROUP_SPREAD: f64 = 0.25;

thread_local! {
    /// Each thread's buffer for a shared cut.
    static SHARED_CUT: std::cell::RefCell<CutNodes> = Default::default();
}

impl EnvTree {
    /// ∫ g L dω for the lobes of `s` at each of `ns` (unit normals, neighbours: a tile of a
    /// grid, a run of a row's texels), `norm(n)` each lobe's exact integral (the albedo E, or
    /// W(α)): one cut for all of them ([`EnvTree::group_cut`]), halved while they spread
    /// over more than 2 α, each summed over it in vector code ([`ggx_sums`], [`split_sums`]).
    pub fn shared_integrals(
        &self,
        s: &Shared,
        ns: &[[f64; 3]],
        norm: impl Fn([f64; 3]) -> f64 + Copy,
    ) -> Vec<[f64; 3]> {
        let material = Material::Ggx { alpha: s.alpha };
        let sum = ns
            .iter()
            .fold([0.0; 3], |a, n| [0, 1, 2].map(|k| a[k] + n[k]));
        let len = crate::base::vec::dot(sum, sum).sqrt();
        let c = sum.map(|x| x / len.max(1e-300));
        let spread = ns
            .iter()
            .map(|&n| crate::base::vec::dot(n, c))
            .fold(1.0, f64::min)
            .clamp(-1.0, 1.0)
            .acos();
        if ns.len() > 1 && !(spread <= (GROUP_SPREAD_PER_ALPHA * s.alpha).min(MAX_GROUP_SPREAD)) {
            // Too far apart to share a cut well: halves.
            let (a, b) = ns.split_at(ns.len() / 2);
            let mut out = self.shared_integrals(s, a, norm);
            out.extend(self.shared_integrals(s, b, norm));
            return out;
        }
        let norms: Vec<f64> = ns.iter().map(|&n| norm(n)).collect();
        let smallest = norms.iter().copied().fold(f64::INFINITY, f64::min);
        let scale = self.mean_brightness() * smallest;
        let lobe = match s.kernel {
            Kernel::Brdf => Lobe::new(material, c, s.v, s.rule, scale),
            Kernel::SplitSum => Lobe::split_sum(s.alpha, c, s.rule, scale),
        };
        if ns.len() == 1 {
            return vec![self.integral(&lobe, norms[0])];
        }
        let mean = self.mean;
        let narrow = self.narrow(material);
        SHARED_CUT.with_borrow_mut(|nodes| {
            self.group_cut(&lobe, spread, nodes);
            ns.iter()
                .zip(&norms)
                .map(|(&n, &e)| {
                    let (p, w) = match s.kernel {
                        Kernel::Brdf => ggx_sums(nodes, s.alpha, n, s.v),
                        Kernel::SplitSum => split_sums(nodes, s.alpha, n),
                    };
                    Cut {
                        residual: [0, 1, 2].map(|k| p[k] - mean[k] * w),
                        weight: w,
                        narrow,
                    }
                    .integral(mean, e)
                })
                .collect()
        })
    }
}

/// The nodes of a cut by field, for many lobes seen from one viewer ([`EnvTree::group_cut`]):
/// each node's brightness-weighted centroid `l` and Ω-weighted centroid `lo` with their half
/// vectors toward the viewer, its power and its solid angle; padded to whole lanes with nodes
/// of no power and no solid angle.
#[derive(Default)]
pub struct CutNodes {
    l: [Vec<f32>; 3],
    h: [Vec<f32>; 3],
    lo: [Vec<f32>; 3],
    ho: [Vec<f32>; 3],
    power: [Vec<f32>; 3],
    omega: Vec<f32>,
}

/// The unit half vector of unit `d` and the viewer `v`.
fn half(d: [f32; 3], v: [f64; 3]) -> [f32; 3] {
    let s = [0, 1, 2].map(|k| d[k] as f64 + v[k]);
    let len = crate::base::vec::dot(s, s).sqrt().max(1e-30);
    s.map(|x| (x / len) as f32)
}

/// Lanes of the vector code over a cut's nodes.
const LANES: usize = 16;

impl CutNodes {
    fn clear(&mut self) {
        for k in 0..3 {
            self.l[k].clear();
            self.h[k].clear();
            self.lo[k].clear();
            self.ho[k].clear();
            self.power[k].clear();
        }
        self.omega.clear();
    }

    /// The cut's nodes (padding included).
    pub fn len(&self) -> usize {
        self.omega.len()
    }

    pub fn is_empty(&self) -> bool {
        self.omega.is_empty()
    }

    fn push(&mut self, node: &Node, v: [f64; 3]) {
        let (h, ho) = (half(node.dir, v), half(node.odir, v));
        for k in 0..3 {
            self.l[k].push(node.dir[k]);
            self.h[k].push(h[k]);
            self.lo[k].push(node.odir[k]);
            self.ho[k].push(ho[k]);
            self.power[k].push(node.power[k]);
        }
        self.omega.push(node.omega);
    }

    /// A point of power `power` and solid angle `omega` in direction `d`.
    fn push_point(&mut self, d: [f32; 3], power: [f32; 3], omega: f32, v: [f64; 3]) {
        let h = half(d, v);
        for k in 0..3 {
            self.l[k].push(d[k]);
            self.h[k].push(h[k]);
            self.lo[k].push(d[k]);
            self.ho[k].push(h[k]);
            self.power[k].push(power[k]);
        }
        self.omega.push(omega);
    }

    fn pad(&mut self) {
        while self.omega.len() % LANES != 0 {
            for k in 0..3 {
                self.l[k].push(0.0);
                self.h[k].push(0.0);
                self.lo[k].push(0.0);
                self.ho[k].push(0.0);
                self.power[k].push(0.0);
            }
            self.omega.push(0.0);
        }
    }
}

/// Σ g(l) P and Σ g(lo) Ω over a cut's nodes for the GGX lobe α, f·(n·l), at unit normal `n`
/// seen from `v` (the viewer of the cut): the integral is then L̄ · E + Σ g P − L̄ Σ g Ω, as
/// [`Cut::integral`] takes it.  Vector code (f32 lanes; the half vectors' n·h by |n − h|², so
/// that the peak keeps its precision).
pub fn ggx_sums(nodes: &CutNodes, alpha: f64, n: [f64; 3], v: [f64; 3]) -> ([f64; 3], f64) {
    let mu_v = crate::base::vec::dot(n, v).max(1e-9);
    let (p, w) = crate::base::cpu::vectorized(
        #[inline(always)]
        || ggx_lanes(nodes, alpha as f32, n.map(|x| x as f32), mu_v as f32),
    );
    let sum = |a: &[f32; LANES]| a.iter().map(|&x| x as f64).sum::<f64>();
    ([sum(&p[0]), sum(&p[1]), sum(&p[2])], sum(&w))
}

/// Σ k(l) P and Σ k(lo) Ω over a cut's nodes for the split-sum kernel about `r`,
/// k = D(h)(r·l)⁺/4 with h = normalize(l + r) (as [`Lobe::split_sum`]); vector code, 1 − (r·h)²
/// taken as |r − l|²/4 so that a narrow peak keeps its precision.
pub fn split_sums(nodes: &CutNodes, alpha: f64, r: [f64; 3]) -> ([f64; 3], f64) {
    let (p, w) = crate::base::cpu::vectorized(
        #[inline(always)]
        || split_lanes(nodes, alpha as f32, r.map(|x| x as f32)),
    );
    let sum = |a: &[f32; LANES]| a.iter().map(|&x| x as f64).sum::<f64>();
    ([sum(&p[0]), sum(&p[1]), sum(&p[2])], sum(&w))
}

#[inline(always)]
fn split_lanes(c: &CutNodes, alpha: f32, r: [f32; 3]) -> ([[f32; LANES]; 3], [f32; LANES]) {
    let a2 = alpha * alpha;
    let scale = a2 * 0.25 / std::f32::consts::PI;
    // (r·h)² = (1 + r·l)/2, so 1 − (r·h)² = (1 − r·l)/2 = |r − l|²/4 for unit l.
    let k = |lx: f32, ly: f32, lz: f32| {
        let cos = r[0] * lx + r[1] * ly + r[2] * lz;
        let (dx, dy, dz) = (r[0] - lx, r[1] - ly, r[2] - lz);
        let s2 = 0.25 * (dx * dx + dy * dy + dz * dz);
        let kk = a2 + (1.0 - a2) * s2;
        if cos > 0.0 {
            scale * cos / (kk * kk)
        } else {
            0.0
        }
    };
    let mut p = [[0f32; LANES]; 3];
    let mut w = [0f32; LANES];
    let len = c.omega.len();
    let mut i0 = 0;
    while i0 + LANES <= len {
        let s = |a: &Vec<f32>| -> [f32; LANES] { a[i0..i0 + LANES].try_into().unwrap() };
        let (lx, ly, lz) = (s(&c.l[0]), s(&c.l[1]), s(&c.l[2]));
        let (ox, oy, oz) = (s(&c.lo[0]), s(&c.lo[1]), s(&c.lo[2]));
        let (p0, p1, p2, om) = (s(&c.power[0]), s(&c.power[1]), s(&c.power[2]), s(&c.omega));
        for i in 0..LANES {
            let gd = k(lx[i], ly[i], lz[i]);
            let go = k(ox[i], oy[i], oz[i]);
            p[0][i] += gd * p0[i];
            p[1][i] += gd * p1[i];
            p[2][i] += gd * p2[i];
            w[i] += go * om[i];
        }
        i0 += LANES;
    }
    (p, w)
}

#[inline(always)]
fn ggx_lanes(
    c: &CutNodes,
    alpha: f32,
    n: [f32; 3],
    mu_v: f32,
) -> ([[f32; LANES]; 3], [f32; LANES]) {
    let a2 = alpha * alpha;
    let av = (mu_v * mu_v * (1.0 - a2) + a2).sqrt();
    let scale = a2 * 0.5 / std::f32::consts::PI;
    // f·(n·l) = D(n·h) G₂ / (4 μ_v) with D = α²/(π k²), k = α² + (1 − α²)(1 − (n·h)²), and
    // G₂/(4 μ_l μ_v) = ½ / (μ_l Λ'_v + μ_v Λ'_l), Λ'_x = √(x² (1 − α²) + α²).
    let g = |lx: f32, ly: f32, lz: f32, hx: f32, hy: f32, hz: f32| {
        let mu_l = n[0] * lx + n[1] * ly + n[2] * lz;
        let (dx, dy, dz) = (n[0] - hx, n[1] - hy, n[2] - hz);
        let q = dx * dx + dy * dy + dz * dz;
        let s2 = (q * (1.0 - 0.25 * q)).max(0.0);
        let k = a2 + (1.0 - a2) * s2;
        let ml = mu_l.max(0.0);
        let den = k * k * (ml * av + mu_v * (ml * ml * (1.0 - a2) + a2).sqrt());
        if mu_l > 0.0 {
            scale * ml / den
        } else {
            0.0
        }
    };
    let mut p = [[0f32; LANES]; 3];
    let mut w = [0f32; LANES];
    let len = c.omega.len();
    let mut i0 = 0;
    while i0 + LANES <= len {
        let s = |a: &Vec<f32>| -> [f32; LANES] { a[i0..i0 + LANES].try_into().unwrap() };
        let (lx, ly, lz) = (s(&c.l[0]), s(&c.l[1]), s(&c.l[2]));
        let (hx, hy, hz) = (s(&c.h[0]), s(&c.h[1]), s(&c.h[2]));
        let (ox, oy, oz) = (s(&c.lo[0]), s(&c.lo[1]), s(&c.lo[2]));
        let (qx, qy, qz) = (s(&c.ho[0]), s(&c.ho[1]), s(&c.ho[2]));
        let (p0, p1, p2, om) = (s(&c.power[0]), s(&c.power[1]), s(&c.power[2]), s(&c.omega));
        for i in 0..LANES {
            let gd = g(lx[i], ly[i], lz[i], hx[i], hy[i], hz[i]);
            let go = g(ox[i], oy[i], oz[i], qx[i], qy[i], qz[i]);
            p[0][i] += gd * p0[i];
            p[1][i] += gd * p1[i];
            p[2][i] += gd * p2[i];
            w[i] += go * om[i];
        }
        i0 += LANES;
    }
    (p, w)
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

/// acos to within 2e-8 rad (Abramowitz & Stegun 4.4.46).
#[inline]
fn acos_approx(x: f64) -> f64 {
    let a = x.abs().min(1.0);
    let p = ((((((-0.001_262_491_1 * a + 0.006_670_090_1) * a - 0.017_088_125_6) * a
        + 0.030_891_881_0)
        * a
        - 0.050_174_304_6)
        * a
        + 0.088_978_987_4)
        * a
        - 0.214_598_801_6)
        * a
        + 1.570_796_305_0;
    let r = (1.0 - a).sqrt() * p;
    if x < 0.0 {
        std::f64::consts::PI - r
    } else {
        r
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
#[inline]
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
    // On the face's own plane (angles do not change with the cube's frame): the centre and
    // the widest corner, that of the smallest cosine.
    let at = |a: f64, b: f64| {
        crate::base::vec::normalize(crate::mappings::cube::face_st_to_point(f, a / mf, b / mf))
    };
    let c = at(i as f64 + 0.5, j as f64 + 0.5);
    let mut cos_rad: f64 = 1.0;
    for (a, b) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let d = at(i as f64 + a, j as f64 + b);
        cos_rad = cos_rad.min(crate::base::vec::dot(c, d));
    }
    (cube_to_world(cube, c), cos_rad.clamp(-1.0, 1.0).acos())
}

/// A direction in the face table's coordinates turned into the world by `cube`'s frame (what
/// `uv_to_dir` does after the table).
fn cube_to_world(cube: &Mapping, p: [f64; 3]) -> [f64; 3] {
    let Mapping::Cube(preset) = *cube else {
        unreachable!("the tree's leaves lie on a cube")
    };
    let r = &preset.frame;
    [0, 1, 2].map(|c| r[0][c] * p[0] + r[1][c] * p[1] + r[2][c] * p[2])
}

/// Nodes of a level from their accumulated sums.
fn finish(acc: &[Acc], m: usize, cube: &Mapping, mean_lum: f64) -> Vec<Node> {
    acc.par_iter()
        .enumerate()
        .map(|(k, a)| {
            let (power, wd, od) = (&a.power, &a.wd, &a.od);
            let (axis, rad) = cone(cube, m, k);
            let l = crate::base::vec::dot(*wd, *wd).sqrt();
            let dir = if l > 0.0 {
                [wd[0] / l, wd[1] / l, wd[2] / l]
            } else {
                axis
            };
            Node {
                power: power.map(|v| v as f32),
                omega: a.omega as f32,
                odir: {
                    let l = crate::base::vec::dot(*od, *od).sqrt();
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
#[derive(Clone, Copy)]
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
    /// For a group's cut: the sine of the group's spread, by which its normals' n·l and n·v
    /// may differ from this lobe's ([`Lobe::eval_bound`]); 0 for one lobe.
    slack: f64,
    /// The radius (radians) of a cone about the peak that the cut leaves out
    /// ([`EnvTree::tail`]); 0 for none.
    core: f64,
    /// [`Lobe::eval_bound`] at the peak, which every node the peak lies in takes
    /// ([`Lobe::bounded`] sets it).
    peak_bound: f64,
}

impl Lobe {
    /// `scale` is the size of the integral (L̄'s brightness × the lobe's albedo): nodes are
    /// opened while their error estimate exceeds `rule.tol` × it.
    pub fn new(material: Material, n: [f64; 3], v: [f64; 3], rule: CutRule, scale: f64) -> Lobe {
        let nv = crate::base::vec::dot(n, v);
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
            slack: 0.0,
            core: 0.0,
            peak_bound: 0.0,
        }
        .bounded()
    }

    /// This lobe with [`Lobe::peak_bound`] for its kernel and slack (after either changes).
    fn bounded(self) -> Lobe {
        Lobe {
            peak_bound: self.eval_bound(self.peak),
            ..self
        }
    }

    /// The lobe at `l`, or for a group's cut ([`Lobe::slack`] > 0) the most any of the
    /// group's lobes can be there: f·(n·l) with n·l raised and n·v lowered by the slack
    /// (it grows with n·l and falls with n·v; the split-sum kernel's cosine raised), so that
    /// a node under this normal's horizon but over a neighbour's still counts.
    #[inline]
    fn eval_bound(&self, l: [f64; 3]) -> f64 {
        match (self.material, self.kernel) {
            (Material::Ggx { alpha }, Kernel::Brdf) if self.slack > 0.0 => {
                let mu_l = crate::base::vec::dot(self.n, l) + self.slack;
                if !(mu_l > 0.0) {
                    return 0.0;
                }
                let mu_v = (crate::base::vec::dot(self.n, self.v) - self.slack).max(1e-9);
                let h = crate::base::vec::normalize([0, 1, 2].map(|k| l[k] + self.v[k]));
                let nh = crate::base::vec::dot(self.n, h).min(1.0);
                brdf::ggx_d(alpha, nh) * brdf::ggx_visibility(alpha, mu_l.min(1.0), mu_v) * mu_l
            }
            (Material::Ggx { alpha }, Kernel::SplitSum) if self.slack > 0.0 => {
                // D at the normal's own half vector, the cosine raised by the slack.
                let c = crate::base::vec::dot(self.n, l);
                if !(c + self.slack > 0.0) {
                    return 0.0;
                }
                brdf::ggx_d_sq(alpha, ((1.0 + c) * 0.5).max(0.0)) * (c + self.slack).min(1.0) * 0.25
            }
            _ => self.eval(l),
        }
    }

    /// The split-sum prefilter's lobe about `r` (n = v = r): D(h)·(n·l)⁺/4, h = normalize(l + r);
    /// `scale` as for [`Lobe::new`].
    pub fn split_sum(alpha: f64, r: [f64; 3], rule: CutRule, scale: f64) -> Lobe {
        Lobe {
            kernel: Kernel::SplitSum,
            ..Lobe::new(Material::Ggx { alpha }, r, r, rule, scale)
        }
        .bounded()
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
        let c = crate::base::vec::dot(self.n, l);
        if !(c > 0.0) {
            return 0.0;
        }
        // (n·h)² for h = normalize(l + n): (1 + c)/2.
        brdf::ggx_d_sq(alpha, (1.0 + c) * 0.5) * c * 0.25
    }

    /// The error of evaluating a node (cone `axis`, radius `rad`, its sine `sin_r`) at its
    /// representative direction, where the lobe is `g`: the node's inner variation × the lobe's
    /// change across it (first order) plus its residual × the lobe's curvature (second order);
    /// the lobe's largest value in the node is taken where the node comes nearest the peak.
    /// `spread` widens the peak to a cone of that radius (a group of lobes whose peaks lie in
    /// it, [`EnvTree::group_cut`]; 0 for one lobe).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn error(
        &self,
        axis: [f64; 3],
        rad: f64,
        sin_r: f64,
        (spread, sin_s, cos_s): (f64, f64, f64),
        straddles: bool,
        g: f64,
        node: &Node,
    ) -> f64 {
        let cos_t = crate::base::vec::dot(axis, self.peak).clamp(-1.0, 1.0);
        // The node's cone widened by the peak's: radius R = rad + spread (its sine and
        // cosine from the caller, the same for every node of a cut).
        let cos_r = (1.0 - sin_r * sin_r).max(0.0).sqrt();
        let (sin_big, cos_big) = if spread > 0.0 {
            (sin_r * cos_s + cos_r * sin_s, cos_r * cos_s - sin_r * sin_s)
        } else {
            (sin_r, cos_r)
        };
        let (near, g_max) = if cos_t >= cos_big || rad + spread >= std::f64::consts::PI {
            (0.0, self.peak_bound.max(g))
        } else {
            // The node's point nearest the peak: the axis turned toward it by R.
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt().max(1e-12);
            let sin_near = sin_t * cos_big - cos_t * sin_big;
            let (a, b) = (sin_near / sin_t, sin_big / sin_t);
            let d = [0, 1, 2].map(|k| a * axis[k] + b * self.peak[k]);
            let near = acos_approx(cos_t * cos_big + sin_t * sin_big);
            (near, self.eval_bound(d).max(g))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A node's cone: its axis the direction of its centre, its radius the angle to its
    /// farthest corner, as the cube's `uv_to_dir` gives them (corners just inside the face).
    #[test]
    fn cones_are_the_centre_and_the_farthest_corner() {
        for preset in ["gl", "d3d"] {
            let cube = Mapping::parse("cube", Some(preset)).unwrap();
            for (m, k) in [
                (1, 0),
                (1, 5),
                (4, 7),
                (4, 3 * 16 + 9),
                (64, 5 * 4096 + 4095),
            ] {
                let (axis, rad) = cone(&cube, m, k);
                let (f, j, i) = (k / (m * m), (k / m) % m, k % m);
                let dir = |a: f64, b: f64| {
                    let (u, v) = (
                        (a / m as f64).clamp(1e-12, 1.0 - 1e-12),
                        (b / m as f64).clamp(1e-12, 1.0 - 1e-12),
                    );
                    crate::base::vec::normalize(cube.uv_to_dir([u, (f as f64 + v) / 6.0]).unwrap())
                };
                let c = dir(i as f64 + 0.5, j as f64 + 0.5);
                assert!(
                    (0..3).all(|q| (axis[q] - c[q]).abs() < 1e-14),
                    "{preset} {m} {k}"
                );
                let far = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                    .map(|(a, b)| crate::base::vec::dot(c, dir(i as f64 + a, j as f64 + b)).acos())
                    .into_iter()
                    .fold(0.0, f64::max);
                assert!((rad - far).abs() < 1e-9, "{preset} {m} {k}: {rad} vs {far}");
            }
        }
    }

    /// A leaf's grid of points is the cube's own `uv_to_dir` at each point's centre, on every
    /// face and for cubes in other frames.
    #[test]
    fn leaf_grid_is_uv_to_dir_at_the_points() {
        let mut pts = Vec::new();
        for preset in ["gl", "d3d"] {
            let cube = Mapping::parse("cube", Some(preset)).unwrap();
            for (m, k, s) in [
                (1, 0, 2),
                (4, 7, 3),
                (4, 5 * 16 + 9, 16),
                (64, 3 * 4096 + 700, 5),
            ] {
                leaf_grid(&cube, m, k, s, &mut pts);
                assert_eq!(pts.len(), s * s);
                let (f, j, i) = (k / (m * m), (k / m) % m, k % m);
                for b in 0..s {
                    for a in 0..s {
                        let u = (i as f64 + (a as f64 + 0.5) / s as f64) / m as f64;
                        let v =
                            (f as f64 + (j as f64 + (b as f64 + 0.5) / s as f64) / m as f64) / 6.0;
                        let d = crate::base::vec::normalize(cube.uv_to_dir([u, v]).unwrap());
                        let got = pts[b * s + a];
                        let err = (0..3).map(|c| (got[c] - d[c]).abs()).fold(0.0, f64::max);
                        assert!(
                            err < 1e-14,
                            "{preset} m {m} k {k} ({a}, {b}): {got:?} vs {d:?}"
                        );
                    }
                }
            }
        }
    }

    /// The vector sums over a cut's nodes (the MatCap's lobe and the split-sum kernel)
    /// against the f64 lobe, point by point: nodes all
    /// round the sphere (under the horizon, grazing, at the peak), one whose two centroids
    /// differ, and lobes from narrow to broad at normals from the viewer to the rim.
    #[test]
    fn vector_sums_match_the_scalar_lobe() {
        let v = [0.0, 0.0, 1.0];
        let mut nodes = CutNodes::default();
        let mut expect = Vec::new();
        // A low-discrepancy spread of directions, powers and solid angles.
        for k in 0..203 {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / 203.0;
            let phi = k as f64 * 2.399_963_229_728_653;
            let r = (1.0 - z * z).sqrt();
            let d = [r * phi.cos(), r * phi.sin(), z];
            let power = [0.5 + (k % 7) as f64, 1.0 + (k % 3) as f64, 0.25];
            let omega = 1e-3 * (1.0 + (k % 5) as f64);
            nodes.push_point(
                d.map(|x| x as f32),
                power.map(|x| x as f32),
                omega as f32,
                v,
            );
            expect.push((d, power, omega));
        }
        nodes.pad();
        assert_eq!(nodes.len() % LANES, 0);
        for alpha in [0.02, 0.0625, 0.36, 1.0] {
            let m = Material::Ggx { alpha };
            for theta in [0.0f64, 0.4, 1.0, 1.45, 1.56] {
                let n = [theta.sin() * 0.6, theta.sin() * 0.8, theta.cos()];
                let (p, w) = ggx_sums(&nodes, alpha, n, v);
                let (mut pe, mut we) = ([0.0; 3], 0.0);
                for &(d, power, omega) in &expect {
                    // The f32 direction the vector code reads.
                    let d = crate::base::vec::normalize(d.map(|x| x as f32 as f64));
                    let g = brdf::eval_cos(m, n, v, d);
                    for k in 0..3 {
                        pe[k] += g * power[k];
                    }
                    we += g * omega;
                }
                for k in 0..3 {
                    assert!(
                        (p[k] - pe[k]).abs() <= 2e-5 * pe[k].abs().max(1e-3),
                        "α {alpha} θ {theta} channel {k}: {} vs {}",
                        p[k],
                        pe[k]
                    );
                }
                assert!(
                    (w - we).abs() <= 2e-5 * we.abs().max(1e-6),
                    "α {alpha} θ {theta}: Σ g Ω {w} vs {we}"
                );
                // The split-sum kernel about n.
                let q = Lobe::split_sum(alpha, n, CutRule::default(), 1.0);
                let (p, w) = split_sums(&nodes, alpha, n);
                let (mut pe, mut we) = ([0.0; 3], 0.0);
                for &(d, power, omega) in &expect {
                    let g = q.eval(crate::base::vec::normalize(d.map(|x| x as f32 as f64)));
                    for k in 0..3 {
                        pe[k] += g * power[k];
                    }
                    we += g * omega;
                }
                for k in 0..3 {
                    assert!(
                        (p[k] - pe[k]).abs() <= 2e-5 * pe[k].abs().max(1e-3),
                        "split sum α {alpha} θ {theta} channel {k}: {} vs {}",
                        p[k],
                        pe[k]
                    );
                }
                assert!(
                    (w - we).abs() <= 2e-5 * we.abs().max(1e-6),
                    "split sum α {alpha} θ {theta}: {w} vs {we}"
                );
            }
        }
    }
}
