//! The silhouette of a mirror ball in a perspective photo, to a few hundredths of a pixel: a
//! forward model of the pixels around the rim, fitted to them.
//!
//! ## Why an edge detector is biased there
//!
//! The rim is not where the brightness changes.  A camera ray that grazes the ball is deflected
//! by almost nothing, so just inside the rim the ball shows the environment *just outside* it,
//! dimmed by its reflectance R — and compressed: the ray at angle θ from the ball's axis (seen
//! from the camera; the ball subtends the cone θ < β, sin β = 1/D for a ball D radii away) hits
//! at incidence i with sin i = D sin θ and leaves deflected by π − 2i, **away from the axis and
//! in the same plane through the axis**.  So a point u pixels inside the rim shows what the
//! photo shows at angle θ' = θ + π − 2i outside it, and θ' − β grows as √u: the last pixel inside
//! the rim averages a swath of the outside some 10–15° wide.  With R = 1 the rim has no step at
//! all (the reflection continues the background); with R < 1 the step is that swath's mean times
//! R against the background next to the rim, which is where a threshold or a gradient maximum
//! lands — off the silhouette by a fraction of a pixel that depends on the scene.  And off the
//! image centre the silhouette (a cone) is an ellipse, not a circle.
//!
//! ## The model
//!
//! For a cone (its axis `a` and half-angle β, in the camera frame) every pixel within a few
//! pixels of the silhouette is predicted from the photo itself.  The pixel square, cut into
//! slices parallel to the rim (the rim is straight at that scale), is the sum over the slices
//! outside the cone of the background there (the photo at that angle; within 2 px of the rim,
//! where the photo's pixels mix ball and background, the background is extended as the straight
//! line fitted to the photo 2–4 px out) and over the slices inside it of R × the mean of the
//! background over the swath those depths reflect (a cumulative integral along the line of the
//! same azimuth, sampled uniformly in √depth where the compression is steepest).
//!
//! The reflection of a slice at depth u leaves the photo's frame when its swath does (a ball
//! near the frame's edge, a narrow field of view): deeper than that depth v, the slice shows
//! what the photo does not, and the model gives it the last value seen plus two free terms of
//! the sector it lies in (32 sectors round the rim), κ(√u − √v) + μ(u − v) — the shape of a
//! smooth background compressed as √depth, and its gradient.  R (shared by the whole rim) and
//! each sector's κ and μ enter linearly and are solved for in closed form; the axis (2 degrees
//! of freedom) and β are fitted by Gauss–Newton on the residuals of all pixels in the band,
//! with Huber weights (a highlight, the ball's stand), a line search along each step, and
//! pixels whose line reads a clipped value left out (a clipped sun has no shape to fit).
//!
//! ## Finding the basin, and the confidence
//!
//! The model's residual has a basin only about a pixel wide, so the cone is first moved by
//! scans: the silhouette is shifted in and out in small steps and, in each of 64 sectors round
//! it, the model's residual (with the sector's own reflectance and free terms) is taken at every
//! shift; a sector is *informative* where its residual has a clear minimum (its median over the
//! shifts more than twice the minimum) and the rim model explains the band there at least
//! twice as well as a smooth field does (a quadratic across the rim plus a slope along it:
//! over a featureless wall a cone fits as well anywhere).  The cone's change is fitted to the
//! informative sectors' minima.  Scans run on a half-size copy of the photo (±1 px in ⅛ px
//! steps, and ±8 px in ½ px steps when that finds nothing), then once on the full photo;
//! Gauss–Newton then moves the cone by at most 1 px from there.
//!
//! A last scan round the final cone measures the **confidence**: the informative sectors whose
//! own minimum lies within ½ px of the cone, as a share of the informative sectors (counted as
//! at least 16 of the 64), times the share of the rim they cover (octants holding one, out of
//! 6, at most 1).  A flat sky seen by a perfect mirror confirms little (there is nothing to see
//! there); a circle that is not a ball's rim is confirmed by few sectors, or only on one side.
//! The reflectance is a second check: a circle that is not a ball's rim is often fitted best by
//! a reflectance no chrome ball has (the caller refuses those).

use super::circle::Plane;
use crate::base::vec::{cross, dot, normalize};
use crate::trace::camera::Camera;
use rayon::prelude::*;

/// A fitted silhouette cone.
#[derive(Clone, Copy, Debug)]
pub struct RimFit {
    /// Unit direction of the ball's centre, camera frame (the camera looks down −Z).
    pub axis: [f64; 3],
    /// The cone's half-angle (radians): sin β = 1/D for a ball D radii away.
    pub beta: f64,
    /// The ball's reflectance as the fit sees it (luminance).
    pub reflectance: f64,
    /// RMS of the band pixels' residuals, relative to the band's mean value.
    pub rms: f64,
    /// How much of the rim confirms the cone (module docs), 0 to 1.
    pub confidence: f64,
    /// The formal standard deviation of the fitted cone's position and size, in pixels (the
    /// largest of the three parameters), times 3 for residuals correlated along the rim.  It
    /// measures the noise of the photo, not a biased model: a fit can be off by more.
    pub uncertainty: f64,
    /// Pixels in the band that were fitted.
    pub pixels: usize,
}

/// Outside the rim, the photo's pixels are taken as the background from this distance (px) on:
/// nearer, a pixel (½ px) read bilinearly (1 px more) mixes in the ball.
const T_CLEAN: f64 = 2.0;
/// The straight line that extends the background to the rim is fitted over [T_CLEAN, T_FIT].
const T_FIT: f64 = 4.0;
/// Samples of the cumulative reflected background per azimuth, uniform in √depth.
const N_IN: usize = 96;
/// Slices of a pixel across the rim.
const SLICES: usize = 16;
const SECTORS: usize = 32;
/// How far (px, per parameter) Gauss–Newton may move the cone from where the full-resolution
/// scan put it (within a quarter of a pixel).  Farther, the band fitted round the scanned cone
/// can lose the rim: over a smooth background a cone moved off it fits the smooth pixels alone.
const TRUST: f64 = 1.0;
/// The factor on the formal standard deviation for residuals correlated along the rim.
const CORRELATED: f64 = 3.0;

