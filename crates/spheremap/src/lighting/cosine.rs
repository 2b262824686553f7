//! The cosine integral E(n) = ∫ L(l) (n·l)⁺ dω — the irradiance; times albedo/π the Lambert
//! MatCap and the irradiance level of a prefiltered chain — to a known bound, fast.
//!
//! ## Why it is fast
//!
//! (n·l)⁺ is linear in l on each side of n's horizon.  A block of the environment wholly above
//! the horizon therefore adds exactly n·M, M = Σ L l dω its first moment, and a block wholly
//! below adds nothing: no error, whatever the block holds.  Only the blocks the horizon
//! crosses are approximated.
//!
//! The environment's points (those of [`envtree::sum_points`], the same a brute-force sum over
//! the map's texels sums) are summed on a world-frame cube of face 2F: per cell and channel the
//! power P = Σ L dω, the moment M = Σ L l dω and the second moment S = Σ L l lᵀ dω, and the
//! same of the solid angle (Ω = Σ dω, M_Ω = Σ l dω, S_Ω = Σ l lᵀ dω).  The leaves are the
//! cells of the cube of face F (2×2 cells each); a leaf holding more than [`SPLIT`] × a mean
//! leaf's power (a bright sky, a lamp) is taken as its four cells.  Points holding more than a
//! quarter of a mean leaf's power (a sun's texels) are kept apart, each a leaf of no extent,
//! exact wherever the horizon passes.  Leaves are grouped 2×2 up to one node per face.  With
//! the map's mean L̄ as a control variate,
//!
//! E(n) = π L̄ + Σ over blocks of ∫_block (n·l)⁺ (L − L̄) dω.
//!
//! Normals are taken in groups of 16 neighbours (4×4 tiles of a canvas's texels, in the
//! order of a Z-order curve on the cube, [`envtree::spatial_key`]).  For a group's
//! bounding cone, the tree is cut into nodes wholly above every normal's horizon — their
//! M − L̄ M_Ω summed once for the group, then one dot product per normal —, nodes wholly below
//! (dropped) and the leaves of the band between, which each normal takes one by one: wholly
//! above or below its own horizon as before, or crossed by it.  Where a leaf is crossed, n·l
//! over its light has the mean μ = n·M/P and the variance σ² = nᵀ(S/P − M Mᵀ/P²)n, both
//! exact; n·l is taken as spread by the semicircle law of that mean and variance (radius
//! w = 2σ), whose clamped integral P · w · f(μ/w) is closed-form.  L̄'s share of the leaf is
//! taken the same way and subtracted, so a constant environment gives π L̄ (every leaf's two
//! terms cancel, to the rounding of a fast 1/√x: 1e-6), a sun of no extent is exact wherever the horizon is, and the
//! approximation — of the shape of the distribution of n·l beyond its first two moments —
//! acts on L − L̄ only in the band the horizon crosses.
//!
//! A whole canvas ([`CosineSource::generate`], one normal per texel) takes half the
//! integrals where its texels come in antipodal pairs (cube, lat-long, octahedral):
//! (n·l)⁺ − (−n·l)⁺ = n·l, so E(−n) = E(n) − n·M with M = ∫ L l dω summed exactly, and the
//! antipode costs one dot product and carries the same error as E(n).

use super::envtree::{self, light_channels};
use crate::base::error::Result;
use crate::mappings::mapping::Mapping;
use crate::resample::EnvMap;
use std::f64::consts::PI;

/// The leaves' cube face by default: the irradiance of each of the 18 bundled HDRIs, with and
/// without a one-texel sun holding a fifth of the energy, within 1e-4 of the brute-force sum
/// (relative to π L̄'s brightness) at every normal tried.
pub const DEFAULT_FACE: usize = 16;

/// A point holding more than this × a mean leaf's power is kept apart (a sun's texels: exact
/// wherever the horizon crosses them, where a disc standing for them and the sky around them
/// would not be).
const HOT: f64 = 0.25;

/// A leaf holding more than this × the mean leaf's power is taken as its four quarters
/// (bright skies and lamps: the error of a leaf's disc grows with its power).
const SPLIT: f64 = 1.0;

/// The Z-order (Morton) index of texel (i, j) of a face: i's bits even, j's odd.
fn morton(i: usize, j: usize) -> usize {
    let spread = |v: usize| {
        let mut x = v as u64 & 0xffff_ffff;
        x = (x | (x << 16)) & 0x0000_ffff_0000_ffff;
        x = (x | (x << 8)) & 0x00ff_00ff_00ff_00ff;
        x = (x | (x << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        x = (x | (x << 2)) & 0x3333_3333_3333_3333;
        ((x | (x << 1)) & 0x5555_5555_5555_5555) as usize
    };
    spread(i) | (spread(j) << 1)
}

/// A node's index in the tree's levels (face after face, each in Z-order, so that the four
/// children of node k are 4k … 4k + 3) from its row-major index k = (f m + j) m + i on a cube
/// of face m.
fn z_index(m: usize, k: usize) -> usize {
    let (f, j, i) = (k / (m * m), (k / m) % m, k % m);
    f * m * m + morton(i, j)
}

/// The row-major index of the node at Z-order index `z` on a cube of face m (the inverse of
/// [`z_index`]).
fn row_major(m: usize, z: usize) -> usize {
    let (f, r) = (z / (m * m), z % (m * m));
    let pick = |mut x: usize| {
        let (mut v, mut bit) = (0, 0);
        while x > 0 {
            v |= (x & 1) << bit;
            x >>= 2;
            bit += 1;
        }
        v
    };
    let (i, j) = (pick(r), pick(r >> 1));
    (f * m + j) * m + i
}

/// The map's mean brightness over the sphere, Σ brightness × dω / Σ dω over its texels.
fn mean_brightness(env: &EnvMap) -> f64 {
    use rayon::prelude::*;
    let (w, h, ch) = (env.width, env.height, env.channels);
    let c = light_channels(ch);
    let texels = &env.mapping.texel_rows(w, h);
    let rows: Vec<(f64, f64)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let (mut s, mut o) = (0.0, 0.0);
            let mut dws = Vec::with_capacity(w);
            texels.solid_angles(y, &mut dws);
            for (x, &dw) in dws.iter().enumerate() {
                if dw > 0.0 {
                    let p = &env.data[(y * w + x) * ch..][..ch];
                    let l = [0, 1, 2].map(|q| p[q.min(ch - 1)] as f64);
                    s += envtree::brightness(l, c) * dw;
                    o += dw;
                }
            }
            (s, o)
        })
        .collect();
    let (s, o) = rows.iter().fold((0.0, 0.0), |a, r| (a.0 + r.0, a.1 + r.1));
    if o > 0.0 && s.is_finite() {
        (s / o).max(0.0)
    } else {
        0.0
    }
}

/// Normals per group (neighbours by [`envtree::spatial_key`]): the lanes of the band's vector
/// code.
const GROUP: usize = 16;

