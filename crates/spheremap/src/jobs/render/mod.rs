//! A CPU rasterizer that draws a mesh with a sphere map, a MatCap or any environment map, the
//! way OpenGL's fixed-function pipeline does — so its `PerVertex` image can be compared pixel
//! for pixel with a real OpenGL — and the way it should be done (`PerPixel`).
//!
//! ## The pipeline (OpenGL 1.x semantics)
//!
//! ```text
//!  object p ──modelview M──► eye e ──projection P──► clip c ──clip──► ÷w ──viewport──► window
//!  normal n ──(M⁻¹)ᵀ, normalized──► eye normal        (-w ≤ z ≤ w; x, y against a guard band)
//! ```
//!
//! * **Camera**: `M = gluLookAt(eye, target, up)`, `P = gluPerspective(fovy, W/H, near, far)`,
//!   exactly as GLU builds them ([`GlCamera`]).
//! * **Window**: pixel (i, j) covers `[i, i+1) × [j, j+1)` with its centre at `(i+½, j+½)`;
//!   image row 0 is the **top** (GL's window row H−1: the image is what `glReadPixels` returns,
//!   flipped to top-down, as every image in spheremap). Depth: `(z/w + 1)/2`, `GL_LESS`.
//! * **Coverage**: vertices are snapped to 1/2^b pixel (`subpixel_bits` b: 8 by default, as
//!   Mesa's llvmpipe and D3D11-class GPUs; 4 as SwiftShader, the least GL and Vulkan allow) and
//!   covered samples are found with exact integer edge functions; a sample exactly on an edge
//!   belongs to the triangle for which the edge is a top or left edge (image coordinates), so a
//!   shared edge is drawn once. Anti-aliasing (`aa` = k) takes k × k samples per pixel on a
//!   regular grid, each depth-tested and shaded, and averages them (supersampling).
//! * **Attributes** are interpolated perspective-correctly (`Σ λᵢ aᵢ/wᵢ / Σ λᵢ/wᵢ`), as GL does
//!   for texture coordinates; depth is interpolated linearly in window space.
//! * **Both faces** are drawn (GL's default: no culling); normals are not flipped (GL's
//!   default: no two-sided lighting), so a back face reflects as its front would.
//!
//! ## Modes
//!
//! * `PerVertex`: GL_SPHERE_MAP texgen per vertex with the foundation's GL-exact f32 code
//!   ([`crate::mappings::texgen::sphere_texgen`], GL_NORMALIZE on; a singular vertex gets (½, ½), as
//!   legacy Mesa), (s, t) interpolated across each triangle, the sphere map sampled with
//!   GL_LINEAR and no mipmaps ([`Texture`]).
//! * `PerPixel`: the reflection vector per pixel, `r = reflect(normalize(e), normalize(n))`
//!   from the interpolated eye position and normal, looked up in the environment: a sphere map
//!   in **eye space** (a sphere map belongs to the view, as in GL; only the interpolation
//!   differs from `PerVertex`), any other mapping in **world** space (`r` rotated back by the
//!   camera's rotation) with spheremap's bilinear lookup.
//! * `Matcap(variant)`: the interpolated eye normal through [`crate::mappings::matcap::matcap_uv`],
//!   sampled in the MatCap image like a sphere map.
//! * `Normals`: the unit eye-space normal as colour, `n/2 + ½`.
//! * `Error`: the angle in degrees between the per-vertex lookup direction (the direction the
//!   interpolated (s, t) stands for) and the per-pixel reflection vector — two channels: the
//!   mean angle over the pixel's covered samples (0 where none) and the covered fraction.

mod draw;
mod files;
mod raster;
mod request;
mod shade;

pub use draw::{render, triangle_ids};
pub use files::{heat_image, RenderFiles, RenderReport};
pub use request::{CameraRequest, RenderRequest};
pub use shade::{heat_colour, Texture, Wrap};

use crate::base::error::{Error, Result};
use crate::base::vec::{cross, dot, sub};
use crate::frame::view::Mat3;
use crate::images::Image;
use crate::mappings::matcap::MatcapVariant;
use crate::resample::EnvMap;

