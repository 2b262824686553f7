//! Order-2 spherical harmonics (9 coefficients per channel) of an environment's radiance, and
//! the irradiance they imply (Ramamoorthi & Hanrahan 2001), in the conventions of three.js and
//! Filament.
//!
//! ## The basis and the coefficients
//!
//! Real SH in the world frame (+Y up, right-handed), in three.js's order and normalization
//! (`SphericalHarmonics3`): for a unit direction (x, y, z)
//!
//! | i | (l, m) | yᵢ |
//! |---|---|---|
//! | 0 | (0, 0) | 0.282095 |
//! | 1 | (1, −1) | 0.488603 y |
//! | 2 | (1, 0) | 0.488603 z |
//! | 3 | (1, 1) | 0.488603 x |
//! | 4 | (2, −2) | 1.092548 xy |
//! | 5 | (2, −1) | 1.092548 yz |
//! | 6 | (2, 0) | 0.315392 (3z² − 1) |
//! | 7 | (2, 1) | 1.092548 xz |
//! | 8 | (2, 2) | 0.546274 (x² − y²) |
//!
//! (the exact constants: ½√(1/π), ½√(3/π), ½√(15/π), ¼√(5/π), ¼√(15/π)).  The radiance
//! coefficients are Lᵢ = ∫ L(ω) yᵢ(ω) dω, summed over the map's texels with their exact solid
//! angles; a white map of radiance 1 has L₀ = 4π · ½√(1/π) = 2√π.  The irradiance is
//! E(n) = Σ Âₗ Lᵢ yᵢ(n) with Â₀ = π, Â₁ = 2π/3, Â₂ = π/4: three.js's
//! `SphericalHarmonics3.getIrradianceAt` (whose coefficients, and `LightProbe.sh`'s, are the Lᵢ).
//!
//! Filament's shader (`Irradiance_SphericalHarmonics`, the `sh.txt` that `cmgen --sh-shader`
//! writes) evaluates E(n)/π = Σ sᵢ pᵢ(n) with the bare polynomials pᵢ = (1, y, z, x, yx, yz,
//! 3z² − 1, zx, x² − y²); its pre-scaled coefficients are sᵢ = Âₗ Lᵢ cᵢ / π, cᵢ the constants
//! of yᵢ above.
//!
//! ## Windowing
//!
//! A bright small source rings: the 9-term irradiance dips below zero opposite it.  The window
//! of Filament (`--sh-window`, after Sloan's "Deringing spherical harmonics") scales band l by
//! (sin x / x)⁴ with x = πl/w; `w` is given, or found per channel (the largest w, by bisection,
//! for which the windowed irradiance has no negative value on a dense set of directions).

use crate::base::error::{Error, Result};
use crate::mappings::mapping::Mapping;
use crate::resample::EnvMap;
use rayon::prelude::*;
use std::f64::consts::PI;

/// The nine basis functions at unit `d` (three.js's order and constants, exact).
#[inline]
pub fn basis(d: [f64; 3]) -> [f64; 9] {
    let [x, y, z] = d;
    let c0 = 0.5 * (1.0 / PI).sqrt();
    let c1 = 0.5 * (3.0 / PI).sqrt();
    let c2 = 0.5 * (15.0 / PI).sqrt();
    let c20 = 0.25 * (5.0 / PI).sqrt();
    let c22 = 0.25 * (15.0 / PI).sqrt();
    [
        c0,
        c1 * y,
        c1 * z,
        c1 * x,
        c2 * x * y,
        c2 * y * z,
        c20 * (3.0 * z * z - 1.0),
        c2 * x * z,
        c22 * (x * x - y * y),
    ]
}

/// The constants cᵢ of the basis (yᵢ = cᵢ pᵢ).
pub fn constants() -> [f64; 9] {
    let c0 = 0.5 * (1.0 / PI).sqrt();
    let c1 = 0.5 * (3.0 / PI).sqrt();
    let c2 = 0.5 * (15.0 / PI).sqrt();
    [
        c0,
        c1,
        c1,
        c1,
        c2,
        c2,
        0.25 * (5.0 / PI).sqrt(),
        c2,
        0.25 * (15.0 / PI).sqrt(),
    ]
}

/// The band of coefficient i.
pub fn band(i: usize) -> usize {
    match i {
        0 => 0,
        1..=3 => 1,
        _ => 2,
    }
}

