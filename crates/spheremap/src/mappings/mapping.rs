//! Every environment mapping behind one type: its canvas, direction ↔ image coordinates, texel
//! solid angle and wrap rule.
//!
//! A mapping's **canvas** is the whole image it is stored in (for a cube map: the face stack,
//! see [`crate::mappings::cube`]).  Canvas coordinates `(u, v) ∈ [0,1]²` run right and **down** (row 0 at
//! the top, as files store it); continuous pixel coordinates are `(u·W, v·H)` with texel centres
//! at `i + ½` ([`crate::frame::conventions`]).  Directions are in the mapping's own frame, which for
//! every preset is converted to ours (right-handed, +Y up; a sphere map's viewer looks down −Z).
//!
//! | name | canvas | preset(s) | texel solid angle |
//! |---|---|---|---|
//! | `sphere` | N×N | gl (default), gl-upload, d3d, skylibs, blender-mirrorball, mirror-ball-photo | exact (disc ∩ rect), 16/N² inside |
//! | `latlong` | 2N×N | blender (default), threejs, skylibs, filament, mitsuba, pbrt | exact per row |
//! | `cube` | F×6F stack | gl (default), d3d | exact (atan formula) |
//! | `angular` | N×N | debevec | quadrature |
//! | `paraboloid` | 2N×N | heidrich-seidel | quadrature |
//! | `octahedral` | N×N | pbrt | 4π/N² |

use crate::base::error::{Error, Result};
use crate::base::real::Real;
use crate::frame::conventions::{mat3_mul, SpherePreset};
use crate::mappings::cube::{self, CubePreset};
use crate::mappings::latlong::LatLongPreset;
use crate::mappings::{angular, latlong, octahedral, paraboloid, sphere};

/// An environment mapping with its preset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mapping {
    Sphere(&'static SpherePreset),
    LatLong(&'static LatLongPreset),
    Cube(&'static CubePreset),
    Angular,
    Paraboloid,
    Octahedral,
}

/// A canvas's texels row by row ([`Mapping::texel_rows`]).
pub struct TexelRows<'a> {
    mapping: &'a Mapping,
    w: usize,
    h: usize,
    /// A lat-long's (cos φ, sin φ) per column.
    cols: Vec<[f64; 2]>,
}

impl TexelRows<'_> {
    /// Row `y`: for each column, (solid angle, direction of the centre, `None` off the map),
    /// into `out` (cleared first).
    pub fn row(&self, y: usize, out: &mut Vec<(f64, Option<[f64; 3]>)>) {
        let (w, h) = (self.w, self.h);
        out.clear();
        let v = (y as f64 + 0.5) / h as f64;
        match self.mapping {
            Mapping::LatLong(_) => {
                let dw = latlong::texel_solid_angle(y, w, h);
                let theta = v * std::f64::consts::PI;
                let (s, c) = (theta.sin(), theta.cos());
                out.extend(
                    self.cols
                        .iter()
                        .map(|&[cp, sp]| (dw, Some([s * cp, c, s * sp]))),
                );
            }
            m => out.extend((0..w).map(|x| {
                let u = (x as f64 + 0.5) / w as f64;
                (m.texel_solid_angle(x, y, w, h), m.uv_to_dir([u, v]))
            })),
        }
    }

    /// Row `y`'s solid angles alone, into `out` (cleared first).
    pub fn solid_angles(&self, y: usize, out: &mut Vec<f64>) {
        let (w, h) = (self.w, self.h);
        out.clear();
        match self.mapping {
            Mapping::LatLong(_) => out.resize(w, latlong::texel_solid_angle(y, w, h)),
            m => out.extend((0..w).map(|x| m.texel_solid_angle(x, y, w, h))),
        }
    }
}

crate::base::named::named_enum! {
    /// The names of [`Mapping`] (without their presets).
    pub enum MappingName: "mapping" as "mapping" {
        Sphere = "sphere",
        LatLong = "latlong" | "equirect" | "equirectangular",
        Cube = "cube" | "cubemap",
        Angular = "angular" | "lightprobe",
        Paraboloid = "paraboloid" | "dual-paraboloid",
        Octahedral = "octahedral",
    }
}

fn only_preset(mapping: &str, preset: Option<&str>, names: &[&str]) -> Result<()> {
    match preset {
        None => Ok(()),
        Some(p) if names.contains(&p) => Ok(()),
        Some(p) => Err(Error::param(
            "preset",
            format!("{mapping} has one preset, {:?}, not {p:?}", names[0]),
        )),
    }
}