/// A camera as `gluLookAt` + `gluPerspective` build it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlCamera {
    /// Modelview, row-major, math convention (`e = M p`).
    pub modelview: [[f64; 4]; 4],
    /// Projection, row-major (`c = P e`).
    pub projection: [[f64; 4]; 4],
    pub width: usize,
    pub height: usize,
    /// The `gluLookAt` arguments it was made from.
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    /// The `gluPerspective` arguments (the aspect is width/height).
    pub fovy_deg: f64,
    pub near: f64,
    pub far: f64,
}

fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = dot(a, a).sqrt();
    (l > 0.0 && l.is_finite()).then(|| a.map(|v| v / l))
}

impl GlCamera {
    /// `gluLookAt(eye, target, up)` then `gluPerspective(fovy_deg, width/height, near, far)`.
    #[allow(clippy::too_many_arguments)]
    pub fn look_at(
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        fovy_deg: f64,
        near: f64,
        far: f64,
        width: usize,
        height: usize,
    ) -> Result<GlCamera> {
        crate::base::limits::check_sides(width, height, crate::base::limits::RENDER_SIDE)?;
        if !eye.iter().chain(&target).chain(&up).all(|v| v.is_finite()) {
            return Err(Error::param("eye", "eye, target and up must be finite"));
        }
        if !(fovy_deg > 0.0 && fovy_deg < 180.0) {
            return Err(Error::param(
                "fovy",
                format!("{fovy_deg}°: must be in (0°, 180°)"),
            ));
        }
        if !(near > 0.0 && far > near && far.is_finite()) {
            return Err(Error::param(
                "near",
                format!("near {near}, far {far}: need 0 < near < far"),
            ));
        }
        // gluLookAt: the one construction the texgen command's `lookat:` spec uses too.
        let modelview = crate::base::parse::look_at(eye, target, up, "camera")?;
        // gluPerspective.
        let c = 1.0 / (0.5 * fovy_deg.to_radians()).tan();
        let aspect = width as f64 / height as f64;
        let projection = [
            [c / aspect, 0.0, 0.0, 0.0],
            [0.0, c, 0.0, 0.0],
            [
                0.0,
                0.0,
                (far + near) / (near - far),
                2.0 * far * near / (near - far),
            ],
            [0.0, 0.0, -1.0, 0.0],
        ];
        Ok(GlCamera {
            modelview,
            projection,
            width,
            height,
            eye,
            target,
            up,
            fovy_deg,
            near,
            far,
        })
    }