/// The cosine lobe's band factors Âₗ.
pub const COSINE: [f64; 3] = [PI, 2.0 * PI / 3.0, PI / 4.0];

/// Nine radiance coefficients per channel (up to 3 channels; grey maps fill the first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sh9 {
    pub coefficients: [[f64; 3]; 9],
    /// 1 or 3.
    pub channels: usize,
}

impl Sh9 {
    /// Projects `env` (its frame is turned into the world's by `world_to_env`ᵀ) onto the basis:
    /// L̄ ∫ yᵢ dω (exact: 2√π L̄ for i = 0, else 0) plus the sum over its texels of
    /// (L − L̄) · yᵢ(d) · dω, L̄ the map's mean radiance.  So a constant map gives exactly
    /// its constant's coefficients, whatever the texel quadrature's error.
    ///
    /// A lat-long map (any preset) takes the fast path: the basis is a polynomial of degree 2
    /// in d, so the coefficients are fixed combinations of the radiance's moments Σ L dω,
    /// Σ L d dω and Σ L d dᵀ dω; with d = cos θ P + sin θ (aₓ E₁ + bₓ E₂) those come from six
    /// sums per row (Σ L, Σ L a, Σ L b, Σ L a², Σ L ab, Σ L b², in f32 over runs of
    /// [`RUN`] texels, added in f64).  [`Sh9::project_reference`] sums the basis texel by texel
    /// in f64; the two agree to about 1e-6 of L₀ (tested).
    pub fn project(env: &EnvMap, world_to_env: &[[f64; 3]; 3]) -> Result<Sh9> {
        let geometry = Geometry::new(env.mapping, env.width, env.height, world_to_env);
        let sums = match geometry.plane() {
            Some(plane) => moment_sums(env, &geometry, &plane),
            None => texel_sums(env, &geometry),
        };
        finish(&sums, super::envtree::light_channels(env.channels))
    }

    /// [`Sh9::project`] texel by texel in f64 (every mapping): the reference of the fast path.
    pub fn project_reference(env: &EnvMap, world_to_env: &[[f64; 3]; 3]) -> Result<Sh9> {
        let geometry = Geometry::new(env.mapping, env.width, env.height, world_to_env);
        finish(
            &texel_sums(env, &geometry),
            super::envtree::light_channels(env.channels),
        )
    }

    /// The radiance the coefficients reconstruct in direction `d` (three.js `getAt`).
    pub fn radiance(&self, d: [f64; 3]) -> [f64; 3] {
        let b = basis(d);
        let mut out = [0.0; 3];
        for i in 0..9 {
            for k in 0..3 {
                out[k] += self.coefficients[i][k] * b[i];
            }
        }
        out
    }

    /// The irradiance at normal `n` (three.js `getIrradianceAt`).
    pub fn irradiance(&self, n: [f64; 3]) -> [f64; 3] {
        let b = basis(n);
        let mut out = [0.0; 3];
        for i in 0..9 {
            for k in 0..3 {
                out[k] += COSINE[band(i)] * self.coefficients[i][k] * b[i];
            }
        }
        out
    }

    /// The coefficients pre-scaled for Filament's shader: sᵢ = Âₗ Lᵢ cᵢ / π.
    pub fn filament(&self) -> [[f64; 3]; 9] {
        let c = constants();
        let mut s = [[0.0; 3]; 9];
        for i in 0..9 {
            for k in 0..3 {
                s[i][k] = COSINE[band(i)] * self.coefficients[i][k] * c[i] / PI;
            }
        }
        s
    }

    /// `sh.txt` as `cmgen --sh-shader` writes it.
    pub fn filament_txt(&self) -> String {
        const NAMES: [&str; 9] = [
            "L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22",
        ];
        let s = self.filament();
        let mut out = String::new();
        for i in 0..9 {
            let v = if self.channels == 3 {
                s[i]
            } else {
                [s[i][0]; 3]
            };
            out.push_str(&format!(
                "({:18.15}, {:18.15}, {:18.15}); // {}, irradiance, pre-scaled base\n",
                v[0], v[1], v[2], NAMES[i]
            ));
        }
        out
    }