/// Room for the nodes a group's walk down the tree keeps (6 roots and at most 3 more a
/// level; [`MAX_FACE`] has 13 levels).
const STACK: usize = 64;

/// The finest leaves' face [`CosineTree::build`] takes.
pub const MAX_FACE: usize = 4096;

/// A group whose normals spread wider than this (radians) is taken normal by normal.
const GROUP_MAX_RADIUS: f64 = 0.2;
/// Normals within this of one another (per component) share one integral in
/// [`CosineTree::irradiance_all`]: |E(n₁) − E(n₂)| ≤ 4 π L̄ |n₁ − n₂|, so E moves by at most
/// 4√3 · 1e-6 = 6.9e-6 of π L̄ (a canvas's antipodal texel centres differ by float rounding,
/// about 1e-7).
pub const ANTIPODE_EPS: f64 = 1e-6;
/// Memory per normal of [`CosineTree::irradiance_all`] and its caller: the normal, its key,
/// place in the order and representative, the representatives' normals and integrals, the
/// results and the texel's values.
const ALL_BYTES: u64 = 24 + 32 + 8 + 8 + 4 + 24 + 24 + 12;
/// The normals of one task of [`CosineTree::irradiance_all`] (64 groups).
const ALL_CHUNK: usize = 64 * GROUP;

/// A node of the cut: its bounding cone and Σ (L − L̄) l dω per channel.
#[derive(Clone, Copy, Debug, Default)]
struct Node {
    axis: [f64; 3],
    sin_r: f64,
    cos_r: f64,
    res: [[f64; 3]; 3],
}

/// A leaf as the band reads it: its bounding cone, and per channel (0..3) and for the solid
/// angle (3) the moment M and the quadratic form of the spread.
#[derive(Clone, Copy, Debug, Default)]
struct Leaf {
    axis: [f32; 3],
    sin_r: f32,
    m: [[f32; 3]; 4],
    /// 4 (P S − M Mᵀ) as xx, yy, zz, 2xy, 2xz, 2yz, so that (P w)² = nᵀ q n (w the
    /// semicircle's radius, twice the deviation of n·l); 0 for power that is not positive
    /// (taken as a point).
    q: [[f32; 6]; 4],
}

impl Leaf {
    fn new(axis: [f32; 3], sin_r: f32, a: &Acc) -> Leaf {
        let q = [0, 1, 2, 3].map(|c| {
            let (p, m, s) = (a.p[c], a.m[c], a.s[c]);
            if !(p > 0.0) {
                return [0.0; 6];
            }
            let v =
                |k: usize, i: usize, j: usize, f: f64| (f * 4.0 * (p * s[k] - m[i] * m[j])) as f32;
            [
                v(0, 0, 0, 1.0),
                v(1, 1, 1, 1.0),
                v(2, 2, 2, 1.0),
                v(3, 0, 1, 2.0),
                v(4, 0, 2, 2.0),
                v(5, 1, 2, 2.0),
            ]
        });
        Leaf {
            axis,
            sin_r,
            m: a.m.map(|m| m.map(|v| v as f32)),
            q,
        }
    }
}

/// A point kept apart: its direction d and, per channel, P − L̄ dω (its (n·d)⁺ (L − L̄) dω is
/// exact at every normal).
#[derive(Clone, Copy, Debug, Default)]
struct Point {
    d: [f32; 3],
    res: [f32; 3],
}

/// What a leaf sums while the tree is built.
#[derive(Clone, Copy, Debug, Default)]
struct Acc {
    p: [f64; 4],
    m: [[f64; 3]; 4],
    /// Σ L l lᵀ dω: xx, yy, zz, xy, xz, yz.
    s: [[f64; 6]; 4],
}

impl Acc {
    /// A point in unit direction `d` holding `p` (per channel, then its solid angle).  (Once
    /// per texel of the map: plain loops, always inlined.)
    #[inline(always)]
    fn point(p: [f64; 4], d: [f64; 3]) -> Acc {
        let dd = [
            d[0] * d[0],
            d[1] * d[1],
            d[2] * d[2],
            d[0] * d[1],
            d[0] * d[2],
            d[1] * d[2],
        ];
        let mut a = Acc {
            p,
            ..Acc::default()
        };
        for c in 0..4 {
            for q in 0..3 {
                a.m[c][q] = p[c] * d[q];
            }
            for q in 0..6 {
                a.s[c][q] = p[c] * dd[q];
            }
        }
        a
    }

    #[inline(always)]
    fn sub(&mut self, o: &Acc) {
        for c in 0..4 {
            self.p[c] -= o.p[c];
            for q in 0..3 {
                self.m[c][q] -= o.m[c][q];
            }
            for q in 0..6 {
                self.s[c][q] -= o.s[c][q];
            }
        }
    }

    #[inline(always)]
    fn add(&mut self, o: &Acc) {
        for c in 0..4 {
            self.p[c] += o.p[c];
            for q in 0..3 {
                self.m[c][q] += o.m[c][q];
            }
            for q in 0..6 {
                self.s[c][q] += o.s[c][q];
            }
        }
    }
}

/// The environment summed for cosine integrals (see the module's notes).
pub struct CosineTree {
    /// Each level's face size and nodes ([`z_index`] order), finest (the leaves) first.
    levels: Vec<(usize, Vec<Node>)>,
    /// The leaves of the finest level ([`z_index`] order), then the points kept apart.
    leaves: Vec<Leaf>,
    /// Per leaf of face F: its quarters where it is split (the first's index in `leaves`, how
    /// many).
    quarters: Vec<(u32, u32)>,
    /// The points kept apart, by leaf.
    points: Vec<Point>,
    /// Per leaf: its points apart (the first's index in `points`, how many).
    apart: Vec<(u32, u32)>,
    /// Per leaf: whether its own entry is summed (not where it is taken as its quarters).
    own: Vec<bool>,
    /// L̄ per channel.
    pub mean: [f64; 3],
    /// M = ∫ L(l) l dω per channel (world frame): E(n) − E(−n) = n·M exactly, since
    /// (n·l)⁺ − (−n·l)⁺ = n·l.
    pub moment: [[f64; 3]; 3],
    /// 1 (grey) or 3 (RGB) channels of light.
    pub channels: usize,
    /// The leaves' cube face F.
    pub face: usize,
}