    /// A camera for `positions` with defaults a user expects: `target` the bounding box's
    /// centre, `eye` on +Z of it far enough that the bounding sphere fits the smaller field of
    /// view with a 10 % margin, `up` +Y, `near`/`far` just around the bounding sphere (near ≥
    /// 1/1000 of the distance, for depth precision). Anything given is used as is.
    #[allow(clippy::too_many_arguments)]
    pub fn framing(
        positions: &[[f32; 3]],
        eye: Option<[f64; 3]>,
        target: Option<[f64; 3]>,
        up: Option<[f64; 3]>,
        fovy_deg: f64,
        near: Option<f64>,
        far: Option<f64>,
        (width, height): (usize, usize),
    ) -> Result<GlCamera> {
        if positions.is_empty() {
            return Err(Error::param("mesh", "has no vertices"));
        }
        for (name, v) in [("eye", eye), ("target", target), ("up", up)] {
            if let Some(v) = v.filter(|v| v.iter().any(|x| !x.is_finite())) {
                return Err(Error::param(name, format!("must be finite, got {v:?}")));
            }
        }
        if !(fovy_deg > 0.0 && fovy_deg < 180.0) {
            return Err(Error::param(
                "fovy",
                format!("{fovy_deg}°: must be in (0°, 180°)"),
            ));
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
        let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let radius = (0.5 * dot(sub(hi, lo), sub(hi, lo)).sqrt()).max(1e-9);
        let target = target.unwrap_or(centre);
        let half = 0.5 * fovy_deg.to_radians();
        let half_min = if width >= height {
            half
        } else {
            (half.tan() * width as f64 / height as f64).atan()
        };
        let eye = eye.unwrap_or([
            target[0],
            target[1],
            target[2] + 1.1 * radius / half_min.sin(),
        ]);
        let d = dot(sub(eye, centre), sub(eye, centre)).sqrt();
        let near = near.unwrap_or(((d - radius) * 0.9).max(d * 1e-3));
        let far = far.unwrap_or((d + radius) * 1.1);
        GlCamera::look_at(
            eye,
            target,
            up.unwrap_or([0.0, 1.0, 0.0]),
            fovy_deg,
            near,
            far,
            width,
            height,
        )
    }

    /// The same camera with its eye turned `angle_deg` about `up` through the target.
    pub fn orbited(&self, angle_deg: f64) -> Result<GlCamera> {
        GlCamera::look_at(
            orbit_eye(self.eye, self.target, self.up, angle_deg),
            self.target,
            self.up,
            self.fovy_deg,
            self.near,
            self.far,
            self.width,
            self.height,
        )
    }

    /// Eye → world rotation (the transpose of the modelview's rotation; gluLookAt's is
    /// orthonormal).
    pub fn eye_to_world(&self) -> Mat3 {
        let m = &self.modelview;
        [
            [m[0][0], m[1][0], m[2][0]],
            [m[0][1], m[1][1], m[2][1]],
            [m[0][2], m[1][2], m[2][2]],
        ]
    }
}

/// The eye turned by `angle_deg` about the axis through `target` along `up` (a right-handed
/// turn: with up = +Y, +Z goes to +X at 90°) — a turntable's camera path.
pub fn orbit_eye(eye: [f64; 3], target: [f64; 3], up: [f64; 3], angle_deg: f64) -> [f64; 3] {
    let k = unit(up).unwrap_or([0.0, 1.0, 0.0]);
    let v = sub(eye, target);
    let (s, c) = angle_deg.to_radians().sin_cos();
    let kxv = cross(k, v);
    let kv = dot(k, v);
    // Rodrigues: v c + (k × v) s + k (k·v)(1 − c).
    std::array::from_fn(|i| target[i] + v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
}

crate::base::named::named_enum! {
    /// The names of [`Mode`] (`--mode`, `mode=`).
    #[derive(Default)]
    pub enum ModeName: "mode" as "mode" {
        PerVertex = "per-vertex",
        #[default]
        PerPixel = "per-pixel",
        Matcap = "matcap",
        Normals = "normals",
        Error = "error",
    }
}

/// What to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    PerVertex,
    PerPixel,
    Matcap(MatcapVariant),
    Normals,
    Error,
}

impl Mode {
    /// `matcap` takes its variant separately.
    pub fn parse(name: &str, matcap: MatcapVariant) -> Result<Mode> {
        Ok(Mode::of(ModeName::parse(name)?, matcap))
    }

    /// The mode of a name (`matcap` with its variant).
    pub fn of(name: ModeName, matcap: MatcapVariant) -> Mode {
        match name {
            ModeName::PerVertex => Mode::PerVertex,
            ModeName::PerPixel => Mode::PerPixel,
            ModeName::Matcap => Mode::Matcap(matcap),
            ModeName::Normals => Mode::Normals,
            ModeName::Error => Mode::Error,
        }
    }

    /// Output channels: 2 for `Error` (degrees, coverage), 3 otherwise.
    pub fn channels(self) -> usize {
        if self == Mode::Error {
            2
        } else {
            3
        }
    }
}

/// The environment a render looks up.
#[derive(Clone, Copy)]
pub enum Env<'a> {
    /// A sphere map (or a MatCap) as a GL texture: (s, t) lookups.
    Texture(&'a Texture<'a>),
    /// Any mapping, looked up by world direction (per-pixel only).
    Map(&'a EnvMap<'a>),
    /// Nothing to look up (`Normals`, `Error`).
    None,
}

