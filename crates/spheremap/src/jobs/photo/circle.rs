//! Finding the ball in a photo: a coarse Hough vote, then a sub-pixel fit to edge points found
//! along radial profiles.
//!
//! 1. **Log luminance.**  A chrome ball reflects 60–80 % of what it mirrors, so its rim is a
//!    step of constant *ratio* against the background just outside it (the grazing reflection
//!    shows almost the same direction as the background).  In log luminance that ratio is a
//!    step of constant height whatever the brightness, which is what the edge detector wants.
//! 2. **Coarse** (on a copy at most 512 px wide): Sobel gradients; every strong edge votes
//!    along its gradient line for centres at all radii; the strongest centre wins; the radius
//!    is the most common distance of radially oriented edges from it.
//! 3. **Sub-pixel** (full resolution): along 720 rays from the centre the profile across the
//!    rim is sampled every ¼ px (bilinear); the edge is the extremum of its derivative with
//!    the sign most rays agree on, refined by a parabola.  A circle is fitted to those points
//!    (algebraic fit, then Gauss–Newton on the geometric distance), points further than 3
//!    robust σ are dropped (the ball's stand, a highlight), and the profiles are taken again
//!    around the new circle with a narrower window.  The RMS of the kept points' distances to
//!    the circle is the reported residual.
//!
//! Coordinates are continuous pixel coordinates: (0, 0) the top-left corner of the image,
//! pixel centres at i + ½.

use crate::base::error::{Error, Result};
use crate::images::Image;

/// A circle in continuous pixel coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    pub cx: f64,
    pub cy: f64,
    pub r: f64,
}

/// A fitted circle with its quality and the edge points it was fitted to.
#[derive(Clone, Debug)]
pub struct CircleFit {
    pub circle: Circle,
    /// The fit's residual: for the edge fit, the RMS distance of the kept edge points from the
    /// circle in pixels; for the perspective rim model, the RMS of the band's pixels relative
    /// to their mean value.
    pub rms: f64,
    /// Points on the outline: the edge points kept (of the 720 profiles), or the fitted
    /// silhouette's.
    pub points: Vec<[f64; 2]>,
    /// How sure the fit is, 0 to 1: for the edge fit, the fraction of the 720 profiles whose
    /// edge point it kept; for the perspective rim model, how much of the rim confirms it
    /// ([`super::rim`]).
    pub confidence: f64,
    /// The ball's reflectance as the perspective rim model sees it.
    pub reflectance: Option<f64>,
    /// The perspective rim model's estimate of its own scatter in pixels, from its residuals
    /// (the noise of the photo; it does not see a biased fit).
    pub uncertainty: Option<f64>,
}

/// Linear luminance of every pixel (non-finite and negative values as 0).
pub(super) fn luminance(img: &Image) -> Vec<f32> {
    let c = img.channels;
    img.data
        .chunks_exact(c)
        .map(|p| match c {
            1 | 2 => p[0],
            _ => 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2],
        })
        .map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 })
        .collect()
}

/// Log luminance, floored so black pixels stay finite.
fn log_of(lum: &[f32]) -> Vec<f32> {
    let mean = lum.iter().map(|&v| v as f64).sum::<f64>() / lum.len().max(1) as f64;
    let floor = (1e-3 * mean).max(1e-6) as f32;
    lum.iter().map(|&v| (v + floor).ln()).collect()
}

/// A single-channel image.
pub(super) struct Plane {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) v: Vec<f32>,
}

impl Plane {
    pub(super) fn at(&self, x: usize, y: usize) -> f32 {
        self.v[y * self.w + x]
    }
    /// Bilinear at a continuous position (clamped at the borders).
    pub(super) fn sample(&self, x: f64, y: f64) -> f32 {
        let fx = (x - 0.5).clamp(0.0, (self.w - 1) as f64);
        let fy = (y - 0.5).clamp(0.0, (self.h - 1) as f64);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.w - 1), (y0 + 1).min(self.h - 1));
        let (ax, ay) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
        let top = self.at(x0, y0) * (1.0 - ax) + self.at(x1, y0) * ax;
        let bot = self.at(x0, y1) * (1.0 - ax) + self.at(x1, y1) * ax;
        top * (1.0 - ay) + bot * ay
    }
    /// Half size by 2×2 averaging (continuous coordinates scale by exactly ½).
    pub(super) fn half(&self) -> Plane {
        let (w, h) = (self.w / 2, self.h / 2);
        let mut v = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                v.push(
                    0.25 * (self.at(2 * x, 2 * y)
                        + self.at(2 * x + 1, 2 * y)
                        + self.at(2 * x, 2 * y + 1)
                        + self.at(2 * x + 1, 2 * y + 1)),
                );
            }
        }
        Plane { w, h, v }
    }
}