impl CosineTree {
    /// Sums `env` (`world_to_env` takes world directions to its frame) into leaves of a
    /// world-frame cube of face `face` (a power of two).
    pub fn build(env: &EnvMap, world_to_env: [[f64; 3]; 3], face: usize) -> Result<CosineTree> {
        let face = face.clamp(1, MAX_FACE).next_power_of_two();
        let cube = Mapping::parse("cube", None)?;
        let channels = light_channels(env.channels);
        // Points holding more than HOT × a mean leaf's power (by the map's mean brightness,
        // summed over its texels first) are kept apart as points of no extent.
        let leaves_n = 6 * face * face;
        let mean_leaf = mean_brightness(env) * 4.0 * PI / leaves_n as f64;
        let hot_power = HOT * mean_leaf;
        // The environment is summed on the cube of twice the face: a bright leaf is kept as
        // its four quarters.
        let fine = if face < MAX_FACE { 2 * face } else { face };
        let per = (fine / face) * (fine / face);
        let mut acc_fine = vec![Acc::default(); 6 * fine * fine];
        let mut hot: Vec<(f64, usize, [f64; 3], [f64; 4])> = Vec::new();
        envtree::sum_points(
            env,
            world_to_env,
            face,
            fine,
            |l, d, dw| {
                let a = Acc::point([l[0] * dw, l[1] * dw, l[2] * dw, dw], d);
                let b = envtree::brightness(l, channels) * dw;
                (
                    a,
                    (b > hot_power).then_some((b, d, [a.p[0], a.p[1], a.p[2], dw])),
                )
            },
            |(a, h), (b, hb)| {
                // Points apart keep their own shares.
                let fold = h.is_none() && hb.is_none();
                if fold {
                    a.add(b);
                }
                fold
            },
            |leaf, (a, h)| {
                let leaf = z_index(fine, leaf);
                acc_fine[leaf].add(&a);
                if let Some((b, d, p)) = h {
                    hot.push((b, leaf, d, p));
                }
            },
        )?;
        // The sums of each run of `per` consecutive entries (a node's children in Z-order).
        let sum_runs = |v: &[Acc], per: usize| -> Vec<Acc> {
            v.chunks_exact(per)
                .map(|c| {
                    let mut r = c[0];
                    for a in &c[1..] {
                        r.add(a);
                    }
                    r
                })
                .collect()
        };
        let mut acc = sum_runs(&acc_fine, per);
        let mut total = Acc::default();
        for a in &acc {
            total.add(a);
        }
        if !total.p.iter().all(|v| v.is_finite()) || !(total.p[3] > 0.0) {
            return Err(crate::base::error::Error::param(
                "env",
                "its radiance does not sum to a finite value (Inf or NaN in the map)",
            ));
        }
        let mean = [0, 1, 2].map(|c| total.p[c] / total.p[3]);
        let moment = [0, 1, 2].map(|c| total.m[c]);
        // At most as many points apart as leaves: the most powerful (ties by order, so the
        // choice is the same on any thread count).
        if hot.len() > leaves_n {
            hot.sort_by(|a, b| b.0.total_cmp(&a.0));
            hot.truncate(leaves_n);
        }
        hot.sort_by_key(|h| h.1);
        // Each quarter without its points apart.
        let mut rest = acc_fine;
        for &(_, leaf, d, p) in &hot {
            rest[leaf].sub(&Acc::point(p, d));
        }
        let rest_leaf = sum_runs(&rest, per);
        // Leaves brighter than SPLIT × the mean leaf are taken as their quarters.
        let split_power = SPLIT * mean_leaf;
        let mut leaves: Vec<Leaf> = Vec::with_capacity(leaves_n);
        let mut own = vec![true; leaves_n];
        for (k, a) in rest_leaf.iter().enumerate() {
            let (axis, rad) = envtree::cone(&cube, face, row_major(face, k));
            let split =
                per > 1 && envtree::brightness([a.p[0], a.p[1], a.p[2]], channels) > split_power;
            own[k] = !split;
            leaves.push(if split {
                Leaf::default()
            } else {
                Leaf::new(axis.map(|v| v as f32), rad.sin() as f32, a)
            });
        }
        // Then per leaf what is kept apart: its quarters (where it is split), its points.
        let mut quarters = vec![(0u32, 0u32); leaves_n];
        let mut points = Vec::with_capacity(hot.len());
        let mut apart = vec![(0u32, 0u32); leaves_n];
        let mut h = 0;
        for k in 0..leaves_n {
            quarters[k].0 = leaves.len() as u32;
            if !own[k] {
                for f in k * per..(k + 1) * per {
                    let (axis, rad) = envtree::cone(&cube, fine, row_major(fine, f));
                    leaves.push(Leaf::new(
                        axis.map(|v| v as f32),
                        rad.sin() as f32,
                        &rest[f],
                    ));
                }
            }
            quarters[k].1 = leaves.len() as u32 - quarters[k].0;
            apart[k].0 = points.len() as u32;
            while h < hot.len() && hot[h].1 / per == k {
                let (_, _, d, p) = hot[h];
                points.push(Point {
                    d: d.map(|v| v as f32),
                    res: [0, 1, 2].map(|c| (p[c] - mean[c] * p[3]) as f32),
                });
                h += 1;
            }
            apart[k].1 = points.len() as u32 - apart[k].0;
        }
        let mut levels = Vec::new();
        let mut m = face;
        loop {
            let nodes = acc
                .iter()
                .enumerate()
                .map(|(k, a)| {
                    let (axis, rad) = envtree::cone(&cube, m, row_major(m, k));
                    Node {
                        axis,
                        sin_r: rad.sin(),
                        cos_r: rad.cos(),
                        res: [0, 1, 2].map(|c| [0, 1, 2].map(|q| a.m[c][q] - mean[c] * a.m[3][q])),
                    }
                })
                .collect();
            levels.push((m, nodes));
            if m == 1 {
                break;
            }
            // In Z-order a node's four children are 4k … 4k + 3.
            acc = sum_runs(&acc, 4);
            m /= 2;
        }
        Ok(CosineTree {
            levels,
            leaves,
            quarters,
            points,
            apart,
            own,
            mean,
            moment,
            channels,
            face,
        })
    }

    /// E(n) = ∫ L(l) (n·l)⁺ dω for each unit normal of `normals` (world frame), into `out`.
    /// Neighbouring normals share the work: they are taken in groups of [`GROUP`] in the
    /// order of [`envtree::spatial_key`] (a batch of a few rows of a canvas: 4×4 tiles of
    /// texels).
    pub fn irradiance(&self, normals: &[[f64; 3]], out: &mut [[f64; 3]]) {
        self.irradiance_ordered(normals, &envtree::spatial_order(normals), out);
    }