    /// The coefficients with band l scaled by Filament's window (sin x / x)⁴, x = πl/w.
    pub fn windowed(&self, w: f64) -> Sh9 {
        let mut out = *self;
        for i in 0..9 {
            let f = window(band(i), w);
            for k in 0..3 {
                out.coefficients[i][k] *= f;
            }
        }
        out
    }

    /// The window size that removes negative irradiance: per channel, the largest w in
    /// [3, 13] (by bisection, as Filament's auto window) whose windowed irradiance is ≥ 0 on a
    /// dense set of directions; the smallest over the channels.  13 (barely windowed) when none
    /// is negative.
    pub fn auto_window(&self) -> f64 {
        let dirs = fibonacci(2048);
        let negative = |sh: &Sh9, k: usize| dirs.iter().any(|&d| sh.irradiance(d)[k] < 0.0);
        let mut cutoff: f64 = 13.0;
        for k in 0..self.channels {
            let (mut lo, mut hi) = (3.0f64, cutoff);
            if !negative(&self.windowed(hi), k) {
                continue;
            }
            for _ in 0..16 {
                if lo + 0.1 >= hi {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                if negative(&self.windowed(mid), k) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            cutoff = cutoff.min(lo);
        }
        cutoff
    }
}

/// Σ L yᵢ dω, Σ yᵢ dω, Σ L dω and Σ dω over a map.
#[derive(Clone, Copy)]
struct Sums {
    ly: [[f64; 3]; 9],
    y: [f64; 9],
    l: [f64; 3],
    omega: f64,
}

const ZERO: Sums = Sums {
    ly: [[0.0; 3]; 9],
    y: [0.0; 9],
    l: [0.0; 3],
    omega: 0.0,
};

/// Lᵢ = L̄ ∫ yᵢ dω (exact) + Σ (L − L̄) yᵢ dω = L̄ exactᵢ + Σ L yᵢ dω − L̄ Σ yᵢ dω.
fn finish(t: &Sums, lc: usize) -> Result<Sh9> {
    let mean = [0, 1, 2].map(|k| t.l[k] / t.omega);
    let mut coefficients = [[0.0; 3]; 9];
    for i in 0..9 {
        let exact = if i == 0 { 2.0 * PI.sqrt() } else { 0.0 };
        for k in 0..lc {
            coefficients[i][k] = mean[k] * exact + t.ly[i][k] - mean[k] * t.y[i];
        }
    }
    if coefficients.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::param(
            "env",
            "its spherical harmonics are not finite (the map holds Inf or NaN)",
        ));
    }
    Ok(Sh9 {
        coefficients,
        channels: lc,
    })
}

/// The sums texel by texel, in f64.
fn texel_sums(env: &EnvMap, geometry: &Geometry) -> Sums {
    let (w, h, c) = (env.width, env.height, env.channels);
    let lc = super::envtree::light_channels(c);
    let rows: Vec<Sums> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut a = ZERO;
            for x in 0..w {
                let Some((d, dw)) = geometry.at(x, y) else {
                    continue;
                };
                let b = basis(d);
                let p = &env.data[(y * w + x) * c..];
                for i in 0..9 {
                    a.y[i] += b[i] * dw;
                }
                a.omega += dw;
                for k in 0..lc {
                    let l = p[k] as f64 * dw;
                    a.l[k] += l;
                    for i in 0..9 {
                        a.ly[i][k] += l * b[i];
                    }
                }
            }
            a
        })
        .collect();
    let mut t = ZERO;
    for r in &rows {
        for i in 0..9 {
            t.y[i] += r.y[i];
            for k in 0..3 {
                t.ly[i][k] += r.ly[i][k];
            }
        }
        for k in 0..3 {
            t.l[k] += r.l[k];
        }
        t.omega += r.omega;
    }
    t
}

/// Texels summed in f32 before the sum goes to f64 (short enough that f32's rounding stays
/// near 1e-6 of the run's sum).
pub const RUN: usize = 64;

/// A lat-long's equator plane: E₁, E₂ (world frame; P × E₁ = E₂) and each column's
/// coordinates (aₓ, bₓ) in it with their products.
struct Plane {
    e1: [f64; 3],
    e2: [f64; 3],
    /// Per column: a, b, a², ab.
    cols: Vec<[f32; 4]>,
}