/// A sphere map in a preset other than GL's (skylibs, a mirror-ball photo, …) resampled into
/// the GL sphere map that texgen's (s, t) address, for the per-vertex and per-pixel modes: the
/// same size, the default footprint filter.  `None` when nothing needs converting (a GL sphere
/// map, another mapping, or a MatCap, which has no preset).  Without it such a map would be
/// read as a GL one: mirrored or turned.
pub fn gl_sphere_for(
    mode: Mode,
    mapping: crate::mappings::mapping::Mapping,
    image: &Image,
    what: &str,
) -> Result<Option<Image>> {
    let crate::mappings::mapping::Mapping::Sphere(p) = mapping else {
        return Ok(None);
    };
    if p.name == "gl" || !matches!(mode, Mode::PerVertex | Mode::PerPixel) {
        return Ok(None);
    }
    let src = EnvMap::new(mapping, image, what)?;
    let gl = crate::mappings::mapping::Mapping::parse("sphere", None)?;
    let opts = crate::resample::ResampleOptions::default();
    let (out, _) = crate::resample::resample(&src, gl, image.width, image.height, &opts, None)?;
    Ok(Some(out))
}

/// An environment image prepared for rendering: a sphere map (or MatCap) becomes a GL
/// texture, any other mapping a direction-lookup map.
pub struct EnvInput<'a> {
    texture: Option<Texture<'a>>,
    map: Option<EnvMap<'a>>,
}

impl<'a> EnvInput<'a> {
    /// `image` in `mapping` (none: nothing to look up); `what` names it in errors.
    pub fn new(
        mapping: crate::mappings::mapping::Mapping,
        image: Option<&'a Image>,
        wrap: Wrap,
        what: &str,
    ) -> Result<Self> {
        let sphere = matches!(mapping, crate::mappings::mapping::Mapping::Sphere(_));
        Ok(match image {
            None => EnvInput {
                texture: None,
                map: None,
            },
            Some(image) if sphere => EnvInput {
                texture: Some(Texture { image, wrap }),
                map: None,
            },
            Some(image) => EnvInput {
                texture: None,
                map: Some(EnvMap::new(mapping, image, what)?),
            },
        })
    }

    /// Whether `mode` can use it: per-vertex and MatCap need (s, t) lookups, i.e. a sphere map
    /// or MatCap image; per-pixel needs some environment.
    pub fn check(&self, mode: Mode) -> Result<()> {
        match mode {
            Mode::Normals | Mode::Error => Ok(()),
            _ if self.texture.is_none() && self.map.is_none() => Err(Error::param(
                "env",
                "per-vertex, per-pixel and matcap need an environment map",
            )),
            Mode::PerVertex | Mode::Matcap(_) if self.texture.is_none() => Err(Error::param(
                "src",
                "per-vertex and matcap look up (s, t) in a sphere map or MatCap image; convert \
                 the map to a sphere map first",
            )),
            _ => Ok(()),
        }
    }

    pub fn env(&self) -> Env<'_> {
        match (&self.texture, &self.map) {
            (Some(t), _) => Env::Texture(t),
            (None, Some(m)) => Env::Map(m),
            _ => Env::None,
        }
    }
}

/// Sub-pixel bits of the rasterizer's fixed-point window coordinates (1/256 pixel), and the
/// default of the vertex snapping (llvmpipe's); coarser snapping rounds to a multiple of
/// 2^(8 − bits) units.
pub(crate) const SUB_BITS: u32 = 8;

/// Render options.
#[derive(Clone, Copy, Debug)]
pub struct RenderOptions {
    pub mode: Mode,
    /// Colour of pixels no triangle covers (linear); the `Error` mode writes 0 there.
    pub background: [f32; 3],
    /// Samples per pixel along each axis (1 = the pixel centre only).
    pub aa: u32,
    /// Sub-pixel bits of the vertex snapping (1..=8): 8 as llvmpipe, 4 as SwiftShader.
    pub subpixel_bits: u32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            mode: Mode::PerPixel,
            background: [0.0; 3],
            aa: 1,
            subpixel_bits: SUB_BITS,
        }
    }
}

