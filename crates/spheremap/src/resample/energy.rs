//! The light a map carries, and how much of a source's light an output kept.
//!
//! A map's **power** per channel is Σ L·dω over its texels with the mapping's exact texel
//! solid angles (over the disc for disc mappings: texels off the map weigh 0).  Its SH9
//! irradiance depends on the radiance only through its moments up to the second, Σ L dω,
//! Σ L d dω and Σ L d dᵀ dω (the spherical harmonics of bands 0–2 span the polynomials of
//! degree ≤ 2 on the sphere).  With P_l the Legendre polynomials and the cosine lobe's band
//! factors A₀ = π, A₁ = 2π/3, A₂ = π/4, the band-l projection at n is
//! (2l + 1)/4π ∫ L(d) P_l(d·n) dω, which gives
//!
//! ```text
//!   E(n) = M₀/4 + M₁·n/2 + (5/32)(3 nᵀM₂n − M₀)
//! ```
//!
//! — the same irradiance as [`crate::lighting::sh::Sh9::irradiance`] of the map's projection
//! (tested against it).  [`LightCheck`] compares an output with its source: the relative
//! power error per channel and the largest SH9 irradiance difference over 642 directions, in
//! units of the source's mean irradiance π L̄ (the unit the irradiance tolerances use).

use super::EnvMap;
use crate::base::error::{Error, Result};
use crate::frame::conventions::mat3_mul;
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use rayon::prelude::*;
use serde::Serialize;

/// The light channels of a map with `channels` channels: RGB of 3 or 4 (an alpha channel
/// carries none), else the first.
pub fn light_channels(channels: usize) -> usize {
    if channels >= 3 {
        3
    } else {
        1
    }
}

/// A map's radiance moments per light channel, its directions turned by a rotation.
#[derive(Clone, Debug, PartialEq)]
pub struct Moments {
    /// Light channels (see [`light_channels`]).
    pub channels: usize,
    /// Σ L dω per channel: the power.
    pub m0: [f64; 3],
    /// Σ L d dω per channel.
    pub m1: [[f64; 3]; 3],
    /// Σ L d dᵀ dω per channel: xx, yy, zz, xy, xz, yz.
    pub m2: [[f64; 6]; 3],
    /// Σ dω (4π, to quadrature rounding).
    pub solid_angle: f64,
}

impl Moments {
    /// The moments of `env` in f64, each texel centre's direction `d` taken as `rotation`·d.
    pub fn of(env: &EnvMap, rotation: &[[f64; 3]; 3]) -> Moments {
        let (w, h, c) = (env.width, env.height, env.channels);
        let lc = light_channels(c);
        let rows = env.mapping.texel_rows(w, h);
        type Acc = ([f64; 3], [[f64; 3]; 3], [[f64; 6]; 3], f64);
        let zero: Acc = ([0.0; 3], [[0.0; 3]; 3], [[0.0; 6]; 3], 0.0);
        // Per row, in order (the sums do not depend on the threads).
        let per_row: Vec<Acc> = (0..h)
            .into_par_iter()
            .with_min_len(4)
            .map_init(Vec::new, |texels, y| {
                let mut a = zero;
                rows.row(y, texels);
                let row = &env.data[y * w * c..(y + 1) * w * c];
                for (x, (px, &(om, dir))) in row.chunks_exact(c).zip(texels.iter()).enumerate() {
                    if !(om > 0.0) {
                        continue;
                    }
                    // A rim texel whose centre is off its disc: the mean direction of its
                    // part on the map.
                    let Some(d0) = dir.or_else(|| on_map_direction(env.mapping, x, y, w, h)) else {
                        continue;
                    };
                    let d = mat3_mul(rotation, d0);
                    let q = [
                        d[0] * d[0],
                        d[1] * d[1],
                        d[2] * d[2],
                        d[0] * d[1],
                        d[0] * d[2],
                        d[1] * d[2],
                    ];
                    a.3 += om;
                    for k in 0..lc {
                        let l = px[k] as f64 * om;
                        a.0[k] += l;
                        for i in 0..3 {
                            a.1[k][i] += l * d[i];
                        }
                        for i in 0..6 {
                            a.2[k][i] += l * q[i];
                        }
                    }
                }
                a
            })
            .collect();
        let (mut m0, mut m1, mut m2, mut sa) = zero;
        for a in &per_row {
            for k in 0..3 {
                m0[k] += a.0[k];
                (0..3).for_each(|i| m1[k][i] += a.1[k][i]);
                (0..6).for_each(|i| m2[k][i] += a.2[k][i]);
            }
            sa += a.3;
        }
        Moments {
            channels: lc,
            m0,
            m1,
            m2,
            solid_angle: sa,
        }
    }