/// Per row and light channel: Σ L, Σ L a, Σ L b, Σ L a², Σ L ab, Σ L b².
type RowSums = [[f64; 6]; 3];

/// One row's six sums per light channel, `C` values per texel (the first `lc` light): each
/// texel's channels are one 4-lane vector, weighed by its column's a, b, a², ab and summed in
/// f32 over runs of [`RUN`] texels, each run's sums added in f64; Σ L b² = Σ L − Σ L a²
/// (a² + b² = 1).
fn row_sums<const C: usize>(row: &[f32], cols: &[[f32; 4]], lc: usize) -> RowSums {
    let mut out = [[0.0f64; 6]; 3];
    for (run, weights) in row.chunks(RUN * C).zip(cols.chunks(RUN)) {
        let mut acc = [[0.0f32; 4]; 5];
        for (px, w) in run.chunks_exact(C).zip(weights) {
            let mut v = [0.0f32; 4];
            v[..C.min(4)].copy_from_slice(&px[..C.min(4)]);
            for i in 0..4 {
                acc[0][i] += v[i];
                acc[1][i] += v[i] * w[0];
                acc[2][i] += v[i] * w[1];
                acc[3][i] += v[i] * w[2];
                acc[4][i] += v[i] * w[3];
            }
        }
        for k in 0..lc {
            for j in 0..5 {
                out[k][j] += acc[j][k] as f64;
            }
        }
    }
    for o in out.iter_mut() {
        o[5] = o[0] - o[3];
    }
    out
}

/// The sums of a lat-long from its moments ([`Sh9::project`]'s fast path).
fn moment_sums(env: &EnvMap, geometry: &Geometry, plane: &Plane) -> Sums {
    let (w, c) = (env.width, env.channels);
    let lc = super::envtree::light_channels(c);
    let sums_of = |row: &[f32]| -> RowSums {
        match c {
            1 => row_sums::<1>(row, &plane.cols, lc),
            2 => row_sums::<2>(row, &plane.cols, lc),
            3 => row_sums::<3>(row, &plane.cols, lc),
            _ => row_sums::<4>(row, &plane.cols, lc),
        }
    };
    // The geometry's own sums: a row of ones through the same arithmetic (channel 0), so
    // that a constant map's Σ L yᵢ dω − L̄ Σ yᵢ dω cancels exactly.
    let ones = sums_of(&vec![1.0f32; w * c])[0];
    // Local moments about (u, v, w) = (cos θ, sin θ a, sin θ b): N₀, N_u, N_v, N_w, N_uu,
    // N_uv, N_uw, N_vv, N_vw, N_ww, per channel (3 light channels, then the geometry's).
    let local = |dw: f64, cs: f64, sn: f64, s: &[f64; 6]| -> [f64; 10] {
        [
            dw * s[0],
            dw * cs * s[0],
            dw * sn * s[1],
            dw * sn * s[2],
            dw * cs * cs * s[0],
            dw * cs * sn * s[1],
            dw * cs * sn * s[2],
            dw * sn * sn * s[3],
            dw * sn * sn * s[4],
            dw * sn * sn * s[5],
        ]
    };
    let add = |mut a: [[f64; 10]; 4], b: [[f64; 10]; 4]| {
        for k in 0..4 {
            for j in 0..10 {
                a[k][j] += b[k][j];
            }
        }
        a
    };
    // Per row in parallel, then added in row order: the same bits on any number of threads.
    let rows: Vec<[[f64; 10]; 4]> = (0..env.height)
        .into_par_iter()
        .map(|y| {
            let (cs, sn, dw) = geometry.rows[y];
            let s = sums_of(&env.data[y * w * c..(y + 1) * w * c]);
            let mut m = [[0.0; 10]; 4];
            for k in 0..lc {
                m[k] = local(dw, cs, sn, &s[k]);
            }
            m[3] = local(dw, cs, sn, &ones);
            m
        })
        .collect();
    let n = rows.into_iter().fold([[0.0; 10]; 4], add);
    // To the world frame: d = u P + v E₁ + w E₂.
    let r = [geometry.pole, plane.e1, plane.e2];
    let world = |n: &[f64; 10]| -> (f64, [f64; 3], [[f64; 3]; 3]) {
        let first = [n[1], n[2], n[3]];
        let second = [[n[4], n[5], n[6]], [n[5], n[7], n[8]], [n[6], n[8], n[9]]];
        let m1 = [0, 1, 2].map(|i| (0..3).map(|a| r[a][i] * first[a]).sum::<f64>());
        let m2 = [0, 1, 2].map(|i| {
            [0, 1, 2].map(|j| {
                let mut s = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        s += r[a][i] * second[a][b] * r[b][j];
                    }
                }
                s
            })
        });
        (n[0], m1, m2)
    };
    let mut t = ZERO;
    let (g0, g1, g2) = world(&n[3]);
    t.y = of_moments(g0, g1, g2);
    t.omega = g0;
    for k in 0..lc {
        let (m0, m1, m2) = world(&n[k]);
        let ly = of_moments(m0, m1, m2);
        for i in 0..9 {
            t.ly[i][k] = ly[i];
        }
        t.l[k] = m0;
    }
    t
}

