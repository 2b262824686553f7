//! # Conventions — the one place where frames, image orientation and texel centres are fixed
//!
//! Everything else in spheremap calls into this module; nothing else decides which way is up.
//!
//! ## Eye space (OpenGL)
//!
//! Right-handed, +X right, +Y up, the viewer at the origin looking down −Z:
//!
//! ```text
//!            +Y
//!             |
//!             |
//!             o------ +X          the viewer looks along −Z (into the screen);
//!            /                    +Z points back out of the screen, at the viewer
//!          +Z
//! ```
//!
//! ## The sphere-map disc
//!
//! A sphere map is the image of a perfect mirror ball seen by an orthographic camera looking down
//! −Z.  Texture coordinates (s, t) ∈ [0,1]²; the disc is the inscribed circle.  Writing
//! `x = 2s − 1`, `y = 2t − 1`, the ball normal is `n = (x, y, √(1 − x² − y²))` and the mapped
//! direction is the reflection of the view ray (0,0,−1): `r = (2zx, 2zy, 2z² − 1)`.
//!
//! ```text
//!   t = 1  +---------------------------+        disc coordinates (x, y) = (2s−1, 2t−1)
//!          |         .-'''''-.         |
//!          |      .'    +Y     '.      |        centre (½,½)  r = (0,0,+1): straight back at
//!          |     /               \     |                      the viewer (you see yourself)
//!          |    |  −X    +Z   +X  |    |        rim x²+y²=1   r = (0,0,−1): the single
//!          |     \               /     |                      direction straight ahead, behind
//!          |      '.    −Y     .'      |                      the ball
//!          |         '-.....-'         |        corners       outside the disc: no direction
//!   t = 0  +---------------------------+
//!        s = 0                       s = 1
//! ```
//!
//! (+X appears at s ≈ 0.854, t = ½; +Y at s = ½, t ≈ 0.854: the ±X/±Y directions sit at
//! radius 1/√2 of the disc, not on the rim.)
//!
//! ## Image rows versus t
//!
//! * **GL texture memory** (what `glTexImage2D` consumes, and what a classic `gen_sphere_map`
//!   loop produces): the first row uploaded is t = 0, the bottom of the picture above.
//! * **Image files and arrays in spheremap** (PNG, EXR, numpy `(H, W, C)`): row 0 is the *top*
//!   of the picture, i.e. t = 1.  A sphere-map file therefore looks like a photo of a chrome
//!   ball: +Y up, −X on the left, you in the middle.  This is [`RowOrder::TopIsT1`], the default.
//!
//! ## Texel centres
//!
//! Texel `i` of `n` covers `[i/n, (i+1)/n)` and its centre is `(i + ½)/n` (the GL and D3D10+
//! rule).  Continuous pixel coordinates put (0,0) at the top-left *corner* of the image and
//! pixel centres at `i + ½`.  Converting between the two never adds or drops a half texel: see
//! [`texel_center`], [`st_to_pixel`], [`pixel_to_st`].
//!
//! ## Presets for other tools
//!
//! Each [`SpherePreset`] is a documented rotation/reflection from the tool's own frame to our eye
//! frame, plus the row order of its image and the orientation of its texture coordinates.  Each
//! is pinned by a test that maps ±X, ±Y, ±Z to concrete pixels (`tests/conventions.rs`).

use crate::base::error::{Error, Result};
use crate::base::real::Real;

crate::base::named::named_enum! {
    /// What to return where the mapping is singular: the sphere map's rim, where r = (0,0,−1)
    /// has no unique (s,t), and — in mesh texgen — zero-length vectors that GL normalizes.
    #[derive(Default)]
    pub enum Singular: "value" as "singular" {
        /// NaN, as current Mesa computes (`rsq(0) = inf`, `0·inf = NaN`).  The honest answer:
        /// there is no single texel for the direction straight ahead.  **The default.**
        #[default]
        Nan = "nan",
        /// The centre (½,½), as legacy Mesa's fixed-function `tnl` path and Blender Cycles'
        /// `direction_to_mirrorball` return.  In texgen this also follows legacy Mesa in
        /// normalizing a zero-length vector to zero instead of NaN.
        Center = "center" | "centre",
    }
}

/// Which texture coordinate the first row of an image holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowOrder {
    /// Row 0 is the top of the picture, t = 1 (image files, numpy arrays; spheremap's default).
    TopIsT1,
    /// Row 0 is t = 0 (GL texture memory, the order `glTexImage2D` uploads).
    TopIsT0,
}

/// Centre of texel `i` of `n` along one axis, in [0,1] texture coordinates: `(i + ½)/n`.
#[inline]
pub fn texel_center(i: usize, n: usize) -> f64 {
    (i as f64 + 0.5) / n as f64
}

/// Texture coordinates (s,t) → continuous pixel coordinates (x, y) of a `width`×`height` image
/// whose rows are ordered as `rows` says.  (0,0) is the top-left corner of the first row; the
/// centre of pixel (col, row) is (col + ½, row + ½).
#[inline]
pub fn st_to_pixel(s: f64, t: f64, width: usize, height: usize, rows: RowOrder) -> (f64, f64) {
    let x = s * width as f64;
    let y = match rows {
        RowOrder::TopIsT1 => (1.0 - t) * height as f64,
        RowOrder::TopIsT0 => t * height as f64,
    };
    (x, y)
}

/// Inverse of [`st_to_pixel`].
#[inline]
pub fn pixel_to_st(x: f64, y: f64, width: usize, height: usize, rows: RowOrder) -> (f64, f64) {
    let s = x / width as f64;
    let t = match rows {
        RowOrder::TopIsT1 => 1.0 - y / height as f64,
        RowOrder::TopIsT0 => y / height as f64,
    };
    (s, t)
}

