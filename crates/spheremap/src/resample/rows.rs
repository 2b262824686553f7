//! The one-sample path for f32, in three passes over each output row so the compiler can
//! vectorize the first two: (1) destination directions (branch-free formulas for the sphere
//! map, with its gutter, and tables for the lat-long), (2) source positions (branch-free
//! lat-long, cube and sphere), (3) the bilinear gathers.  Other mappings use the generic
//! per-texel functions in passes 1–2.  Same formulas as the generic path (tested equal).
//! Where the canvas's mirror symmetries are folds of the source's positions (the default
//! view of a sphere map or lat-long from a lat-long or sphere map: [`Fold`]), passes 1–2
//! run on half of each row and half of the rows, and the mirrored texels' positions are
//! their partners' folded.

use super::dest::Dst;
use super::lanes::Lanes;
use super::options::Outside;
use super::source::Src;
pub(crate) use crate::base::cpu::vectorized;
use crate::base::cpu::{simd, Simd};
use crate::base::real::{atan2_poly, atan2_upper, floor_v, mad, vmax, vmin};
use crate::base::vec::IDENTITY3 as IDENTITY;
use crate::frame::conventions::RowOrder;
use crate::mappings::mapping::Mapping;

pub(crate) struct Scratch {
    pub(crate) d: [Lanes<f32>; 3],
    pub(crate) on: Lanes<bool>,
    pub(crate) p: [Lanes<f32>; 2],
    /// Pass 2b: the top-left tap's index into the source data, or `SLOW` when the lookup
    /// needs the general path; and the bilinear fractions.
    pub(crate) idx: Lanes<u32>,
    pub(crate) frac: [Lanes<f32>; 2],
    /// Canvas points for [`Points::At`] (x, y).
    pub(crate) pts: [Lanes<f32>; 2],
    /// How many of the lanes the passes compute (the first ones; all unless `set_live`).
    live: usize,
}

/// Which destination points passes 1–2 take.
#[derive(Clone, Copy)]
pub(crate) enum Points {
    /// The texel centres of row y.
    Row(usize),
    /// `Scratch::pts`, within the box [x₀, x₁] × [y₀, y₁] when the caller knows one (it lets
    /// a sphere-map destination skip its gutter's formulas for boxes well inside the disc).
    At(Option<[f32; 4]>),
}

/// `Scratch::idx` of a lookup that takes the general path.
pub(crate) const SLOW: u32 = u32::MAX;

impl Scratch {
    pub(crate) fn new(w: usize) -> Self {
        let z = || Lanes::new(w, 0.0);
        Scratch {
            d: [z(), z(), z()],
            on: Lanes::new(w, false),
            p: [z(), z()],
            idx: Lanes::new(w, SLOW),
            frac: [z(), z()],
            pts: [z(), z()],
            live: w,
        }
    }

    /// The passes compute the first `n` lanes only (at most all of them): a chunk that
    /// fills part of its arrays leaves the rest alone.
    pub(crate) fn set_live(&mut self, n: usize) {
        self.live = n.min(self.on.len());
    }
}

/// Per-run constants.
pub(crate) struct Plan {
    /// Sphere destination: rotation · (preset frame)ᵀ, eye → source frame.
    sphere_m: [[f32; 3]; 3],
    /// Lat-long destination: cos φ, sin φ per column.
    cos_phi: Lanes<f32>,
    sin_phi: Lanes<f32>,
    /// Source preset frame (sphere, cube): source frame → the mapping's eye/GL frame.
    src_frame: [[f32; 3]; 3],
    /// The canvas's mirror symmetries as the source positions see them: `[columns, rows]`,
    /// the right half of a row from its left half, and row h − 1 − y from row y (see
    /// [`Fold`]; `None` where the mirror is no simple fold of the source's positions).
    pub(crate) fold: [Option<Fold>; 2],
}

/// A mirror of the destination canvas (column x ↔ w − 1 − x, or row y ↔ h − 1 − y) seen
/// from the source: the canvas mirror reflects one axis of the destination's own frame —
///
/// ```text
///   sphere map    column mirror: a → −a, so R = (2z·a, 2z·b, 1 − 2q) has Rx → −Rx
///                 row mirror:    b → −b, Ry → −Ry          (the gutter's formula too)
///   lat-long      φ(x) = 2π((x + ½)/w − u₀),  φ(w − 1 − x) = 2π(1 − 2u₀) − φ(x):
///                 2u₀ ∈ ℤ: φ → −φ (z → −z);  2u₀ − ½ ∈ ℤ: φ → π − φ (x → −x)
///                 row mirror: θ → π − θ (y → −y)
/// ```
///
/// — and when the rotation to the source's mapping frame takes that axis onto one of the
/// source's axes (the default view does: the identity), the mirror reflects that source
/// axis, and the source position becomes `k − p` in one coordinate:
///
/// ```text
///   lat-long source  x → −x: u → 2u₀ + ½ − u    z → −z: u → 2u₀ − u    (both mod 1)
///                    y → −y: θ → π − θ, py → h − py
///   sphere source    x → −x: px → w − px        y → −y: py → h − py   (either row order)
/// ```
///
/// So a mirrored lane's position is its partner's folded, not computed again (its passes
/// would be the job's slowest arithmetic: from a lat-long, two atan2s and two square roots,
/// long-latency divisions and roots).  The
/// folded value is the mirror image of the partner's to the rounding of one subtraction;
/// the directions' exact mirror images would give the same values but for the last bits
/// of the polynomial atan2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Fold {
    /// The position coordinate that folds: 0 = px, 1 = py.
    axis: usize,
    /// p → k − p …
    k: f32,
    /// … then wrapped into [0, period) (lat-long u), or not wrapped (0).
    period: f32,
}

impl Fold {
    /// The fold of a reflection of source axis `k` (its mapping's frame), if it is one.
    fn of_source_axis(s: &Mapping, wf: f32, hf: f32, k: usize) -> Option<Fold> {
        let f = |axis, k, period| Some(Fold { axis, k, period });
        match (s, k) {
            (Mapping::LatLong(p), 0) => f(0, ((2.0 * p.u_plus_x + 0.5) * wf as f64) as f32, wf),
            (Mapping::LatLong(p), 2) => f(0, (2.0 * p.u_plus_x * wf as f64) as f32, wf),
            (Mapping::LatLong(_), 1) | (Mapping::Sphere(_), 1) => f(1, hf, 0.0),
            (Mapping::Sphere(_), 0) => f(0, wf, 0.0),
            _ => None,
        }
    }

    /// The canvas's column and row mirrors for a source `s` and a destination `d` whose
    /// directions reach the source's mapping frame through `t` (row-major).
    fn of(s: &Src<f32>, d: &Dst<f32>, t: &[[f64; 3]; 3]) -> [Option<Fold>; 2] {
        // The destination frame's axis that each canvas mirror reflects.
        let (col, row) = match d.m {
            Mapping::Sphere(_) => (Some(0), Some(1)),
            Mapping::LatLong(p) => {
                let whole = |v: f64| v == v.round();
                let u2 = 2.0 * p.u_plus_x;
                let col = if whole(u2) {
                    Some(2)
                } else if whole(u2 - 0.5) {
                    Some(0)
                } else {
                    None
                };
                (col, Some(1))
            }
            _ => (None, None),
        };
        // Column i of t taken onto a source axis (±eₖ, to rounding): that axis.
        let onto = |i: usize| {
            (0..3).find(|&k| {
                (t[k][i].abs() - 1.0).abs() < 1e-12 && {
                    (0..3).all(|j| j == k || t[j][i].abs() < 1e-12)
                }
            })
        };
        [col, row].map(|a| {
            let k = onto(a?)?;
            Fold::of_source_axis(&s.m, s.wf, s.hf, k)
        })
    }

