//! Sampling analytics of an environment mapping, and the per-vertex interpolation error of a
//! mesh seen by a camera with tessellation advice.
//!
//! ## A mapping's texels
//!
//! For texel (x, y) of a W × H canvas, with J the 3 × 2 Jacobian of the direction with respect
//! to the pixel position at the texel centre (central differences of ±1/1000 texel)
//! and σ₁ ≥ σ₂ its singular values (radians per pixel along the texel's most and least
//! stretched directions):
//!
//! * **solid angle**: exact (the mapping's own closed form or quadrature, as
//!   [`Mapping::solid_angles`]); the sphere map's interior texels are 16/N² sr;
//! * **anisotropy** σ₁/σ₂ (1 = square footprint on the sphere; the sphere map reaches
//!   1/cos²(θ/2) toward its rim);
//! * **angular resolution** σ₁ in degrees per texel: the coarsest angular step of the texel,
//!   along its most stretched direction (on an equal-area map such as the sphere map, √(σ₁σ₂)
//!   is the same everywhere and σ₁ is what degrades toward the rim).
//!
//! Texels whose centre is off the map (outside a disc) are NaN.
//!
//! ## A mesh's per-vertex error
//!
//! GL computes (s, t) at the vertices and interpolates it linearly over each triangle (in object
//! space: perspective-correct). The exact lookup interpolates position and normal and reflects
//! per point. The error at a point is the angle between the direction the interpolated (s, t)
//! stands for and the exact reflection vector; a triangle's error is the largest over a grid of
//! barycentric points (order 6: 28 points, vertices included). **Tessellation advice**: for each
//! triangle over the threshold, the smallest k (edges split in k, k² sub-triangles; new
//! vertices on the flat triangle with interpolated, renormalized normals) whose piecewise-linear
//! (s, t) brings the error below the threshold, found by measuring, not by a rule of thumb; k is
//! capped at [`MAX_SPLIT`] (triangles that still fail, e.g. those reflecting toward the sphere
//! map's singular rim, are counted apart).

use crate::base::error::{Error, Result};
use crate::base::vec::{dot, sub};
use crate::frame::conventions::Singular;
use crate::images::Image;
use crate::jobs::render::{GlCamera, PixelError};
use crate::mappings::mapping::Mapping;
use crate::mappings::sphere::{dir_to_st, reflect, st_to_dir};
use crate::mesh::Mesh;
use rayon::prelude::*;

/// Per-texel maps of a mapping's canvas (row-major, NaN off the map).
#[derive(Clone, Debug)]
pub struct MappingMaps {
    pub width: usize,
    pub height: usize,
    pub solid_angle: Vec<f64>,
    pub anisotropy: Vec<f64>,
    /// Degrees per texel.
    pub resolution_deg: Vec<f64>,
}

/// min, max, mean over the finite values, and how many there are (`texels` in reports; with
/// none, min and max are ±∞ and mean NaN, written as null in JSON).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Stats {
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    #[serde(rename = "texels")]
    pub count: usize,
}

pub fn stats(v: &[f64]) -> Stats {
    let (mut min, mut max, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0);
    for &x in v.iter().filter(|x| x.is_finite()) {
        min = min.min(x);
        max = max.max(x);
        sum += x;
        n += 1;
    }
    Stats {
        min,
        max,
        mean: if n > 0 { sum / n as f64 } else { f64::NAN },
        count: n,
    }
}

/// The canvas (width, height) of `mapping` at size `n` (1..=[`crate::base::limits::ANALYZE_SIZE`]) for analysis, or an
/// error naming the argument `what`.
pub fn canvas(mapping: Mapping, what: &str, n: usize) -> Result<(usize, usize)> {
    crate::base::limits::check_range(what, n, 1, crate::base::limits::ANALYZE_SIZE)?;
    Ok(mapping.canvas(n))
}

/// The analytics of `mapping` on a `width` × `height` canvas.
pub fn mapping_maps(mapping: Mapping, width: usize, height: usize) -> Result<MappingMaps> {
    mapping.size_of(width, height, "size")?;
    let solid_angle = mapping.solid_angles(width, height);
    let (w, h) = (width as f64, height as f64);
    let per: Vec<(f64, f64)> = (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % width) as f64 + 0.5, (i / width) as f64 + 0.5);
            let dir = |dx: f64, dy: f64| mapping.uv_to_dir([(x + dx) / w, (y + dy) / h]);
            let e = 1e-3;
            let (Some(xp), Some(xm), Some(yp), Some(ym)) =
                (dir(e, 0.0), dir(-e, 0.0), dir(0.0, e), dir(0.0, -e))
            else {
                return (f64::NAN, f64::NAN);
            };
            // Columns of J (per pixel).
            let a = sub(xp, xm).map(|v| v / (2.0 * e));
            let b = sub(yp, ym).map(|v| v / (2.0 * e));
            // Singular values from the 2×2 Gram matrix [[a·a, a·b], [a·b, b·b]].
            let (p, q, r) = (dot(a, a), dot(a, b), dot(b, b));
            let tr = 0.5 * (p + r);
            let disc = (0.25 * (p - r) * (p - r) + q * q).sqrt();
            let (s1, s2) = ((tr + disc).sqrt(), (tr - disc).max(0.0).sqrt());
            if !(s2 > 0.0) {
                return (f64::NAN, f64::NAN);
            }
            (s1 / s2, s1.to_degrees())
        })
        .collect();
    let solid_angle = solid_angle
        .iter()
        .zip(&per)
        .map(|(s, p)| if p.0.is_finite() { *s } else { f64::NAN })
        .collect();
    Ok(MappingMaps {
        width,
        height,
        solid_angle,
        anisotropy: per.iter().map(|p| p.0).collect(),
        resolution_deg: per.iter().map(|p| p.1).collect(),
    })
}

