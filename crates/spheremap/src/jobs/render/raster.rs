//! Clipping, triangle setup in fixed point, and the band-parallel rasterizer (see the module
//! docs of `render` for the rules).

use super::shade::{Shader, NA};
use super::{RenderOptions, Vertices, SUB_BITS};
use crate::base::error::{Error, Result};
use crate::images::Image;
use rayon::prelude::*;

/// Units of the fixed-point window coordinates per pixel.
const SUB: f64 = (1 << SUB_BITS) as f64;

/// Refuses a snapping precision outside 1..=8 bits.
pub(crate) fn check_subpixel_bits(bits: u32) -> Result<()> {
    if (1..=SUB_BITS).contains(&bits) {
        Ok(())
    } else {
        Err(Error::param(
            "subpixel_bits",
            format!("{bits}: must be 1..={SUB_BITS}"),
        ))
    }
}
/// Guard band: x and y are clipped at ±GUARD·w, far outside the viewport, so clipping never
/// creates an edge inside the image and window coordinates stay small enough for i64 edge
/// functions.
const GUARD: f64 = 4.0;
/// Rows per parallel band.
const BAND: usize = 16;

/// A triangle ready to rasterize.
pub(crate) struct Tri {
    /// Index of the mesh triangle it comes from (clipping may make several).
    src: u32,
    /// Window position in 1/256 pixel, image rows (y down).
    x: [i64; 3],
    y: [i64; 3],
    /// Window depth and 1/w per vertex.
    z: [f64; 3],
    inv_w: [f64; 3],
    attr: [[f64; NA]; 3],
    /// Twice the area in fixed-point units² (positive).
    area: i64,
    /// Edge i (vertex i → i+1) owns samples exactly on it (top-left rule).
    owned: [bool; 3],
    /// Pixel bounds, inclusive.
    px0: usize,
    px1: usize,
    py0: usize,
    py1: usize,
}

/// A clip-space polygon vertex: clip coordinates and attributes.
type PV = ([f64; 4], [f64; NA]);

fn lerp_pv(a: &PV, b: &PV, t: f64) -> PV {
    (
        std::array::from_fn(|i| a.0[i] + t * (b.0[i] - a.0[i])),
        std::array::from_fn(|i| a.1[i] + t * (b.1[i] - a.1[i])),
    )
}

/// Signed distances to the six clip planes (inside ≥ 0).
fn plane_dist(c: &[f64; 4], plane: usize) -> f64 {
    let [x, y, z, w] = *c;
    match plane {
        0 => z + w, // near
        1 => w - z, // far
        2 => x + GUARD * w,
        3 => GUARD * w - x,
        4 => y + GUARD * w,
        _ => GUARD * w - y,
    }
}

/// Sutherland–Hodgman against the six planes; attributes interpolated linearly in clip space
/// (as GL clips).
fn clip_polygon(mut poly: Vec<PV>) -> Vec<PV> {
    for plane in 0..6 {
        if poly.is_empty() {
            break;
        }
        let mut out = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let a = &poly[i];
            let b = &poly[(i + 1) % poly.len()];
            let (da, db) = (plane_dist(&a.0, plane), plane_dist(&b.0, plane));
            if da >= 0.0 {
                out.push(*a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                out.push(lerp_pv(a, b, da / (da - db)));
            }
        }
        poly = out;
    }
    poly
}

/// Clips, projects, snaps and orients every triangle.
pub(crate) fn setup(
    triangles: &[[u32; 3]],
    v: &Vertices,
    width: usize,
    height: usize,
    subpixel_bits: u32,
) -> Result<Vec<Tri>> {
    check_subpixel_bits(subpixel_bits)?;
    let snap = 1i64 << (SUB_BITS - subpixel_bits);
    let n = v.clip.len();
    let pv = |i: u32| -> PV {
        let i = i as usize;
        let (e, nn, st) = (v.eye[i], v.normal[i], v.st[i]);
        (
            v.clip[i],
            [
                e[0],
                e[1],
                e[2],
                nn[0],
                nn[1],
                nn[2],
                st[0] as f64,
                st[1] as f64,
            ],
        )
    };
    const CHUNK: usize = 4096;
    let chunks: Vec<Vec<Tri>> = triangles
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut out = Vec::new();
            for (j, t) in chunk.iter().enumerate() {
                let src = (c * CHUNK + j) as u32;
                if t.iter().any(|&i| i as usize >= n) {
                    continue; // checked below
                }
                let p = [pv(t[0]), pv(t[1]), pv(t[2])];
                let inside = p.iter().all(|q| (0..6).all(|k| plane_dist(&q.0, k) >= 0.0));
                let poly = if inside {
                    p.to_vec()
                } else {
                    clip_polygon(p.to_vec())
                };
                for k in 1..poly.len().saturating_sub(1) {
                    if let Some(tri) =
                        make_tri(src, [&poly[0], &poly[k], &poly[k + 1]], width, height, snap)
                    {
                        out.push(tri);
                    }
                }
            }
            out
        })
        .collect();
    if let Some(t) = triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= n))
    {
        return Err(Error::param(
            "mesh",
            format!("triangle {t:?} indexes past the {n} vertices"),
        ));
    }
    Ok(chunks.into_iter().flatten().collect())
}