/// Two unit vectors completing `a` to an orthonormal frame.
fn basis(a: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let t = if a[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = normalize(cross(a, t));
    (e1, cross(a, e1))
}

/// The cone and the frame it is described in.
#[derive(Clone, Copy, Debug)]
struct Cone {
    a: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
    beta: f64,
}

impl Cone {
    fn new(a: [f64; 3], beta: f64) -> Cone {
        let a = normalize(a);
        let (e1, e2) = basis(a);
        Cone { a, e1, e2, beta }
    }
    fn dir(&self, theta: f64, psi: f64) -> [f64; 3] {
        let (s, c) = theta.sin_cos();
        let (sp, cp) = psi.sin_cos();
        [0, 1, 2].map(|i| c * self.a[i] + s * (cp * self.e1[i] + sp * self.e2[i]))
    }
    /// Polar angle and azimuth of a unit direction.
    fn angles(&self, d: [f64; 3]) -> (f64, f64) {
        let theta = dot(d, self.a).clamp(-1.0, 1.0).acos();
        let psi = dot(d, self.e2).atan2(dot(d, self.e1));
        (theta, psi)
    }
}

/// The background along one azimuth: outside the rim by pixel distance, and the cumulative
/// reflected background inside it by depth.
struct Line {
    /// Background at t = k·OUT_STEP px outside the rim.
    out: Vec<f32>,
    /// Depths u_i = depth·(i/N_IN)², the reflected background there and its integral to them.
    depth: f64,
    val: Vec<f64>,
    cum: Vec<f64>,
    /// Depth up to which the reflection is seen on the photo (its swath is in the frame).
    valid: f64,
    /// The line reads a clipped (saturated) pixel: its model cannot be trusted.
    clipped: bool,
}

const OUT_STEP: f64 = 0.25;

impl Line {
    fn outside(&self, t: f64) -> f64 {
        let x = (t / OUT_STEP).clamp(0.0, (self.out.len() - 1) as f64);
        let i = (x as usize).min(self.out.len() - 2);
        let f = x - i as f64;
        self.out[i] as f64 * (1.0 - f) + self.out[i + 1] as f64 * f
    }
    /// The reflected background at depth `u` (within the depth reached).
    fn value(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, self.depth);
        let x = N_IN as f64 * (u / self.depth).sqrt();
        let i = (x as usize).min(N_IN - 1);
        let f = x - i as f64;
        self.val[i] * (1.0 - f) + self.val[i + 1] * f
    }
    /// ∫₀ᵘ (reflected background) du'.
    fn integral(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, self.depth);
        let x = N_IN as f64 * (u / self.depth).sqrt();
        let i = (x as usize).min(N_IN - 1);
        let ui = self.depth * (i as f64 / N_IN as f64).powi(2);
        let uj = self.depth * ((i + 1) as f64 / N_IN as f64).powi(2);
        let f = ((u - ui) / (uj - ui)).clamp(0.0, 1.0);
        self.cum[i] * (1.0 - f) + self.cum[i + 1] * f
    }
}

/// What the fit reads: the photo's luminance, its camera, the clipping level.
pub(super) struct Photo<'a> {
    pub lum: &'a Plane,
    pub camera: &'a Camera,
    /// Values at or above this are clipped (None: nothing is).
    pub clip: Option<f32>,
    /// Pixels of the full-resolution photo per pixel of `lum` (1, or 2 on a half-size copy).
    pub scale: f64,
}

impl Photo<'_> {
    fn inside(&self, p: [f64; 2]) -> bool {
        p[0] >= 0.5
            && p[1] >= 0.5
            && p[0] <= self.lum.w as f64 - 0.5
            && p[1] <= self.lum.h as f64 - 0.5
    }
    /// The photo at camera direction `d` (None off the photo).
    fn at(&self, d: [f64; 3]) -> Option<(f32, bool)> {
        let p = self.camera.camera_dir_to_pixel(d)?;
        if !self.inside(p) {
            return None;
        }
        let v = self.lum.sample(p[0], p[1]);
        Some((v, self.clip.is_some_and(|c| v >= c)))
    }
}