/// The largest subdivision the advice considers (k² sub-triangles).
pub const MAX_SPLIT: u32 = 64;

/// Per-triangle error analysis of a mesh seen by a camera.
#[derive(Clone, Debug)]
pub struct MeshError {
    /// Largest error (degrees) over each triangle's barycentric grid.
    pub triangle_error_deg: Vec<f64>,
    /// Whether each triangle faces the camera and its centroid is in view.
    pub in_view: Vec<bool>,
    /// Advised split per triangle (1 = fine as is; `MAX_SPLIT + 1` = not enough).
    pub split: Vec<u32>,
    pub threshold_deg: f64,
}

impl MeshError {
    /// Triangles in view over the threshold.
    pub fn over(&self) -> Vec<usize> {
        (0..self.split.len())
            .filter(|&i| self.in_view[i] && self.triangle_error_deg[i] > self.threshold_deg)
            .collect()
    }
    /// Triangles after the adaptive advice (in-view triangles split, the rest kept).
    pub fn triangles_after(&self) -> u64 {
        self.split
            .iter()
            .zip(&self.in_view)
            .map(|(k, v)| if *v { (*k).min(MAX_SPLIT) as u64 } else { 1 }.pow(2))
            .sum()
    }
    /// The uniform split that would satisfy every fixable in-view triangle.
    pub fn uniform_split(&self) -> u32 {
        self.split
            .iter()
            .zip(&self.in_view)
            .filter(|(k, v)| **v && **k <= MAX_SPLIT)
            .map(|(k, _)| *k)
            .max()
            .unwrap_or(1)
    }
    /// In-view triangles no split up to `MAX_SPLIT` fixes.
    pub fn unfixable(&self) -> usize {
        self.split
            .iter()
            .zip(&self.in_view)
            .filter(|(k, v)| **v && **k > MAX_SPLIT)
            .count()
    }
}

/// The report of `spheremap analyze --json` and the `summary` of Python's `analyze`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AnalyzeSummary {
    pub mapping: &'static str,
    pub preset: &'static str,
    pub width: usize,
    pub height: usize,
    /// Texel solid angles (sr), their largest over smallest ratio, anisotropy, and the
    /// coarsest angular step per texel (degrees).
    pub solid_angle_sr: Stats,
    pub solid_angle_max_over_min: f64,
    pub anisotropy: Stats,
    pub resolution_deg: Stats,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshSummary>,
    /// The figure written (`run_files`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
}

/// A mesh's per-vertex error, summed up.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MeshSummary {
    /// The mesh file, when it came from one.
    pub file: Option<String>,
    pub triangles: usize,
    pub in_view: usize,
    pub threshold_deg: f64,
    /// How many in-view triangles are over the threshold, and the first 1000 of them.
    pub over: usize,
    pub over_indices: Vec<usize>,
    /// The error over the covered pixels of the heat map.
    pub pixel_error_deg: PixelError,
    pub uniform_split: u32,
    pub triangles_after_uniform: u64,
    pub triangles_after_adaptive: u64,
    pub unfixable: usize,
    /// Advised splits above 1: how many triangles each.
    pub split_histogram: std::collections::BTreeMap<String, usize>,
    pub max_split: u32,
}

impl MappingMaps {
    /// The summary of these maps of `mapping`.
    pub fn summary(&self, mapping: Mapping) -> AnalyzeSummary {
        let sa = stats(&self.solid_angle);
        AnalyzeSummary {
            mapping: mapping.name(),
            preset: mapping.preset_name(),
            width: self.width,
            height: self.height,
            solid_angle_sr: sa,
            solid_angle_max_over_min: sa.max / sa.min,
            anisotropy: stats(&self.anisotropy),
            resolution_deg: stats(&self.resolution_deg),
            mesh: None,
            output: None,
        }
    }
}