/// The photo's linear and log luminance, once it is large enough to hold a ball.
pub(super) fn planes(img: &Image) -> Result<(Plane, Plane)> {
    if img.width < 16 || img.height < 16 {
        return Err(Error::param(
            "image",
            format!(
                "{}x{} is too small to find a ball in",
                img.width, img.height
            ),
        ));
    }
    let lin = Plane {
        w: img.width,
        h: img.height,
        v: luminance(img),
    };
    let log = Plane {
        w: img.width,
        h: img.height,
        v: log_of(&lin.v),
    };
    Ok((lin, log))
}

/// Finds the ball: coarse detection (or `hint`), then the sub-pixel fit.
pub fn find_circle(img: &Image, hint: Option<Circle>) -> Result<CircleFit> {
    let (lin, log) = planes(img)?;
    let start = match hint {
        Some(c) => c,
        None => coarse(&log)?[0],
    };
    let mut f = refine(&log, &lin, start)?;
    f.confidence = f.points.len() as f64 / RAYS as f64;
    Ok(f)
}

pub(super) const RAYS: usize = 720;
/// The photo's copy at most 512 px on its longer side (halved as often as needed), how many
/// full-resolution pixels one of its pixels spans, and its Sobel gradient (gx, gy, |g|) at every
/// pixel (0 on the border).
fn small_gradients(full: &Plane) -> (Plane, f64, Vec<(f32, f32, f32)>) {
    let mut p = Plane {
        w: full.w,
        h: full.h,
        v: full.v.clone(),
    };
    let mut scale = 1.0;
    while p.w.max(p.h) > 512 && p.w >= 32 && p.h >= 32 {
        p = p.half();
        scale *= 2.0;
    }
    let (w, h) = (p.w, p.h);
    let mut grad = vec![(0f32, 0f32, 0f32); w * h];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let gx = (p.at(x + 1, y - 1) + 2.0 * p.at(x + 1, y) + p.at(x + 1, y + 1))
                - (p.at(x - 1, y - 1) + 2.0 * p.at(x - 1, y) + p.at(x - 1, y + 1));
            let gy = (p.at(x - 1, y + 1) + 2.0 * p.at(x, y + 1) + p.at(x + 1, y + 1))
                - (p.at(x - 1, y - 1) + 2.0 * p.at(x, y - 1) + p.at(x + 1, y - 1));
            grad[y * w + x] = (gx, gy, gx.hypot(gy));
        }
    }
    (p, scale, grad)
}