    /// `to[i]` = `from[i]` folded, over the shorter of the two (the loops decide the
    /// wrap once, so each vectorizes).
    #[inline(always)]
    fn apply<'a>(&self, to: impl Iterator<Item = &'a mut f32>, from: impl Iterator<Item = f32>) {
        let (k, period) = (self.k, self.period);
        if period > 0.0 {
            let inv = 1.0 / period;
            to.zip(from).for_each(|(a, p)| {
                let v = k - p;
                *a = v - crate::base::real::floor_fast(v * inv) * period;
            });
        } else {
            to.zip(from).for_each(|(a, p)| *a = k - p);
        }
    }
}

impl Plan {
    pub(crate) fn new(s: &Src<f32>, d: &Dst<f32>, rot: &[[f64; 3]; 3], w: usize) -> Self {
        use crate::frame::view::{mul, transpose};
        let sphere_m = match d.m {
            Mapping::Sphere(p) => mul(rot, &transpose(&p.frame)),
            _ => *rot,
        };
        let (mut cos_phi, mut sin_phi) = (vec![], vec![]);
        if let Mapping::LatLong(p) = d.m {
            for x in 0..w {
                let phi = ((x as f64 + 0.5) / w as f64 - p.u_plus_x) * std::f64::consts::TAU;
                cos_phi.push(phi.cos() as f32);
                sin_phi.push(phi.sin() as f32);
            }
        }
        let src_frame = match s.m {
            Mapping::Sphere(p) => p.frame,
            Mapping::Cube(p) => p.frame,
            _ => IDENTITY,
        };
        let fold = Fold::of(s, d, &mul(&src_frame, &sphere_m));
        let sphere_m = sphere_m.map(|r| r.map(|v| v as f32));
        let src_frame = src_frame.map(|r| r.map(|v| v as f32));
        Plan {
            fold,
            sphere_m,
            cos_phi: Lanes::from_slice(&cos_phi),
            sin_phi: Lanes::from_slice(&sin_phi),
            src_frame,
        }
    }
}

#[inline(always)]
fn apply<const F: bool>(m: &[[f32; 3]; 3], e: [f32; 3]) -> [f32; 3] {
    // Written out: `[0, 1, 2].map(..)` is not inlined and stops vectorization.
    let row = |r: &[f32; 3]| mad::<F>(r[0], e[0], mad::<F>(r[1], e[1], r[2] * e[2]));
    [row(&m[0]), row(&m[1]), row(&m[2])]
}

/// The sphere map's direction at disc coordinates (a, b) ∈ [−1, 1]², turned by `m`, and
/// whether it is on the disc; off it, the gutter: the radial mirror image across the rim
/// (see `Dst::mirrored`).  Branch-free, so the callers' loops vectorize.
///
/// `ALL_IN`: the caller knows (a, b) is on the disc; the gutter's square root and division
/// are left out, and the result is the same.
#[inline(always)]
fn sphere_dir<const F: bool, const ALL_IN: bool>(
    m: &[[f32; 3]; 3],
    a: f32,
    b: f32,
) -> ([f32; 3], bool) {
    let (a2, b2, inside) = if ALL_IN {
        (a, b, true)
    } else {
        let d2 = mad::<F>(a, a, b * b);
        let inside = d2 <= 1.0;
        let rho = d2.sqrt();
        let k = if inside {
            1.0
        } else {
            vmin(vmax(2.0 - rho, 0.0), 1.0 - 1e-6) / rho
        };
        (a * k, b * k, inside)
    };
    let q = a2 * a2 + b2 * b2;
    let z2 = 2.0 * vmax(1.0 - q, 0.0).sqrt();
    (apply::<F>(m, [z2 * a2, z2 * b2, 1.0 - 2.0 * q]), inside)
}

/// Pass 1 of a sphere-map destination at canvas points `pts` (scaled by `k` to the disc);
/// `ALL_IN` as in [`sphere_dir`].
#[inline(always)]
fn sphere_at<const F: bool, const ALL_IN: bool>(
    m: &[[f32; 3]; 3],
    [kx, ky]: [f32; 2],
    flip: bool,
    [ptx, pty]: [&[f32]; 2],
    [dx, dy, dz]: [&mut [f32]; 3],
    on: &mut [bool],
) {
    let w = on.len();
    let (ptx, pty, dx, dy, dz) = (
        &ptx[..w],
        &pty[..w],
        &mut dx[..w],
        &mut dy[..w],
        &mut dz[..w],
    );
    for x in 0..w {
        let a = mad::<F>(ptx[x], kx, -1.0);
        let yf = mad::<F>(pty[x], ky, -1.0);
        let b = if flip { -yf } else { yf };
        let (r, inside) = sphere_dir::<F, ALL_IN>(m, a, b);
        dx[x] = r[0];
        dy[x] = r[1];
        dz[x] = r[2];
        on[x] = inside;
    }
}

/// Whether the canvas box [x₀, x₁] × [y₀, y₁] lies inside the sphere map's disc, well clear
/// of its rim, with disc coordinates a = x·kx − 1, b = y·ky − 1.
fn box_inside([x0, x1, y0, y1]: [f32; 4], kx: f32, ky: f32) -> bool {
    // The farthest corner, in f64; the margin covers the points' own rounding (NaN: false).
    let d = |p: f32, k: f32| (p as f64 * k as f64 - 1.0).abs();
    let (a, b) = (d(x0, kx).max(d(x1, kx)), d(y0, ky).max(d(y1, ky)));
    a * a + b * b < 1.0 - 1e-4
}