    /// The power Σ L dω of each light channel.
    pub fn power(&self) -> Vec<f64> {
        self.m0[..self.channels].to_vec()
    }

    /// The irradiance at unit normal `n` that the map's SH9 projection gives, per channel.
    pub fn irradiance(&self, n: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| {
            let (m1, m2) = (self.m1[k], self.m2[k]);
            let quad = m2[0] * n[0] * n[0]
                + m2[1] * n[1] * n[1]
                + m2[2] * n[2] * n[2]
                + 2.0 * (m2[3] * n[0] * n[1] + m2[4] * n[0] * n[2] + m2[5] * n[1] * n[2]);
            let dot = m1[0] * n[0] + m1[1] * n[1] + m1[2] * n[2];
            self.m0[k] / 4.0 + dot / 2.0 + 5.0 / 32.0 * (3.0 * quad - self.m0[k])
        })
    }
}

/// The canvas (u, v) of the centres of a g×g grid over texel (x, y) of a `w`×`h` canvas.
pub(crate) fn texel_points(
    x: usize,
    y: usize,
    (w, h): (usize, usize),
    g: usize,
) -> impl Iterator<Item = [f64; 2]> {
    (0..g * g).map(move |i| {
        let (a, b) = (i % g, i / g);
        [
            (x as f64 + (a as f64 + 0.5) / g as f64) / w as f64,
            (y as f64 + (b as f64 + 0.5) / g as f64) / h as f64,
        ]
    })
}

/// The normalized mean direction of the part of texel (x, y) on the map (16×16 points), or
/// `None` where no point is.
fn on_map_direction(
    m: crate::mappings::mapping::Mapping,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
) -> Option<[f64; 3]> {
    let mut s = [0f64; 3];
    for uv in texel_points(x, y, (w, h), 16) {
        if let Some(d) = m.uv_to_dir(uv) {
            let wt = m.density(uv);
            (0..3).for_each(|i| s[i] += wt * d[i]);
        }
    }
    let l = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    (l > 0.0).then(|| s.map(|v| v / l))
}

/// How much of a source's light an output kept (`--json`'s `light`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LightCheck {
    /// Σ L dω per light channel of the source and of the output.
    pub source_power: Vec<f64>,
    pub power: Vec<f64>,
    /// (output − source) / source per channel (0 where the source's is 0).
    pub power_error: Vec<f64>,
    /// The largest |ΔE(n)| of the SH9 irradiance over 642 directions and the channels, in
    /// units of the source's mean irradiance π L̄ of that channel; `None` where the output is
    /// not meant to hold the source's irradiance (a blurred prefilter level).
    pub irradiance_error: Option<f64>,
}

impl LightCheck {
    /// Compares `output`'s power with `source`'s, not the irradiance.
    pub fn power_only(source: &Moments, output: &Moments) -> LightCheck {
        LightCheck {
            irradiance_error: None,
            ..Self::compare(source, output)
        }
    }

    /// Compares `output`'s moments (in the source's frame) with `source`'s.
    pub fn compare(source: &Moments, output: &Moments) -> LightCheck {
        let lc = source.channels.min(output.channels);
        let rel = |a: f64, b: f64| if a != 0.0 { (b - a) / a } else { 0.0 };
        let mut worst = 0f64;
        for n in directions() {
            let (es, eo) = (source.irradiance(n), output.irradiance(n));
            for k in 0..lc {
                // π L̄ = π Σ L dω / 4π.
                let unit = source.m0[k] / 4.0;
                if unit > 0.0 {
                    worst = worst.max((eo[k] - es[k]).abs() / unit);
                }
            }
        }
        LightCheck {
            source_power: source.power()[..lc].to_vec(),
            power: output.power()[..lc].to_vec(),
            power_error: (0..lc).map(|k| rel(source.m0[k], output.m0[k])).collect(),
            irradiance_error: Some(worst),
        }
    }

    /// The power error of largest magnitude over the channels, with its sign.
    pub fn worst_signed_power_error(&self) -> f64 {
        self.power_error
            .iter()
            .fold(0f64, |a, &e| if e.abs() > a.abs() { e } else { a })
    }
}