/// Hough vote on a copy at most 512 px on its longer side: the candidate circles, the most
/// likely first.
pub(super) fn coarse(full: &Plane) -> Result<Vec<Circle>> {
    let (p, scale, grad) = small_gradients(full);
    let (w, h) = (p.w, p.h);
    let mut mags: Vec<f32> = grad.iter().map(|g| g.2).filter(|&m| m > 0.0).collect();
    if mags.len() < 16 {
        return Err(Error::data(
            "image",
            "no edges: is there a ball in the photo?",
        ));
    }
    // The strongest 20 % of edges vote.
    let k = mags.len() * 80 / 100;
    let (_, thr, _) = mags.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    let thr = *thr;
    let (rmin, rmax) = (0.04 * w.min(h) as f32, 0.5 * w.max(h) as f32);
    let mut acc = vec![0f32; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let (gx, gy, m) = grad[y * w + x];
            if m < thr {
                continue;
            }
            let (ux, uy) = (gx / m, gy / m);
            for sign in [-1.0f32, 1.0] {
                let mut r = rmin;
                while r <= rmax {
                    let cx = x as f32 + 0.5 + sign * ux * r;
                    let cy = y as f32 + 0.5 + sign * uy * r;
                    if cx < 0.0 || cy < 0.0 || cx >= w as f32 || cy >= h as f32 {
                        break;
                    }
                    acc[cy as usize * w + cx as usize] += 1.0;
                    r += 0.5;
                }
            }
        }
    }
    // Smooth the accumulator (3×3 box); its strongest local maxima are the candidates.
    let mut sm = vec![0f32; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let mut s = 0.0;
            for dy in 0..3 {
                for dx in 0..3 {
                    s += acc[(y + dy - 1) * w + x + dx - 1];
                }
            }
            sm[y * w + x] = s;
        }
    }
    let mut peaks: Vec<(usize, usize, f32)> = vec![];
    const NMS: usize = 4;
    for y in NMS..h.saturating_sub(NMS) {
        for x in NMS..w.saturating_sub(NMS) {
            let v = sm[y * w + x];
            if v <= 0.0 {
                continue;
            }
            let mut is_max = true;
            'n: for yy in y - NMS..=y + NMS {
                for xx in x - NMS..=x + NMS {
                    let u = sm[yy * w + xx];
                    if u > v || (u == v && (yy, xx) < (y, x)) {
                        is_max = false;
                        break 'n;
                    }
                }
            }
            if is_max {
                peaks.push((x, y, v));
            }
        }
    }
    peaks.sort_by(|a, b| b.2.total_cmp(&a.2));
    peaks.truncate(12);
    // Each candidate centre gets its radius (the most common distance of radially oriented
    // strong edges); the circle with the longest edge along it wins: a mirror ball's
    // rim is darker than the background just outside it all the way round (its reflectance
    // is below 1), while reflected shapes inside it (a window) match a circle only in parts.
    let bins = (rmax.ceil() as usize) + 2;
    let mut found: Vec<(Circle, f32)> = Vec::new();
    for &(px, py, _) in &peaks {
        let (cx, cy) = (px as f32 + 0.5, py as f32 + 0.5);
        let mut hist = vec![0f32; bins];
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let (gx, gy, m) = grad[y * w + x];
                if m < thr {
                    continue;
                }
                let (dx, dy) = (x as f32 + 0.5 - cx, y as f32 + 0.5 - cy);
                let r = dx.hypot(dy);
                if r < rmin || r > rmax {
                    continue;
                }
                if ((dx * gx + dy * gy) / (r * m)).abs() > 0.9 {
                    hist[r as usize] += m;
                }
            }
        }
        for _ in 0..2 {
            let Some((i, _)) = (1..bins - 1)
                .map(|i| (i, hist[i - 1] + hist[i] + hist[i + 1]))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .filter(|b| b.1 > 0.0)
            else {
                break;
            };
            let c = Circle {
                cx: cx as f64,
                cy: cy as f64,
                r: i as f64 + 0.5,
            };
            // The length of edge along it: inside the ball the reflections make edges everywhere,
            // so small circles there are fully supported too, but only the rim is long.
            let score = rim_support(&p, &c) * c.r as f32;
            found.push((c, score));
            // The second radius peak at the same centre, away from the first.
            for j in i.saturating_sub(3)..(i + 4).min(bins) {
                hist[j] = 0.0;
            }
        }
    }
    if found.is_empty() {
        return Err(Error::data(
            "image",
            "found no circular edge: is there a ball in the photo? (or give --circle)",
        ));
    }
    found.sort_by(|a, b| b.1.total_cmp(&a.1));
    // The best few, without near-duplicates.
    let mut out: Vec<Circle> = Vec::new();
    for (c, _) in found {
        let c = Circle {
            cx: c.cx * scale,
            cy: c.cy * scale,
            r: c.r * scale,
        };
        let near = |o: &Circle| {
            (o.cx - c.cx).hypot(o.cy - c.cy) < 0.05 * c.r && (o.r - c.r).abs() < 0.05 * c.r
        };
        if !out.iter().any(near) {
            out.push(c);
        }
        if out.len() == CANDIDATES {
            break;
        }
    }
    Ok(out)
}