/// The background lines of cone `c` at `bins` azimuths, reading `depth` px inside the rim.
fn lines(photo: &Photo, c: &Cone, bins: usize, depth: f64, out_len: f64) -> Vec<Option<Line>> {
    (0..bins)
        .into_par_iter()
        .map(|k| {
            let psi = k as f64 * std::f64::consts::TAU / bins as f64;
            let cam = photo.camera;
            let h = 1e-4 * c.beta;
            let p0 = cam.camera_dir_to_pixel(c.dir(c.beta - h, psi))?;
            let p1 = cam.camera_dir_to_pixel(c.dir(c.beta + h, psi))?;
            let g = (p1[0] - p0[0]).hypot(p1[1] - p0[1]) / (2.0 * h);
            let clipped = std::cell::Cell::new(false);
            let read = |theta: f64| -> Option<f64> {
                let (v, cl) = photo.at(c.dir(theta, psi))?;
                clipped.set(clipped.get() | cl);
                Some(v as f64)
            };
            // The straight line through the background 2–4 px out, for t < T_CLEAN.
            let fit: Vec<(f64, f64)> = (0..=8)
                .map(|i| T_CLEAN + (T_FIT - T_CLEAN) * i as f64 / 8.0)
                .map(|t| read(c.beta + t / g).map(|v| (t, v)))
                .collect::<Option<_>>()?;
            let n = fit.len() as f64;
            let (mt, mv) = (
                fit.iter().map(|p| p.0).sum::<f64>() / n,
                fit.iter().map(|p| p.1).sum::<f64>() / n,
            );
            let slope = fit.iter().map(|p| (p.0 - mt) * (p.1 - mv)).sum::<f64>()
                / fit.iter().map(|p| (p.0 - mt).powi(2)).sum::<f64>();
            let line = |t: f64| mv + slope * (t - mt);
            // The background at pixel distance t outside the rim.
            let background = |t: f64| -> Option<f64> {
                if t < T_CLEAN {
                    Some(line(t))
                } else {
                    read(c.beta + t / g)
                }
            };
            let steps = (out_len / OUT_STEP).ceil() as usize + 2;
            let out = (0..steps)
                .map(|i| background(i as f64 * OUT_STEP).map(|v| v as f32))
                .collect::<Option<Vec<f32>>>()?;
            // Inside: depth u at θ = β − u/g reflects θ' = θ + π − 2 asin(D sin θ).
            let d = 1.0 / c.beta.sin();
            let mut cum = vec![0f64; N_IN + 1];
            let mut val = vec![0f64; N_IN + 1];
            let mut prev = background(0.0)?;
            val[0] = prev;
            let mut valid = depth;
            for i in 1..=N_IN {
                let (u0, u1) = (
                    depth * ((i - 1) as f64 / N_IN as f64).powi(2),
                    depth * (i as f64 / N_IN as f64).powi(2),
                );
                let theta = c.beta - u1 / g;
                let deflect = std::f64::consts::PI - 2.0 * (d * theta.sin()).min(1.0).asin();
                let theta_r = theta + deflect;
                // Pixel distance outside the rim of the reflected direction (its own line).
                let t_r = match cam.camera_dir_to_pixel(c.dir(theta_r, psi)) {
                    Some(pr) => {
                        let rim = cam.camera_dir_to_pixel(c.dir(c.beta, psi))?;
                        (pr[0] - rim[0]).hypot(pr[1] - rim[1])
                    }
                    None => f64::INFINITY,
                };
                let v = if t_r < T_CLEAN {
                    Some(line(t_r))
                } else if t_r.is_finite() {
                    read(theta_r)
                } else {
                    None
                };
                let Some(v) = v else {
                    valid = u0;
                    for j in i..=N_IN {
                        cum[j] = cum[i - 1];
                        val[j] = prev;
                    }
                    break;
                };
                cum[i] = cum[i - 1] + 0.5 * (prev + v) * (u1 - u0);
                val[i] = v;
                prev = v;
            }
            Some(Line {
                out,
                depth,
                val,
                cum,
                valid,
                clipped: clipped.get(),
            })
        })
        .collect()
}

/// The weights of `SLICES` slices of a unit pixel square across a straight edge whose normal
/// makes angle φ with the x axis (the square's projection on the normal is a trapezoid), and
/// the slices' half-width.
fn slices(cos_phi: f64, sin_phi: f64) -> ([f64; SLICES], f64) {
    let (a, b) = (cos_phi.abs(), sin_phi.abs());
    let half = 0.5 * (a + b);
    let ds = 2.0 * half / SLICES as f64;
    let (lo, hi) = (a.min(b), a.max(b));
    let mut w = [0f64; SLICES];
    let mut sum = 0.0;
    for (j, wj) in w.iter_mut().enumerate() {
        let s = -half + (j as f64 + 0.5) * ds;
        // Density of x cos φ + y sin φ for (x, y) uniform on the unit square.
        let d = if s.abs() <= 0.5 * (hi - lo) {
            1.0 / hi
        } else {
            ((half - s.abs()) / (lo * hi).max(1e-12)).max(0.0)
        };
        *wj = d;
        sum += d;
    }
    for wj in &mut w {
        *wj /= sum;
    }
    (w, 0.5 * ds)
}

/// A pixel of the band: where it is and what it holds.
#[derive(Clone, Copy)]
struct BandPixel {
    x: usize,
    y: usize,
    v: f32,
}

/// The depth (px, positive inside) of a pixel centre under the cone's silhouette, and the
/// gradient of θ there (rad/px).
fn depth_and_gradient(cam: &Camera, c: &Cone, centre: [f64; 2]) -> Option<(f64, f64, f64, f64)> {
    let theta_at = |dx: f64, dy: f64| -> Option<f64> {
        let d = cam.pixel_to_camera_dir([centre[0] + dx, centre[1] + dy])?;
        Some(c.angles(d).0)
    };
    let d = cam.pixel_to_camera_dir(centre)?;
    let (theta, psi) = c.angles(d);
    let gx = theta_at(0.5, 0.0)? - theta_at(-0.5, 0.0)?;
    let gy = theta_at(0.0, 0.5)? - theta_at(0.0, -0.5)?;
    let gl = gx.hypot(gy);
    if !(gl > 0.0) {
        return None;
    }
    Some(((c.beta - theta) / gl, gx / gl, gy / gl, psi))
}

fn depth(cam: &Camera, c: &Cone, centre: [f64; 2]) -> Option<f64> {
    depth_and_gradient(cam, c, centre).map(|v| v.0)
}

/// What the model makes of one pixel: its value is R·a + b + κ·k + μ·m, with R the ball's
/// reflectance and κ, μ the free shape of the reflection of what lies beyond the photo in the
/// pixel's sector (module docs).
#[derive(Clone, Copy, Debug)]
struct Terms {
    a: f64,
    b: f64,
    k: f64,
    m: f64,
    sector: usize,
}