/// What a render did.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    /// Triangles drawn after clipping (a clipped triangle may become several).
    pub triangles: usize,
    /// Pixels with at least one covered sample.
    pub covered_pixels: usize,
}

/// Mean, 95th percentile and largest lookup-angle error over the covered pixels of an error
/// render (degrees; `p95` and `max` are `None` when no pixel is covered).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PixelError {
    pub mean: f64,
    pub p95: Option<f64>,
    pub max: Option<f64>,
}

impl PixelError {
    /// The statistics of an error render `heat` (degrees, coverage per pixel).
    pub fn of(heat: &Image) -> PixelError {
        let mut px: Vec<f64> = heat
            .data
            .chunks_exact(2)
            .filter(|p| p[1] > 0.0)
            .map(|p| p[0] as f64)
            .collect();
        px.sort_by(f64::total_cmp);
        let pct = |q: f64| {
            px.get(((px.len().max(1) - 1) as f64 * q).round() as usize)
                .copied()
        };
        PixelError {
            mean: px.iter().sum::<f64>() / px.len().max(1) as f64,
            p95: pct(0.95),
            max: pct(1.0),
        }
    }
}

/// The report of `spheremap render --json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RenderSummary {
    pub output: String,
    pub mode: String,
    pub width: usize,
    pub height: usize,
    /// Triangles drawn after clipping, and pixels with a covered sample.
    pub triangles_drawn: usize,
    pub covered_pixels: usize,
    /// The camera's matrices (row-major).
    pub modelview: [[f64; 4]; 4],
    pub projection: [[f64; 4]; 4],
    pub seconds: f64,
    /// Values the output format clipped, and values beyond the half range.
    pub clipped: u64,
    pub clamped_half: u64,
    /// The error mode's statistics, and the angle the heat map's colour scale ends at.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_deg: Option<PixelError>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_scale_deg: Option<f64>,
}

/// The report of `spheremap render --turntable --json`: the frames written (one GIF, or one
/// file per frame), their count, the mode and the size of a frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TurntableReport {
    pub output: Vec<String>,
    pub frames: u32,
    pub mode: ModeName,
    pub width: usize,
    pub height: usize,
    pub seconds: f64,
}

/// Per-vertex data in eye space.
pub(crate) struct Vertices {
    pub eye: Vec<[f64; 3]>,
    pub normal: Vec<[f64; 3]>,
    pub st: Vec<[f32; 2]>,
    pub clip: Vec<[f64; 4]>,
}

impl crate::jobs::Report for RenderSummary {
    fn lines(&self) -> Vec<String> {
        let extra = self.error_deg.as_ref().map_or(String::new(), |e| {
            let (mean, p95, max) = (e.mean, e.p95.unwrap_or(0.0), e.max.unwrap_or(0.0));
            format!(
                "; per-vertex vs per-pixel lookup angle: mean {mean:.3}°, 95 % {p95:.3}°, max \
                 {max:.3}° (PNG colour scale 0..{}°)",
                self.error_scale_deg.unwrap_or(0.0)
            )
        });
        vec![format!(
            "-> {} ({}x{}, {}, {} triangles, {} pixels covered){extra}: {:.3} s",
            self.output,
            self.width,
            self.height,
            self.mode,
            self.triangles_drawn,
            self.covered_pixels,
            self.seconds
        )]
    }
}

impl crate::jobs::Report for TurntableReport {
    fn lines(&self) -> Vec<String> {
        let files = match self.output.as_slice() {
            [one] => one.clone(),
            [first, .., last] => format!("{first} ... {last}"),
            [] => String::new(),
        };
        vec![format!(
            "-> {files} ({} frames, {}x{}, {}): {:.3} s",
            self.frames, self.width, self.height, self.mode, self.seconds
        )]
    }
}

#[cfg(test)]
pub(crate) mod tests;