/// Circle candidates from a vote over centre *and* radius (on a copy at most 512 px on its
/// longer side): every strong edge votes, along its gradient line on both sides, for the
/// circles through it; the cells with the most votes are the circles with the most edge along
/// them.  A mirror ball's rim is a whole circle of edges (the background against the ball's
/// dimmer, compressed reflection, and the reflection's own detail drawn out along the rim),
/// while a reflected horizon or a window inside the ball is only an arc, and straight edges
/// spread their votes over many circles.
pub(super) fn coarse_circles(full: &Plane) -> Vec<Circle> {
    let (p, scale, grad) = small_gradients(full);
    let (w, h) = (p.w, p.h);
    if w < 8 || h < 8 {
        return vec![];
    }
    let mut mags: Vec<f32> = grad.iter().map(|g| g.2).filter(|&m| m > 0.0).collect();
    if mags.len() < 16 {
        return vec![];
    }
    // The strongest 30 % of edges vote (a dim rim is still among them on a smooth background).
    let k = mags.len() * 70 / 100;
    let (_, thr, _) = mags.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    let thr = (*thr).max(1e-3);
    // Cells of 2 px in centre and radius.
    const CELL: f32 = 2.0;
    let (rmin, rmax) = (0.04 * w.min(h) as f32, 0.5 * w.max(h) as f32);
    let (nx, ny) = (
        (w as f32 / CELL) as usize + 1,
        (h as f32 / CELL) as usize + 1,
    );
    let nr = ((rmax - rmin) / CELL) as usize + 1;
    let mut acc = vec![0u16; nx * ny * nr];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let (gx, gy, m) = grad[y * w + x];
            if m < thr {
                continue;
            }
            let (ux, uy) = (gx / m, gy / m);
            for sign in [-1.0f32, 1.0] {
                let mut ri = 0;
                while ri < nr {
                    let r = rmin + (ri as f32 + 0.5) * CELL;
                    let cx = x as f32 + 0.5 + sign * ux * r;
                    let cy = y as f32 + 0.5 + sign * uy * r;
                    if cx < 0.0 || cy < 0.0 || cx >= w as f32 || cy >= h as f32 {
                        break;
                    }
                    let i = ((ri * ny) + (cy / CELL) as usize) * nx + (cx / CELL) as usize;
                    acc[i] = acc[i].saturating_add(1);
                    ri += 1;
                }
            }
        }
    }
    // Votes per cell, smoothed over the 3×3×3 neighbourhood; a circle's share is its votes over
    // its circumference (in edge pixels), so a small circle is not drowned by a large one.
    let at = |xi: usize, yi: usize, ri: usize| acc[(ri * ny + yi) * nx + xi] as f32;
    let mut cells: Vec<(usize, usize, usize, f32, f32)> = Vec::new();
    for ri in 1..nr.saturating_sub(1) {
        for yi in 1..ny - 1 {
            for xi in 1..nx - 1 {
                let v = at(xi, yi, ri);
                if v < 8.0 {
                    continue;
                }
                let mut sum = 0.0;
                for dr in 0..3 {
                    for dy in 0..3 {
                        for dx in 0..3 {
                            sum += at(xi + dx - 1, yi + dy - 1, ri + dr - 1);
                        }
                    }
                }
                let r = rmin + (ri as f32 + 0.5) * CELL;
                cells.push((xi, yi, ri, sum, sum / (std::f32::consts::TAU * r)));
            }
        }
    }
    // The best by votes, then by share; near-duplicates dropped.
    let mut out: Vec<Circle> = Vec::new();
    for key in [3usize, 4] {
        let mut sorted = cells.clone();
        sorted.sort_by(|a, b| {
            let (ka, kb) = if key == 3 { (a.3, b.3) } else { (a.4, b.4) };
            kb.total_cmp(&ka)
        });
        let mut taken = 0;
        for &(xi, yi, ri, _, _) in &sorted {
            let c = Circle {
                cx: ((xi as f32 + 0.5) * CELL) as f64 * scale,
                cy: ((yi as f32 + 0.5) * CELL) as f64 * scale,
                r: (rmin + (ri as f32 + 0.5) * CELL) as f64 * scale,
            };
            let near = |o: &Circle| {
                (o.cx - c.cx).hypot(o.cy - c.cy) < 0.1 * c.r.max(o.r)
                    && (o.r - c.r).abs() < 0.1 * c.r.max(o.r)
            };
            if out.iter().any(near) {
                continue;
            }
            out.push(c);
            taken += 1;
            if taken == CANDIDATES / 2 {
                break;
            }
        }
    }
    out
}

/// Candidate circles the perspective search fits.
pub(super) const CANDIDATES: usize = 6;

