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
//! pixels of the silhouette is predicted from the photo itself: the pixel square, cut into
//! slices parallel to the rim (the rim is straight at that scale), is the sum over the slices
//! outside the cone of the background there (the photo at that angle; within 2 px of the rim,
//! where the photo's pixels mix ball and background, the background is extended as the straight
//! line fitted to the photo 2–4 px out) and over the slices inside it of R × the mean of the
//! background over the swath those depths reflect (a cumulative integral along the line of the
//! same azimuth, sampled uniformly in √depth where the compression is steepest).  R enters
//! linearly and is solved for in closed form; the axis (2 degrees of freedom) and β are fitted
//! by Gauss–Newton on the residuals of all pixels in the band, with Huber weights (a highlight,
//! the ball's stand, a clipped sun).
//!
//! ## Confidence
//!
//! The cone is moved by scans: the silhouette is shifted in and out in small steps and, in each
//! of 64 sectors round it, the model's residual is taken at every shift; a sector's rim lies at
//! its clear minimum, and the cone's change is fitted to the sectors' minima.  The confidence is
//! the fraction of the 64 sectors whose own minimum lies within ½ px of the fitted cone.  A
//! flat sky seen by a perfect mirror confirms little (there is nothing to see there); a circle
//! that is not a ball's rim is confirmed by few sectors.

