//! MatCap ("lit sphere") lookups.  A MatCap is indexed by the eye-space *normal*, not by the
//! reflection vector, so it is not a sphere map; it shares the disc and the image
//! orientation of [`crate::frame::conventions`] (row 0 = v = 1, +Y up).
//!
//! Three variants, all taking eye-space normals `n` (normalized here; zero → NaN) and, where
//! they need it, the eye-space position `p` of the shaded point (the viewer is at the origin):
//!
//! * [`MatcapVariant::Classic`]: `uv = n.xy · ½ + ½`.  Correct for an orthographic camera
//!   looking down −Z.
//! * [`MatcapVariant::ThreeJs`]: three.js `MeshMatcapMaterial`: with `v = normalize(−p)` (toward
//!   the viewer), `x = normalize(v.z, 0, −v.x)`, `y = v × x`, `uv = (x·n, y·n) · 0.495 + ½`.
//!   The basis follows the view ray, keeping `x` horizontal in eye space; 0.495 hides the
//!   undersized discs of many MatCap images.  Degenerate when the view ray is vertical
//!   (`v.x = v.z = 0`): NaN.
//! * [`MatcapVariant::Perspective`]: defined here.  **What it corrects:** under a perspective
//!   camera the view ray through a pixel is not −Z, so the classic lookup shades a sphere away
//!   from the screen centre as if seen obliquely — its silhouette normals (perpendicular to the
//!   view ray) land inside the disc instead of on its rim and the normal facing the viewer lands
//!   off-centre, so off-axis objects look lit from a shifted direction.  We rotate `n` by the
//!   *minimal* rotation `R` that takes the view ray `d = normalize(p)` to (0,0,−1) and apply
//!   the classic lookup: every point is shaded exactly as an orthographic camera looking along
//!   its own view ray would shade it.  Consequences (tested): `n = −d` → centre, `n ⊥ d` → rim,
//!   identical to classic on the optical axis.  Unlike three.js, the basis has no roll of its
//!   own (the minimal rotation never spins about the view ray, so the MatCap's "up" stays the
//!   screen's up as nearly as possible in the corners) and no singularity for vertical view
//!   rays; only `p` on the +Z axis behind the viewer (`d = (0,0,1)`) is undefined (NaN).
//!   `R v = c v + k×v + k (k·v)/(1 + c)` with `k = d × (0,0,−1) = (−d_y, d_x, 0)`, `c = −d_z`.

use crate::base::real::{dot3, Real};

crate::base::named::named_enum! {
    /// How a MatCap is looked up (the module's list).
    #[derive(Default)]
    pub enum MatcapVariant: "MatCap variant" as "matcap_variant" {
        #[default]
        Classic = "classic",
        ThreeJs = "threejs" | "three",
        Perspective = "perspective",
    }
}

impl MatcapVariant {
    /// The scale applied to the basis coordinates: ½ (the full disc) except three.js's 0.495.
    pub fn default_scale(self) -> f64 {
        match self {
            Self::ThreeJs => 0.495,
            _ => 0.5,
        }
    }
}

#[inline]
fn normalize<T: Real>(v: [T; 3]) -> [T; 3] {
    let l2 = dot3(v, v);
    if !(l2 > T::ZERO) {
        return [T::NAN; 3];
    }
    let k = T::ONE / l2.sqrt();
    [v[0] * k, v[1] * k, v[2] * k]
}

/// MatCap texture coordinates (u, v) (v up, like t) for eye-space normal `n` at eye-space
/// position `p` (`None`: an orthographic view, view ray (0,0,−1) everywhere).
pub fn matcap_uv<T: Real>(
    n: [T; 3],
    p: Option<[T; 3]>,
    variant: MatcapVariant,
    scale: T,
) -> [T; 2] {
    let n = normalize(n);
    let (a, b) = match variant {
        MatcapVariant::Classic => (n[0], n[1]),
        MatcapVariant::ThreeJs => {
            let v = match p {
                Some(p) => normalize([-p[0], -p[1], -p[2]]),
                None => [T::ZERO, T::ZERO, T::ONE],
            };
            let x = normalize([v[2], T::ZERO, -v[0]]);
            let y = [
                v[1] * x[2] - v[2] * x[1],
                v[2] * x[0] - v[0] * x[2],
                v[0] * x[1] - v[1] * x[0],
            ];
            (dot3(x, n), dot3(y, n))
        }
        MatcapVariant::Perspective => match p {
            None => (n[0], n[1]),
            Some(p) => {
                let d = normalize(p);
                let c = -d[2];
                let onepc = T::ONE + c;
                if !(onepc > T::ZERO) {
                    return [T::NAN, T::NAN];
                }
                let k = [-d[1], d[0], T::ZERO];
                let kxn = [
                    k[1] * n[2] - k[2] * n[1],
                    k[2] * n[0] - k[0] * n[2],
                    k[0] * n[1] - k[1] * n[0],
                ];
                let kn = dot3(k, n) / onepc;
                (c * n[0] + kxn[0] + k[0] * kn, c * n[1] + kxn[1] + k[1] * kn)
            }
        },
    };
    [a * scale + T::HALF, b * scale + T::HALF]
}