/// How much of a circle is edge: the fraction of 180 directions where the log luminance
/// changes by more than 0.1 across 1 px somewhere within ±2 px of the circle.  A mirror ball's
/// rim is an edge all the way round (its reflectance is below 1, so it is darker than the
/// background just outside); reflected shapes inside it (a window) match a circle in parts.
fn rim_support(p: &Plane, c: &Circle) -> f32 {
    let mut n = 0;
    for i in 0..180 {
        let a = i as f64 * std::f64::consts::TAU / 180.0;
        let (ux, uy) = (a.cos(), a.sin());
        let at = |t: f64| p.sample(c.cx + ux * (c.r + t), c.cy + uy * (c.r + t));
        let prof: Vec<f32> = (0..11).map(|k| at(-2.5 + 0.5 * k as f64)).collect();
        if (0..9).any(|k| (prof[k + 2] - prof[k]).abs() > 0.1) {
            n += 1;
        }
    }
    n as f32 / 180.0
}

/// The edge along one ray from the centre, between radii `r0` and `r1`: the outermost clear
/// extremum of the profile's derivative with sign `sign` (+1: brighter outside; `None`:
/// either), sub-sample by a parabola.
fn edge_on_ray(
    p: &Plane,
    c: &Circle,
    angle: f64,
    (r0, r1): (f64, f64),
    sign: Option<f32>,
) -> Option<f64> {
    const STEP: f64 = 0.25;
    let (ux, uy) = (angle.cos(), angle.sin());
    let n = ((r1 - r0) / STEP) as usize + 1;
    if n < 5 {
        return None;
    }
    let prof: Vec<f32> = (0..n)
        .map(|i| {
            let r = r0 + i as f64 * STEP;
            p.sample(c.cx + ux * r, c.cy + uy * r)
        })
        .collect();
    // Central differences, signed so the wanted edge is a maximum.
    let der: Vec<f32> = (1..n - 1)
        .map(|i| {
            let d = prof[i + 1] - prof[i - 1];
            sign.map_or(d.abs(), |s| s * d)
        })
        .collect();
    let m = der.iter().copied().fold(f32::MIN, f32::max);
    if !(m > 0.0) {
        return None;
    }
    // In a narrow window around a good circle the silhouette is the *outermost* clear step:
    // just inside the rim the ball shows reflected edges, compressed there, that can be much
    // stronger than the rim itself (a step of the ball's reflectance, often only 0.3 in log).
    // "Clear": above 0.04 (a 4 % change of luminance per ½ px) and above 4× the typical
    // change in the outer quarter of the window (the background's own texture and noise).
    // Relative to the strongest step it would not do: a reflected edge can be ten times the
    // rim's.
    let mut outer: Vec<f32> = der[der.len() * 3 / 4..].iter().map(|v| v.abs()).collect();
    outer.sort_by(|a, b| a.total_cmp(b));
    let t = (4.0 * outer[outer.len() / 2]).max(0.04).min(m);
    let k = (1..der.len() - 1)
        .rev()
        .find(|&i| der[i] >= t && der[i] >= der[i - 1] && der[i] >= der[i + 1])?;
    let (a, b, cc) = (der[k - 1] as f64, der[k] as f64, der[k + 1] as f64);
    let den = a - 2.0 * b + cc;
    let off = if den < 0.0 { 0.5 * (a - cc) / den } else { 0.0 };
    Some(r0 + (k as f64 + 1.0 + off.clamp(-1.0, 1.0)) * STEP)
}

/// The sign of the rim step (+1: brighter outside the ball) by majority of the profiles.
fn rim_sign(p: &Plane, c: &Circle, half: f64) -> f32 {
    let mut votes = 0i32;
    for i in 0..90 {
        let a = i as f64 * std::f64::consts::TAU / 90.0;
        let (ux, uy) = (a.cos(), a.sin());
        let inside = p.sample(c.cx + ux * (c.r - half), c.cy + uy * (c.r - half));
        let outside = p.sample(c.cx + ux * (c.r + half), c.cy + uy * (c.r + half));
        votes += if outside > inside { 1 } else { -1 };
    }
    if votes >= 0 {
        1.0
    } else {
        -1.0
    }
}