impl MeshError {
    /// The summary, with the pixel statistics of `heat` (an error render: degrees and
    /// coverage per pixel).
    pub fn summary(&self, file: Option<&str>, heat: &Image) -> MeshSummary {
        let over = self.over();
        let k = self.uniform_split();
        let mut hist = std::collections::BTreeMap::new();
        for (s, v) in self.split.iter().zip(&self.in_view) {
            if *v && *s > 1 {
                *hist.entry(s.to_string()).or_insert(0usize) += 1;
            }
        }
        let n = self.split.len();
        MeshSummary {
            file: file.map(String::from),
            triangles: n,
            in_view: self.in_view.iter().filter(|v| **v).count(),
            threshold_deg: self.threshold_deg,
            over: over.len(),
            over_indices: over.into_iter().take(1000).collect(),
            pixel_error_deg: PixelError::of(heat),
            uniform_split: k,
            triangles_after_uniform: n as u64 * (k as u64).pow(2),
            triangles_after_adaptive: self.triangles_after(),
            unfixable: self.unfixable(),
            split_histogram: hist,
            max_split: MAX_SPLIT,
        }
    }
}

/// A mesh's error through `cam`: per triangle ([`mesh_error`]) and per pixel (the error render,
/// 2× supersampled: degrees and coverage).
pub fn mesh_report(mesh: &Mesh, cam: &GlCamera, threshold_deg: f64) -> Result<(MeshError, Image)> {
    use crate::jobs::render::{render, Env, Mode, RenderOptions};
    let err = mesh_error(mesh, cam, threshold_deg)?;
    let opts = RenderOptions {
        mode: Mode::Error,
        aa: 2,
        ..Default::default()
    };
    let (heat, _) = render(mesh, cam, Env::None, &opts)?;
    Ok((err, heat))
}

/// Eye-space vertex data of one triangle.
struct EyeTri {
    p: [[f64; 3]; 3],
    n: [[f64; 3]; 3],
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = dot(v, v).sqrt();
    v.map(|x| x / l)
}

fn bary(t: &[[f64; 3]; 3], l: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| l[0] * t[0][k] + l[1] * t[1][k] + l[2] * t[2][k])
}

impl EyeTri {
    /// The exact reflection vector at barycentric `l` (the per-pixel lookup).
    fn exact(&self, l: [f64; 3]) -> [f64; 3] {
        reflect(unit(bary(&self.p, l)), unit(bary(&self.n, l)))
    }
    /// GL's (s, t) at barycentric `l` if it were a vertex: texgen of the interpolated position
    /// and renormalized normal (GL_NORMALIZE).
    fn st_at(&self, l: [f64; 3]) -> [f64; 2] {
        dir_to_st(self.exact(l), Singular::Center)
    }
}

fn angle_deg(st: [f64; 2], r: [f64; 3]) -> f64 {
    match st_to_dir(st) {
        Some(d) => (dot(d, unit(r))).clamp(-1.0, 1.0).acos().to_degrees(),
        None => 180.0,
    }
}

/// Barycentric points of order `m`: (i/m, j/m, 1 − …).
fn grid(m: usize) -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    for i in 0..=m {
        for j in 0..=m - i {
            let (a, b) = (i as f64 / m as f64, j as f64 / m as f64);
            v.push([a, b, 1.0 - a - b]);
        }
    }
    v
}

/// The largest error over the triangle when it is split k × k: the (s, t) of the sub-vertices
/// interpolated linearly inside each sub-triangle, against the exact lookup.
fn split_error(t: &EyeTri, k: usize, pts: &[[f64; 3]]) -> f64 {
    let kf = k as f64;
    let node = |i: usize, j: usize| [i as f64 / kf, j as f64 / kf, 1.0 - (i + j) as f64 / kf];
    let mut worst: f64 = 0.0;
    for i in 0..k {
        for j in 0..k - i {
            // Up to two sub-triangles per cell: (i,j),(i+1,j),(i,j+1) and (i+1,j),(i+1,j+1),(i,j+1).
            let mut subs = vec![[node(i, j), node(i + 1, j), node(i, j + 1)]];
            if i + j + 2 <= k {
                subs.push([node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)]);
            }
            for s in subs {
                let st = s.map(|l| t.st_at(l));
                for q in pts {
                    let l = bary(&s, *q);
                    let st_i = [
                        q[0] * st[0][0] + q[1] * st[1][0] + q[2] * st[2][0],
                        q[0] * st[0][1] + q[1] * st[1][1] + q[2] * st[2][1],
                    ];
                    worst = worst.max(angle_deg(st_i, t.exact(l)));
                }
            }
        }
    }
    worst
}