/// The model of one pixel for a cone, with its depth and azimuth; `None` where the model does
/// not reach.
fn model_pixel(
    photo: &Photo,
    c: &Cone,
    lines: &[Option<Line>],
    p: &BandPixel,
) -> Option<(Terms, f64, f64)> {
    let centre = [p.x as f64 + 0.5, p.y as f64 + 0.5];
    // Depth inside the rim at the pixel centre, and the rim's outward normal.
    let (u, nx, ny, psi) = depth_and_gradient(photo.camera, c, centre)?;
    let bins = lines.len();
    let psi = psi.rem_euclid(std::f64::consts::TAU);
    let fk = psi / std::f64::consts::TAU * bins as f64;
    let k0 = (fk as usize) % bins;
    let k1 = (k0 + 1) % bins;
    let wk = fk - fk.floor();
    let (l0, l1) = (lines[k0].as_ref()?, lines[k1].as_ref()?);
    if l0.clipped || l1.clipped {
        return None;
    }
    // Where the reflection leaves the photo: deeper, the reflected background continues as
    // its value there plus the free terms in (√u − √v) and (u − v).
    let v = l0.valid.min(l1.valid);
    let j_v = (1.0 - wk) * l0.value(v) + wk * l1.value(v);
    let (w, h) = slices(nx, ny);
    let mut t = Terms {
        a: 0.0,
        b: 0.0,
        k: 0.0,
        m: 0.0,
        sector: (psi / std::f64::consts::TAU * SECTORS as f64) as usize % SECTORS,
    };
    for (j, wj) in w.iter().enumerate() {
        let s = -0.5 * SLICES as f64 * 2.0 * h + (j as f64 + 0.5) * 2.0 * h;
        let (lo, hi) = (u - s - h, u - s + h); // depth interval of the slice
        let norm = wj / (2.0 * h);
        if hi > 0.0 {
            let (i0, i1) = (lo.max(0.0), hi);
            if i1 > l0.depth {
                return None;
            }
            // The part the photo's reflection reaches.
            let (r0, r1) = (i0.min(v), i1.min(v));
            if r1 > r0 {
                let integral = |l: &Line| l.integral(r1) - l.integral(r0);
                t.a += norm * ((1.0 - wk) * integral(l0) + wk * integral(l1));
            }
            // The part beyond it.
            let (e0, e1) = (i0.max(v), i1.max(v));
            if e1 > e0 {
                t.a += norm * j_v * (e1 - e0);
                let sq = |x: f64| 2.0 / 3.0 * x.powf(1.5) - v.sqrt() * x;
                t.k += norm * (sq(e1) - sq(e0));
                t.m += norm * 0.5 * ((e1 - v).powi(2) - (e0 - v).powi(2));
            }
        }
        if lo < 0.0 {
            let (t0, t1) = (-(hi.min(0.0)), -lo);
            let tm = 0.5 * (t0 + t1);
            let outside = (1.0 - wk) * l0.outside(tm) + wk * l1.outside(tm);
            t.b += norm * outside * (t1 - t0);
        }
    }
    Some((t, u, psi))
}

/// The model of the band for a cone: each pixel's terms, depth and azimuth (None where the
/// model does not reach).
struct Eval {
    ab: Vec<Option<Terms>>,
    /// Each modelled pixel's depth (px, positive inside) and azimuth about the axis.
    at: Vec<Option<(f64, f64)>>,
}

fn evaluate(photo: &Photo, c: &Cone, band: &[BandPixel], half: f64) -> Eval {
    let g_rim = {
        let cam = photo.camera;
        let p0 = cam.camera_dir_to_pixel(c.dir(c.beta, 0.0));
        let p1 = cam.camera_dir_to_pixel(c.dir(c.beta * 1.001, 0.0));
        match (p0, p1) {
            (Some(p0), Some(p1)) => (p1[0] - p0[0]).hypot(p1[1] - p0[1]) / (c.beta * 0.001),
            _ => 1.0,
        }
    };
    let r_px = c.beta * g_rim;
    let bins = ((std::f64::consts::TAU * r_px) as usize).clamp(256, 4096);
    // The lines reach 2 px past the band (pixel extent, and a step of the fit).
    let depth = half + 2.5;
    let ls = lines(photo, c, bins, depth, half + 2.5);
    let m: Vec<Option<(Terms, f64, f64)>> = band
        .par_iter()
        .map(|p| model_pixel(photo, c, &ls, p).filter(|m| m.1.abs() <= half + 1.5))
        .collect();
    Eval {
        ab: m.iter().map(|m| m.map(|(t, _, _)| t)).collect(),
        at: m.iter().map(|m| m.map(|(_, u, psi)| (u, psi))).collect(),
    }
}

/// The linear part of the model: the reflectance, and each sector's free terms.
#[derive(Clone, Debug)]
struct Linear {
    r: f64,
    km: Vec<[f64; 2]>,
}

impl Linear {
    fn predict(&self, t: &Terms) -> f64 {
        let [k, m] = self.km[t.sector];
        self.r * t.a + t.b + k * t.k + m * t.m
    }
}

/// Weighted sums of one sector for the linear solve: Gram of (a, k, m) and their products
/// with y = value − b.
#[derive(Clone, Copy, Default)]
struct Sums {
    g: [[f64; 3]; 3],
    y: [f64; 3],
    yy: f64,
    n: f64,
}

impl Sums {
    fn add(&mut self, t: &Terms, y: f64, w: f64) {
        let x = [t.a, t.k, t.m];
        for a in 0..3 {
            for b in 0..3 {
                self.g[a][b] += w * x[a] * x[b];
            }
            self.y[a] += w * x[a] * y;
        }
        self.yy += w * y * y;
        self.n += w;
    }
    /// The 2×2 block of the free terms with a ridge (a sector without pixels beyond the
    /// photo's reflection has none), inverted.
    fn free_inverse(&self) -> [[f64; 2]; 2] {
        let ridge = 1e-9 * (self.g[1][1] + self.g[2][2]) + 1e-12;
        let (p, q, r) = (self.g[1][1] + ridge, self.g[1][2], self.g[2][2] + ridge);
        let det = p * r - q * q;
        [[r / det, -q / det], [-q / det, p / det]]
    }
    /// With R given, the free terms that fit best.
    fn free(&self, r: f64) -> [f64; 2] {
        let inv = self.free_inverse();
        let v = [self.y[1] - r * self.g[0][1], self.y[2] - r * self.g[0][2]];
        [
            inv[0][0] * v[0] + inv[0][1] * v[1],
            inv[1][0] * v[0] + inv[1][1] * v[1],
        ]
    }
    /// (a⊥·a⊥, a⊥·y⊥): the products of a and y with the free terms projected out.
    fn reduced(&self) -> (f64, f64) {
        let inv = self.free_inverse();
        let ga = [self.g[0][1], self.g[0][2]];
        let gy = [self.y[1], self.y[2]];
        let quad = |u: [f64; 2], v: [f64; 2]| {
            u[0] * (inv[0][0] * v[0] + inv[0][1] * v[1])
                + u[1] * (inv[1][0] * v[0] + inv[1][1] * v[1])
        };
        (self.g[0][0] - quad(ga, ga), self.y[0] - quad(ga, gy))
    }
    /// The weighted mean squared residual with its own best R and free terms.
    fn cost(&self) -> Option<(f64, f64)> {
        let (aa, ay) = self.reduced();
        if !(aa > 0.0) || self.n <= 0.0 {
            return None;
        }
        let r = (ay / aa).clamp(0.02, 2.0);
        let [k, m] = self.free(r);
        let x = [r, k, m];
        // Σ w (y − x·t)² = yy − 2 x·y + xᵀ G x.
        let mut quad = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                quad += x[a] * self.g[a][b] * x[b];
            }
        }
        let sse = self.yy - 2.0 * (x[0] * self.y[0] + x[1] * self.y[1] + x[2] * self.y[2]) + quad;
        Some((sse.max(0.0) / self.n, r))
    }
}