/// The edge position along a ray, refined in *linear* luminance: where the profile crosses
/// half-way between the levels just inside and just outside.  For a straight edge the pixels
/// are the box-filtered step, a linear ramp that bilinear interpolation reproduces, so the
/// crossing is the edge itself; the log-space extremum is biased toward the dark side.
fn linear_crossing(lin: &Plane, c: &Circle, angle: f64, r: f64) -> Option<f64> {
    let (ux, uy) = (angle.cos(), angle.sin());
    let at = |t: f64| lin.sample(c.cx + ux * t, c.cy + uy * t) as f64;
    // The nearest samples made of whole pixels on either side: a pixel whose centre is 1 px
    // or more from the edge lies wholly on one side, and bilinear at ±1.5 px reads only such.
    let (inside, outside) = (at(r - 1.5), at(r + 1.5));
    let mid = 0.5 * (inside + outside);
    if !((outside - inside).abs() > 1e-6 * (inside.abs() + outside.abs())) {
        return None;
    }
    const STEP: f64 = 0.05;
    let n = (3.0 / STEP) as usize;
    let mut prev = at(r - 1.5) - mid;
    for i in 1..=n {
        let t = r - 1.5 + i as f64 * STEP;
        let v = at(t) - mid;
        if (prev <= 0.0) != (v <= 0.0) {
            return Some(t - STEP * v / (v - prev));
        }
        prev = v;
    }
    None
}

pub(super) fn refine(p: &Plane, lin: &Plane, start: Circle) -> Result<CircleFit> {
    let mut c = start;
    let mut fit = None;
    // Windows: wide first (the coarse radius is good to a few coarse pixels), then narrow.
    // The first pass takes steps of either sign; the later ones only the sign of the rim
    // (measured across the first pass's circle: which side is brighter).
    let r0 = c.r;
    for (pass, half) in [(0.2 * r0).max(8.0), (0.05 * r0).max(5.0), 4.0, 2.5]
        .into_iter()
        .enumerate()
    {
        let sign = (pass > 1).then(|| rim_sign(p, &c, 1.5));
        let pts: Vec<[f64; 2]> = (0..RAYS)
            .filter_map(|i| {
                let a = i as f64 * std::f64::consts::TAU / RAYS as f64;
                let window = ((c.r - half).max(1.0), c.r + half);
                let r = edge_on_ray(p, &c, a, window, sign)?;
                let r = linear_crossing(lin, &c, a, r).unwrap_or(r);
                Some([c.cx + r * a.cos(), c.cy + r * a.sin()])
            })
            .collect();
        let f = robust_circle(&pts)
            .ok_or_else(|| Error::data("image", "could not fit a circle to the ball's edge"))?;
        c = f.circle;
        fit = Some(f);
    }
    let f = fit.expect("the passes ran");
    if !(f.circle.r > 2.0) {
        return Err(Error::data("image", "the fitted ball is smaller than 2 px"));
    }
    Ok(f)
}

/// Circle fit with outlier rejection (3 robust σ, twice).
pub fn robust_circle(pts: &[[f64; 2]]) -> Option<CircleFit> {
    let mut kept: Vec<[f64; 2]> = pts.to_vec();
    let mut c = fit_circle(&kept)?;
    for _ in 0..2 {
        let res: Vec<f64> = kept.iter().map(|p| residual(&c, p)).collect();
        let mut abs: Vec<f64> = res.iter().map(|r| r.abs()).collect();
        abs.sort_by(|a, b| a.total_cmp(b));
        let sigma = (1.4826 * abs[abs.len() / 2]).max(0.02);
        kept = kept
            .iter()
            .zip(&res)
            .filter(|(_, r)| r.abs() <= 3.0 * sigma)
            .map(|(p, _)| *p)
            .collect();
        c = fit_circle(&kept)?;
    }
    let rms =
        (kept.iter().map(|p| residual(&c, p).powi(2)).sum::<f64>() / kept.len() as f64).sqrt();
    Some(CircleFit {
        circle: c,
        rms,
        points: kept,
        confidence: 1.0,
        reflectance: None,
        uncertainty: None,
    })
}

fn residual(c: &Circle, p: &[f64; 2]) -> f64 {
    (p[0] - c.cx).hypot(p[1] - c.cy) - c.r
}