    /// [`CosineTree::irradiance`] with the normals' order given (groups of [`GROUP`]
    /// consecutive ones).
    fn irradiance_ordered(&self, normals: &[[f64; 3]], order: &[u32], out: &mut [[f64; 3]]) {
        let mut band = vec![0u32; self.leaves.len() + 4];
        let mut pband = vec![0u32; self.points.len() + 4];
        let mut ns = Vec::with_capacity(GROUP);
        let mut os = vec![[0.0; 3]; GROUP];
        for idx in order.chunks(GROUP) {
            ns.clear();
            ns.extend(idx.iter().map(|&i| normals[i as usize]));
            let os = &mut os[..ns.len()];
            let s = ns
                .iter()
                .fold([0.0; 3], |s, n| [0, 1, 2].map(|q| s[q] + n[q]));
            let len = crate::base::vec::dot(s, s).sqrt();
            let axis = if len > 0.0 { s.map(|v| v / len) } else { ns[0] };
            // The widest angle from the axis: that of the smallest cosine.
            let rg = ns
                .iter()
                .map(|n| crate::base::vec::dot(*n, axis))
                .fold(1.0, f64::min)
                .clamp(-1.0, 1.0)
                .acos();
            if rg > GROUP_MAX_RADIUS && ns.len() > 1 {
                for (n, o) in ns.iter().zip(os.iter_mut()) {
                    self.group(
                        std::slice::from_ref(n),
                        *n,
                        0.0,
                        std::slice::from_mut(o),
                        (&mut band, &mut pband),
                    );
                }
            } else {
                self.group(&ns, axis, rg, os, (&mut band, &mut pband));
            }
            for (&i, o) in idx.iter().zip(os.iter()) {
                out[i as usize] = *o;
            }
        }
    }

    /// E at every unit normal of `ns`, on all threads, each normal and its antipode by one
    /// integral: E(−n) = E(n) − n·M.  Each normal is taken to the side of its largest
    /// component's positive axis (c = ±n); normals whose c lie within [`ANTIPODE_EPS`] of each
    /// other (per component: the same direction, or antipodes, up to rounding) share the
    /// integral of the first of them in the order of ([`envtree::spatial_key`] of c, index),
    /// which moves E by at most 4 π L̄ · √3 ε.  The integrals are taken in that order (groups
    /// of neighbours) in fixed chunks, so the values are the same on any thread count.
    pub fn irradiance_all(&self, ns: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.irradiance_shared(ns).0
    }

    /// [`CosineTree::irradiance_all`] and the number of integrals it took.
    fn irradiance_shared(&self, ns: &[[f64; 3]]) -> (Vec<[f64; 3]>, usize) {
        use rayon::prelude::*;
        let side = |n: [f64; 3]| {
            if n[envtree::major_axis(n)] < 0.0 {
                -1.0
            } else {
                1.0
            }
        };
        // (key, index): on the positive faces the key has 34 bits (face 0, 2 or 4, then a
        // 32-bit Morton code), so with fewer than 2³⁰ normals both pack into one u64.
        let keys: Vec<(u64, [f64; 3])> = ns
            .par_iter()
            .map(|&n| {
                let c = n.map(|v| side(n) * v);
                (envtree::spatial_key(c), c)
            })
            .collect();
        let order: Vec<usize> = if ns.len() < 1 << 30 {
            let mut packed: Vec<u64> = keys
                .par_iter()
                .enumerate()
                .map(|(i, &(k, _))| (((k >> 33) & 3) << 62) | ((k & 0xffff_ffff) << 30) | i as u64)
                .collect();
            packed.par_sort_unstable();
            packed
                .iter()
                .map(|&p| (p & ((1 << 30) - 1)) as usize)
                .collect()
        } else {
            let mut o: Vec<(u64, usize)> =
                keys.iter().enumerate().map(|(i, &(k, _))| (k, i)).collect();
            o.par_sort_unstable();
            o.into_iter().map(|(_, i)| i).collect()
        };
        // The representatives (their c), and per normal its representative.
        let mut reps: Vec<[f64; 3]> = Vec::new();
        let mut rep_of = vec![0u32; ns.len()];
        let mut last = [f64::NAN; 3];
        for &i in &order {
            let c = keys[i].1;
            if (0..3).any(|q| !((c[q] - last[q]).abs() <= ANTIPODE_EPS)) {
                reps.push(c);
                last = c;
            }
            rep_of[i] = reps.len() as u32 - 1;
        }
        let mut e = vec![[0.0; 3]; reps.len()];
        // The representatives are in the spatial order already.
        let order: Vec<u32> = (0..ALL_CHUNK as u32).collect();
        e.par_chunks_mut(ALL_CHUNK)
            .zip(reps.par_chunks(ALL_CHUNK))
            .for_each(|(o, n)| self.irradiance_ordered(n, &order[..n.len()], o));
        let out = ns
            .par_iter()
            .zip(rep_of.par_iter())
            .map(|(&n, &r)| {
                let (c, e) = (reps[r as usize], e[r as usize]);
                if crate::base::vec::dot(n, c) >= 0.0 {
                    e
                } else {
                    [0, 1, 2].map(|ch| e[ch] - crate::base::vec::dot(c, self.moment[ch]))
                }
            })
            .collect();
        (out, reps.len())
    }