/// Passes 1 and 2 for `pts`; `F`: compiled for FMA (see [`mad`]).
#[inline(always)]
fn stages<const C: usize, const F: bool>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    pts: Points,
    sc: &mut Scratch,
) {
    // Every slice cut to w here: with their lengths known, the loops below need no bounds
    // checks, and the compiler leaves no last vector's worth of lanes to a scalar loop.
    let w = sc.live;
    let [dx, dy, dz] = &mut sc.d;
    let (dx, dy, dz) = (&mut dx[..w], &mut dy[..w], &mut dz[..w]);
    let on = &mut sc.on[..w];
    let y = match pts {
        Points::Row(y) => y,
        Points::At(_) => usize::MAX,
    };
    match d.m {
        Mapping::Sphere(p) if matches!(pts, Points::At(_)) => {
            // The same formulas as below, with a and b per point.
            let flip = matches!(p.rows, RowOrder::TopIsT1);
            let (kx, ky) = (2.0 / d.wf, 2.0 / d.hf);
            let m = &plan.sphere_m;
            let [ptx, pty] = &sc.pts;
            let (ptx, pty) = (&ptx[..w], &pty[..w]);
            let out = [&mut *dx, &mut *dy, &mut *dz];
            // Most chunks of points lie well inside the disc: their box says so, and they
            // skip the gutter's formulas (a square root and a division per point).
            if matches!(pts, Points::At(Some(b)) if box_inside(b, kx, ky)) {
                sphere_at::<F, true>(m, [kx, ky], flip, [ptx, pty], out, on);
            } else {
                sphere_at::<F, false>(m, [kx, ky], flip, [ptx, pty], out, on);
            }
        }
        _ if matches!(pts, Points::At(_)) => {
            let [ptx, pty] = &sc.pts;
            let (ptx, pty) = (&ptx[..w], &pty[..w]);
            for x in 0..w {
                let (r, o) = d.dir(ptx[x], pty[x]);
                dx[x] = r[0];
                dy[x] = r[1];
                dz[x] = r[2];
                on[x] = o;
            }
        }
        Mapping::Sphere(p) => {
            let yf = (2.0 * (y as f64 + 0.5) / d.hf as f64 - 1.0) as f32;
            let b = match p.rows {
                RowOrder::TopIsT1 => -yf,
                RowOrder::TopIsT0 => yf,
            };
            // The canvas's width, not the lanes': a row folded in half computes half.
            let (k0, k1) = (2.0 / d.wf, 1.0 / d.wf - 1.0);
            let m = &plan.sphere_m;
            for x in 0..w {
                // Through i32 (canvases are narrower than 2³¹): AVX2 has no vector
                // conversion from 64-bit integers, and `x as f32` went lane by lane.
                let a = x as i32 as f32 * k0 + k1;
                let (r, inside) = sphere_dir::<F, false>(m, a, b);
                dx[x] = r[0];
                dy[x] = r[1];
                dz[x] = r[2];
                on[x] = inside;
            }
        }
        Mapping::LatLong(_) => {
            let theta = (y as f64 + 0.5) / d.hf as f64 * std::f64::consts::PI;
            let (st, ct) = (theta.sin() as f32, theta.cos() as f32);
            let m = &plan.sphere_m;
            let (cos_phi, sin_phi) = (&plan.cos_phi[..w], &plan.sin_phi[..w]);
            for x in 0..w {
                let r = apply::<F>(m, [st * cos_phi[x], ct, st * sin_phi[x]]);
                dx[x] = r[0];
                dy[x] = r[1];
                dz[x] = r[2];
                on[x] = true;
            }
        }
        _ => {
            let py = y as f32 + 0.5;
            for x in 0..w {
                let (r, o) = d.dir(x as f32 + 0.5, py);
                dx[x] = r[0];
                dy[x] = r[1];
                dz[x] = r[2];
                on[x] = o;
            }
        }
    }
    let [px, py] = &mut sc.p;
    let (px, py) = (&mut px[..w], &mut py[..w]);
    let (dx, dy, dz) = (&dx[..w], &dy[..w], &dz[..w]);
    let (wf, hf) = (s.wf, s.hf);
    match s.m {
        Mapping::LatLong(p) => {
            let u0 = p.u_plus_x as f32;
            let i2pi = 1.0 / std::f32::consts::TAU;
            // The row is θ/π · h: one product, θ · (h/π).
            let h_pi = hf * (1.0 / std::f32::consts::PI);
            for x in 0..w {
                let (a, b, c) = (dx[x], dy[x], dz[x]);
                let u = mad::<F>(atan2_poly::<F>(c, a), i2pi, u0);
                // (F: compiled for FMA, so for AVX2 too.)
                let u = u - floor_v::<F>(u);
                // θ = atan2(√(a² + c²), b): its first argument is ≥ 0.
                let theta = atan2_upper::<F>(mad::<F>(a, a, c * c).sqrt(), b);
                px[x] = u * wf;
                py[x] = theta * h_pi;
            }
        }
        Mapping::Cube(_) => {
            let m = &plan.src_frame;
            let f = wf;
            for x in 0..w {
                let [a, b, c] = apply::<F>(m, [dx[x], dy[x], dz[x]]);
                let (ax, ay, az) = (a.abs(), b.abs(), c.abs());
                let is_x = ax >= ay && ax >= az;
                let is_y = !is_x && ay >= az;
                // The GL face table (crate::mappings::cube), branch-free.
                let ma = if is_x {
                    a
                } else if is_y {
                    b
                } else {
                    c
                };
                let sgn = if ma < 0.0 { -1.0 } else { 1.0 };
                let scv = if is_x {
                    -c * sgn
                } else if is_y {
                    a
                } else {
                    a * sgn
                };
                let tcv = if is_x {
                    -b
                } else if is_y {
                    c * sgn
                } else {
                    -b
                };
                let axis = if is_x {
                    0.0
                } else if is_y {
                    2.0
                } else {
                    4.0
                };
                let face = axis + if ma < 0.0 { 1.0 } else { 0.0 };
                let inv = 1.0 / ma.abs();
                let ss = mad::<F>(scv, inv, 1.0) * 0.5;
                let tt = vmin(mad::<F>(tcv, inv, 1.0) * 0.5, 1.0 - 1.0 / 4096.0);
                px[x] = ss * f;
                py[x] = (face + tt) * f;
            }
        }
        Mapping::Sphere(p) => {
            let m = &plan.src_frame;
            let flip = matches!(p.rows, RowOrder::TopIsT1);
            for x in 0..w {
                let [a, b, c] = apply::<F>(m, [dx[x], dy[x], dz[x]]);
                let il = 1.0 / mad::<F>(a, a, mad::<F>(b, b, c * c)).sqrt();
                let (a, b, c) = (a * il, b * il, c * il);
                let q = mad::<F>(a, a, b * b);
                // 1 + z without cancellation (crate::mappings::sphere::dir_to_st).
                let zp1 = if c >= 0.0 { 1.0 + c } else { q / (1.0 - c) };
                let h2 = mad::<F>(zp1, zp1, q);
                let k = 0.5 / h2.sqrt();
                let (ss, tt) = if h2 > 0.0 {
                    (a * k + 0.5, b * k + 0.5)
                } else {
                    (1.0, 0.5) // straight ahead: the rim
                };
                let v = if flip { 1.0 - tt } else { tt };
                px[x] = ss * wf;
                py[x] = v * hf;
            }
        }
        _ => {
            for x in 0..w {
                let q = s.position([dx[x], dy[x], dz[x]]);
                px[x] = q[0];
                py[x] = q[1];
            }
        }
    }
}

/// Pass 2b: for each position, the index of its top-left tap and the bilinear fractions
/// when all four taps are plain texels of one tile (no wrap, not near a disc's rim, not
/// across a cube seam) — the common case of `Src::lookup` — else `SLOW`.
#[inline(always)]
fn taps<const C: usize>(s: &Src<f32>, sc: &mut Scratch) {
    // Level 0 only (pyramid levels go through `taps_level`): all rows are held.
    debug_assert!(s.rowmap.is_empty());
    // Indices are u32: a source too large for them takes the general path throughout.
    if s.data.len() >= SLOW as usize {
        sc.idx.fill(SLOW);
        return;
    }
    let c = s.hf * 0.5;
    let face = s.wf;
    let r2 = s.safe_r2;
    match s.m {
        Mapping::LatLong(_) | Mapping::Octahedral => taps_with::<C>(s, sc, |_, _, _| true),
        // Both tap rows on the face the position belongs to.
        Mapping::Cube(_) => taps_with::<C>(s, sc, |_, p1, fy| {
            let f0 = (p1 / face).floor() * face;
            fy >= f0 && fy + 1.0 < f0 + face
        }),
        Mapping::Sphere(_) | Mapping::Angular => taps_with::<C>(s, sc, |p0, p1, _| {
            let (dx, dy) = (p0 - c, p1 - c);
            dx * dx + dy * dy <= r2
        }),
        Mapping::Paraboloid => sc.idx.fill(SLOW),
    }
}

/// Where pass 2b writes: tap indices and bilinear fractions.
pub(crate) struct Taps<'a> {
    pub(crate) idx: &'a mut [u32],
    pub(crate) ax: &'a mut [f32],
    pub(crate) ay: &'a mut [f32],
}