/// Error per triangle of `mesh` seen by `cam`, and the split each needs to be under
/// `threshold_deg`.
pub fn mesh_error(mesh: &Mesh, cam: &GlCamera, threshold_deg: f64) -> Result<MeshError> {
    if !(threshold_deg > 0.0 && threshold_deg.is_finite()) {
        return Err(Error::param(
            "threshold",
            "must be a positive number of degrees",
        ));
    }
    if mesh.normals.len() != mesh.positions.len() {
        return Err(Error::param("mesh", "needs one normal per vertex"));
    }
    let n = mesh.positions.len();
    if let Some(t) = mesh
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= n))
    {
        return Err(Error::param(
            "mesh",
            format!("triangle {t:?} indexes past the {n} vertices"),
        ));
    }
    let mv = crate::mappings::texgen::ModelviewState::new(cam.modelview)?;
    let m = &cam.modelview;
    let nm = &mv.normal_matrix;
    let eye_p = |p: [f32; 3]| -> [f64; 3] {
        std::array::from_fn(|i| {
            m[i][0] * p[0] as f64 + m[i][1] * p[1] as f64 + m[i][2] * p[2] as f64 + m[i][3]
        })
    };
    let eye_n = |v: [f32; 3]| -> [f64; 3] {
        unit(std::array::from_fn(|i| {
            nm[i][0] * v[0] as f64 + nm[i][1] * v[1] as f64 + nm[i][2] * v[2] as f64
        }))
    };
    let pts = grid(6);
    let sub_pts = grid(3);
    let proj = &cam.projection;
    let results: Vec<(f64, bool, u32)> = mesh
        .triangles
        .par_iter()
        .map(|tri| {
            let t = EyeTri {
                p: tri.map(|i| eye_p(mesh.positions[i as usize])),
                n: tri.map(|i| eye_n(mesh.normals[i as usize])),
            };
            // In view: facing the camera and the centroid inside the frustum.
            let c = bary(&t.p, [1.0 / 3.0; 3]);
            let face = {
                let (a, b) = (sub(t.p[1], t.p[0]), sub(t.p[2], t.p[0]));
                [
                    a[1] * b[2] - a[2] * b[1],
                    a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0],
                ]
            };
            let clip: [f64; 4] = std::array::from_fn(|i| {
                proj[i][0] * c[0] + proj[i][1] * c[1] + proj[i][2] * c[2] + proj[i][3]
            });
            let in_frustum = clip[3] > 0.0 && (0..3).all(|k| clip[k].abs() <= clip[3]);
            let in_view = in_frustum && dot(face, c) < 0.0;
            let e = split_error(&t, 1, &pts);
            if !e.is_finite() {
                return (f64::NAN, false, 1);
            }
            if e <= threshold_deg || !in_view {
                return (e, in_view, 1);
            }
            // Smallest k with the error under the threshold: double, then bisect.
            let ok = |k: u32| split_error(&t, k as usize, &sub_pts) <= threshold_deg;
            let mut hi = 2;
            while hi <= MAX_SPLIT && !ok(hi) {
                hi *= 2;
            }
            if hi > MAX_SPLIT {
                if ok(MAX_SPLIT) {
                    hi = MAX_SPLIT;
                } else {
                    return (e, in_view, MAX_SPLIT + 1);
                }
            }
            let mut lo = hi / 2; // fails (or is 1, which failed)
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if ok(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            (e, in_view, hi)
        })
        .collect();
    Ok(MeshError {
        triangle_error_deg: results.iter().map(|r| r.0).collect(),
        in_view: results.iter().map(|r| r.1).collect(),
        split: results.iter().map(|r| r.2).collect(),
        threshold_deg,
    })
}

/// `spheremap analyze` and Python's `analyze` as one request: the mapping whose canvas is
/// analysed (of a map's size, else of `size`), and for a mesh the camera, its heat map's size
/// and the error threshold.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnalyzeRequest {
    /// sphere, latlong, cube, angular, paraboloid or octahedral, and its preset.
    pub mapping: String,
    pub preset: Option<String>,
    /// The canvas size N without a map (sphere N×N, latlong 2N×N, cube faces N×N, ...).
    pub size: usize,
    /// The mesh's camera and its heat map's `width` × `height`.
    #[serde(flatten)]
    pub view: crate::jobs::render::CameraRequest,
    /// The error threshold in degrees of the triangle list and the tessellation advice.
    pub threshold: f64,
}

impl Default for AnalyzeRequest {
    fn default() -> Self {
        AnalyzeRequest {
            mapping: "sphere".into(),
            preset: None,
            size: 256,
            view: Default::default(),
            threshold: 1.0,
        }
    }
}

/// What an analysis found: the mapping's texel maps and, with a mesh, its error and the error
/// render (degrees and coverage per pixel); `summary` is the report.
#[derive(Clone, Debug)]
pub struct Analysis {
    pub maps: MappingMaps,
    pub mesh: Option<(MeshError, Image)>,
    pub summary: AnalyzeSummary,
}

impl AnalyzeRequest {
    /// The mapping, checked with the other fields; errors name the field.
    pub fn resolve(&self) -> Result<Mapping> {
        if !(self.threshold.is_finite() && self.threshold >= 0.0) {
            return Err(Error::param(
                "threshold",
                format!(
                    "expected a non-negative number of degrees, got {}",
                    self.threshold
                ),
            ));
        }
        Mapping::parse(&self.mapping, self.preset.as_deref())
            .map_err(|e| crate::mappings::mapping::name_fields(e, "mapping", "preset"))
    }