    /// The normals `ns` within `rg` of `axis`; `band` a buffer of at least as many entries as
    /// the tree has leaves (with its points apart) and 4 more.
    fn group(
        &self,
        ns: &[[f64; 3]],
        axis: [f64; 3],
        rg: f64,
        out: &mut [[f64; 3]],
        (band, pband): (&mut [u32], &mut [u32]),
    ) {
        let (sin_g, cos_g) = rg.sin_cos();
        let mut agg = [[0.0f64; 3]; 3];
        // Crossed nodes whose children are still to test: at most 3 more per level below the
        // roots (one popped, four pushed), see `build`'s cap on the face.
        let mut stack = [(0u8, 0u32); STACK];
        let mut sp = 0;
        let (mut nb, mut np) = (0, 0);
        let top = self.levels.len() - 1;
        // The roots first, then the four children (4k … 4k + 3 in Z-order) of each crossed node.
        let (mut lv, mut first, mut count) = (top, 0, self.levels[top].1.len());
        loop {
            for (q, node) in self.levels[lv].1[first..first + count].iter().enumerate() {
                // Every normal of the group against every direction of the node: the angle
                // between them is within θ ± (r + r_g); wholly above when θ + r + r_g < π/2
                // (the node's M − L̄ M_Ω joins the group's sum), wholly below when
                // θ − r − r_g > π/2 (dropped); else crossed: a leaf joins the band, a node's
                // children are tested.  Branch-free but for the rare points apart.
                let c = crate::base::vec::dot(node.axis, axis);
                let cos_t = node.cos_r * cos_g - node.sin_r * sin_g;
                let sin_t = node.sin_r * cos_g + node.cos_r * sin_g;
                let sure = cos_t > 0.0;
                let above = sure & (c >= sin_t);
                let crossed = !above & !(sure & (c <= -sin_t));
                let w = if above { 1.0 } else { 0.0 };
                for ch in 0..3 {
                    for q in 0..3 {
                        agg[ch][q] += w * node.res[ch][q];
                    }
                }
                let k = (first + q) as u32;
                if lv == 0 {
                    let ku = k as usize;
                    band[nb] = k;
                    nb += (crossed & self.own[ku]) as usize;
                    if crossed {
                        let (a, n) = self.quarters[ku];
                        for p in a..a + n {
                            band[nb] = p;
                            nb += 1;
                        }
                        let (a, n) = self.apart[ku];
                        for p in a..a + n {
                            pband[np] = p;
                            np += 1;
                        }
                    }
                } else {
                    stack[sp] = (lv as u8, k);
                    sp += crossed as usize;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            let (l, k) = stack[sp];
            (lv, first, count) = (l as usize - 1, 4 * k as usize, 4);
        }
        let (band, pband) = (&band[..nb], &pband[..np]);
        // The band, normal by normal: GROUP lanes (the group's normals, the last repeated).
        let mut nx = [[0f32; GROUP]; 3];
        for i in 0..GROUP {
            let n = ns[i.min(ns.len() - 1)];
            for q in 0..3 {
                nx[q][i] = n[q] as f32;
            }
        }
        let mean = self.mean.map(|v| v as f32);
        let acc = band_sum_dispatch(&self.leaves, band, &self.points, pband, &nx, mean);
        for (i, (n, o)) in ns.iter().zip(out.iter_mut()).enumerate() {
            *o = [0, 1, 2].map(|ch| {
                PI * self.mean[ch] + crate::base::vec::dot(*n, agg[ch]) + acc[ch][i] as f64
            });
        }
    }
}

/// [`band_sum`] compiled for the widest vectors this CPU has.
fn band_sum_dispatch(
    leaves: &[Leaf],
    band: &[u32],
    points: &[Point],
    pband: &[u32],
    nx: &[[f32; GROUP]; 3],
    mean: [f32; 3],
) -> [[f32; GROUP]; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        use crate::base::cpu::{simd, Simd};
        #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
        unsafe fn avx512(
            l: &[Leaf],
            b: &[u32],
            p: &[Point],
            pb: &[u32],
            n: &[[f32; GROUP]; 3],
            m: [f32; 3],
        ) -> [[f32; GROUP]; 3] {
            band_sum::<true>(l, b, p, pb, n, m)
        }
        #[target_feature(enable = "avx2,fma")]
        unsafe fn avx2(
            l: &[Leaf],
            b: &[u32],
            p: &[Point],
            pb: &[u32],
            n: &[[f32; GROUP]; 3],
            m: [f32; 3],
        ) -> [[f32; GROUP]; 3] {
            band_sum::<true>(l, b, p, pb, n, m)
        }
        match simd() {
            // SAFETY: the features were detected at run time.
            Simd::Avx512 => return unsafe { avx512(leaves, band, points, pband, nx, mean) },
            // SAFETY: the features were detected at run time.
            Simd::Avx2 => return unsafe { avx2(leaves, band, points, pband, nx, mean) },
            Simd::Portable => {}
        }
    }
    band_sum::<false>(leaves, band, points, pband, nx, mean)
}

/// a·b + c, fused where `FMA` (code compiled for a CPU with fused multiply-add; elsewhere
/// `mul_add` would be a library call).
#[inline(always)]
fn fma<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// n·m for lane `i` of `nx`.
#[inline(always)]
fn dot_lane<const FMA: bool>(nx: &[[f32; GROUP]; 3], i: usize, m: [f32; 3]) -> f32 {
    fma::<FMA>(nx[2][i], m[2], fma::<FMA>(nx[1][i], m[1], nx[0][i] * m[0]))
}

/// Σ over the band's leaves of ∫ (n·l)⁺ (L − L̄) dω for the [`GROUP`] normals `nx` (by
/// coordinate).
#[inline(always)]
fn band_sum<const FMA: bool>(
    leaves: &[Leaf],
    band: &[u32],
    points: &[Point],
    pband: &[u32],
    nx: &[[f32; GROUP]; 3],
    mean: [f32; 3],
) -> [[f32; GROUP]; 3] {
    let mut acc = [[0f32; GROUP]; 3];
    // Per lane the products nᵢnⱼ the spreads' quadratic forms take.
    let mut nn = [[0f32; GROUP]; 6];
    for i in 0..GROUP {
        let (x, y, z) = (nx[0][i], nx[1][i], nx[2][i]);
        nn[0][i] = x * x;
        nn[1][i] = y * y;
        nn[2][i] = z * z;
        nn[3][i] = x * y;
        nn[4][i] = x * z;
        nn[5][i] = y * z;
    }
    let quad = |q: &[f32; 6], i: usize| -> f32 {
        let a = fma::<FMA>(nn[2][i], q[2], fma::<FMA>(nn[1][i], q[1], nn[0][i] * q[0]));
        let b = fma::<FMA>(nn[5][i], q[5], fma::<FMA>(nn[4][i], q[4], nn[3][i] * q[3]));
        (a + b).max(0.0)
    };
    for &k in band.iter() {
        let leaf = &leaves[k as usize];
        // Lane by lane, branch-free (so that it runs as vector code): where the leaf is
        // wholly above the lane's horizon, n·M exactly; crossed, the discs; below, 0.
        let mut keep = [0f32; GROUP];
        let mut lin = [0f32; GROUP];
        let mut t_o = [0f32; GROUP];
        let mut geo = [0f32; GROUP];
        for i in 0..GROUP {
            let h0 = dot_lane::<FMA>(nx, i, leaf.axis);
            keep[i] = if h0 <= -leaf.sin_r { 0.0 } else { 1.0 };
            lin[i] = if h0 >= leaf.sin_r { 1.0 } else { 0.0 };
            t_o[i] = dot_lane::<FMA>(nx, i, leaf.m[3]);
            let x = quad(&leaf.q[3], i);
            let y = rsqrt::<FMA>(x);
            geo[i] = disc::<FMA>(x * y, t_o[i] * y, t_o[i]);
        }
        for ch in 0..3 {
            let (m, q, mc) = (leaf.m[ch], &leaf.q[ch], mean[ch]);
            for i in 0..GROUP {
                let t = dot_lane::<FMA>(nx, i, m);
                let x = quad(q, i);
                let y = rsqrt::<FMA>(x);
                let crossed = fma::<FMA>(-mc, geo[i], disc::<FMA>(x * y, t * y, t));
                let exact = fma::<FMA>(-mc, t_o[i], t);
                acc[ch][i] = fma::<FMA>(
                    keep[i],
                    fma::<FMA>(lin[i], exact - crossed, crossed),
                    acc[ch][i],
                );
            }
        }
    }
    // The points apart: (n·d)⁺ (P − L̄ dω), exact.
    for &k in pband {
        let p = &points[k as usize];
        let mut h = [0f32; GROUP];
        for i in 0..GROUP {
            h[i] = dot_lane::<FMA>(nx, i, p.d).max(0.0);
        }
        for ch in 0..3 {
            for i in 0..GROUP {
                acc[ch][i] = fma::<FMA>(h[i], p.res[ch], acc[ch][i]);
            }
        }
    }
    acc
}

/// 1/√x to 6.6e-4 relative for x ≥ 0 (finite and large at 0) with no division: the integer
/// estimate and one modified Newton step (Moroz, Walczyk, Hrynchyshyn, Holimath and Cieśliński
/// 2018, "Fast calculation of inverse square root with the use of magic constant").
#[inline(always)]
fn rsqrt<const FMA: bool>(x: f32) -> f32 {
    let y = f32::from_bits(0x5f1f_fff9u32.wrapping_sub(x.to_bits() >> 1));
    y * 0.703_952_3 * fma::<FMA>(-x * y, y, 2.389_244_6)
}

/// ∫ (n·l)⁺ L dω of light of power `p` whose n·l has mean `t`/`p` and is spread as an even
/// disc of radius `w` across the horizon: p · w · f(μ/w), f the clamped mean of the semicircle
/// law, f(u) = (2/π)(u A(u) + B(u)), A(u) = π/4 + (u√(1−u²) + asin u)/2, B(u) = (1−u²)^{3/2}/3
/// (u for u ≥ 1, 0 for u ≤ −1).  Given `pw` = (P w)⁺ and `u` = t / (P w) (from reciprocals
/// kept per leaf and lane; any value where P w is 0).  Power that is not positive (a map with
/// negative values) is clamped as a point.
#[inline(always)]
fn disc<const FMA: bool>(pw: f32, u: f32, t: f32) -> f32 {
    // Branch-free: P·w·f(u) for |u| < 1, and past the ends t (u ≥ 1) or 0 (the fit's end
    // values are 1 and 0 to rounding).  No positive spread: (t)⁺, a point.
    let uc = u.clamp(-1.0, 1.0);
    let x = uc * uc;
    let even = DISC_EVEN[..3]
        .iter()
        .rev()
        .fold(DISC_EVEN[3], |acc, &c| fma::<FMA>(acc, x, c));
    fma::<FMA>(pw, fma::<FMA>(0.5, uc, even), (t - pw).max(0.0))
}

/// The even part of f(u) − u/2 as a cubic in u² (f(u) − f(−u) = u, since y and −y are alike
/// under the semicircle law): within 4.1e-5 of it (at u = 0), its coefficients summing to ½
/// so that f(1) = 1 and f(−1) = 0 (iteratively reweighted least squares on Chebyshev nodes).
#[allow(clippy::excessive_precision)]
const DISC_EVEN: [f32; 4] = [
    2.122_467e-1,
    3.172_921_2e-1,
    -2.260_061_2e-2,
    -6.938_214_4e-3,
];

/// The leaves' face for a tolerance (relative to π L̄): 8 from 2e-3 up, 32 below 5e-5, else
/// 16.  Measured on the 18 bundled HDRIs, with and without a one-texel sun holding a fifth of
/// the energy (worst over 2,000 normals against the brute-force sum;
/// `examples/irradiance_accuracy.rs`): face 8 within 1.2e-3, face 16 within 8e-5, face 32
/// within 3.5e-5.
pub fn face_for_tolerance(tol: f64) -> usize {
    if tol >= 2e-3 {
        8
    } else if tol < 5e-5 {
        32
    } else {
        DEFAULT_FACE
    }
}

/// The cosine integral as a texel source: for each direction d of a canvas, the normal
/// `normal(d)` and then `scale` × E(n) (e.g. 1/π: the radiance a white Lambertian surface
/// reflects).
pub struct CosineSource<'a, F: Fn([f64; 3]) -> [f64; 3] + Sync> {
    pub tree: &'a CosineTree,
    pub normal: F,
    /// Per channel (the albedo / π of a MatCap, 1/π for the prefilter, 1 for E).
    pub scale: [f64; 3],
    /// Channels written (the light's, or 3 for a coloured albedo on a grey map).
    pub channels: usize,
}