/// Sums of one sector for the smooth alternative to a rim: the pixels as a quadratic in their
/// depth under the cone plus a slope along the rim.  Where that fits as well as the rim model
/// (a flat wall, a clear sky), the band shows nothing of a rim.
#[derive(Clone, Copy, Default)]
struct Smooth {
    g: [[f64; 4]; 4],
    y: [f64; 4],
    yy: f64,
    n: f64,
}

impl Smooth {
    fn add(&mut self, u: f64, along: f64, y: f64) {
        let x = [1.0, u, u * u, along];
        for a in 0..4 {
            for b in 0..4 {
                self.g[a][b] += x[a] * x[b];
            }
            self.y[a] += x[a] * y;
        }
        self.yy += y * y;
        self.n += 1.0;
    }
    /// The mean square of the pixels.
    fn mean_square(&self) -> f64 {
        self.yy / self.n.max(1.0)
    }
    /// The mean squared residual of the best such fit.
    fn cost(&self) -> f64 {
        // Gaussian elimination with partial pivoting on the 4×4 normal equations.
        let mut m = [[0f64; 5]; 4];
        for a in 0..4 {
            m[a][..4].copy_from_slice(&self.g[a]);
            m[a][4] = self.y[a];
        }
        let scale = (0..4).map(|a| self.g[a][a]).fold(0.0, f64::max) * 1e-12 + 1e-300;
        for col in 0..4 {
            let piv = (col..4)
                .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
                .unwrap_or(col);
            m.swap(col, piv);
            if m[col][col].abs() <= scale {
                continue; // a direction the pixels do not span
            }
            for r in 0..4 {
                if r != col {
                    let f = m[r][col] / m[col][col];
                    for k in col..5 {
                        m[r][k] -= f * m[col][k];
                    }
                }
            }
        }
        // Σ (y − x·β)² = yy − β·(Xᵀy) at the least-squares β.
        let mut fit = 0.0;
        for a in 0..4 {
            if m[a][a].abs() > scale {
                fit += m[a][4] / m[a][a] * self.y[a];
            }
        }
        (self.yy - fit).max(0.0) / self.n.max(1.0)
    }
}

/// The linear part that fits best (weighted least squares over the kept pixels): R shared by
/// the whole rim, the free terms per sector.
fn solve_linear(band: &[BandPixel], terms: &[Option<Terms>], w: &[f64], keep: &[bool]) -> Linear {
    let mut sums = [Sums::default(); SECTORS];
    for i in 0..band.len() {
        if let (true, Some(t)) = (keep[i], terms[i]) {
            sums[t.sector].add(&t, band[i].v as f64 - t.b, w[i]);
        }
    }
    let (mut aa, mut ay) = (0.0, 0.0);
    for s in &sums {
        let (a, y) = s.reduced();
        aa += a;
        ay += y;
    }
    let r = if aa > 0.0 {
        (ay / aa).clamp(0.02, 2.0)
    } else {
        1.0
    };
    Linear {
        r,
        km: sums.iter().map(|s| s.free(r)).collect(),
    }
}

/// The pixels within `half` + 2 px of the cone's silhouette (those a fit may look at).
fn band_pixels(photo: &Photo, c: &Cone, half: f64) -> Vec<BandPixel> {
    let cam = photo.camera;
    let (w, h) = (photo.lum.w, photo.lum.h);
    // Bounding box of the silhouette.
    let mut bx = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for k in 0..256 {
        let psi = k as f64 * std::f64::consts::TAU / 256.0;
        if let Some(p) = cam.camera_dir_to_pixel(c.dir(c.beta, psi)) {
            bx = [
                bx[0].min(p[0]),
                bx[1].min(p[1]),
                bx[2].max(p[0]),
                bx[3].max(p[1]),
            ];
        }
    }
    let m = half + 3.0;
    let x0 = (bx[0] - m).floor().max(0.0) as usize;
    let y0 = (bx[1] - m).floor().max(0.0) as usize;
    let x1 = ((bx[2] + m).ceil().max(0.0) as usize).min(w);
    let y1 = ((bx[3] + m).ceil().max(0.0) as usize).min(h);
    let f = cam.focal_px().unwrap_or(1.0);
    (y0..y1)
        .into_par_iter()
        .flat_map_iter(|y| {
            (x0..x1).filter_map(move |x| {
                let d = cam.pixel_to_camera_dir([x as f64 + 0.5, y as f64 + 0.5])?;
                let (theta, _) = c.angles(d);
                // A generous pixel scale: f / cos² at most doubles near the frame's corners.
                let g = f / dot(d, [0.0, 0.0, -1.0]).powi(2);
                if (c.beta - theta).abs() * g > m {
                    return None;
                }
                // The exact depth (as the model takes it) within the band.
                let u = depth(cam, c, [x as f64 + 0.5, y as f64 + 0.5])?;
                (u.abs() <= half).then(|| BandPixel {
                    x,
                    y,
                    v: photo.lum.at(x, y),
                })
            })
        })
        .collect()
}