    /// Analyses the mapping's canvas — that of a `width` × `height` map (`map`: its size and
    /// its name in errors; checked against the mapping), else that of `size` — and a mesh (with
    /// its file's name for the report) through the camera.
    pub fn run(
        &self,
        map: Option<((usize, usize), &str)>,
        mesh: Option<(&Mesh, Option<&str>)>,
    ) -> Result<Analysis> {
        let mapping = self.resolve()?;
        let (w, h) = match map {
            Some(((w, h), map)) => {
                mapping.size_of(w, h, map)?;
                (w, h)
            }
            None => canvas(mapping, "size", self.size)?,
        };
        let maps = mapping_maps(mapping, w, h)?;
        let mut summary = maps.summary(mapping);
        let mesh = match mesh {
            Some((mesh, name)) => {
                let cam = self.view.camera(&mesh.positions)?;
                let (err, heat) = mesh_report(mesh, &cam, self.threshold)?;
                summary.mesh = Some(err.summary(name, &heat));
                Some((err, heat))
            }
            None => None,
        };
        Ok(Analysis {
            maps,
            mesh,
            summary,
        })
    }

    /// The figure of an analysis: the mapping's panels and, with its mesh, the error heat map
    /// (clipped at twice the threshold) and the triangles over the threshold.
    pub fn figure(&self, a: &Analysis, mesh: Option<&Mesh>) -> Result<Image> {
        use crate::jobs::render::{self, Env, Mode, RenderOptions};
        let mut panels = vec![figure::mapping_figure(&a.maps, a.summary.mapping)];
        if let (Some((err, heat)), Some(mesh)) = (&a.mesh, mesh) {
            let top = (2.0 * self.threshold).max(1e-6);
            let deg: Vec<f64> = heat
                .data
                .chunks_exact(2)
                .map(|p| match p[0] as f64 {
                    _ if p[1] <= 0.0 => f64::NAN,
                    d => d.min(top),
                })
                .collect();
            panels.push(figure::panel(
                &deg,
                heat.width,
                heat.height,
                0.0,
                top,
                false,
                &format!(
                    "per-vertex vs per-pixel lookup angle (threshold {}°)",
                    self.threshold
                ),
                "deg",
            ));
            let cam = self.view.camera(&mesh.positions)?;
            let normals_opts = RenderOptions {
                mode: Mode::Normals,
                ..Default::default()
            };
            let (normals, _) = render::render(mesh, &cam, Env::None, &normals_opts)?;
            let ids = render::triangle_ids(mesh, &cam)?;
            panels.push(figure::triangles_panel(&ids, &normals, err));
        }
        Ok(if panels.len() == 1 {
            panels.remove(0)
        } else {
            let items: Vec<_> = panels.iter().map(|p| (p, String::new())).collect();
            crate::images::draw::contact_sheet(&items, 1, [0.02; 3], [0.9; 3])
        })
    }

    /// `spheremap analyze`: analyses the map at `map` (its size) or the canvas of `size`, and
    /// the mesh at `mesh`, and writes the figure to `output`; the report.
    pub fn run_files(
        &self,
        map: Option<&str>,
        mesh: Option<&str>,
        output: &str,
        write: &crate::images::codec::WriteOptions,
    ) -> Result<AnalyzeSummary> {
        use crate::images::codec::{read_image, write_image, ReadOptions};
        use std::path::Path;
        let size = match map {
            Some(path) => {
                let img = read_image(Path::new(path), &ReadOptions::default())?;
                Some(((img.width, img.height), path))
            }
            None => None,
        };
        let mesh_data = mesh
            .map(|p| crate::mesh::load_mesh(Path::new(p)))
            .transpose()?;
        let a = self.run(size, mesh_data.as_ref().zip(Some(mesh)))?;
        write_image(
            Path::new(output),
            &self.figure(&a, mesh_data.as_ref())?,
            write,
        )?;
        Ok(a.summary)
    }
}