impl<F: Fn([f64; 3]) -> [f64; 3] + Sync> CosineSource<'_, F> {
    /// The texel values of the integrals `e`, `channels` per normal.
    fn values(&self, e: &[[f64; 3]], out: &mut [f32]) {
        let c = self.channels;
        let grey = self.tree.channels == 1;
        for (o, e) in out.chunks_exact_mut(c).zip(e) {
            for k in 0..c {
                let v = if grey { e[0] } else { e[k] };
                o[k] = (v * self.scale[k]) as f32;
            }
        }
    }

    /// A `width`×`height` canvas of `mapping` from this source: with one normal per texel
    /// (`opts.samples == 1`) all at once ([`CosineTree::irradiance_all`], antipodes by one
    /// integral), else batch by batch as any ray source.
    pub fn generate(
        &self,
        mapping: Mapping,
        width: usize,
        height: usize,
        opts: &crate::trace::generate::GenerateOptions,
        progress: Option<&crate::resample::Progress>,
    ) -> Result<(crate::images::Image, crate::trace::generate::GenerateReport)> {
        use crate::trace::generate;
        use rayon::prelude::*;
        if opts.samples != 1 {
            return generate::generate(mapping, width, height, self, opts, progress);
        }
        let eval = |dirs: &[[f32; 3]]| -> Result<Vec<f32>> {
            let normals: Vec<[f64; 3]> = dirs
                .par_iter()
                .map(|d| (self.normal)(crate::base::vec::normalize(d.map(|v| v as f64))))
                .collect();
            let e = self.tree.irradiance_all(&normals);
            let mut out = vec![0f32; dirs.len() * self.channels];
            out.par_chunks_mut(ALL_CHUNK * self.channels)
                .zip(e.par_chunks(ALL_CHUNK))
                .for_each(|(o, e)| self.values(e, o));
            Ok(out)
        };
        generate::generate_all(
            mapping,
            width,
            height,
            self.channels,
            &eval,
            ALL_BYTES,
            opts,
            progress,
        )
    }
}