/// Pass 2b's loop; `tile_ok(px, py, floor(py − ½))` is the mapping's own condition.
/// (`floor` here is one instruction: the callers are compiled for AVX2.)
#[inline(always)]
fn taps_with<const C: usize>(
    s: &Src<f32>,
    sc: &mut Scratch,
    tile_ok: impl Fn(f32, f32, f32) -> bool,
) {
    let n = sc.live;
    let [px, py] = &sc.p;
    let [ax, ay] = &mut sc.frac;
    let (px, py, ax, ay) = (&px[..n], &py[..n], &mut ax[..n], &mut ay[..n]);
    let idx = &mut sc.idx[..n];
    let (wf, hf) = (s.wf, s.hf);
    let row = (s.w * C) as u32;
    for x in 0..n {
        let (p0, p1) = (px[x], py[x]);
        let (qx, qy) = (p0 - 0.5, p1 - 0.5);
        let (fx, fy) = (qx.floor(), qy.floor());
        // Written as `!(in range)` so that NaN positions fail too.
        let ok = tile_ok(p0, p1, fy) && fx >= 0.0 && fy >= 0.0 && fx + 1.0 < wf && fy + 1.0 < hf;
        // SAFETY: clamped into 0..=w and 0..=h first (NaN becomes 0), so the conversions
        // are in range; plain `as` would add a saturating fix-up that stops vectorization.
        let (xi, yi) = unsafe {
            (
                vmin(vmax(fx, 0.0), wf).to_int_unchecked::<i32>() as u32,
                vmin(vmax(fy, 0.0), hf).to_int_unchecked::<i32>() as u32,
            )
        };
        idx[x] = if ok { yi * row + xi * C as u32 } else { SLOW };
        ax[x] = qx - fx;
        ay[x] = qy - fy;
    }
}

/// Per-level constants of pass 2b, indexed by level (so one pass serves lanes at any level).
pub(crate) struct LevelTab {
    scale: [f32; 32],
    wf: [f32; 32],
    hf: [f32; 32],
    r2: [f32; 32],
    row: [u32; 32],
    /// Level k's canvas row y at `pair[off[k] + y]`: where it lies in the level's data when
    /// rows y and y + 1 are both held (so a lookup's two tap rows are consecutive there),
    /// else `SLOW`.  One table for all levels, sliced by `off`.
    off: [u32; 32],
    pair: Vec<u32>,
    /// The tap indices fit u32 at every level.
    ok: bool,
    /// Level k holds all its rows in order (`pair` is the identity there): pass 2b needs no
    /// table, and vectorizes (the compiler will not vectorize the table's gather).
    full: [bool; 32],
}

impl LevelTab {
    pub(crate) fn new<const C: usize>(levels: &[Src<f32>]) -> Self {
        let mut t = LevelTab {
            scale: [0.0; 32],
            wf: [0.0; 32],
            hf: [0.0; 32],
            r2: [0.0; 32],
            row: [0; 32],
            off: [0; 32],
            pair: vec![],
            ok: levels.iter().all(|l| l.data.len() < SLOW as usize),
            full: [false; 32],
        };
        for (k, l) in levels.iter().enumerate().take(32) {
            t.scale[k] = 1.0 / (1u64 << k) as f32;
            t.wf[k] = l.wf;
            t.hf[k] = l.hf;
            t.r2[k] = l.safe_r2;
            t.row[k] = (l.w * C) as u32;
            t.off[k] = t.pair.len() as u32;
            t.full[k] = (0..l.h.saturating_sub(1)).all(|y| l.held_pair(y) == Some(y));
            // h + 1 entries: pass 2b clamps a row into 0..=h before reading.
            for y in 0..=l.h {
                let r = if y + 1 < l.h {
                    l.held_pair(y).map_or(SLOW, |r| r as u32)
                } else {
                    SLOW
                };
                t.pair.push(r);
            }
        }
        t.ok &= t.pair.len() < SLOW as usize;
        t
    }
}

/// Pass 2b at level `k` for the level-0 positions `p[range]`: the index into that level's
/// data (or `SLOW`), and the fractions, into `out[range]`.
#[inline(always)]
pub(crate) fn taps_level<const C: usize>(
    m: Mapping,
    t: &LevelTab,
    k: usize,
    p: &[Lanes<f32>; 2],
    range: std::ops::Range<usize>,
    out: Taps,
) {
    let Taps { idx, ax, ay } = out;
    let (idx, ax, ay) = (
        &mut idx[range.clone()],
        &mut ax[range.clone()],
        &mut ay[range.clone()],
    );
    let (px, py) = (&p[0][range.clone()], &p[1][range]);
    let (cube, disc) = match m {
        Mapping::Cube(_) => (true, false),
        Mapping::Sphere(_) | Mapping::Angular => (false, true),
        Mapping::Paraboloid => {
            idx.fill(SLOW);
            return;
        }
        _ => (false, false),
    };
    let k = k.min(31);
    let (wf, hf, sc, r2, row) = (t.wf[k], t.hf[k], t.scale[k], t.r2[k], t.row[k]);
    let pair = &t.pair[t.off[k] as usize..];
    // The table holds h + 1 entries from `off[k]` (checked once here, not per lane).
    let pair = &pair[..=(hf as usize).min(pair.len() - 1)];
    let n = idx
        .len()
        .min(ax.len())
        .min(ay.len())
        .min(px.len())
        .min(py.len());
    let lv = LevelConsts {
        wf,
        hf,
        sc,
        r2,
        row,
        ok: t.ok,
        cube,
        disc,
    };
    let out = Taps { idx, ax, ay };
    // A full level's rows are where they are, with no table: that loop vectorizes (the
    // compiler will not vectorize the table's gather).
    if t.full[k] {
        taps_loop::<C, true>(&lv, pair, px, py, n, out)
    } else {
        taps_loop::<C, false>(&lv, pair, px, py, n, out)
    }
}

/// A level's constants in [`taps_level`].
struct LevelConsts {
    wf: f32,
    hf: f32,
    sc: f32,
    r2: f32,
    row: u32,
    ok: bool,
    /// The mapping's own test of a tap pair: cube (both rows on one face), disc (inside).
    cube: bool,
    disc: bool,
}