impl Mapping {
    /// `name` (see [`MappingName`]: `equirect` is an alias of `latlong`, …) with an optional
    /// preset name (the default preset when `None`).
    pub fn parse(name: &str, preset: Option<&str>) -> Result<Mapping> {
        Ok(match MappingName::parse(name)? {
            MappingName::Sphere => Mapping::Sphere(SpherePreset::by_name(preset.unwrap_or("gl"))?),
            MappingName::LatLong => {
                Mapping::LatLong(LatLongPreset::by_name(preset.unwrap_or("blender"))?)
            }
            MappingName::Cube => Mapping::Cube(CubePreset::by_name(preset.unwrap_or("gl"))?),
            MappingName::Angular => {
                only_preset(name, preset, &["debevec"])?;
                Mapping::Angular
            }
            MappingName::Paraboloid => {
                only_preset(name, preset, &["heidrich-seidel"])?;
                Mapping::Paraboloid
            }
            MappingName::Octahedral => {
                only_preset(name, preset, &["pbrt"])?;
                Mapping::Octahedral
            }
        })
    }

    pub fn name(&self) -> &'static str {
        match self {
            Mapping::Sphere(_) => "sphere",
            Mapping::LatLong(_) => "latlong",
            Mapping::Cube(_) => "cube",
            Mapping::Angular => "angular",
            Mapping::Paraboloid => "paraboloid",
            Mapping::Octahedral => "octahedral",
        }
    }

    pub fn preset_name(&self) -> &'static str {
        match self {
            Mapping::Sphere(p) => p.name,
            Mapping::LatLong(p) => p.name,
            Mapping::Cube(p) => p.name,
            Mapping::Angular => "debevec",
            Mapping::Paraboloid => "heidrich-seidel",
            Mapping::Octahedral => "pbrt",
        }
    }

    /// Canvas (width, height) for a map of "size" N: the sphere/angular/octahedral side, the
    /// lat-long and paraboloid height, the cube face.
    pub fn canvas(&self, n: usize) -> (usize, usize) {
        match self {
            Mapping::Sphere(_) | Mapping::Angular | Mapping::Octahedral => (n, n),
            Mapping::LatLong(_) | Mapping::Paraboloid => (2 * n, n),
            Mapping::Cube(_) => (n, 6 * n),
        }
    }

    /// The size N of a canvas of `w`×`h`, checking its shape.  A lat-long may have any aspect
    /// (its texels need not be square); N is then its height.
    pub fn size_of(&self, w: usize, h: usize, what: &str) -> Result<usize> {
        let bad = |want: &str| {
            Err(Error::data(
                what,
                format!("a {} map is {want}, got {w}x{h}", self.name()),
            ))
        };
        if w == 0 || h == 0 {
            return bad("not empty");
        }
        match self {
            Mapping::Sphere(_) | Mapping::Angular | Mapping::Octahedral if w != h => {
                bad("square (N x N)")
            }
            Mapping::Paraboloid if w != 2 * h => bad("two discs side by side (2N x N)"),
            Mapping::Cube(_) if h != 6 * w => {
                bad("a face stack (F x 6F; other layouts are converted on reading)")
            }
            Mapping::Cube(_) => Ok(w),
            _ => Ok(h),
        }
    }

    /// The smallest canvas (width, height) an input map of this mapping may have: a disc or
    /// square map of 2×2 (one texel would hold the whole sphere, or most of it, in one
    /// value), a lat-long or paraboloid pair of 2×1, a cube of faces of 1×1 (a mip chain's
    /// last level).
    pub fn min_input(&self) -> (usize, usize) {
        match self {
            Mapping::Sphere(_) | Mapping::Angular | Mapping::Octahedral => (2, 2),
            Mapping::LatLong(_) | Mapping::Paraboloid => (2, 1),
            Mapping::Cube(_) => (1, 6),
        }
    }

    /// [`Mapping::size_of`] for a map given as input, also refusing one smaller than
    /// [`Mapping::min_input`] (naming that size) and warning, naming its aspect, of a
    /// lat-long that is not 2:1 (its texels are then not square in angle: often a map of
    /// another mapping named as a lat-long).
    pub fn check_input(&self, w: usize, h: usize, what: &str) -> Result<usize> {
        let n = self.size_of(w, h, what)?;
        let (mw, mh) = self.min_input();
        if w < mw || h < mh {
            return Err(Error::data(
                what,
                format!(
                    "{w}x{h} is too small for a {} map: the smallest is {mw}x{mh}",
                    self.name()
                ),
            ));
        }
        if matches!(self, Mapping::LatLong(_)) && w != 2 * h {
            crate::base::error::warn(&format!(
                "{what}: a lat-long map is 2:1 (2N x N), this one is {w}x{h} ({:.3}:1): each \
                 texel spans {:.3}° of longitude and {:.3}° of latitude; is it another \
                 mapping?",
                w as f64 / h as f64,
                360.0 / w as f64,
                180.0 / h as f64
            ));
        }
        Ok(n)
    }

    /// Direction (this mapping's frame, any non-zero length) → canvas (u, v).  NaN where the
    /// direction has no single point (zero input; a sphere map's straight-ahead direction).
    #[inline(always)]
    pub fn dir_to_uv<T: Real>(&self, d: [T; 3]) -> [T; 2] {
        match self {
            Mapping::Sphere(p) => {
                let [s, t] = sphere::dir_to_st(mat3_mul(&p.frame, d), Default::default());
                let t = match p.rows {
                    crate::frame::conventions::RowOrder::TopIsT1 => T::ONE - t,
                    crate::frame::conventions::RowOrder::TopIsT0 => t,
                };
                [s, t]
            }
            Mapping::LatLong(p) => p.dir_to_uv(d),
            Mapping::Cube(p) => {
                let (face, s, t) = cube::dir_to_face_st(mat3_mul(&p.frame, d));
                let sixth = T::from_f64(1.0 / 6.0);
                [s, (T::from_f64(face as f64) + t) * sixth]
            }
            Mapping::Angular => angular::dir_to_uv(d),
            Mapping::Paraboloid => paraboloid::dir_to_uv(d),
            Mapping::Octahedral => octahedral::dir_to_uv(d),
        }
    }

    /// Canvas (u, v) → unit direction in this mapping's frame; `None` off the map (outside a
    /// disc, outside the canvas).
    #[inline(always)]
    pub fn uv_to_dir<T: Real>(&self, uv: [T; 2]) -> Option<[T; 3]> {
        match self {
            Mapping::Sphere(p) => {
                let t = match p.rows {
                    crate::frame::conventions::RowOrder::TopIsT1 => T::ONE - uv[1],
                    crate::frame::conventions::RowOrder::TopIsT0 => uv[1],
                };
                sphere::st_to_dir([uv[0], t]).map(|d| transpose_mul(&p.frame, d))
            }
            Mapping::LatLong(p) => p.uv_to_dir(uv),
            Mapping::Cube(p) => {
                let [u, v] = uv;
                if !(u >= T::ZERO && u <= T::ONE && v >= T::ZERO && v <= T::ONE) {
                    return None;
                }
                let fv = v * T::from_f64(6.0);
                let face = fv.floor().to_f64().min(5.0) as usize;
                let t = fv - T::from_f64(face as f64);
                Some(transpose_mul(&p.frame, cube::face_st_to_dir(face, u, t)))
            }
            Mapping::Angular => angular::uv_to_dir(uv),
            Mapping::Paraboloid => paraboloid::uv_to_dir(uv),
            Mapping::Octahedral => octahedral::uv_to_dir(uv),
        }
    }

    /// Exact solid angle of canvas texel (`x`, `y`) of a `w`×`h` canvas (0 off the map).
    pub fn texel_solid_angle(&self, x: usize, y: usize, w: usize, h: usize) -> f64 {
        match self {
            Mapping::Sphere(_) => sphere::texel_solid_angle(x, y, w),
            Mapping::LatLong(_) => latlong::texel_solid_angle(y, w, h),
            Mapping::Cube(_) => cube::texel_solid_angle(x, y % w, w),
            Mapping::Angular => angular::texel_solid_angle(x, y, w),
            Mapping::Paraboloid => paraboloid::texel_solid_angle(x, y, h),
            Mapping::Octahedral => octahedral::texel_solid_angle(w),
        }
    }

    /// All texel solid angles of a `w`×`h` canvas, row-major.
    pub fn solid_angles(&self, w: usize, h: usize) -> Vec<f64> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| self.texel_solid_angle(x, y, w, h))
            .collect()
    }

    /// The texels of a `w`×`h` canvas row by row, each with its exact solid angle and the
    /// direction of its centre: what [`Mapping::texel_solid_angle`] and [`Mapping::uv_to_dir`]
    /// at ((x + ½)/w, (y + ½)/h) give, bit for bit, with the work a row or a column shares
    /// done once (a lat-long's solid angle and latitude per row, its longitude per column).
    pub fn texel_rows(&self, w: usize, h: usize) -> TexelRows<'_> {
        let cols = match self {
            Mapping::LatLong(p) => (0..w)
                .map(|x| {
                    let u = (x as f64 + 0.5) / w as f64;
                    let phi = (u - p.u_plus_x) * std::f64::consts::TAU;
                    [phi.cos(), phi.sin()]
                })
                .collect(),
            _ => Vec::new(),
        };
        TexelRows {
            mapping: self,
            w,
            h,
            cols,
        }
    }

    /// Whether part of the canvas is off the map (the corners of a disc).
    pub fn has_outside(&self) -> bool {
        matches!(
            self,
            Mapping::Sphere(_) | Mapping::Angular | Mapping::Paraboloid
        )
    }

    /// dω/du dv up to a constant factor at canvas point (u, v) — the weight that makes an average
    /// over image area an average over solid angle.  0 off the map.
    #[inline(always)]
    pub fn density<T: Real>(&self, uv: [T; 2]) -> T {
        let disc = |a: T, b: T| a * a + b * b;
        match self {
            Mapping::Sphere(_) | Mapping::Octahedral => T::ONE,
            Mapping::LatLong(_) => (uv[1] * T::from_f64(std::f64::consts::PI)).sin().abs(),
            Mapping::Cube(_) => {
                let fv = uv[1] * T::from_f64(6.0);
                let t = fv - fv.floor();
                let (a, b) = (T::TWO * uv[0] - T::ONE, T::TWO * t - T::ONE);
                let q = T::ONE + disc(a, b);
                T::ONE / (q * q.sqrt())
            }
            Mapping::Angular => {
                let rho = disc(T::TWO * uv[0] - T::ONE, T::TWO * uv[1] - T::ONE).sqrt();
                if rho > T::ZERO {
                    (T::from_f64(std::f64::consts::PI) * rho).sin().abs() / rho
                } else {
                    T::from_f64(std::f64::consts::PI)
                }
            }
            Mapping::Paraboloid => {
                let uh = uv[0] * T::TWO;
                let uh = uh - uh.floor();
                let q = T::ONE + disc(T::TWO * uh - T::ONE, T::TWO * uv[1] - T::ONE);
                T::ONE / (q * q)
            }
        }
    }
}