use super::circle::Plane;
use crate::camera::Camera;
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
    /// Fraction of the 64 sectors round the rim that confirm it (module docs), 0 to 1.
    pub confidence: f64,
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

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    a.map(|v| v / l)
}

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
    /// Depths u_i = depth·(i/N_IN)² and the integral of the reflected background to them.
    depth: f64,
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
            let mut prev = background(0.0)?;
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
                    }
                    break;
                };
                cum[i] = cum[i - 1] + 0.5 * (prev + v) * (u1 - u0);
                prev = v;
            }
            Some(Line {
                out,
                depth,
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

/// The model of one pixel for a cone: (A, B) with value = R·A + B, and its depth; `None` where
/// the model does not reach.
fn model_pixel(
    photo: &Photo,
    c: &Cone,
    lines: &[Option<Line>],
    p: &BandPixel,
) -> Option<(f64, f64, f64, f64)> {
    let centre = [p.x as f64 + 0.5, p.y as f64 + 0.5];
    // Depth inside the rim at the pixel centre, and the rim's outward normal.
    let (u, nx, ny, psi) = depth_and_gradient(photo.camera, c, centre)?;
    let bins = lines.len();
    let fk = psi.rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU * bins as f64;
    let k0 = (fk as usize) % bins;
    let k1 = (k0 + 1) % bins;
    let wk = fk - fk.floor();
    let (l0, l1) = (lines[k0].as_ref()?, lines[k1].as_ref()?);
    if l0.clipped || l1.clipped {
        return None;
    }
    let (w, h) = slices(nx, ny);
    let (mut a, mut b) = (0.0, 0.0);
    for (j, wj) in w.iter().enumerate() {
        let s = -0.5 * SLICES as f64 * 2.0 * h + (j as f64 + 0.5) * 2.0 * h;
        let (lo, hi) = (u - s - h, u - s + h); // depth interval of the slice
        if hi > 0.0 {
            let (i0, i1) = (lo.max(0.0), hi);
            if i1 > l0.valid.min(l1.valid) {
                return None;
            }
            let integral = |l: &Line| l.integral(i1) - l.integral(i0);
            a += wj * ((1.0 - wk) * integral(l0) + wk * integral(l1)) / (2.0 * h);
        }
        if lo < 0.0 {
            let (t0, t1) = (-(hi.min(0.0)), -lo);
            let tm = 0.5 * (t0 + t1);
            let outside = (1.0 - wk) * l0.outside(tm) + wk * l1.outside(tm);
            b += wj * outside * (t1 - t0) / (2.0 * h);
        }
    }
    Some((a, b, u, psi.rem_euclid(std::f64::consts::TAU)))
}

/// Residuals of the band for a cone: per pixel (A, B, sector) or None, and the reflectance
/// that fits best with `weights`.
struct Eval {
    ab: Vec<Option<(f64, f64, usize)>>,
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
    let m: Vec<Option<(f64, f64, f64, f64)>> = band
        .par_iter()
        .map(|p| model_pixel(photo, c, &ls, p).filter(|m| m.2.abs() <= half + 1.5))
        .collect();
    let sector = |psi: f64| (psi / std::f64::consts::TAU * SECTORS as f64) as usize % SECTORS;
    Eval {
        ab: m
            .iter()
            .map(|m| m.map(|(a, b, _, psi)| (a, b, sector(psi))))
            .collect(),
        at: m.iter().map(|m| m.map(|(_, _, u, psi)| (u, psi))).collect(),
    }
}

/// The reflectance that fits (weighted least squares over the pixels all of `evals` model).
fn best_r(band: &[BandPixel], ab: &[Option<(f64, f64, usize)>], w: &[f64], keep: &[bool]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..band.len() {
        if let (true, Some((a, b, _))) = (keep[i], ab[i]) {
            num += w[i] * a * (band[i].v as f64 - b);
            den += w[i] * a * a;
        }
    }
    if den > 0.0 {
        (num / den).clamp(0.02, 2.0)
    } else {
        1.0
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

/// Sectors of the rim scanned one by one.
const SCAN_SECTORS: usize = 64;

/// Where the rim lies, sector by sector: the silhouette is shifted outward by each of `range`/
/// `step` steps and, in each of 64 sectors round it, the model's residual (with the sector's own
/// reflectance) is taken at every shift; a sector's rim is at its clear minimum.  The cone's
/// change (the axis by two, β by one) is then fitted to the sectors' shifts,
/// s(ψ) = δβ + δ₁ cos ψ + δ₂ sin ψ, with Huber weights.  The model's residual has a basin only
/// about a pixel wide where the background is textured (with R near 1 a misplaced rim looks like
/// noise), so a fit from a start a few pixels off needs this search.
fn scan(photo: &Photo, c: &Cone, g0: f64, range: f64, step: f64) -> Option<(Cone, usize)> {
    let half = 3.0;
    let band = band_pixels(photo, c, half + range);
    let k = (range / step).round() as i32;
    let shifts: Vec<f64> = (-k..=k).map(|j| j as f64 * step).collect();
    // Per sector and shift: Σa², Σa(o−b), Σ(o−b)², n.
    let mut sums = vec![vec![[0f64; 4]; shifts.len()]; SCAN_SECTORS];
    for (j, sh) in shifts.iter().enumerate() {
        let e = evaluate(photo, &moved(c, [0.0, 0.0, *sh], g0), &band, half);
        for i in 0..band.len() {
            let (Some((a, b, _)), Some((u, psi))) = (e.ab[i], e.at[i]) else {
                continue;
            };
            if u.abs() > half {
                continue;
            }
            let sec = (psi / std::f64::consts::TAU * SCAN_SECTORS as f64) as usize % SCAN_SECTORS;
            let ob = band[i].v as f64 - b;
            let t = &mut sums[sec][j];
            t[0] += a * a;
            t[1] += a * ob;
            t[2] += ob * ob;
            t[3] += 1.0;
        }
    }
    // Each sector's shift at its minimum.
    let mut found: Vec<(f64, f64)> = Vec::new(); // (ψ, shift)
    for (sec, row) in sums.iter().enumerate() {
        let cost: Vec<f64> = row
            .iter()
            .map(|t| {
                if t[3] < 12.0 || t[0] <= 0.0 {
                    return f64::INFINITY;
                }
                let r = (t[1] / t[0]).clamp(0.02, 2.0);
                (t[2] - 2.0 * r * t[1] + r * r * t[0]) / t[3]
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
    // The sectors whose own minimum lies on the fitted cone (within ½ px).
    let confirming = found
        .iter()
        .filter(|&&(psi, sh)| (sh - (p[0] * psi.cos() + p[1] * psi.sin() + p[2])).abs() <= 0.5)
        .count();
    Some((moved(c, p, g0), confirming))
}

/// Fits the silhouette cone starting from `axis`, `beta` (good to a few pixels).
pub(super) fn fit(photo: &Photo, axis: [f64; 3], beta: f64) -> Option<RimFit> {
    let c = Cone::new(axis, beta);
    let g0 = photo.camera.focal_px()?;
    // Sector scans bring the start within the model's basin.
    // The narrow scan first (the edge fit's start is usually within a pixel or two); when too
    // few sectors confirm its result, a wide scan, then the narrow one again, and the better.
    let narrow = scan(photo, &c, g0, 1.5, 0.125);
    let (mut c, confirming) = match narrow {
        Some(n) if n.1 * 2 >= SCAN_SECTORS => n,
        _ => {
            let wide =
                scan(photo, &c, g0, 6.0, 0.5).and_then(|w| scan(photo, &w.0, g0, 1.5, 0.125));
            match (narrow, wide) {
                (Some(n), Some(w)) => {
                    if w.1 > n.1 {
                        w
                    } else {
                        n
                    }
                }
                (n, w) => n.or(w)?,
            }
        }
    };
    // A second narrow scan from where the first left the cone.
    if let Some(again) = scan(photo, &c, g0, 1.0, 0.125) {
        if again.1 >= confirming {
            c = again.0;
        }
    }
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
            let plus: Vec<Eval> = (0..3)
                .map(|j| {
                    let mut p = [0.0; 3];
                    p[j] = H;
                    evaluate(photo, &at(p), &band, half)
                })
                .collect();
            let minus: Vec<Eval> = (0..3)
                .map(|j| {
                    let mut p = [0.0; 3];
                    p[j] = -H;
                    evaluate(photo, &at(p), &band, half)
                })
                .collect();
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
            let r = best_r(&band, &base.ab, &ones, &keep);
            let resid = |e: &Eval, r: f64, i: usize| {
                let (a, b, _) = e.ab[i].unwrap();
                band[i].v as f64 - (r * a + b)
            };
            // Huber weights at 1.5 robust σ.
            let mut abs: Vec<f64> = (0..band.len())
                .filter(|&i| keep[i])
                .map(|i| resid(&base, r, i).abs())
                .collect();
            abs.sort_by(|a, b| a.total_cmp(b));
            let sigma = (1.4826 * abs[abs.len() / 2]).max(1e-9);
            let w: Vec<f64> = (0..band.len())
                .map(|i| {
                    if !keep[i] {
                        return 0.0;
                    }
                    let e = resid(&base, r, i).abs() / (1.5 * sigma);
                    if e <= 1.0 {
                        1.0
                    } else {
                        1.0 / e
                    }
                })
                .collect();
            let r = best_r(&band, &base.ab, &w, &keep);
            let rp: Vec<f64> = plus
                .iter()
                .map(|e| best_r(&band, &e.ab, &w, &keep))
                .collect();
            let rm: Vec<f64> = minus
                .iter()
                .map(|e| best_r(&band, &e.ab, &w, &keep))
                .collect();
            let mut jtj = [[0f64; 3]; 3];
            let mut jtr = [0f64; 3];
            for i in 0..band.len() {
                if !keep[i] {
                    continue;
                }
                let r0 = resid(&base, r, i);
                let j: [f64; 3] = [0, 1, 2]
                    .map(|k| (resid(&plus[k], rp[k], i) - resid(&minus[k], rm[k], i)) / (2.0 * H));
                for a in 0..3 {
                    for b in 0..3 {
                        jtj[a][b] += w[i] * j[a] * j[b];
                    }
                    jtr[a] += w[i] * j[a] * r0;
                }
            }
            // Levenberg–Marquardt damping keeps a flat direction (a featureless sector) from
            // taking a wild step.
            for (k, row) in jtj.iter_mut().enumerate() {
                row[k] *= 1.0 + 1e-3;
            }
            let step = super::circle::solve3(jtj, jtr.map(|v| -v))?;
            let step = step.map(|v| v.clamp(-1.0, 1.0));
            // A line search along the step (the model is far from linear over a pixel): the
            // best of ½, 1 and 2 steps by the weighted cost.
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
                let rr = best_r(&band, &e.ab, &w, &both);
                let r0 = best_r(&band, &base.ab, &w, &both);
                let (mut new, mut old) = (0.0, 0.0);
                for i in (0..band.len()).filter(|&i| both[i]) {
                    new += w[i] * resid(&e, rr, i).powi(2);
                    old += w[i] * resid(&base, r0, i).powi(2);
                }
                new / old
            };
            let mut best = (1.0, 0.0);
            for m in [0.5, 1.0, 2.0, 4.0] {
                let cm = cost_at(step.map(|v| m * v));
                if cm < best.0 {
                    best = (cm, m);
                }
            }
            let step = step.map(|v| best.1 * v);
            c = at(step);
            let moved = step.iter().map(|v| v.abs()).fold(0.0, f64::max);
            if moved < 5e-3 || best.1 == 0.0 {
                break;
            }
        }
    }
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
    let r = best_r(&band, &base.ab, &ones, &keep);
    let (mut sum2, mut mean) = (0.0, 0.0);
    for i in 0..band.len() {
        if let Some((a, b, _)) = base.ab[i] {
            let v = band[i].v as f64;
            sum2 += (v - (r * a + b)).powi(2);
            mean += v;
        }
    }
    mean /= n as f64;
    Some(RimFit {
        axis: c.a,
        beta: c.beta,
        reflectance: r,
        rms: (sum2 / n as f64).sqrt() / mean.abs().max(1e-12),
        confidence: confirming as f64 / SCAN_SECTORS as f64,
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