/// [`taps_level`]'s loop over `n` lanes, for a level that holds all its rows in order or
/// not (`FULL`).
#[inline(always)]
fn taps_loop<const C: usize, const FULL: bool>(
    lv: &LevelConsts,
    pair: &[u32],
    px: &[f32],
    py: &[f32],
    n: usize,
    out: Taps,
) {
    let LevelConsts {
        wf,
        hf,
        sc,
        r2,
        row,
        ok: all_ok,
        cube,
        disc,
    } = *lv;
    let Taps { idx, ax, ay } = out;
    let (idx, ax, ay, px, py) = (
        &mut idx[..n],
        &mut ax[..n],
        &mut ay[..n],
        &px[..n],
        &py[..n],
    );
    let last = pair.len() - 1;
    for x in 0..n {
        let (p0, p1) = (px[x] * sc, py[x] * sc);
        let (qx, qy) = (p0 - 0.5, p1 - 0.5);
        let (fx, fy) = (qx.floor(), qy.floor());
        let tile = if cube {
            let f0 = (p1 / wf).floor() * wf;
            fy >= f0 && fy + 1.0 < f0 + wf
        } else if disc {
            let c = hf * 0.5;
            let (dx, dy) = (p0 - c, p1 - c);
            dx * dx + dy * dy <= r2
        } else {
            true
        };
        let ok = all_ok & tile & (fx >= 0.0) & (fy >= 0.0) & (fx + 1.0 < wf) & (fy + 1.0 < hf);
        // SAFETY: clamped first (NaN becomes 0), so the conversions are in range.
        let (xi, yi) = unsafe {
            (
                vmin(vmax(fx, 0.0), wf).to_int_unchecked::<i32>() as u32,
                vmin(vmax(fy, 0.0), hf).to_int_unchecked::<i32>() as u32,
            )
        };
        // (`ok` has checked yi + 1 < h.)
        let r = if FULL {
            yi
        } else {
            pair[(yi as usize).min(last)]
        };
        idx[x] = if ok && r != SLOW {
            r * row + xi * C as u32
        } else {
            SLOW
        };
        ax[x] = qx - fx;
        ay[x] = qy - fy;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn stages_avx2<const C: usize, const TAPS: bool>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    pts: Points,
    sc: &mut Scratch,
) {
    stages::<C, true>(s, d, plan, pts, sc);
    if TAPS {
        taps::<C>(s, sc)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
unsafe fn stages_avx512<const C: usize, const TAPS: bool>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    pts: Points,
    sc: &mut Scratch,
) {
    stages::<C, true>(s, d, plan, pts, sc);
    if TAPS {
        taps::<C>(s, sc)
    }
}

/// Passes 1–2, and 2b when `TAPS`, for `pts`, with the widest vectors this CPU has.
fn passes_with<const C: usize, const TAPS: bool>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    pts: Points,
    sc: &mut Scratch,
) {
    #[cfg(target_arch = "x86_64")]
    match simd() {
        // SAFETY: the features were detected at run time.
        Simd::Avx512 => unsafe { stages_avx512::<C, TAPS>(s, d, plan, pts, sc) },
        // SAFETY: the features were detected at run time.
        Simd::Avx2 => unsafe { stages_avx2::<C, TAPS>(s, d, plan, pts, sc) },
        Simd::Portable => {
            stages::<C, false>(s, d, plan, pts, sc);
            if TAPS {
                taps::<C>(s, sc);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        stages::<C, false>(s, d, plan, pts, sc);
        if TAPS {
            taps::<C>(s, sc);
        }
    }
}

/// Passes 1–2 and 2b for `pts`: directions, source positions, level-0 taps.
pub(crate) fn passes<const C: usize>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    pts: Points,
    sc: &mut Scratch,
) {
    passes_with::<C, true>(s, d, plan, pts, sc)
}

/// Passes 1–2 only (directions and source positions), for points that are not looked up.
pub(crate) fn positions<const C: usize>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    pts: Points,
    sc: &mut Scratch,
) {
    passes_with::<C, false>(s, d, plan, pts, sc)
}

/// How far ahead (in texels) pass 3 prefetches the source lines: the gathers wait on the
/// last-level cache otherwise (their addresses are known a whole row in advance).
pub(crate) const AHEAD: usize = 64;

/// Prefetches the four taps of the lookup whose top-left index is `j` (`SLOW`: nothing).
#[inline(always)]
pub(crate) fn prefetch<const C: usize>(data: &[f32], row: usize, j: u32) {
    #[cfg(target_arch = "x86_64")]
    if j != SLOW {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = data.as_ptr().wrapping_add(j as usize);
        // SAFETY: prefetching is a hint; it never faults, whatever the address.
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>(p as *const i8);
            _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(row) as *const i8);
            // The taps' last values (on the next line 2C/16 of the time).
            _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(2 * C - 1) as *const i8);
            _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(row + 2 * C - 1) as *const i8);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (data, row, j);
}

/// The bilinear value at top-left index `i00` (not `SLOW`) with fractions (ax, ay).
#[inline(always)]
pub(crate) fn bilerp<const C: usize>(
    data: &[f32],
    row: usize,
    i00: u32,
    ax: f32,
    ay: f32,
) -> [f32; C] {
    let i00 = i00 as usize;
    let i01 = i00 + row;
    debug_assert!(i01 + 2 * C <= data.len());
    let mut out = [0.0f32; C];
    for k in 0..C {
        // SAFETY: pass 2b gave an index only where 0 ≤ x0 < w − 1 and 0 ≤ y0 < h − 1,
        // which keeps all four taps in the w×h×C slice.
        let (a, b, c, d) = unsafe {
            (
                *data.get_unchecked(i00 + k),
                *data.get_unchecked(i00 + C + k),
                *data.get_unchecked(i01 + k),
                *data.get_unchecked(i01 + C + k),
            )
        };
        let top = a + ax * (b - a);
        let bot = c + ax * (d - c);
        out[k] = top + ay * (bot - top);
    }
    out
}

/// One lookup at each texel centre of row `y`, into `out`, and with `mirror` (when
/// `plan.fold[1]` is some), of row h − 1 − y into `mirror`.  Where `plan.fold[0]` is some,
/// only the left half of the row goes through the passes (see [`Fold`]).
pub(crate) fn row<const C: usize>(
    s: &Src<f32>,
    d: &Dst<f32>,
    plan: &Plan,
    y: usize,
    sc: &mut Scratch,
    out: &mut [std::mem::MaybeUninit<f32>],
    mirror: Option<&mut [std::mem::MaybeUninit<f32>]>,
) {
    let w = out.len() / C;
    sc.set_live(w);
    match plan.fold[0] {
        Some(f) => {
            sc.set_live(w.div_ceil(2));
            positions::<C>(s, d, plan, Points::Row(y), sc);
            sc.set_live(w);
            vectorized(
                #[inline(always)]
                || {
                    fold_cols(f, sc);
                    taps::<C>(s, sc)
                },
            );
        }
        None => passes::<C>(s, d, plan, Points::Row(y), sc),
    }
    lookups::<C>(s, d, sc, out);
    if let Some(m) = mirror {
        match plan.fold[1] {
            Some(f) => vectorized(
                #[inline(always)]
                || {
                    fold_all(f, sc);
                    taps::<C>(s, sc)
                },
            ),
            // (Not asked for by the callers; computed, so the row is right all the same.)
            None => passes::<C>(s, d, plan, Points::Row(d.hf as usize - 1 - y), sc),
        }
        lookups::<C>(s, d, sc, m);
    }
}

/// Lanes ⌈w/2⌉.. from lanes ..⌊w/2⌋, reversed and folded by `f` (the row's right half
/// from its left half; `w` is `sc.live`).
#[inline(always)]
fn fold_cols(f: Fold, sc: &mut Scratch) {
    let w = sc.live;
    let (l, r) = (w.div_ceil(2), w / 2);
    let on = &mut sc.on[..w];
    let (on_l, on_r) = on.split_at_mut(l);
    on_r.iter_mut()
        .zip(on_l[..r].iter().rev())
        .for_each(|(a, b)| *a = *b);
    for (axis, p) in sc.p.iter_mut().enumerate() {
        let (pl, pr) = p[..w].split_at_mut(l);
        let src = pl[..r].iter().rev().copied();
        if axis == f.axis {
            f.apply(pr.iter_mut(), src);
        } else {
            pr.iter_mut().zip(src).for_each(|(a, b)| *a = b);
        }
    }
}

/// Every live lane's position folded by `f` in place (row y's into row h − 1 − y's).  (The
/// loops of [`Fold::apply`], reading and writing one slice: through `apply` with a copy to
/// read from, J4 took 12 M instructions more.)
#[inline(always)]
fn fold_all(f: Fold, sc: &mut Scratch) {
    let w = sc.live;
    let (k, period) = (f.k, f.period);
    let p = &mut sc.p[f.axis][..w];
    if period > 0.0 {
        let inv = 1.0 / period;
        p.iter_mut().for_each(|a| {
            let v = k - *a;
            *a = v - crate::base::real::floor_fast(v * inv) * period;
        });
    } else {
        p.iter_mut().for_each(|a| *a = k - *a);
    }
}