impl crate::jobs::Report for AnalyzeSummary {
    /// A line for the mapping and one for the mesh.
    fn lines(&self) -> Vec<String> {
        let (sa, an, re) = (self.solid_angle_sr, self.anisotropy, self.resolution_deg);
        let mut lines = vec![format!(
            "{} {}x{}: texel solid angle {}..{} sr (max/min {:.3}), anisotropy up to {:.3}, \
             coarsest step {:.4}..{:.4} deg/texel",
            self.mapping,
            self.width,
            self.height,
            figure::num(sa.min),
            figure::num(sa.max),
            sa.max / sa.min,
            an.max,
            re.min,
            re.max
        )];
        if let Some(m) = &self.mesh {
            lines.push(format!(
                "{}: {} of {} triangles in view over {}°; split each edge in {} \
                 ({} triangles) or adaptively ({} triangles); {} cannot get under it (they \
                 reflect toward the sphere map's rim)",
                m.file.as_deref().unwrap_or("mesh"),
                m.over,
                m.in_view,
                m.threshold_deg,
                m.uniform_split,
                m.triangles_after_uniform,
                m.triangles_after_adaptive,
                m.unfixable
            ));
        }
        if let Some(o) = &self.output {
            lines.push(format!("-> {o}"));
        }
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_map_texels() {
        let m = Mapping::parse("sphere", None).unwrap();
        let n = 64;
        let a = mapping_maps(m, n, n).unwrap();
        // Interior: 16/N² sr; anisotropy 1/cos²(θ/2) = 1/(1 − r²) at radius r:
        // at the centre 1, growing to the rim.
        let c = n / 2 * n + n / 2;
        assert!((a.solid_angle[c] - 16.0 / (n * n) as f64).abs() < 1e-12);
        assert!((a.anisotropy[c] - 1.0).abs() < 1e-3, "{}", a.anisotropy[c]);
        let (x, y) = (n / 2 + 20, n / 2);
        let r = ((x as f64 + 0.5) / n as f64 * 2.0 - 1.0)
            .hypot((y as f64 + 0.5) / n as f64 * 2.0 - 1.0);
        let want = 1.0 / (1.0 - r * r);
        assert!(
            (a.anisotropy[y * n + x] / want - 1.0).abs() < 1e-3,
            "{} {want}",
            a.anisotropy[y * n + x]
        );
        // At the centre the texel is square: resolution² = solid angle; toward the rim the
        // coarse step is σ₁ = σ₂ · anisotropy with σ₁σ₂ = 16/N² (equal area).
        let res = a.resolution_deg[c].to_radians();
        assert!((res * res / a.solid_angle[c] - 1.0).abs() < 1e-3);
        let i = y * n + x;
        let s1 = a.resolution_deg[i].to_radians();
        assert!((s1 * s1 / a.anisotropy[i] / (16.0 / (n * n) as f64) - 1.0).abs() < 1e-3);
        // Off the disc: NaN.
        assert!(a.anisotropy[0].is_nan() && a.solid_angle[0].is_nan());
        let s = stats(&a.anisotropy);
        assert!(s.min >= 1.0 - 1e-9 && s.max > 10.0);
    }

    #[test]
    fn cube_and_latlong() {
        let cube = mapping_maps(Mapping::parse("cube", None).unwrap(), 16, 96).unwrap();
        // A cube face's centre texel is square; its corner texel sees 1/(3√3)… less solid angle.
        // Gnomonic faces: anisotropy √(1 + x² + y²) at face point (x, y): 1 at the centre, √3 at
        // the corners (16 texels: the centre texels sit at x = ±1/16, the corner ones at ±15/16).
        let s = stats(&cube.anisotropy);
        let corner = (1.0f64 + 2.0 * (15.0f64 / 16.0).powi(2)).sqrt();
        assert!(
            s.min < 1.005 && (s.max / corner - 1.0).abs() < 1e-3,
            "{s:?} {corner}"
        );
        let ll = mapping_maps(Mapping::parse("latlong", None).unwrap(), 64, 32).unwrap();
        // Lat-long: anisotropy 1/cos(latitude) at the texel centre.
        let y = 4;
        let lat = (0.5 - (y as f64 + 0.5) / 32.0) * std::f64::consts::PI;
        assert!((ll.anisotropy[y * 64 + 10] * lat.cos() - 1.0).abs() < 2e-3);
    }

    use crate::jobs::render::tests::uv_sphere;
    use crate::jobs::Report;

    #[test]
    fn the_request_checks_its_fields_and_reports_the_canvas_and_the_mesh() {
        let r = AnalyzeRequest::default();
        assert_eq!(
            (r.mapping.as_str(), r.size, r.threshold),
            ("sphere", 256, 1.0)
        );
        let bad = AnalyzeRequest {
            threshold: f64::NAN,
            ..Default::default()
        };
        assert!(bad
            .resolve()
            .unwrap_err()
            .to_string()
            .starts_with("threshold: "));
        let bad = AnalyzeRequest {
            mapping: "mercator".into(),
            ..Default::default()
        };
        assert!(bad
            .resolve()
            .unwrap_err()
            .to_string()
            .starts_with("mapping: "));
        let r = AnalyzeRequest {
            mapping: "latlong".into(),
            size: 16,
            view: crate::jobs::render::CameraRequest {
                width: 32,
                height: 24,
                ..Default::default()
            },
            ..Default::default()
        };
        let mesh = uv_sphere(8, 16);
        let a = r.run(None, Some((&mesh, Some("ball.obj")))).unwrap();
        assert_eq!((a.summary.width, a.summary.height), (32, 16));
        let (err, heat) = a.mesh.as_ref().unwrap();
        assert_eq!((heat.width, heat.height), (32, 24));
        assert_eq!(err.in_view.len(), mesh.triangles.len());
        let m = a.summary.mesh.as_ref().unwrap();
        assert_eq!(m.file.as_deref(), Some("ball.obj"));
        let lines = a.summary.lines();
        assert!(
            lines[0].starts_with("latlong 32x16: texel solid angle"),
            "{lines:?}"
        );
        assert!(lines[1].starts_with("ball.obj: "), "{lines:?}");
        // A map's own size is the canvas, checked against the mapping.
        let a = r.run(Some(((64, 32), "map.exr")), None).unwrap();
        assert_eq!(
            (a.maps.width, a.maps.height, a.mesh.is_none()),
            (64, 32, true)
        );
        let sphere = AnalyzeRequest::default();
        let e = sphere.run(Some(((64, 32), "map.exr")), None).unwrap_err();
        assert!(e.to_string().starts_with("map.exr: "), "{e}");
        let fig = r
            .figure(&r.run(None, Some((&mesh, None))).unwrap(), Some(&mesh))
            .unwrap();
        assert!(fig.width > 0 && fig.height > 0);
    }

    /// Splits every triangle k × k (flat positions, interpolated renormalized normals).
    fn subdivide(m: &Mesh, k: usize) -> Mesh {
        let mut out = Mesh {
            positions: vec![],
            normals: vec![],
            triangles: vec![],
            normals_from_file: true,
        };
        for t in &m.triangles {
            let base = out.positions.len() as u32;
            let mut index = std::collections::HashMap::new();
            for i in 0..=k {
                for j in 0..=k - i {
                    let l = [
                        i as f64 / k as f64,
                        j as f64 / k as f64,
                        1.0 - (i + j) as f64 / k as f64,
                    ];
                    let p = bary(&t.map(|v| m.positions[v as usize].map(|x| x as f64)), l);
                    let n = unit(bary(&t.map(|v| m.normals[v as usize].map(|x| x as f64)), l));
                    index.insert((i, j), base + out.positions.len() as u32 - base);
                    out.positions.push(p.map(|x| x as f32));
                    out.normals.push(n.map(|x| x as f32));
                }
            }
            for i in 0..k {
                for j in 0..k - i {
                    out.triangles
                        .push([index[&(i, j)], index[&(i + 1, j)], index[&(i, j + 1)]]);
                    if i + j + 2 <= k {
                        out.triangles.push([
                            index[&(i + 1, j)],
                            index[&(i + 1, j + 1)],
                            index[&(i, j + 1)],
                        ]);
                    }
                }
            }
        }
        out
    }

    #[test]
    fn tessellation_advice_holds_when_applied() {
        let cam = GlCamera::look_at(
            [0.3, 0.5, 4.0],
            [0.0; 3],
            [0.0, 1.0, 0.0],
            40.0,
            0.5,
            10.0,
            256,
            256,
        )
        .unwrap();
        let coarse = uv_sphere(8, 16);
        let tau = 2.0;
        let e = mesh_error(&coarse, &cam, tau).unwrap();
        let over = e.over();
        assert!(!over.is_empty());
        let k = e.uniform_split();
        assert!(k > 1 && k <= MAX_SPLIT, "{k}");
        // Only triangles reflecting toward the sphere map's rim (grazing, at the silhouette)
        // can be beyond any split.
        let fine = subdivide(&coarse, k as usize);
        let e2 = mesh_error(&fine, &cam, tau).unwrap();
        // Every piece of a fixable coarse triangle in view (k² pieces each, in order).
        let kk = (k * k) as usize;
        let fixable = |c: usize| e.in_view[c] && e.split[c] <= MAX_SPLIT;
        let worst = (0..fine.triangles.len())
            .filter(|&i| fixable(i / kk))
            .map(|i| e2.triangle_error_deg[i])
            .fold(0.0, f64::max);
        let worst_before = over
            .iter()
            .map(|&i| e.triangle_error_deg[i])
            .fold(0.0, f64::max);
        eprintln!(
            "{} of {} over {tau}°, worst {worst_before:.2}°; uniform split {k}, unfixable {}; after: worst {worst:.3}°",
            over.len(),
            coarse.triangles.len(),
            e.unfixable()
        );
        assert!(worst <= tau * 1.05, "{worst}");
    }
}

/// Figures of the analytics (PNG-ready linear RGB).
pub mod figure {
    use super::{stats, MappingMaps};
    use crate::images::draw;
    use crate::images::Image;
    use crate::jobs::render::heat_colour;