impl<F: Fn([f64; 3]) -> [f64; 3] + Sync> crate::trace::generate::RaySource for CosineSource<'_, F> {
    fn channels(&self) -> usize {
        self.channels
    }
    fn rows_per_call(&self) -> usize {
        // Tiles of 4×4 texels for the groups of normals.
        4
    }
    fn trace(&self, _: &[[f32; 3]], dirs: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        let normals: Vec<[f64; 3]> = dirs
            .iter()
            .map(|d| (self.normal)(crate::base::vec::normalize(d.map(|v| v as f64))))
            .collect();
        let mut e = vec![[0.0; 3]; normals.len()];
        self.tree.irradiance(&normals, &mut e);
        self.values(&e, out);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn z_order_puts_a_nodes_children_at_4k() {
        for m in [1usize, 2, 8, 32] {
            let mut seen = vec![false; 6 * m * m];
            for k in 0..6 * m * m {
                let z = z_index(m, k);
                assert_eq!(row_major(m, z), k);
                seen[z] = true;
            }
            assert!(seen.iter().all(|&s| s));
        }
        // Texel (i, j) of face f at face 8 and its children (2i + di, 2j + dj) at face 16.
        let (f, j, i) = (4, 5, 3);
        let parent = z_index(8, (f * 8 + j) * 8 + i);
        let mut kids: Vec<usize> = [(0, 0), (0, 1), (1, 0), (1, 1)]
            .iter()
            .map(|(dj, di)| z_index(16, (f * 16 + 2 * j + dj) * 16 + 2 * i + di))
            .collect();
        kids.sort();
        assert_eq!(kids, (4 * parent..4 * parent + 4).collect::<Vec<_>>());
    }

    #[test]
    fn rsqrt_is_within_6_6e_4() {
        for e in -60..60 {
            for m in [1.0f64, 1.3, 1.7, 2.2, 3.1] {
                let x = m * 2f64.powi(e);
                let want = 1.0 / x.sqrt();
                for got in [rsqrt::<false>(x as f32), rsqrt::<true>(x as f32)] {
                    let rel = (got as f64 - want).abs() / want;
                    assert!(rel < 6.6e-4, "{x}: {got} vs {want}");
                }
            }
        }
        // Zero: finite, so that a point (no spread) gets P w = 0 and a finite μ/w.
        let y = rsqrt::<false>(0.0);
        assert!(y.is_finite() && y > 1e18 && 0.0 * y == 0.0);
    }

    #[test]
    fn the_disc_is_the_semicircle_law_clamped() {
        // f(1) = 1 (wholly above: μ), f(−1) = 0 to rounding, f(0) = 2/(3π) to the fit's 4.1e-5.
        assert!((disc::<false>(1.0, 1.0, 1.0) - 1.0).abs() < 1e-6);
        assert!(disc::<false>(1.0, -1.0, -1.0).abs() < 1e-6);
        assert!((disc::<false>(1.0, 0.0, 0.0) as f64 - 2.0 / (3.0 * PI)).abs() < 4.2e-5);
        // No spread: a point, (t)⁺.
        assert_eq!(disc::<false>(0.0, f32::INFINITY, 0.3), 0.3);
        assert_eq!(disc::<false>(0.0, f32::NEG_INFINITY, -0.3), 0.0);
        assert_eq!(disc::<false>(0.0, 0.0, 0.0), 0.0);
        // The semicircle law's clamped mean by a fine midpoint rule.
        for u in [-0.7, -0.2, 0.3, 0.9] {
            let n = 200_000;
            let (mut s, mut wsum) = (0.0, 0.0);
            for i in 0..n {
                let y = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let wt = (1.0 - y * y).sqrt();
                s += wt * (u + y).max(0.0);
                wsum += wt;
            }
            let want = s / wsum;
            let got = disc::<false>(1.0, u as f32, u as f32) as f64;
            assert!((got - want).abs() < 4.2e-5, "u {u}: {got} vs {want}");
        }
    }
}

#[cfg(test)]
mod against_brute_force {
    use super::*;
    use crate::resample::IDENTITY;

    #[test]
    fn antipodes_by_one_integral_match_the_sum_over_their_texels() {
        // Normals, their antipodes and near-repeats (1e-12 off, as rounding leaves a canvas's
        // antipodal texels) at once: one integral per ± pair, each within the same bound as
        // the normal's own.
        for (channels, rot) in [(3, IDENTITY), (1, TURNED)] {
            let data = map(channels);
            let env = map_env(&data, channels);
            let half = normals(150);
            let mut ns = half.clone();
            ns.extend(half.iter().map(|n| n.map(|v| -v)));
            ns.extend(half.iter().take(20).map(|n| n.map(|v| -v * (1.0 + 1e-12))));
            let t = CosineTree::build(&env, rot, 16).unwrap();
            let scale = PI * envtree::brightness(t.mean, t.channels);
            let (got, integrals) = t.irradiance_shared(&ns);
            assert_eq!(integrals, 150);
            let mut worst = 0.0f64;
            for (n, g) in ns.iter().zip(&got) {
                let w = brute(&data, channels, &rot, *n);
                for q in 0..channels {
                    worst = worst.max((g[q] - w[q]).abs() / scale);
                }
            }
            eprintln!("{channels} channel(s), ± normals: worst {worst:.2e} of π L̄");
            assert!(worst < 1e-4, "{worst:.2e}");
            // The moment is the map's: E(n) − E(−n) = n·M by the brute force too.
            for n in half.iter().take(5) {
                let (a, b) = (
                    brute(&data, channels, &rot, *n),
                    brute(&data, channels, &rot, n.map(|v| -v)),
                );
                for q in 0..channels {
                    let m = crate::base::vec::dot(*n, t.moment[q]);
                    assert!(
                        ((a[q] - b[q]) - m).abs() < 1e-9 * scale,
                        "{q}: {} {m}",
                        a[q] - b[q]
                    );
                }
            }
        }
    }