/// Least-squares circle: Kåsa's algebraic fit, then Gauss–Newton on the geometric distances.
pub fn fit_circle(pts: &[[f64; 2]]) -> Option<Circle> {
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p[0]).sum::<f64>() / n,
        pts.iter().map(|p| p[1]).sum::<f64>() / n,
    );
    // Kåsa on centred coordinates: x² + y² + D x + E y + F = 0.
    let mut m = [[0f64; 3]; 3];
    let mut b = [0f64; 3];
    for p in pts {
        let (x, y) = (p[0] - mx, p[1] - my);
        let row = [x, y, 1.0];
        let z = -(x * x + y * y);
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += row[i] * row[j];
            }
            b[i] += row[i] * z;
        }
    }
    let s = solve3(m, b)?;
    let (cx, cy) = (-0.5 * s[0], -0.5 * s[1]);
    let r2 = cx * cx + cy * cy - s[2];
    if !(r2 > 0.0) {
        return None;
    }
    let mut c = [cx, cy, r2.sqrt()];
    for _ in 0..20 {
        let mut jtj = [[0f64; 3]; 3];
        let mut jtr = [0f64; 3];
        for p in pts {
            let (dx, dy) = (p[0] - mx - c[0], p[1] - my - c[1]);
            let d = dx.hypot(dy).max(1e-12);
            let r = d - c[2];
            let j = [-dx / d, -dy / d, -1.0];
            for i in 0..3 {
                for k in 0..3 {
                    jtj[i][k] += j[i] * j[k];
                }
                jtr[i] += j[i] * r;
            }
        }
        let step = solve3(jtj, jtr)?;
        for i in 0..3 {
            c[i] -= step[i];
        }
        if step.iter().map(|v| v.abs()).fold(0.0, f64::max) < 1e-10 {
            break;
        }
    }
    (c[2] > 0.0 && c.iter().all(|v| v.is_finite())).then_some(Circle {
        cx: c[0] + mx,
        cy: c[1] + my,
        r: c[2],
    })
}

/// Solves a 3×3 system by Cramer's rule (`None` when singular).
pub(crate) fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |a: &[[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(&m);
    let scale = m.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
    if !(d.abs() > 1e-14 * scale.powi(3)) {
        return None;
    }
    let mut out = [0f64; 3];
    for k in 0..3 {
        let mut a = m;
        for i in 0..3 {
            a[i][k] = b[i];
        }
        out[k] = det(&a) / d;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A disc of value `a` on background `b`, anti-aliased by 8×8 supersampling.
    fn disc(w: usize, h: usize, c: Circle, a: f32, b: f32) -> Image {
        let mut img = Image::new(w, h, 1);
        for y in 0..h {
            for x in 0..w {
                let mut inside = 0;
                for k in 0..64 {
                    let px = x as f64 + ((k % 8) as f64 + 0.5) / 8.0;
                    let py = y as f64 + ((k / 8) as f64 + 0.5) / 8.0;
                    if (px - c.cx).hypot(py - c.cy) < c.r {
                        inside += 1;
                    }
                }
                let f = inside as f32 / 64.0;
                img.data[y * w + x] = a * f + b * (1.0 - f);
            }
        }
        img
    }

    #[test]
    fn fit_circle_exact_points() {
        let c = Circle {
            cx: 10.25,
            cy: -3.5,
            r: 7.75,
        };
        let pts: Vec<[f64; 2]> = (0..50)
            .map(|i| {
                let a = i as f64 * 0.37;
                [c.cx + c.r * a.cos(), c.cy + c.r * a.sin()]
            })
            .collect();
        let f = fit_circle(&pts).unwrap();
        assert!((f.cx - c.cx).abs() < 1e-9 && (f.cy - c.cy).abs() < 1e-9);
        assert!((f.r - c.r).abs() < 1e-9);
    }

    #[test]
    fn finds_a_disc_to_a_tenth_of_a_pixel() {
        for (c, a, b) in [
            (
                Circle {
                    cx: 160.3,
                    cy: 118.7,
                    r: 83.45,
                },
                0.3,
                0.9,
            ),
            (
                Circle {
                    cx: 140.0,
                    cy: 130.2,
                    r: 101.1,
                },
                0.8,
                0.2,
            ),
        ] {
            let img = disc(320, 240, c, a, b);
            let f = find_circle(&img, None).unwrap();
            let e = (f.circle.cx - c.cx)
                .abs()
                .max((f.circle.cy - c.cy).abs())
                .max((f.circle.r - c.r).abs());
            assert!(e < 0.1, "{:?} vs {c:?}: {e}", f.circle);
            assert!(f.rms < 0.1, "rms {}", f.rms);
        }
    }

    #[test]
    fn blank_image_is_an_error() {
        let img = Image::new(64, 64, 3);
        assert!(find_circle(&img, None).is_err());
        assert!(find_circle(&Image::new(8, 8, 1), None).is_err());
    }
}