#[inline(always)]
fn transpose_mul<T: Real>(m: &[[f64; 3]; 3], d: [T; 3]) -> [T; 3] {
    let c = |j: usize| {
        T::from_f64(m[0][j]) * d[0] + T::from_f64(m[1][j]) * d[1] + T::from_f64(m[2][j]) * d[2]
    };
    [c(0), c(1), c(2)]
}

/// A mapping parser's error named as the caller's fields: an unknown preset as `preset`, any
/// other as `mapping` (the parsers name them "preset" and "mapping").
pub fn name_fields(e: Error, mapping: &str, preset: &str) -> Error {
    match e {
        Error::InvalidParameter { ref name, .. } if name == "preset" => e.named(preset),
        other => other.named(mapping),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn inputs_smaller_than_their_mapping_s_smallest_are_refused_naming_it() {
        let parse = |n| Mapping::parse(n, None).unwrap();
        for (name, (w, h), ok) in [
            ("sphere", (1, 1), false),
            ("sphere", (2, 2), true),
            ("angular", (1, 1), false),
            ("octahedral", (1, 1), false),
            ("latlong", (1, 1), false),
            ("latlong", (2, 1), true),
            ("paraboloid", (2, 1), true),
            ("cube", (1, 6), true),
        ] {
            let m = parse(name);
            assert_eq!(m.check_input(w, h, "in").is_ok(), ok, "{name} {w}x{h}");
            if !ok {
                let (mw, mh) = m.min_input();
                let e = m.check_input(w, h, "in").unwrap_err().to_string();
                assert!(e.contains(&format!("the smallest is {mw}x{mh}")), "{e}");
            }
            // Outputs (mip levels down to one texel) are not held to it.
            assert!(m.size_of(w, h, "out").is_ok());
        }
    }

    /// `texel_rows` gives each texel's solid angle and centre direction bit for bit as the
    /// per-texel functions do, in every mapping and preset.
    #[test]
    fn texel_rows_are_the_texels_bit_for_bit() {
        let mut row = Vec::new();
        for m in all() {
            let (w, h) = match m {
                Mapping::Cube(_) => (6, 36),
                Mapping::LatLong(_) => (14, 7),
                _ => (9, 9),
            };
            let rows = m.texel_rows(w, h);
            for y in 0..h {
                rows.row(y, &mut row);
                assert_eq!(row.len(), w);
                for (x, &(dw, d)) in row.iter().enumerate() {
                    let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
                    assert_eq!(
                        dw.to_bits(),
                        m.texel_solid_angle(x, y, w, h).to_bits(),
                        "{m:?} {x} {y}"
                    );
                    assert_eq!(d, m.uv_to_dir(uv), "{m:?} {x} {y}");
                }
                let mut dws = Vec::new();
                rows.solid_angles(y, &mut dws);
                assert!(dws
                    .iter()
                    .zip(&row)
                    .all(|(a, b)| a.to_bits() == b.0.to_bits()));
            }
        }
    }

    fn all() -> Vec<Mapping> {
        let mut v = vec![];
        for p in crate::frame::conventions::PRESETS {
            v.push(Mapping::Sphere(p));
        }
        for p in crate::mappings::latlong::LATLONG_PRESETS {
            v.push(Mapping::LatLong(p));
        }
        for p in cube::CUBE_PRESETS {
            v.push(Mapping::Cube(p));
        }
        v.extend([Mapping::Angular, Mapping::Paraboloid, Mapping::Octahedral]);
        v
    }

    #[test]
    fn every_mapping_round_trips_in_f64_and_f32() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for m in all() {
            for _ in 0..5000 {
                let d = [rnd(), rnd(), rnd()];
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if l < 1e-3 {
                    continue;
                }
                let uv = m.dir_to_uv(d);
                let back = m
                    .uv_to_dir(uv)
                    .unwrap_or_else(|| panic!("{m:?} {d:?} {uv:?}"));
                for k in 0..3 {
                    assert!((back[k] - d[k] / l).abs() < 1e-9, "{m:?} {d:?} {back:?}");
                }
                // The fast path agrees with the reference to f32 precision (≈1e-6 of the canvas).
                let uv32 = m.dir_to_uv([d[0] as f32, d[1] as f32, d[2] as f32]);
                let du = (uv32[0] as f64 - uv[0]).abs();
                let du = if matches!(m, Mapping::LatLong(_)) {
                    du.min(1.0 - du)
                } else {
                    du
                };
                // The sphere map's rim compresses 1e-7 of direction into 1e-4 of radius.
                let tol = if eye_z(&m, d) / l < -0.999 {
                    1e-3
                } else {
                    4e-6
                };
                assert!(
                    du < tol && (uv32[1] as f64 - uv[1]).abs() < tol,
                    "{m:?} {d:?} {uv:?} {uv32:?}"
                );
            }
        }
    }

    /// The z of a direction in a sphere map's eye frame (0 for other mappings).
    fn eye_z(m: &Mapping, d: [f64; 3]) -> f64 {
        match m {
            Mapping::Sphere(p) => p.to_eye(d)[2],
            _ => 0.0,
        }
    }

    #[test]
    fn solid_angles_sum_to_4pi() {
        for m in all() {
            for n in [8usize, 33] {
                let (w, h) = m.canvas(n);
                let s: f64 = m.solid_angles(w, h).iter().sum();
                let tol = if matches!(m, Mapping::Angular | Mapping::Paraboloid) {
                    1e-6
                } else {
                    1e-9
                };
                assert!((s - 4.0 * PI).abs() < tol, "{m:?} n={n}: {s}");
            }
        }
    }

    /// The density is proportional to the exact texel solid angle (texel centres, fully inside).
    #[test]
    fn density_matches_solid_angle() {
        for m in all() {
            let n = 64;
            let (w, h) = m.canvas(n);
            let mut ratios = vec![];
            for (x, y) in [(20usize, 30usize), (25, 7), (40, 50), (10, 31)] {
                let (x, y) = (x * w / 64, y * h / 64);
                let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
                if m.uv_to_dir(uv).is_none() || m.texel_solid_angle(x, y, w, h) == 0.0 {
                    continue;
                }
                ratios.push(m.texel_solid_angle(x, y, w, h) / m.density(uv));
            }
            for r in &ratios {
                assert!((r / ratios[0] - 1.0).abs() < 2e-3, "{m:?}: {ratios:?}");
            }
        }
    }

    #[test]
    fn parse_names_and_errors() {
        assert_eq!(
            Mapping::parse("latlong", None).unwrap().preset_name(),
            "blender"
        );
        assert_eq!(
            Mapping::parse("cube", Some("d3d")).unwrap().preset_name(),
            "d3d"
        );
        let e = Mapping::parse("cylinder", None).unwrap_err().to_string();
        assert!(
            e.starts_with("mapping: unknown mapping \"cylinder\""),
            "{e}"
        );
        let e = Mapping::parse("angular", Some("gl"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("preset: angular has one preset"), "{e}");
    }
}