/// The live lanes' positions folded by `f` in place (the filtered path's images of a chunk).
pub(crate) fn fold_lanes(f: &Fold, sc: &mut Scratch) {
    vectorized(
        #[inline(always)]
        || fold_all(*f, sc),
    )
}

/// Pass 2b alone, at level 0, for the live lanes' positions (after [`fold_lanes`]).
pub(crate) fn retap<const C: usize>(s: &Src<f32>, sc: &mut Scratch) {
    vectorized(
        #[inline(always)]
        || taps::<C>(s, sc),
    )
}

/// Pass 3 of a row: the lookups of its pass-2b results in `sc` into `out`.
fn lookups<const C: usize>(
    s: &Src<f32>,
    d: &Dst<f32>,
    sc: &Scratch,
    out: &mut [std::mem::MaybeUninit<f32>],
) {
    let black = d.outside == Outside::Black;
    let data = s.data;
    let row = s.w * C;
    let w = out.len() / C;
    let out = &mut out[..w * C];
    let t = RowTexels::new::<C>(s, black, sc, w);
    // The loop prefetches AHEAD texels ahead, so the first AHEAD texels' lines are asked
    // for here, all at once, rather than waited for one by one (the source rarely fits
    // the caches: 24 MB for a 2048×1024 RGB lat-long).
    for &j in &t.idx[..AHEAD.min(w)] {
        prefetch::<C>(data, row, j);
    }
    #[cfg(target_arch = "x86_64")]
    if !black && (C == 3 || C == 4) && simd() != Simd::Portable {
        if let Some(l) = t.lim {
            // SAFETY: AVX2 was detected at run time (simd()); C is 3 or 4.
            unsafe { pairs_avx2::<C>(&t, l, out) };
            return;
        }
    }
    t.one_by_one::<C>(out);
}

/// [`row`]'s lookups two texels at a time in 8-lane vectors (the two texels' 4-lane
/// [`bilerp4`]s side by side: the same arithmetic, so the same bits), for C = 3 or 4 and
/// no black outside; `lim` is [`vec4_limit`].  A pair either of whose lookups is not plain
/// goes one texel at a time.  (Prefetching once per pair, the first texel's lines and
/// one texel more, made J2 slower: where the row runs down a cube face's columns, the
/// second texel's taps are on other lines.)
///
/// # Safety
/// The CPU has AVX2; C is 3 or 4.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn pairs_avx2<const C: usize>(
    t: &RowTexels,
    lim: u32,
    out: &mut [std::mem::MaybeUninit<f32>],
) {
    use std::arch::x86_64::*;
    let (data, row) = (t.s.data, t.s.w * C);
    let w = t.idx.len();
    let (idx, fx, fy) = (t.idx, t.fx, t.fy);
    // The two texels' values packed together ([v₀ v₁ v₂ v₀' v₁' v₂' · ·] for RGB).
    let pack3 = _mm256_setr_epi32(0, 1, 2, 4, 5, 6, 7, 7);
    let spread = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
    let mut x = 0;
    // A pair's 8-value store ends at 2C + (8 − 2C) values past its first: for C = 3 the
    // last pair of the row goes one texel at a time.
    let pairs_end = if C == 3 { w.saturating_sub(1) } else { w };
    while x + 2 <= pairs_end {
        if let Some(&j) = idx.get(x + AHEAD + 1) {
            prefetch::<C>(data, row, idx[x + AHEAD]);
            prefetch::<C>(data, row, j);
        }
        let (i0, i1) = (*idx.get_unchecked(x), *idx.get_unchecked(x + 1));
        if i0 <= lim && i1 <= lim {
            // SAFETY (the reads): both indices are within `lim`, so each 4-value read ends
            // inside the data (vec4_limit).
            let (q0, q1) = (
                data.as_ptr().add(i0 as usize),
                data.as_ptr().add(i1 as usize),
            );
            let ld = |o: usize| _mm256_loadu2_m128(q1.add(o), q0.add(o));
            let (a, b) = (ld(0), ld(C));
            let (cc, d) = (ld(row), ld(row + C));
            // [ax₀ ×4, ax₁ ×4] from the two consecutive fractions.
            let two = |f: &[f32]| {
                let v = _mm_castsi128_ps(_mm_loadl_epi64(f.as_ptr().add(x) as *const __m128i));
                _mm256_permutevar8x32_ps(_mm256_castps128_ps256(v), spread)
            };
            let (vx, vy) = (two(fx), two(fy));
            let top = _mm256_add_ps(a, _mm256_mul_ps(vx, _mm256_sub_ps(b, a)));
            let bot = _mm256_add_ps(cc, _mm256_mul_ps(vx, _mm256_sub_ps(d, cc)));
            let v = _mm256_add_ps(top, _mm256_mul_ps(vy, _mm256_sub_ps(bot, top)));
            let v = if C == 3 {
                _mm256_permutevar8x32_ps(v, pack3)
            } else {
                v
            };
            // SAFETY: x·C + 8 ≤ out.len(): x + 2 ≤ w for C = 4, x + 3 ≤ w for C = 3.
            // For C = 3 the last two values are the next texel's first, which it writes
            // next.
            _mm256_storeu_ps(out.as_mut_ptr().add(x * C) as *mut f32, v);
        } else {
            t.texel::<C>(x, out);
            t.texel::<C>(x + 1, out);
        }
        x += 2;
    }
    while x < w {
        t.texel::<C>(x, out);
        x += 1;
    }
}

/// A row's pass-2b results, for [`row`]'s lookups.
struct RowTexels<'a, 'b> {
    s: &'a Src<'b, f32>,
    black: bool,
    /// [`vec4_limit`].
    lim: Option<u32>,
    idx: &'a [u32],
    on: &'a [bool],
    fx: &'a [f32],
    fy: &'a [f32],
    p0: &'a [f32],
    p1: &'a [f32],
}

impl<'a, 'b> RowTexels<'a, 'b> {
    /// The first `w` lanes of pass 2b's results in `sc`, for a row with `black` outside.
    /// Every slice is cut to the row, so the loops carry no bounds checks.
    fn new<const C: usize>(s: &'a Src<'b, f32>, black: bool, sc: &'a Scratch, w: usize) -> Self {
        RowTexels {
            s,
            black,
            lim: vec4_limit::<C>(s.data.len(), s.w * C),
            idx: &sc.idx[..w],
            on: &sc.on[..w],
            fx: &sc.frac[0][..w],
            fy: &sc.frac[1][..w],
            p0: &sc.p[0][..w],
            p1: &sc.p[1][..w],
        }
    }

    /// Every texel's lookup into `out` (the row), one at a time.
    fn one_by_one<const C: usize>(&self, out: &mut [std::mem::MaybeUninit<f32>]) {
        let (data, row, w) = (self.s.data, self.s.w * C, self.idx.len());
        let ahead = w.saturating_sub(AHEAD);
        for x in 0..ahead {
            prefetch::<C>(data, row, self.idx[x + AHEAD]);
            self.texel::<C>(x, out);
        }
        for x in ahead..w {
            self.texel::<C>(x, out);
        }
    }