/// A `mapping` canvas `m` times coarser than `fine` (its sides multiples of `m`), each texel
/// the solid-angle-weighted mean of its m×m children (their plain mean where none is on the
/// map), so that it holds their light: the power Σ L·dω of the two canvases is the same, as
/// far as the children's solid angles add up to their parent's (exactly for cube faces,
/// lat-long rows and the octahedral map).  With `m` = 1, `fine` itself.
pub fn reduce(mapping: Mapping, fine: Image, m: usize) -> Image {
    assert!(m >= 1 && fine.width % m == 0 && fine.height % m == 0);
    if m == 1 {
        return fine;
    }
    let (fw, fh, c) = (fine.width, fine.height, fine.channels);
    let (w, h) = (fw / m, fh / m);
    let omega = mapping.solid_angles(fw, fh);
    let mut out = Image::new(w, h, c);
    out.data
        .par_chunks_mut(w * c)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                let mut acc = vec![0.0f64; c];
                let mut plain = vec![0.0f64; c];
                let mut wsum = 0.0;
                for fy in y * m..(y + 1) * m {
                    for fx in x * m..(x + 1) * m {
                        let at = fy * fw + fx;
                        let o = omega[at];
                        wsum += o;
                        for k in 0..c {
                            let v = fine.data[at * c + k] as f64;
                            acc[k] += v * o;
                            plain[k] += v;
                        }
                    }
                }
                for k in 0..c {
                    row[x * c + k] = if wsum > 0.0 {
                        (acc[k] / wsum) as f32
                    } else {
                        (plain[k] / (m * m) as f64) as f32
                    };
                }
            }
        });
    out
}

/// Adds a sun to `img` (a canvas of `mapping`): a disc of `diameter_deg` degrees toward unit
/// direction `dir` (the map's frame), of uniform radiance, holding `fraction` of the result's
/// power in each light channel.  Texels are covered by 8×8 points each.  For tests and
/// measurements of how outputs keep small bright sources.
pub fn add_sun(
    img: &mut Image,
    mapping: Mapping,
    dir: [f64; 3],
    diameter_deg: f64,
    fraction: f64,
) -> Result<()> {
    if !(0.0..1.0).contains(&fraction) {
        return Err(Error::param(
            "fraction",
            format!("{fraction} is not in [0, 1)"),
        ));
    }
    if !(diameter_deg > 0.0 && diameter_deg < 180.0) {
        return Err(Error::param(
            "diameter",
            format!("{diameter_deg}° is not in (0, 180)"),
        ));
    }
    let (w, h, c) = (img.width, img.height, img.channels);
    let power = {
        let env = EnvMap::new(mapping, img, "map")?;
        Moments::of(&env, &super::IDENTITY).m0
    };
    let cos_r = (diameter_deg.to_radians() / 2.0).cos();
    const G: usize = 8;
    let cover: Vec<f64> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let n = texel_points(x, y, (w, h), G)
                .filter_map(|uv| mapping.uv_to_dir(uv))
                .filter(|d| d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2] >= cos_r)
                .count();
            n as f64 / (G * G) as f64 * mapping.texel_solid_angle(x, y, w, h)
        })
        .collect();
    let sun_sa: f64 = cover.iter().sum();
    if !(sun_sa > 0.0) {
        return Err(Error::param("diameter", "the sun covers no texel's points"));
    }
    for k in 0..light_channels(c) {
        // Radiance × solid angle per texel, as radiance: ∝ covered solid angle / texel's.
        let add = fraction / (1.0 - fraction) * power[k] / sun_sa;
        for (i, &f) in cover.iter().enumerate() {
            if f > 0.0 {
                let om = mapping.texel_solid_angle(i % w, i / w, w, h);
                img.data[i * c + k] += (add * f / om) as f32;
            }
        }
    }
    Ok(())
}

/// 642 directions: a twice-subdivided icosahedron's vertices, normalized.
fn directions() -> Vec<[f64; 3]> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let norm = |p: [f64; 3]| {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        p.map(|x| x / l)
    };
    v.iter_mut().for_each(|p| *p = norm(*p));
    for _ in 0..3 {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(f.len() * 4);
        for t in &f {
            let mut m = [0usize; 3];
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[e] = *mid.entry(key).or_insert_with(|| {
                    v.push(norm(std::array::from_fn(|i| v[a][i] + v[b][i])));
                    v.len() - 1
                });
            }
            next.extend([
                [t[0], m[0], m[2]],
                [t[1], m[1], m[0]],
                [t[2], m[2], m[1]],
                m,
            ]);
        }
        f = next;
    }
    v
}