/// A named sphere-map convention of another tool, expressed against ours.
///
/// A direction `d` given in the preset's own frame maps to our eye-space direction
/// `frame · d`; the GL sphere mapping gives (s,t); the preset's image stores t in the row order
/// `rows`; and the preset's own texture coordinates are `(s, t)` or `(s, 1 − t)`
/// (`v_down`, the D3D/Vulkan/Metal origin at the top-left).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpherePreset {
    pub name: &'static str,
    /// Row-major 3×3 rotation or reflection: preset frame → our eye frame.
    pub frame: [[f64; 3]; 3],
    pub rows: RowOrder,
    /// The preset's texture coordinate v is 1 − t (origin at the top-left).
    pub v_down: bool,
    pub doc: &'static str,
}

use crate::base::vec::IDENTITY3;

/// All presets, the first being ours.
pub const PRESETS: &[SpherePreset] = &[
    SpherePreset {
        name: "gl",
        frame: IDENTITY3,
        rows: RowOrder::TopIsT1,
        v_down: false,
        doc: "OpenGL GL_SPHERE_MAP in eye space (right-handed, +Y up, looking down -Z); \
              image file with row 0 = t = 1. spheremap's own convention.",
    },
    SpherePreset {
        name: "gl-upload",
        frame: IDENTITY3,
        rows: RowOrder::TopIsT0,
        v_down: false,
        doc: "The same map in GL texture memory order: row 0 = t = 0, as glTexImage2D consumes \
              it and as a classic gen_sphere_map loop writes it (a vertical flip of the file).",
    },
    SpherePreset {
        name: "d3d",
        // D3D view space is left-handed, looking down +Z: z_gl = -z_d3d.
        frame: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]],
        rows: RowOrder::TopIsT1,
        v_down: true,
        doc: "The GL map addressed from Direct3D/Vulkan/Metal: left-handed view space (+Z \
              forward, so z is negated), texture origin at the top-left (v = 1 - t). The file's \
              pixels are the same as 'gl'.",
    },
    SpherePreset {
        name: "skylibs",
        // skylibs' `sphere` mapping (envmap.projections world2sphere/sphere2world): the GL
        // formula applied to (x, -y, -z), i.e. our map of the world rotated 180° about X, with
        // its v = row/H equal to that map's t.  Its centre is -Z (forward), not the viewer.
        frame: [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
        rows: RowOrder::TopIsT0,
        v_down: false,
        doc: "skylibs EnvironmentMap format 'sphere' (world2sphere: u = 1/2 + r x, v = 1/2 - r y, \
              r = sin(acos(-z)/2) / (2 sqrt(x^2+y^2)), v = row/H): world right-handed +Y up; the \
              centre of the disc is -Z (forward), the rim +Z; row 0 at the top, +Y up, +X right. \
              Equal to 'gl' for the world rotated 180 degrees about X, stored in GL upload order \
              (equivalently: 'gl' of (x, y, -z), a reflection, in file order).",
    },
    SpherePreset {
        name: "blender-mirrorball",
        // Blender world is Z-up: (x, y, z)_blender = (x, -z, y)_ours, so ours = (x, z, -y).
        frame: [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]],
        rows: RowOrder::TopIsT1,
        v_down: false,
        doc: "Blender Cycles environment texture, projection 'Mirror Ball' (direction_to_mirrorball): \
              Blender world (right-handed, +Z up), the ball seen from -Y looking along +Y; image \
              origin bottom-left as Blender stores it. Equal to 'gl' for a viewer looking along \
              Blender's +Y with +Z up.",
    },
    SpherePreset {
        name: "mirror-ball-photo",
        frame: IDENTITY3,
        rows: RowOrder::TopIsT1,
        v_down: false,
        doc: "A photo of a chrome ball from an orthographic camera, as the camera stored it: \
              directions in the camera's eye frame. Identical to 'gl' (not mirrored): the ball's \
              right side reflects the camera's +X.",
    },
];

impl SpherePreset {
    /// Looks a preset up by name.
    pub fn by_name(name: &str) -> Result<&'static SpherePreset> {
        PRESETS.iter().find(|p| p.name == name).ok_or_else(|| {
            let names: Vec<_> = PRESETS.iter().map(|p| p.name).collect();
            Error::param(
                "preset",
                format!(
                    "unknown preset {name:?}; expected one of: {}",
                    names.join(", ")
                ),
            )
        })
    }

    /// Preset-frame direction → our eye frame.
    pub fn to_eye(&self, d: [f64; 3]) -> [f64; 3] {
        mat3_mul(&self.frame, d)
    }

    /// Our eye frame → preset frame (the frames are orthogonal: the inverse is the transpose).
    pub fn from_eye(&self, d: [f64; 3]) -> [f64; 3] {
        let f = &self.frame;
        [
            f[0][0] * d[0] + f[1][0] * d[1] + f[2][0] * d[2],
            f[0][1] * d[0] + f[1][1] * d[1] + f[2][1] * d[2],
            f[0][2] * d[0] + f[1][2] * d[1] + f[2][2] * d[2],
        ]
    }

    /// The preset's own texture coordinates for our (s,t).
    pub fn st_to_uv(&self, s: f64, t: f64) -> (f64, f64) {
        if self.v_down {
            (s, 1.0 - t)
        } else {
            (s, t)
        }
    }
}

#[inline]
pub(crate) fn mat3_mul<T: Real>(m: &[[f64; 3]; 3], d: [T; 3]) -> [T; 3] {
    let r = |i: usize| {
        T::from_f64(m[i][0]) * d[0] + T::from_f64(m[i][1]) * d[1] + T::from_f64(m[i][2]) * d[2]
    };
    [r(0), r(1), r(2)]
}