/// The cone moved by `p` = (axis along e1, axis along e2, β), in pixels at the focal length
/// `g0`; the new cone keeps the old frame's orientation (so parameters mean the same in every
/// evaluation).
fn moved(c: &Cone, p: [f64; 3], g0: f64) -> Cone {
    let a = [0, 1, 2].map(|i| c.a[i] + (p[0] * c.e1[i] + p[1] * c.e2[i]) / g0);
    let mut cone = Cone::new(a, c.beta + p[2] / g0);
    cone.e1 = normalize(cross(cross(cone.a, c.e1), cone.a));
    cone.e2 = cross(cone.a, cone.e1);
    cone
}

/// How many times better than the smooth alternative ([`Smooth`]) the rim model must explain a
/// sector's band for the sector to count.
const EVIDENCE: f64 = 2.0;
/// Sectors of the rim scanned one by one.
const SCAN_SECTORS: usize = 64;

/// Where the rim lies, sector by sector: the silhouette is shifted outward by each of `range`/
/// `step` steps and, in each of 64 sectors round it, the model's residual (with the sector's own
/// reflectance) is taken at every shift; a sector's rim is at its clear minimum.  The cone's
/// change (the axis by two, β by one) is then fitted to the sectors' shifts,
/// s(ψ) = δβ + δ₁ cos ψ + δ₂ sin ψ, with Huber weights.  The model's residual has a basin only
/// about a pixel wide where the background is textured (with R near 1 a misplaced rim looks like
/// noise), so a fit from a start a few pixels off needs this search.
fn scan(photo: &Photo, c: &Cone, g0: f64, range: f64, step: f64) -> Option<Scan> {
    let half = 3.0;
    let band = band_pixels(photo, c, half + range);
    let k = (range / step).round() as i32;
    let shifts: Vec<f64> = (-k..=k).map(|j| j as f64 * step).collect();
    // Per sector and shift: the sums of the sector's own linear solve.
    let mut sums = vec![vec![Sums::default(); shifts.len()]; SCAN_SECTORS];
    let mut smooth = vec![vec![Smooth::default(); shifts.len()]; SCAN_SECTORS];
    let evals: Vec<Eval> = shifts
        .par_iter()
        .map(|sh| evaluate(photo, &moved(c, [0.0, 0.0, *sh], g0), &band, half))
        .collect();
    for (j, e) in evals.iter().enumerate() {
        for i in 0..band.len() {
            let (Some(t), Some((u, psi))) = (e.ab[i], e.at[i]) else {
                continue;
            };
            if u.abs() > half {
                continue;
            }
            let x = psi / std::f64::consts::TAU * SCAN_SECTORS as f64;
            let sec = x as usize % SCAN_SECTORS;
            sums[sec][j].add(&t, band[i].v as f64 - t.b, 1.0);
            smooth[sec][j].add(u, x - x.floor() - 0.5, band[i].v as f64);
        }
    }
    // Each sector's shift at its minimum.
    let mut found: Vec<(f64, f64)> = Vec::new(); // (ψ, shift)
    for (sec, row) in sums.iter().enumerate() {
        let cost: Vec<f64> = row
            .iter()
            .map(|t| {
                if t.n < 12.0 {
                    return f64::INFINITY;
                }
                t.cost().map_or(f64::INFINITY, |c| c.0)
            })
            .collect();
        if cost.iter().any(|v| !v.is_finite()) {
            continue;
        }
        let (j, min) = cost
            .iter()
            .copied()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        if j == 0 || j + 1 == cost.len() {
            continue; // at the end of the range: no minimum seen
        }
        // A clear minimum: the sector's median cost is well above it.
        let mut sorted = cost.clone();
        sorted.sort_by(|a, b| a.total_cmp(b));
        if !(sorted[sorted.len() / 2] > 2.0 * min) {
            continue;
        }
        // Evidence of a rim: the rim model explains the band clearly better than a smooth
        // field does (over a featureless wall a cone fits as well anywhere; on a noise-free
        // one both residuals vanish, hence the floor far below any photo's noise).
        let alt = smooth[sec][j].cost();
        let floor = 1e-8 * smooth[sec][j].mean_square();
        if !(alt > EVIDENCE * min + floor) {
            continue;
        }
        let (a, b, cc) = (cost[j - 1], cost[j], cost[j + 1]);
        let den = a - 2.0 * b + cc;
        let off = if den > 0.0 {
            (0.5 * (a - cc) / den).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        let psi = (sec as f64 + 0.5) / SCAN_SECTORS as f64 * std::f64::consts::TAU;
        found.push((psi, shifts[j] + off * step));
    }
    if found.len() < 8 {
        return None;
    }
    // s(ψ) = δβ + δ₁ cos ψ + δ₂ sin ψ, Huber-weighted (the rim moves out where the axis moves).
    let mut p = [0f64; 3];
    let mut scale = step;
    for _ in 0..4 {
        let mut m = [[0f64; 3]; 3];
        let mut v = [0f64; 3];
        for &(psi, sh) in &found {
            let row = [psi.cos(), psi.sin(), 1.0];
            let res = sh - (p[0] * row[0] + p[1] * row[1] + p[2]);
            let w = if res.abs() <= 1.5 * scale {
                1.0
            } else {
                1.5 * scale / res.abs()
            };
            for a in 0..3 {
                for b in 0..3 {
                    m[a][b] += w * row[a] * row[b];
                }
                v[a] += w * row[a] * sh;
            }
        }
        p = super::circle::solve3(m, v)?;
        let mut res: Vec<f64> = found
            .iter()
            .map(|&(psi, sh)| (sh - (p[0] * psi.cos() + p[1] * psi.sin() + p[2])).abs())
            .collect();
        res.sort_by(|a, b| a.total_cmp(b));
        scale = (1.4826 * res[res.len() / 2]).max(0.5 * step);
    }
    // The sectors whose own minimum lies on the fitted cone, and on the cone scanned around
    // (within ½ px at full resolution), and the octants of the rim they occupy.
    let tol = 0.5 / photo.scale;
    let agree = |p: [f64; 3]| {
        let mut octants = [false; 8];
        let mut n = 0;
        for &(psi, sh) in &found {
            if (sh - (p[0] * psi.cos() + p[1] * psi.sin() + p[2])).abs() <= tol {
                n += 1;
                octants[((psi / std::f64::consts::TAU * 8.0) as usize).min(7)] = true;
            }
        }
        (n, octants.iter().filter(|o| **o).count())
    };
    let (confirming, octants) = agree(p);
    let (confirming_start, octants_start) = agree([0.0; 3]);
    Some(Scan {
        cone: moved(c, p, g0),
        informative: found.len(),
        confirming,
        octants,
        start: (confirming_start, octants_start),
    })
}

/// What a scan found: the moved cone and how the sectors agree with it.
#[derive(Clone, Copy, Debug)]
struct Scan {
    cone: Cone,
    /// Sectors with a clear minimum of their own.
    informative: usize,
    /// Informative sectors whose minimum lies on the fitted cone.
    confirming: usize,
    /// Octants round the rim holding a confirming sector.
    octants: usize,
    /// The same two counts for the cone the scan started from.
    start: (usize, usize),
}

impl Scan {
    /// The confidence (module docs): the share of the informative sectors that confirm the
    /// cone, counted against at least a quarter of all sectors, and scaled down when the
    /// confirming ones leave much of the rim unseen.
    fn confidence(&self) -> f64 {
        self.score(self.confirming, self.octants)
    }
    /// The confidence of the cone the scan started from.
    fn confidence_at_start(&self) -> f64 {
        self.score(self.start.0, self.start.1)
    }
    fn score(&self, confirming: usize, octants: usize) -> f64 {
        let agree = confirming as f64 / self.informative.max(SCAN_SECTORS / 4) as f64;
        agree * (octants as f64 / 6.0).min(1.0)
    }
}

/// Fits the silhouette cone starting from `axis`, `beta` (good to some 15 px): sector scans on
/// the half-size copy `coarse` bring it within the model's basin, Gauss–Newton on the full photo
/// settles it, and a last scan there measures the confidence.
pub(super) fn fit(photo: &Photo, coarse: &Photo, axis: [f64; 3], beta: f64) -> Option<RimFit> {
    let c = Cone::new(axis, beta);
    let g0 = photo.camera.focal_px()?;
    let g1 = coarse.camera.focal_px()?;
    // On the half-size copy: narrow (±1 px, ⅛ px steps; ±2 and ¼ full-resolution px), and
    // when that does not find the rim with some confidence, wide (±8 px in ½ px steps) and
    // narrow again; the better of the two.
    let narrow = scan(coarse, &c, g1, 1.0, 0.125);
    let first = match narrow {
        Some(n) if n.confidence() >= 0.5 => n,
        _ => {
            let wide =
                scan(coarse, &c, g1, 8.0, 0.5).and_then(|w| scan(coarse, &w.cone, g1, 1.0, 0.125));
            match (narrow, wide) {
                (Some(n), Some(w)) => {
                    if w.confidence() > n.confidence() {
                        w
                    } else {
                        n
                    }
                }
                (n, w) => n.or(w)?,
            }
        }
    };
    let mut c = first.cone;
    let mut normal: Option<([[f64; 3]; 3], f64)> = None;
    // Full resolution: a narrow scan, then Gauss–Newton.
    if let Some(again) = scan(photo, &c, g0, 1.0, 0.125) {
        c = again.cone;
    }
    // How far Gauss–Newton has moved the cone from the scans' (px, per parameter).
    let mut total = [0.0f64; 3];
    {
        let half = 3.0;
        let band = band_pixels(photo, &c, half);
        if band.len() < 64 {
            return None;
        }
        let iterations = 8;
        for _ in 0..iterations {
            // Parameters in pixels: the axis moved along e1, e2, and β.
            let at = |p: [f64; 3]| moved(&c, p, g0);
            const H: f64 = 0.1;
            let base = evaluate(photo, &c, &band, half);
            let mut pm: Vec<Eval> = (0..6)
                .into_par_iter()
                .map(|j| {
                    let mut p = [0.0; 3];
                    p[j % 3] = if j < 3 { H } else { -H };
                    evaluate(photo, &at(p), &band, half)
                })
                .collect();
            let minus = pm.split_off(3);
            let plus = pm;
            let keep: Vec<bool> = (0..band.len())
                .map(|i| {
                    base.ab[i].is_some() && plus.iter().chain(&minus).all(|e| e.ab[i].is_some())
                })
                .collect();
            let n = keep.iter().filter(|k| **k).count();
            if n < 64 {
                return None;
            }
            let ones = vec![1.0; band.len()];
            let r = solve_linear(&band, &base.ab, &ones, &keep);
            let resid =
                |e: &Eval, r: &Linear, i: usize| band[i].v as f64 - r.predict(&e.ab[i].unwrap());
            // Huber weights at 1.5 robust σ.
            let mut abs: Vec<f64> = (0..band.len())
                .filter(|&i| keep[i])
                .map(|i| resid(&base, &r, i).abs())
                .collect();
            abs.sort_by(|a, b| a.total_cmp(b));
            let sigma = (1.4826 * abs[abs.len() / 2]).max(1e-9);
            let w: Vec<f64> = (0..band.len())
                .map(|i| {
                    if !keep[i] {
                        return 0.0;
                    }
                    let e = resid(&base, &r, i).abs() / (1.5 * sigma);
                    if e <= 1.0 {
                        1.0
                    } else {
                        1.0 / e
                    }
                })
                .collect();
            let r = solve_linear(&band, &base.ab, &w, &keep);
            let rp: Vec<Linear> = plus
                .iter()
                .map(|e| solve_linear(&band, &e.ab, &w, &keep))
                .collect();
            let rm: Vec<Linear> = minus
                .iter()
                .map(|e| solve_linear(&band, &e.ab, &w, &keep))
                .collect();
            let mut jtj = [[0f64; 3]; 3];
            let mut jtr = [0f64; 3];
            for i in 0..band.len() {
                if !keep[i] {
                    continue;
                }
                let r0 = resid(&base, &r, i);
                let j: [f64; 3] = [0, 1, 2].map(|k| {
                    (resid(&plus[k], &rp[k], i) - resid(&minus[k], &rm[k], i)) / (2.0 * H)
                });
                for a in 0..3 {
                    for b in 0..3 {
                        jtj[a][b] += w[i] * j[a] * j[b];
                    }
                    jtr[a] += w[i] * j[a] * r0;
                }
            }
            // The covariance of the parameters (R profiled out), for the uncertainty reported.
            let wsum: f64 = (0..band.len()).filter(|&i| keep[i]).map(|i| w[i]).sum();
            let s2 = (0..band.len())
                .filter(|&i| keep[i])
                .map(|i| w[i] * resid(&base, &r, i).powi(2))
                .sum::<f64>()
                / (wsum - 4.0 - 2.0 * SECTORS as f64).max(1.0);
            normal = Some((jtj, s2));
            // Levenberg–Marquardt damping keeps a flat direction (a featureless sector) from
            // taking a wild step.
            for (k, row) in jtj.iter_mut().enumerate() {
                row[k] *= 1.0 + 1e-3;
            }
            let step = super::circle::solve3(jtj, jtr.map(|v| -v))?;
            let step = step.map(|v| v.clamp(-1.0, 1.0));
            // Each multiple of the step, cut back to the trust region round the scanned cone.
            let within = |m: f64| -> [f64; 3] {
                [0, 1, 2].map(|k| (total[k] + m * step[k]).clamp(-TRUST, TRUST) - total[k])
            };
            // A line search along the step (the model is far from linear over a pixel): the
            // best of ½, 1, 2 and 4 steps by the weighted cost.
            // Costs are compared over the pixels both cones model (a moved cone can lose a
            // pixel whose reflection leaves the photo).
            let cost_at = |p: [f64; 3]| {
                let e = evaluate(photo, &at(p), &band, half);
                let both: Vec<bool> = (0..band.len())
                    .map(|i| keep[i] && e.ab[i].is_some())
                    .collect();
                if both.iter().filter(|b| **b).count() * 10 < n * 9 {
                    return f64::INFINITY;
                }
                let rr = solve_linear(&band, &e.ab, &w, &both);
                let r0 = solve_linear(&band, &base.ab, &w, &both);
                let (mut new, mut old) = (0.0, 0.0);
                for i in (0..band.len()).filter(|&i| both[i]) {
                    new += w[i] * resid(&e, &rr, i).powi(2);
                    old += w[i] * resid(&base, &r0, i).powi(2);
                }
                new / old
            };
            let mut best = (1.0, 0.0);
            let costs: Vec<(f64, f64)> = [0.5, 1.0, 2.0, 4.0]
                .into_par_iter()
                .map(|m| (cost_at(within(m)), m))
                .collect();
            for (cm, m) in costs {
                if cm < best.0 {
                    best = (cm, m);
                }
            }
            let step = within(best.1);
            for k in 0..3 {
                total[k] += step[k];
            }
            c = at(step);
            let moved = step.iter().map(|v| v.abs()).fold(0.0, f64::max);
            if moved < 5e-3 || best.1 == 0.0 {
                break;
            }
        }
    }
    // One standard deviation of each parameter (px), the largest reported: σ² (JᵀWJ)⁻¹ with the
    // residuals' spread, times √(pixels per independent sample) — the residuals of neighbouring
    // pixels are not independent (the model's error is smooth along the rim).
    let (jtj, s2) = normal?;
    let var = [0, 1, 2].map(|k| {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        super::circle::solve3(jtj, e).map_or(f64::INFINITY, |x| x[k])
    });
    let uncertainty = var
        .iter()
        .map(|v| (v.max(0.0) * s2).sqrt() * CORRELATED)
        .fold(0.0, f64::max);
    // The confidence of the cone reported: a last narrow scan around it, which must not move it.
    let last = scan(photo, &c, g0, 1.0, 0.125);
    // The report at 3 px: reflectance and residual.
    let half = 3.0;
    let band = band_pixels(photo, &c, half);
    let base = evaluate(photo, &c, &band, half);
    let keep: Vec<bool> = base.ab.iter().map(|v| v.is_some()).collect();
    let n = keep.iter().filter(|k| **k).count();
    if n < 64 {
        return None;
    }
    let ones = vec![1.0; band.len()];
    let lin = solve_linear(&band, &base.ab, &ones, &keep);
    let r = lin.r;
    let (mut sum2, mut mean) = (0.0, 0.0);
    for i in 0..band.len() {
        if let Some(t) = base.ab[i] {
            let v = band[i].v as f64;
            sum2 += (v - lin.predict(&t)).powi(2);
            mean += v;
        }
    }
    mean /= n as f64;
    Some(RimFit {
        axis: c.a,
        beta: c.beta,
        reflectance: r,
        rms: (sum2 / n as f64).sqrt() / mean.abs().max(1e-12),
        confidence: last.map_or(0.0, |l| l.confidence_at_start()),
        uncertainty,
        pixels: n,
    })
}

/// Points on the silhouette of a fitted cone, projected (for the outline the geometry takes).
pub(super) fn outline(camera: &Camera, f: &RimFit, n: usize) -> Vec<[f64; 2]> {
    let c = Cone::new(f.axis, f.beta);
    (0..n)
        .filter_map(|k| {
            camera.camera_dir_to_pixel(c.dir(f.beta, k as f64 * std::f64::consts::TAU / n as f64))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slices_integrate_the_pixel_square() {
        for phi in [0.0f64, 0.3, 0.785, 1.2, 1.57] {
            let (w, h) = slices(phi.cos(), phi.sin());
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // The fraction of the square on one side of a line through its centre is ½.
            let left: f64 = w[..SLICES / 2].iter().sum();
            assert!((left - 0.5).abs() < 1e-9, "{phi}: {left}");
            assert!((2.0 * h * SLICES as f64 - (phi.cos().abs() + phi.sin().abs())).abs() < 1e-12);
        }
    }
}