    const INK: [f32; 3] = [0.9, 0.9, 0.9];
    const BG: [f32; 3] = [0.02, 0.02, 0.02];
    const OFF: [f32; 3] = [0.06, 0.06, 0.07];

    /// A number for a legend: 4 significant digits, scientific when small or large.
    pub fn num(v: f64) -> String {
        if v == 0.0 || (1e-2..1e4).contains(&v.abs()) {
            let s = format!("{v:.3}");
            let s = s.trim_end_matches('0').trim_end_matches('.');
            s.to_string()
        } else {
            format!("{v:.2e}")
        }
    }

    /// One panel: `values` (row-major w × h, NaN = off the map) coloured from `lo` to `hi`, a
    /// title above, a colour bar with `lo`, the middle and `hi` below.
    #[allow(clippy::too_many_arguments)]
    pub fn panel(
        values: &[f64],
        w: usize,
        h: usize,
        lo: f64,
        hi: f64,
        log: bool,
        title: &str,
        unit: &str,
    ) -> Image {
        // A constant map (relative range under 1e-9) is one colour with one label.
        let constant = !(hi - lo > 1e-9 * hi.abs().max(lo.abs()));
        let log = log && !constant;
        let title = match (unit.is_empty(), log) {
            (true, false) => title.to_string(),
            (true, true) => format!("{title} (log scale)"),
            (false, false) => format!("{title} ({unit})"),
            (false, true) => format!("{title} ({unit}, log scale)"),
        };
        let bar = 10;
        let width = w.max(draw::text_width(&title, 1) + 8).max(300);
        let height = 14 + h + 8 + bar + 20;
        let mut img = Image::new(width, height, 3);
        for p in img.data.chunks_exact_mut(3) {
            p.copy_from_slice(&BG);
        }
        draw::text(&mut img, &title, 0, 2, 1, INK);
        // Colour position of a value: linear, or logarithmic (lo > 0).
        let f = |v: f64| -> f64 {
            let (v, lo, hi) = if log {
                (v.max(lo).ln(), lo.ln(), hi.ln())
            } else {
                (v, lo, hi)
            };
            if constant {
                0.5
            } else {
                (v - lo) / (hi - lo)
            }
        };
        for y in 0..h {
            for x in 0..w {
                let v = values[y * w + x];
                let c = if v.is_finite() {
                    heat_colour(f(v) as f32)
                } else {
                    OFF
                };
                img.pixel_mut(x, 14 + y).copy_from_slice(&c);
            }
        }
        let mid = if log {
            (lo * hi).sqrt()
        } else {
            0.5 * (lo + hi)
        };
        let labels = if constant {
            vec![(0.5, num(lo))]
        } else {
            vec![(0.0, num(lo)), (0.5, num(mid)), (1.0, num(hi))]
        };
        let bw = width - 24; // room for three labels of up to 12 characters
        draw::colour_bar(
            &mut img,
            8,
            (14 + h + 8) as i64,
            bw,
            bar,
            heat_colour,
            &labels,
            INK,
        );
        img
    }