    /// Texel x's lookup into `out` (the row).
    #[inline(always)]
    fn texel<const C: usize>(&self, x: usize, out: &mut [std::mem::MaybeUninit<f32>]) {
        if self.black && !self.on[x] {
            out[x * C..x * C + C].iter_mut().for_each(|v| {
                v.write(0.0);
            });
            return;
        }
        let (data, row) = (self.s.data, self.s.w * C);
        let i00 = self.idx[x];
        if self.lim.is_some_and(|l| i00 <= l) {
            // 4-lane vectors (bit for bit `bilerp`'s arithmetic).
            let v = bilerp4::<C>(data, row, i00 as usize, self.fx[x], self.fy[x]);
            if x * C + 4 <= out.len() {
                // One 4-value store; for C = 3 its last value is the next texel's first,
                // which that texel writes next.
                // SAFETY: x·C + 4 ≤ out.len() (just checked); f32 and MaybeUninit<f32>
                // share their layout.
                unsafe { (out.as_mut_ptr().add(x * C) as *mut [f32; 4]).write_unaligned(v) };
            } else {
                for k in 0..C {
                    out[x * C + k].write(v[k]);
                }
            }
            return;
        }
        let v = if i00 == SLOW {
            let mut acc = [0.0f32; C];
            self.s.lookup([self.p0[x], self.p1[x]], 1.0, &mut acc);
            acc
        } else {
            bilerp::<C>(data, row, i00, self.fx[x], self.fy[x])
        };
        for k in 0..C {
            out[x * C + k].write(v[k]);
        }
    }
}

/// The largest top-left index whose [`bilerp4`] reads (`i00 + row + C + 4` values) stay
/// inside `len` values; `None` for C ∉ {3, 4} or when no index qualifies.
#[inline]
pub(crate) fn vec4_limit<const C: usize>(len: usize, row: usize) -> Option<u32> {
    if C != 3 && C != 4 {
        return None;
    }
    len.checked_sub(row + C + 4)
        .map(|l| l.min(SLOW as usize - 1) as u32)
}