/// Σ yᵢ L dω from the moments Σ L dω, Σ L d dω and Σ L d dᵀ dω (the basis is quadratic).
fn of_moments(m0: f64, m1: [f64; 3], m2: [[f64; 3]; 3]) -> [f64; 9] {
    let c = constants();
    let [x, y, z] = [0, 1, 2];
    [
        c[0] * m0,
        c[1] * m1[y],
        c[2] * m1[z],
        c[3] * m1[x],
        c[4] * m2[x][y],
        c[5] * m2[y][z],
        c[6] * (3.0 * m2[z][z] - m0),
        c[7] * m2[x][z],
        c[8] * (m2[x][x] - m2[y][y]),
    ]
}

/// Which window a report applies: written as users give it, `"auto"`, a size in bands, or
/// nothing (`null`, `"none"`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Window {
    #[default]
    None,
    /// The largest window that leaves no negative irradiance ([`Sh9::auto_window`]).
    Auto,
    /// A window of this size, in bands.
    Size(f64),
}

impl Window {
    /// A window of `bands`: a positive, finite number.
    pub fn size(bands: f64) -> Result<Window> {
        if bands.is_finite() && bands > 0.0 {
            Ok(Window::Size(bands))
        } else {
            Err(Error::param("window", Window::expected(&bands.to_string())))
        }
    }

    fn expected(got: &str) -> String {
        format!("expected \"auto\" or a positive number of bands, got {got}")
    }
}

impl std::str::FromStr for Window {
    type Err = Error;
    fn from_str(s: &str) -> Result<Window> {
        match s {
            "auto" => Ok(Window::Auto),
            "none" => Ok(Window::None),
            _ => match s.parse::<f64>() {
                Ok(w) => Window::size(w),
                Err(_) => Err(Error::param("window", Window::expected(&format!("{s:?}")))),
            },
        }
    }
}

impl serde::Serialize for Window {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            Window::None => s.serialize_none(),
            Window::Auto => s.serialize_str("auto"),
            Window::Size(w) => s.serialize_f64(*w),
        }
    }
}

impl<'de> serde::Deserialize<'de> for Window {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Window;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("\"auto\" or a positive number of bands")
            }
            fn visit_unit<E: serde::de::Error>(self) -> std::result::Result<Window, E> {
                Ok(Window::None)
            }
            fn visit_none<E: serde::de::Error>(self) -> std::result::Result<Window, E> {
                Ok(Window::None)
            }
            fn visit_some<D: serde::Deserializer<'de>>(
                self,
                d: D,
            ) -> std::result::Result<Window, D::Error> {
                d.deserialize_any(V)
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> std::result::Result<Window, E> {
                s.parse().map_err(|e: Error| E::custom(e))
            }
            fn visit_f64<E: serde::de::Error>(self, w: f64) -> std::result::Result<Window, E> {
                Window::size(w).map_err(E::custom)
            }
            fn visit_i64<E: serde::de::Error>(self, w: i64) -> std::result::Result<Window, E> {
                self.visit_f64(w as f64)
            }
            fn visit_u64<E: serde::de::Error>(self, w: u64) -> std::result::Result<Window, E> {
                self.visit_f64(w as f64)
            }
        }
        d.deserialize_any(V)
    }
}