fn make_tri(src: u32, p: [&PV; 3], width: usize, height: usize, snap: i64) -> Option<Tri> {
    let (w, h) = (width as f64, height as f64);
    let unit = SUB / snap as f64;
    let mut x = [0i64; 3];
    let mut y = [0i64; 3];
    let mut z = [0f64; 3];
    let mut inv_w = [0f64; 3];
    for k in 0..3 {
        let c = &p[k].0;
        if !(c[3] > 0.0) {
            return None; // only on the near plane's edge after clipping: nothing to draw
        }
        let iw = 1.0 / c[3];
        // Viewport: x right, image rows down (GL's window y flipped).
        let xw = (c[0] * iw + 1.0) * 0.5 * w;
        let yw = (1.0 - c[1] * iw) * 0.5 * h;
        x[k] = (xw * unit).round() as i64 * snap;
        y[k] = (yw * unit).round() as i64 * snap;
        z[k] = (c[2] * iw + 1.0) * 0.5;
        inv_w[k] = iw;
    }
    let mut attr = [p[0].1, p[1].1, p[2].1];
    let mut area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
    if area == 0 {
        return None;
    }
    if area < 0 {
        x.swap(1, 2);
        y.swap(1, 2);
        z.swap(1, 2);
        inv_w.swap(1, 2);
        attr.swap(1, 2);
        area = -area;
    }
    // With E_ab(p) = (b − a) × (p − a) > 0 inside (y down), an edge is top (horizontal, the
    // interior below: dy = 0, dx > 0) or left (the interior to its right: dy < 0).
    let owned = std::array::from_fn(|i| {
        let j = (i + 1) % 3;
        let (dx, dy) = (x[j] - x[i], y[j] - y[i]);
        dy < 0 || (dy == 0 && dx > 0)
    });
    let sub = SUB as i64;
    let clampx = |v: i64| (v.max(0) / sub).min(width as i64 - 1) as usize;
    let clampy = |v: i64| (v.max(0) / sub).min(height as i64 - 1) as usize;
    let (xmin, xmax) = (*x.iter().min()?, *x.iter().max()?);
    let (ymin, ymax) = (*y.iter().min()?, *y.iter().max()?);
    if xmax < 0 || ymax < 0 || xmin > width as i64 * sub || ymin > height as i64 * sub {
        return None;
    }
    Some(Tri {
        src,
        x,
        y,
        z,
        inv_w,
        attr,
        area,
        owned,
        px0: clampx(xmin),
        px1: clampx(xmax),
        py0: clampy(ymin),
        py1: clampy(ymax),
    })
}

/// Sample offsets inside a pixel, in 1/256 pixel: a regular k × k grid.
fn offsets(aa: u32) -> Vec<(i64, i64)> {
    let k = aa as i64;
    let o = |i: i64| ((2 * i + 1) as f64 * SUB / (2 * k) as f64).round() as i64;
    let mut v = Vec::new();
    for j in 0..k {
        for i in 0..k {
            v.push((o(i), o(j)));
        }
    }
    v
}

/// Rasterizes `tris` and shades the visible samples; returns the image and the number of
/// covered pixels.
pub(crate) fn draw(
    tris: &[Tri],
    shader: &Shader,
    width: usize,
    height: usize,
    opts: &RenderOptions,
) -> Result<(Image, usize)> {
    let c = opts.mode.channels();
    let offs = offsets(opts.aa);
    let ns = offs.len();
    // The image, and per band in flight a depth (8 bytes), a triangle id (4) and two
    // barycentrics (16) per sample.
    crate::base::limits::check_memory(
        "size",
        (width * height * c * 4) as u128
            + (width * BAND * ns * 28 * rayon::current_num_threads()) as u128,
        crate::base::limits::default_max_memory(),
    )?;
    let bins = bin_triangles(tris, height);
    let mut img = Image::new(width, height, c);
    let covered: usize = img
        .data
        .par_chunks_mut(width * c * BAND)
        .zip(bins.par_iter())
        .enumerate()
        .map(|(b, (out, bin))| {
            let y0 = b * BAND;
            let rows = out.len() / (width * c);
            draw_band(tris, bin, shader, width, y0, rows, &offs, opts, out)
        })
        .sum();
    Ok((img, covered))
}