    #[test]
    fn a_canvas_takes_one_integral_per_antipodal_pair_on_any_thread_count() {
        use crate::trace::generate::{generate_all, GenerateOptions};
        let data = map(3);
        let env = map_env(&data, 3);
        let t = CosineTree::build(&env, IDENTITY, 16).unwrap();
        let scale = PI * envtree::brightness(t.mean, t.channels);
        let view = crate::frame::view::look_up([0.3, -0.5, -1.0], [0.0, 1.0, 0.0]).unwrap();
        // (mapping, width, height, rotation, whether its texel centres come in ± pairs)
        let cube = Mapping::parse("cube", None).unwrap();
        for (m, w, h, rotation, paired) in [
            (cube, 16, 96, IDENTITY, true),
            (cube, 12, 72, view, true),
            (
                Mapping::parse("latlong", None).unwrap(),
                64,
                32,
                IDENTITY,
                true,
            ),
            (
                Mapping::parse("octahedral", None).unwrap(),
                32,
                32,
                IDENTITY,
                true,
            ),
            (
                Mapping::parse("sphere", None).unwrap(),
                32,
                32,
                IDENTITY,
                false,
            ),
        ] {
            let opts = GenerateOptions {
                rotation,
                samples: 1,
                ..Default::default()
            };
            let counts = std::sync::Mutex::new((0, 0));
            let eval = |dirs: &[[f32; 3]]| -> Result<Vec<f32>> {
                let ns: Vec<[f64; 3]> = dirs
                    .iter()
                    .map(|d| crate::base::vec::normalize(d.map(|v| v as f64)))
                    .collect();
                let (_, k) = t.irradiance_shared(&ns);
                *counts.lock().unwrap() = (ns.len(), k);
                Ok(vec![0.0; dirs.len()])
            };
            generate_all(m, w, h, 1, &eval, 0, &opts, None).unwrap();
            let (n, k) = counts.into_inner().unwrap();
            if paired {
                assert_eq!(2 * k, n, "{}", m.name());
            } else {
                assert_eq!(k, n, "{}", m.name());
            }
            // The source on the whole canvas: within 2e-5 of π L̄ of its batches (other
            // groups), the same bits on 1 and 3 threads.
            let source = CosineSource {
                tree: &t,
                normal: |d| d,
                scale: [1.0; 3],
                channels: 3,
            };
            let (a, _) = crate::trace::generate::generate(m, w, h, &source, &opts, None).unwrap();
            let run = |threads| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| source.generate(m, w, h, &opts, None).unwrap().0)
            };
            let b = run(1);
            assert_eq!(b, run(3), "{}", m.name());
            let worst = a
                .data
                .iter()
                .zip(&b.data)
                .map(|(x, y)| (x - y).abs() as f64 / scale)
                .fold(0.0, f64::max);
            assert!(worst < 2e-5, "{}: {worst:.2e}", m.name());
        }
    }

    /// World → map: a rotation about the y axis by asin 0.6, for a turned frame.
    const TURNED: [[f64; 3]; 3] = [[0.8, 0.0, 0.6], [0.0, 1.0, 0.0], [-0.6, 0.0, 0.8]];

    /// The lat-long of [`map`]'s data (256×128).
    fn map_env(data: &[f32], channels: usize) -> EnvMap<'_> {
        EnvMap {
            mapping: Mapping::parse("latlong", None).unwrap(),
            width: 256,
            height: 128,
            channels,
            data,
        }
    }

    /// Fibonacci normals over the sphere.
    fn normals(n: usize) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = i as f64 * 2.399963229728653;
                [r * phi.cos(), z, r * phi.sin()]
            })
            .collect()
    }

    /// A 256×128 lat-long with gradients, a soft bright spot and a one-texel sun holding a
    /// fifth of the energy (grey: the first channel only).
    fn map(channels: usize) -> Vec<f32> {
        let (w, h) = (256, 128);
        let ll = Mapping::parse("latlong", None).unwrap();
        let mut data = vec![0f32; w * h * channels];
        let mut total = 0.0;
        for y in 0..h {
            for x in 0..w {
                let spot =
                    40.0 * (-((x as f32 - 160.0).powi(2) + (y as f32 - 40.0).powi(2)) / 30.0).exp();
                let v = [
                    0.2 + x as f32 / w as f32,
                    0.1 + y as f32 / h as f32 + spot,
                    0.3 + spot * 0.5,
                ];
                for c in 0..channels {
                    data[(y * w + x) * channels + c] = v[c];
                }
                total += v[0] as f64 * ll.texel_solid_angle(x, y, w, h);
            }
        }
        let (x, y) = (70, 51);
        let add = (0.25 * total / ll.texel_solid_angle(x, y, w, h)) as f32;
        for c in 0..channels {
            data[(y * w + x) * channels + c] += add * [1.0, 0.9, 0.7][c];
        }
        data
    }

    /// Σ over the map's texels of L (n·l)⁺ dω, world → map by `rot`.
    fn brute(data: &[f32], c: usize, rot: &[[f64; 3]; 3], n: [f64; 3]) -> [f64; 3] {
        let (w, h) = (256, 128);
        let ll = Mapping::parse("latlong", None).unwrap();
        let nm = [0, 1, 2].map(|i| rot[i][0] * n[0] + rot[i][1] * n[1] + rot[i][2] * n[2]);
        let mut e = [0.0; 3];
        for y in 0..h {
            for x in 0..w {
                let d = ll
                    .uv_to_dir([(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64])
                    .unwrap();
                let t = crate::base::vec::dot(nm, d);
                if t > 0.0 {
                    let dw = ll.texel_solid_angle(x, y, w, h);
                    for q in 0..c {
                        e[q] += data[(y * w + x) * c + q] as f64 * t * dw;
                    }
                }
            }
        }
        e
    }

    #[test]
    fn a_constant_map_gives_pi_times_itself_at_every_normal() {
        let ll = Mapping::parse("latlong", None).unwrap();
        let (w, h) = (64, 32);
        let data: Vec<f32> = (0..w * h).flat_map(|_| [0.3f32, 1.7, 0.05]).collect();
        let env = EnvMap {
            mapping: ll,
            width: w,
            height: h,
            channels: 3,
            data: &data,
        };
        for face in [8, 16, 32] {
            let t = CosineTree::build(&env, IDENTITY, face).unwrap();
            let ns = normals(500);
            let mut out = vec![[0.0; 3]; ns.len()];
            t.irradiance(&ns, &mut out);
            for e in &out {
                for (q, want) in [0.3f32, 1.7, 0.05].iter().enumerate() {
                    let want = PI * *want as f64;
                    assert!((e[q] - want).abs() <= 1e-5 * want, "face {face}: {e:?}");
                }
            }
        }
    }

    #[test]
    fn a_map_with_a_sun_matches_the_sum_over_its_texels() {
        // A turned frame too: world → map a rotation about a slanted axis.
        for (channels, rot) in [(3, IDENTITY), (1, TURNED)] {
            let data = map(channels);
            let env = map_env(&data, channels);
            let ns = normals(300);
            let want: Vec<[f64; 3]> = ns
                .iter()
                .map(|n| brute(&data, channels, &rot, *n))
                .collect();
            for (face, bound) in [(8, 5e-4), (16, 1e-4), (32, 1e-4)] {
                let t = CosineTree::build(&env, rot, face).unwrap();
                let scale = PI * envtree::brightness(t.mean, t.channels);
                let mut got = vec![[0.0; 3]; ns.len()];
                t.irradiance(&ns, &mut got);
                let worst = got
                    .iter()
                    .zip(&want)
                    .flat_map(|(g, w)| (0..channels).map(move |q| (g[q] - w[q]).abs() / scale))
                    .fold(0.0, f64::max);
                eprintln!("{channels} channel(s), face {face}: worst {worst:.2e} of π L̄");
                assert!(
                    worst < bound,
                    "{channels} channel(s), face {face}: {worst:.2e}"
                );
            }
        }
    }

    #[test]
    fn neighbours_and_lone_normals_agree() {
        // The same normals in groups of neighbours and one by one (the groups' cut is only
        // where work is shared, not what is summed).
        let data = map(3);
        let env = map_env(&data, 3);
        let t = CosineTree::build(&env, IDENTITY, 16).unwrap();
        let row: Vec<[f64; 3]> = (0..64)
            .map(|i| {
                let a = i as f64 * 0.01;
                crate::base::vec::normalize([a.cos(), 0.3, a.sin()])
            })
            .collect();
        let mut grouped = vec![[0.0; 3]; row.len()];
        t.irradiance(&row, &mut grouped);
        for (n, g) in row.iter().zip(&grouped) {
            let mut one = [[0.0; 3]];
            t.irradiance(std::slice::from_ref(n), &mut one);
            for q in 0..3 {
                assert!(
                    (one[0][q] - g[q]).abs() <= 1e-5 * g[q].abs().max(1.0),
                    "{one:?} {g:?}"
                );
            }
        }
    }
}