/// three.js's forms of the coefficients.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ThreeJs {
    /// `SphericalHarmonics3.coefficients` (set with `fromArray` of the flattened list, or per
    /// coefficient); a `LightProbe` takes the same with intensity 1.
    pub spherical_harmonics3: [[f64; 3]; 9],
    /// The same, flattened (27 numbers: `new LightProbe(new SphericalHarmonics3().fromArray(…))`).
    pub array: Vec<f64>,
}

/// Filament's form: pre-scaled for `Irradiance_SphericalHarmonics` (E/π).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Filament {
    pub sh: [[f64; 3]; 9],
    /// `sh.txt` as `cmgen --sh-shader` writes it.
    pub sh_txt: String,
}

/// The report of `spheremap irradiance` and Python's `irradiance_sh`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct IrradianceReport {
    pub input: String,
    /// 1 (grey) or 3.
    pub channels: usize,
    /// The window's size in bands, when one was applied.
    pub window: Option<f64>,
    /// The radiance coefficients Lᵢ (three.js's order and normalization; windowed).
    pub coefficients: [[f64; 3]; 9],
    pub threejs: ThreeJs,
    pub filament: Filament,
    /// The irradiance the coefficients give at the six axes, +X −X +Y −Y +Z −Z.
    pub irradiance_axes: [[f64; 3]; 6],
    /// Files written.
    pub output: Vec<String>,
    pub seconds: f64,
}