#[allow(clippy::too_many_arguments)]
fn draw_band(
    tris: &[Tri],
    bin: &[u32],
    shader: &Shader,
    width: usize,
    y0: usize,
    rows: usize,
    offs: &[(i64, i64)],
    opts: &RenderOptions,
    out: &mut [f32],
) -> usize {
    let ns = offs.len();
    let (id, bary) = visibility(tris, bin, width, y0, rows, offs);
    let c = opts.mode.channels();
    let mut covered = 0;
    let mut sample = [0f32; 3];
    let bg = opts.background;
    let error = shader.is_error();
    for p in 0..width * rows {
        let mut acc = [0f32; 3];
        let mut hits = 0;
        for s in 0..ns {
            let k = p * ns + s;
            if id[k] == u32::MAX {
                if !error {
                    for ch in 0..c {
                        acc[ch] += bg[ch];
                    }
                }
                continue;
            }
            hits += 1;
            let t = &tris[id[k] as usize];
            let [l0, l1] = bary[k];
            let l = [l0, l1, 1.0 - l0 - l1];
            let q: [f64; 3] = std::array::from_fn(|i| l[i] * t.inv_w[i]);
            let qs = 1.0 / (q[0] + q[1] + q[2]);
            let a: [f64; NA] = std::array::from_fn(|i| {
                (q[0] * t.attr[0][i] + q[1] * t.attr[1][i] + q[2] * t.attr[2][i]) * qs
            });
            shader.shade(&a, &mut sample[..c]);
            for ch in 0..c {
                acc[ch] += sample[ch];
            }
        }
        if hits > 0 {
            covered += 1;
        }
        let o = &mut out[p * c..(p + 1) * c];
        if error {
            // Degrees: the mean over the covered samples (0 where none); then the coverage.
            o[0] = if hits > 0 { acc[0] / hits as f32 } else { 0.0 };
            o[1] = hits as f32 / ns as f32;
        } else {
            for ch in 0..c {
                o[ch] = acc[ch] / ns as f32;
            }
        }
    }
    covered
}

/// The visible triangle and its barycentrics (vertices 0 and 1) at every sample of a band of
/// `rows` rows from `y0` (`u32::MAX`: none).
fn visibility(
    tris: &[Tri],
    bin: &[u32],
    width: usize,
    y0: usize,
    rows: usize,
    offs: &[(i64, i64)],
) -> (Vec<u32>, Vec<[f64; 2]>) {
    let ns = offs.len();
    let n = width * rows * ns;
    let mut depth = vec![1.0f64; n];
    let mut id = vec![u32::MAX; n];
    let mut bary = vec![[0f64; 2]; n];
    let sub = SUB as i64;
    for &ti in bin {
        let t = &tris[ti as usize];
        let (ya, yb) = (t.py0.max(y0), t.py1.min(y0 + rows - 1));
        let e = |i: usize, px: i64, py: i64| -> i64 {
            let j = (i + 1) % 3;
            (t.x[j] - t.x[i]) * (py - t.y[i]) - (t.y[j] - t.y[i]) * (px - t.x[i])
        };
        let inv_area = 1.0 / t.area as f64;
        for py in ya..=yb {
            for px in t.px0..=t.px1 {
                for (s, &(ox, oy)) in offs.iter().enumerate() {
                    let (fx, fy) = (px as i64 * sub + ox, py as i64 * sub + oy);
                    let e0 = e(0, fx, fy);
                    let e1 = e(1, fx, fy);
                    let e2 = e(2, fx, fy);
                    let inside = |e: i64, k: usize| e > 0 || (e == 0 && t.owned[k]);
                    if !(inside(e0, 0) && inside(e1, 1) && inside(e2, 2)) {
                        continue;
                    }
                    // λ of vertex 2 is E_01/A, of 0 is E_12/A, of 1 is E_20/A.
                    let l0 = e1 as f64 * inv_area;
                    let l1 = e2 as f64 * inv_area;
                    let l2 = e0 as f64 * inv_area;
                    let zz = l0 * t.z[0] + l1 * t.z[1] + l2 * t.z[2];
                    let k = ((py - y0) * width + px) * ns + s;
                    if zz < depth[k] {
                        depth[k] = zz;
                        id[k] = ti;
                        bary[k] = [l0, l1];
                    }
                }
            }
        }
    }
    (id, bary)
}

/// The triangles touching each band of rows.
fn bin_triangles(tris: &[Tri], height: usize) -> Vec<Vec<u32>> {
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); height.div_ceil(BAND)];
    for (i, t) in tris.iter().enumerate() {
        for bin in &mut bins[t.py0 / BAND..=t.py1 / BAND] {
            bin.push(i as u32);
        }
    }
    bins
}

/// Per pixel, the index of the mesh triangle seen through its centre (`u32::MAX`: none).
pub(crate) fn triangle_ids(tris: &[Tri], width: usize, height: usize) -> Vec<u32> {
    let offs = offsets(1);
    let bins = bin_triangles(tris, height);
    let mut out = vec![u32::MAX; width * height];
    out.par_chunks_mut(width * BAND)
        .zip(bins.par_iter())
        .enumerate()
        .for_each(|(b, (o, bin))| {
            let rows = o.len() / width;
            let (id, _) = visibility(tris, bin, width, b * BAND, rows, &offs);
            for (dst, i) in o.iter_mut().zip(id) {
                if i != u32::MAX {
                    *dst = tris[i as usize].src;
                }
            }
        });
    out
}