    /// The mesh with its triangles coloured by the advice: grey = under the threshold, orange =
    /// over it (a split fixes it), red = no split up to `MAX_SPLIT` does; shaded by the eye-space
    /// normal's z (from a `Normals` render, `n/2 + ½`), on the dark background.
    pub fn triangles_panel(ids: &[u32], normals: &Image, err: &super::MeshError) -> Image {
        let (w, h) = (normals.width, normals.height);
        let title = format!(
            "triangles over {} deg: orange = split fixes it, red = no split does",
            num(err.threshold_deg)
        );
        let width = w.max(draw::text_width(&title, 1) + 8);
        let mut img = Image::new(width, 14 + h + 4, 3);
        for p in img.data.chunks_exact_mut(3) {
            p.copy_from_slice(&BG);
        }
        draw::text(&mut img, &title, 0, 2, 1, INK);
        for y in 0..h {
            for x in 0..w {
                let id = ids[y * w + x];
                if id == u32::MAX {
                    continue;
                }
                let t = id as usize;
                let shade = 0.25 + 0.75 * (2.0 * normals.pixel(x, y)[2] - 1.0).abs();
                let base = if err.in_view[t] && err.triangle_error_deg[t] > err.threshold_deg {
                    if err.split[t] > super::MAX_SPLIT {
                        [0.9, 0.05, 0.03]
                    } else {
                        [1.0, 0.45, 0.05]
                    }
                } else {
                    [0.45, 0.45, 0.45]
                };
                img.pixel_mut(x, 14 + y)
                    .copy_from_slice(&base.map(|c: f32| c * shade));
            }
        }
        img
    }

    /// The three panels of a mapping's analytics side by side.
    pub fn mapping_figure(m: &MappingMaps, name: &str) -> Image {
        let (w, h) = (m.width, m.height);
        let sa = stats(&m.solid_angle);
        let an = stats(&m.anisotropy);
        let re = stats(&m.resolution_deg);
        // Log scales where the range spans more than a factor of 4.
        let lg = |s: &super::Stats| s.min > 0.0 && s.max > 4.0 * s.min;
        let p1 = panel(
            &m.solid_angle,
            w,
            h,
            sa.min,
            sa.max,
            lg(&sa),
            &format!("{name}: texel solid angle"),
            "sr",
        );
        let p2 = panel(
            &m.anisotropy,
            w,
            h,
            1.0,
            an.max,
            lg(&an),
            "anisotropy (1 = square)",
            "",
        );
        let p3 = panel(
            &m.resolution_deg,
            w,
            h,
            re.min,
            re.max,
            lg(&re),
            "angular resolution: coarsest step",
            "deg/texel",
        );
        let items = [
            (&p1, String::new()),
            (&p2, String::new()),
            (&p3, String::new()),
        ];
        draw::contact_sheet(&items, 3, BG, INK)
    }
}