impl IrradianceReport {
    /// Projects `env` and fills the report.
    pub fn of(
        env: &EnvMap,
        world_to_env: &[[f64; 3]; 3],
        window: Window,
        input: &str,
    ) -> Result<IrradianceReport> {
        let t0 = std::time::Instant::now();
        let raw = Sh9::project(env, world_to_env)?;
        let w = match window {
            Window::None => None,
            Window::Auto => Some(raw.auto_window()),
            Window::Size(w) => Some(w),
        };
        let sh = match w {
            Some(w) => raw.windowed(w),
            None => raw,
        };
        let axes = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        Ok(IrradianceReport {
            input: input.to_string(),
            channels: sh.channels,
            window: w,
            coefficients: sh.coefficients,
            threejs: ThreeJs {
                spherical_harmonics3: sh.coefficients,
                array: sh.coefficients.iter().flatten().copied().collect(),
            },
            filament: Filament {
                sh: sh.filament(),
                sh_txt: sh.filament_txt(),
            },
            irradiance_axes: axes.map(|a| sh.irradiance(a)),
            output: Vec::new(),
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

/// Where a map's texels look (world frame) and their solid angles.  For a lat-long map (any
/// preset) the direction of texel (x, y) is cos θ_y · P + sin θ_y · Q_x (P the pole, Q_x the
/// equator under column x), so rows and columns are computed once; other mappings ask the
/// mapping per texel.
struct Geometry {
    mapping: Mapping,
    w: usize,
    h: usize,
    map_to_world: [[f64; 3]; 3],
    /// Lat-long: per row (cos θ, sin θ, dω), per column Q_x, and P (world frame).
    rows: Vec<(f64, f64, f64)>,
    cols: Vec<[f64; 3]>,
    pole: [f64; 3],
}

impl Geometry {
    fn new(mapping: Mapping, w: usize, h: usize, world_to_env: &[[f64; 3]; 3]) -> Geometry {
        let r = world_to_env;
        let map_to_world = [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[j][i]));
        let g = Geometry {
            mapping,
            w,
            h,
            map_to_world,
            rows: Vec::new(),
            cols: Vec::new(),
            pole: [0.0; 3],
        };
        if let Mapping::LatLong(_) = mapping {
            let dir = |u: f64, v: f64| mapping.uv_to_dir([u, v]).map(|d| g.world(d));
            if let (Some(pole), Some(_)) = (dir(0.5, 0.0), dir(0.5, 0.5)) {
                let rows: Vec<(f64, f64, f64)> = (0..h)
                    .map(|y| {
                        let th = (y as f64 + 0.5) / h as f64 * PI;
                        (th.cos(), th.sin(), mapping.texel_solid_angle(0, y, w, h))
                    })
                    .collect();
                let cols: Vec<[f64; 3]> = (0..w)
                    .map(|x| dir((x as f64 + 0.5) / w as f64, 0.5).unwrap_or([0.0; 3]))
                    .collect();
                let fast = Geometry {
                    rows,
                    cols,
                    pole,
                    ..g
                };
                // Used only where it reproduces the mapping (to rounding) at sample texels.
                let agrees = [(0, 0), (w / 3, h / 5), (w - 1, h - 1), (w / 2, h / 2)]
                    .iter()
                    .all(|&(x, y)| {
                        let slow = g_slow(&fast, x, y);
                        let quick = fast.at(x, y);
                        match (slow, quick) {
                            (Some((a, da)), Some((b, db))) => {
                                (0..3).all(|k| (a[k] - b[k]).abs() < 1e-9)
                                    && (da - db).abs() <= 1e-12 * da.abs().max(1e-30)
                            }
                            _ => false,
                        }
                    });
                return if agrees {
                    fast
                } else {
                    Geometry {
                        rows: Vec::new(),
                        cols: Vec::new(),
                        ..fast
                    }
                };
            }
        }
        g
    }

    fn world(&self, d: [f64; 3]) -> [f64; 3] {
        let r = &self.map_to_world;
        crate::base::vec::normalize(
            [0, 1, 2].map(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]),
        )
    }

    /// The lat-long's equator plane, when its columns lie in it (to 1e-9).
    fn plane(&self) -> Option<Plane> {
        let (p, q0) = (self.pole, *self.cols.first()?);
        let along = crate::base::vec::dot(q0, p);
        let e1 = crate::base::vec::normalize([0, 1, 2].map(|k| q0[k] - along * p[k]));
        let e2 = crate::base::vec::cross(p, e1);
        let mut cols = Vec::with_capacity(self.cols.len());
        for q in &self.cols {
            let (a, b) = (crate::base::vec::dot(*q, e1), crate::base::vec::dot(*q, e2));
            if (0..3).any(|k| (a * e1[k] + b * e2[k] - q[k]).abs() > 1e-9) {
                return None;
            }
            cols.push([a, b, a * a, a * b].map(|v| v as f32));
        }
        Some(Plane { e1, e2, cols })
    }

    /// Texel (x, y)'s world direction and solid angle (`None` off the map).
    #[inline]
    fn at(&self, x: usize, y: usize) -> Option<([f64; 3], f64)> {
        if self.rows.is_empty() {
            return g_slow(self, x, y);
        }
        let (c, s, dw) = self.rows[y];
        let q = &self.cols[x];
        let p = &self.pole;
        Some(([0, 1, 2].map(|k| c * p[k] + s * q[k]), dw))
    }
}

/// [`Geometry::at`] by asking the mapping.
fn g_slow(g: &Geometry, x: usize, y: usize) -> Option<([f64; 3], f64)> {
    let dw = g.mapping.texel_solid_angle(x, y, g.w, g.h);
    if !(dw > 0.0) {
        return None;
    }
    let uv = [(x as f64 + 0.5) / g.w as f64, (y as f64 + 0.5) / g.h as f64];
    g.mapping.uv_to_dir(uv).map(|d| (g.world(d), dw))
}

/// Filament's sinc⁴ window of band `l` for window size `w` (bands).
pub fn window(l: usize, w: f64) -> f64 {
    if l == 0 {
        return 1.0;
    }
    if l as f64 >= w {
        return 0.0;
    }
    let x = PI * l as f64 / w;
    (x.sin() / x).powi(4)
}

/// `n` directions spread evenly over the sphere (a Fibonacci lattice).
pub fn fibonacci(n: usize) -> Vec<[f64; 3]> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_white_map_has_two_root_pi_and_irradiance_pi() {
        let m = Mapping::parse("latlong", None).unwrap();
        let img = crate::images::Image {
            width: 64,
            height: 32,
            channels: 3,
            data: vec![1.0; 64 * 32 * 3],
        };
        let env = EnvMap::new(m, &img, "env").unwrap();
        let sh = Sh9::project(&env, &crate::resample::IDENTITY).unwrap();
        let c0 = sh.coefficients[0][0];
        assert!((c0 - 2.0 * PI.sqrt()).abs() < 1e-9 * c0, "{c0}");
        for d in fibonacci(50) {
            let e = sh.irradiance(d)[1];
            assert!((e - PI).abs() < 1e-6 * PI, "{e}");
        }
        // Filament's pre-scaled L00 is E/π = 1 for a white map.
        assert!((sh.filament()[0][2] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn the_lat_long_rows_and_columns_are_the_mapping_per_texel() {
        let turn = crate::frame::view::look_up([1.0, 0.3, -0.2], [0.0, 1.0, 0.0]).unwrap();
        for preset in [
            None,
            Some("blender"),
            Some("threejs"),
            Some("skylibs"),
            Some("filament"),
            Some("mitsuba"),
            Some("pbrt"),
        ] {
            let m = Mapping::parse("latlong", preset).unwrap();
            let (w, h) = (24, 12);
            let g = Geometry::new(m, w, h, &turn);
            assert!(!g.rows.is_empty(), "{preset:?}: the fast path is used");
            for y in 0..h {
                for x in 0..w {
                    let (a, da) = g.at(x, y).unwrap();
                    let (b, db) = g_slow(&g, x, y).unwrap();
                    assert!(
                        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12),
                        "{preset:?} {x} {y}"
                    );
                    assert!((da - db).abs() < 1e-15);
                }
            }
        }
    }

    #[test]
    fn the_moment_path_agrees_with_the_texel_sum() {
        let turn = crate::frame::view::look_up([1.0, 0.3, -0.2], [0.2, 1.0, 0.1]).unwrap();
        for (preset, w, c) in [
            (None, 203, 3),
            (Some("blender"), 128, 1),
            (Some("threejs"), 96, 4),
            (Some("skylibs"), 70, 2),
        ] {
            let m = Mapping::parse("latlong", preset).unwrap();
            let h = w / 2;
            let data: Vec<f32> = (0..w * h * c)
                .map(|i| {
                    let (x, y) = ((i / c) % w, (i / c) / w);
                    let spot = if (x, y) == (w / 3, h / 4) {
                        5000.0
                    } else {
                        0.0
                    };
                    spot + 0.5 + 0.4 * ((i as f32) * 0.37).sin() + 0.1 * (i % c) as f32
                })
                .collect();
            let img = crate::images::Image {
                width: w,
                height: h,
                channels: c,
                data,
            };
            let env = EnvMap::new(m, &img, "env").unwrap();
            let g = Geometry::new(m, w, h, &turn);
            assert!(g.plane().is_some(), "{preset:?}: the moment path is used");
            let fast = Sh9::project(&env, &turn).unwrap();
            // The same bits on any number of threads (batch runs compare files by hash).
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let again = pool.install(|| Sh9::project(&env, &turn).unwrap());
                assert_eq!(
                    again.coefficients, fast.coefficients,
                    "{preset:?}, {threads} threads"
                );
            }
            let slow = Sh9::project_reference(&env, &turn).unwrap();
            assert_eq!(fast.channels, slow.channels);
            for k in 0..slow.channels {
                let scale = slow.coefficients[0][k].abs();
                for i in 0..9 {
                    let (a, b) = (fast.coefficients[i][k], slow.coefficients[i][k]);
                    assert!(
                        (a - b).abs() < 2e-6 * scale,
                        "{preset:?} c{c} L{i}[{k}]: {a} vs {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn other_mappings_sum_texels() {
        let m = Mapping::parse("octahedral", None).unwrap();
        let img = crate::images::Image {
            width: 32,
            height: 32,
            channels: 3,
            data: vec![1.0; 32 * 32 * 3],
        };
        let env = EnvMap::new(m, &img, "env").unwrap();
        assert!(Geometry::new(m, 32, 32, &crate::resample::IDENTITY)
            .plane()
            .is_none());
        let sh = Sh9::project(&env, &crate::resample::IDENTITY).unwrap();
        assert!((sh.coefficients[0][0] - 2.0 * PI.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn the_basis_is_orthonormal() {
        let dirs = fibonacci(200_000);
        let dw = 4.0 * PI / dirs.len() as f64;
        for i in 0..9 {
            for j in 0..9 {
                let s: f64 = dirs.iter().map(|&d| basis(d)[i] * basis(d)[j] * dw).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((s - want).abs() < 1e-3, "{i} {j}: {s}");
            }
        }
    }

    #[test]
    fn the_window_is_one_at_band_zero_and_falls() {
        assert_eq!(window(0, 4.0), 1.0);
        assert!(window(1, 4.0) > window(2, 4.0));
        assert_eq!(window(3, 3.0), 0.0);
    }
}