/// [`bilerp`] for C = 3 or 4 on 4-lane vectors (same arithmetic, so the same bits; for
/// C = 3 the fourth lane is the next texel's first value, unused); needs
/// `i00 + row + C + 4 ≤ data.len()`.
#[inline(always)]
pub(crate) fn bilerp4<const C: usize>(
    data: &[f32],
    row: usize,
    i00: usize,
    ax: f32,
    ay: f32,
) -> [f32; 4] {
    assert!(C == 3 || C == 4);
    debug_assert!(i00 + row + C + 4 <= data.len());
    #[cfg(target_arch = "x86_64")]
    {
        // Written with SSE (x86-64's baseline): left to itself, the compiler splits the
        // vectors into pairs and singles here.
        use std::arch::x86_64::*;
        // SAFETY: the caller checked that the four 4-value reads are inside `data`.
        unsafe {
            let p = data.as_ptr().add(i00);
            let (a, b) = (_mm_loadu_ps(p), _mm_loadu_ps(p.add(C)));
            let (c, d) = (_mm_loadu_ps(p.add(row)), _mm_loadu_ps(p.add(row + C)));
            let (vx, vy) = (_mm_set1_ps(ax), _mm_set1_ps(ay));
            let top = _mm_add_ps(a, _mm_mul_ps(vx, _mm_sub_ps(b, a)));
            let bot = _mm_add_ps(c, _mm_mul_ps(vx, _mm_sub_ps(d, c)));
            let v = _mm_add_ps(top, _mm_mul_ps(vy, _mm_sub_ps(bot, top)));
            std::mem::transmute::<__m128, [f32; 4]>(v)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        // SAFETY: the caller checked that the four 4-value reads are inside `data`.
        let ld = |i: usize| unsafe { (data.as_ptr().add(i) as *const [f32; 4]).read_unaligned() };
        let (a, b, c, d) = (ld(i00), ld(i00 + C), ld(i00 + row), ld(i00 + row + C));
        std::array::from_fn(|k| {
            let top = a[k] + ax * (b[k] - a[k]);
            let bot = c[k] + ax * (d[k] - c[k]);
            top + ay * (bot - top)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::images::Image;
    use crate::resample::env::EnvMap;

    /// The AVX2 pairs give the one-by-one lookups' values bit for bit, whatever mix of
    /// plain and general (`SLOW`) lookups a row holds, for 3 and 4 channels, odd and even
    /// widths (the one-by-one loop is what CPUs without AVX2 run).
    #[test]
    fn pairs_give_the_one_by_one_values() {
        if simd() == Simd::Portable {
            return;
        }
        fn check<const C: usize>(n: usize) {
            let ll = Mapping::parse("latlong", None).unwrap();
            let mut img = Image::new(64, 32, C);
            for (i, v) in img.data.iter_mut().enumerate() {
                *v = ((i * 7919) % 1013) as f32 / 1013.0;
            }
            let e = EnvMap::new(ll, &img, "t").unwrap();
            let s = Src::<f32>::new(&e);
            let sp = Mapping::parse("sphere", None).unwrap();
            let d = Dst::<f32>::new(sp, n, n, &IDENTITY, Outside::Gutter);
            let plan = Plan::new(&s, &d, &IDENTITY, n);
            let mut sc = Scratch::new(n);
            let mut slow = 0;
            for y in 0..n {
                passes::<C>(&s, &d, &plan, Points::Row(y), &mut sc);
                slow += sc.idx.iter().filter(|&&i| i == SLOW).count();
                let t = RowTexels::new::<C>(&s, false, &sc, n);
                let mut a = vec![std::mem::MaybeUninit::new(-1.0f32); n * C];
                let mut b = a.clone();
                t.one_by_one::<C>(&mut a);
                // SAFETY: AVX2 is there (checked above); C is 3 or 4.
                unsafe { pairs_avx2::<C>(&t, t.lim.unwrap(), &mut b) };
                // SAFETY: both rows are fully written (and were initialized before).
                let (a, b) = unsafe {
                    (
                        a.iter()
                            .map(|v| v.assume_init().to_bits())
                            .collect::<Vec<_>>(),
                        b.iter()
                            .map(|v| v.assume_init().to_bits())
                            .collect::<Vec<_>>(),
                    )
                };
                assert_eq!(a, b, "C = {C}, n = {n}, row {y}");
            }
            // The seam of the lat-long (u wraps) sends some lookups the general way.
            assert!(slow > 0);
        }
        for n in [31, 32, 65] {
            check::<3>(n);
            check::<4>(n);
        }
    }

    /// `bilerp4` reads `i00 + row + C + 4` values: the limit keeps every such read inside
    /// the data, and a source too small for any (a 2×2 RGB canvas: 12 values, a read of 13)
    /// gets none, rather than a limit of 0 that would let index 0 read past the end.
    #[test]
    fn vec4_limit_keeps_the_four_lane_reads_inside_the_data() {
        assert_eq!(vec4_limit::<3>(12, 6), None);
        assert_eq!(vec4_limit::<3>(13, 6), Some(0));
        assert_eq!(vec4_limit::<4>(16, 8), Some(0));
        assert_eq!(vec4_limit::<3>(3 * 64 * 32, 3 * 64), Some(3 * 64 * 31 - 7));
        assert_eq!(vec4_limit::<1>(1000, 10), None);
        assert_eq!(vec4_limit::<2>(1000, 10), None);
        let data: Vec<f32> = (0..3 * 8 * 4).map(|v| v as f32 * 0.37).collect();
        let row = 3 * 8;
        let l = vec4_limit::<3>(data.len(), row).unwrap() as usize;
        for i in (0..=l).step_by(3) {
            let v = bilerp4::<3>(&data, row, i, 0.3, 0.7);
            assert_eq!(v[..3], bilerp::<3>(&data, row, i as u32, 0.3, 0.7));
        }
    }

    /// A box well inside the disc takes the shortcut without the gutter's formulas; its
    /// directions and positions are bit for bit those of the general formulas, for every
    /// view and row order (and `box_inside` refuses boxes that reach the rim).
    #[test]
    fn points_inside_the_disc_take_the_same_values_by_the_shortcut() {
        let ll = Mapping::parse("latlong", None).unwrap();
        let img = Image::new(64, 32, 3);
        let e = EnvMap::new(ll, &img, "t").unwrap();
        let s = Src::<f32>::new(&e);
        let n = 96;
        let k = 2.0 / n as f32;
        assert!(box_inside([20.0, 76.0, 40.0, 56.0], k, k));
        assert!(!box_inside([0.0, 96.0, 47.0, 49.0], k, k));
        assert!(!box_inside([48.0, 48.0, 0.0, 1.0], k, k));
        assert!(box_inside([48.0, 48.0, 0.5, 1.0], k, k));
        for preset in [None, Some("skylibs")] {
            let sp = Mapping::parse("sphere", preset).unwrap();
            for rot in [
                IDENTITY,
                crate::frame::view::look_up([1.0, 0.3, 0.0], [0.0, 1.0, 0.0]).unwrap(),
            ] {
                let d = Dst::<f32>::new(sp, n, n, &rot, Outside::Gutter);
                let plan = Plan::new(&s, &d, &rot, n);
                let within = [20.0, 76.0, 40.0, 56.0];
                let m = 500;
                let mut a = Scratch::new(m);
                for i in 0..m {
                    let (u, v) = ((i * 37 % 101) as f32 / 100.0, (i * 53 % 97) as f32 / 96.0);
                    a.pts[0][i] = within[0] + u * (within[1] - within[0]);
                    a.pts[1][i] = within[2] + v * (within[3] - within[2]);
                }
                let mut b = Scratch::new(m);
                b.pts = a.pts.clone();
                passes::<3>(&s, &d, &plan, Points::At(Some(within)), &mut a);
                passes::<3>(&s, &d, &plan, Points::At(None), &mut b);
                assert_eq!(a.d, b.d);
                assert_eq!(a.p, b.p);
                assert_eq!(a.idx, b.idx);
                assert!(a.on.iter().all(|&o| o));
            }
        }
    }

    /// Rows computed through the canvas's mirror symmetries ([`Fold`]: half a row's passes
    /// and half the rows') give the values that the passes give everywhere, to the rounding
    /// of the fold, for each pair of sphere-map and lat-long sources and destinations and
    /// their presets, odd and even canvases, both outsides; a turned view takes no fold.
    #[test]
    fn folded_rows_give_the_values_of_every_rows_passes() {
        fn check<const C: usize>(src: &str, sp: Option<&str>, dst: &str, dp: Option<&str>) {
            let sm = Mapping::parse(src, sp).unwrap();
            let dm = Mapping::parse(dst, dp).unwrap();
            let (sw, sh) = sm.canvas(48);
            // Smooth and periodic along a lat-long's rows, so the seam is no jump; a fold
            // that misses by one destination texel moves a value by ~0.1.
            let mut img = Image::new(sw, sh, C);
            for y in 0..sh {
                for x in 0..sw {
                    let (u, v) = ((x as f32 + 0.5) / sw as f32, (y as f32 + 0.5) / sh as f32);
                    for c in 0..C {
                        let t = std::f32::consts::TAU * u * (c + 1) as f32;
                        img.data[(y * sw + x) * C + c] = t.sin() * (3.0 * v).cos() + 2.0 * v;
                    }
                }
            }
            let e = EnvMap::new(sm, &img, "t").unwrap();
            let s = Src::<f32>::new(&e);
            for (w, h) in [dm.canvas(31), dm.canvas(32), (63, 32)] {
                if matches!(dm, Mapping::Sphere(_)) && w != h {
                    continue;
                }
                for outside in [Outside::Gutter, Outside::Black] {
                    let d = Dst::<f32>::new(dm, w, h, &IDENTITY, outside);
                    let plan = Plan::new(&s, &d, &IDENTITY, w);
                    let what = format!("{src} {sp:?} -> {dst} {dp:?} {w}x{h} {outside:?} C={C}");
                    // A lat-long source folds along any of its axes.  A sphere map does not
                    // along its view axis: the default lat-long's column mirror (2u₀ ∈ ℤ:
                    // blender, pbrt; z → −z) from the default sphere map (z its view axis),
                    // or a row mirror from Blender's mirror ball (whose view axis is world y).
                    let folds = plan.fold.map(|f| f.is_some());
                    let z_cols = matches!(dp, None | Some("blender") | Some("pbrt"));
                    match (src, dst, sp) {
                        ("latlong", ..) => assert_eq!(folds, [true, true], "{what}"),
                        ("sphere", "latlong", None) => assert_eq!(folds, [!z_cols, true]),
                        ("sphere", "sphere", None) => assert_eq!(folds, [true, true]),
                        _ => {}
                    }
                    let turned = crate::frame::view::look_up([0.1, 0.3, -1.0], [0.0, 1.0, 0.0]);
                    let turned = turned.unwrap();
                    let t = Plan::new(&s, &Dst::<f32>::new(dm, w, h, &turned, outside), &turned, w);
                    assert_eq!(t.fold, [None, None], "{what}: turned");
                    let plain = Plan {
                        fold: [None, None],
                        ..Plan::new(&s, &d, &IDENTITY, w)
                    };
                    let mut sc = Scratch::new(w);
                    let nan = std::mem::MaybeUninit::new(f32::NAN);
                    let (mut a, mut b) = (vec![nan; w * h * C], vec![nan; w * h * C]);
                    for (y, r) in a.chunks_mut(w * C).enumerate() {
                        row::<C>(&s, &d, &plain, y, &mut sc, r, None);
                    }
                    let (top, rest) = b.split_at_mut(h / 2 * w * C);
                    let (mid, bottom) = rest.split_at_mut(h % 2 * w * C);
                    let rows = top.chunks_mut(w * C).zip(bottom.chunks_mut(w * C).rev());
                    for (y, (r, m)) in rows.enumerate() {
                        row::<C>(&s, &d, &plan, y, &mut sc, r, Some(m));
                    }
                    if !mid.is_empty() {
                        row::<C>(&s, &d, &plan, h / 2, &mut sc, mid, None);
                    }
                    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                        // SAFETY: initialized (NaN where a row failed to write).
                        let (x, y) = unsafe { (x.assume_init(), y.assume_init()) };
                        let at = (i / C % w, i / C / w);
                        assert!((x - y).abs() <= 2e-5, "{what}: {x} vs {y} at {at:?}");
                    }
                }
            }
        }
        for dp in [None, Some("skylibs"), Some("blender-mirrorball")] {
            for sp in ["blender", "skylibs", "mitsuba", "pbrt"] {
                check::<3>("latlong", Some(sp), "sphere", dp);
            }
            check::<1>("latlong", None, "sphere", dp);
            check::<4>("sphere", dp, "sphere", None);
            check::<3>("sphere", dp, "latlong", None);
        }
        for dp in ["blender", "skylibs", "mitsuba", "pbrt"] {
            check::<3>("sphere", None, "latlong", Some(dp));
            check::<3>("latlong", Some("skylibs"), "latlong", Some(dp));
        }
    }
}
