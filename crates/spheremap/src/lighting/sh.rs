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

use super::brdf;
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
    pub fn project(env: &EnvMap, world_to_env: &[[f64; 3]; 3]) -> Result<Sh9> {
        let (w, h, c) = (env.width, env.height, env.channels);
        let lc = super::envtree::light_channels(c);
        let m = env.mapping;
        let geometry = Geometry::new(m, w, h, world_to_env);
        // One pass: Σ L yᵢ dω, Σ yᵢ dω, Σ L dω and Σ dω; then
        // Lᵢ = L̄ ∫ yᵢ dω (exact) + Σ (L − L̄) yᵢ dω = L̄ exactᵢ + Σ L yᵢ dω − L̄ Σ yᵢ dω.
        #[derive(Clone, Copy)]
        struct Sums {
            ly: [[f64; 3]; 9],
            y: [f64; 9],
            l: [f64; 3],
            omega: f64,
        }
        let zero = Sums {
            ly: [[0.0; 3]; 9],
            y: [0.0; 9],
            l: [0.0; 3],
            omega: 0.0,
        };
        let rows: Vec<Sums> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut a = zero;
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
        let mut t = zero;
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

/// Which window a report applies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    None,
    /// The largest window that leaves no negative irradiance ([`Sh9::auto_window`]).
    Auto,
    /// A window of this size, in bands.
    Size(f64),
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
        brdf::normalize([0, 1, 2].map(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]))
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
