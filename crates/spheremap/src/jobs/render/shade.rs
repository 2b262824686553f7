//! Per-sample shading for each mode, the GL_LINEAR texture lookup, and the heat colour map.

use super::{Env, GlCamera, Mode, Vertices};
use crate::frame::conventions::Singular;
use crate::frame::view::Mat3;
use crate::images::Image;
use crate::mappings::matcap::matcap_uv;
use crate::mappings::sphere::{dir_to_st, reflect, st_to_dir};
use crate::resample::Sampler;

/// Interpolated attributes: eye position (3), eye normal (3), (s, t) (2).
pub(crate) const NA: usize = 8;

crate::base::named::named_enum! {
    /// GL texture wrap modes (for s and t alike).
    #[derive(Default)]
    pub enum Wrap: "wrap" as "wrap" {
        /// GL_CLAMP_TO_EDGE (the default here: a sphere map has no neighbour across its
        /// border).
        #[default]
        ClampToEdge = "clamp-to-edge" | "clamp",
        /// GL_REPEAT (OpenGL's own default).
        Repeat = "repeat",
    }
}

/// An image used as a GL 2D texture with GL_LINEAR filtering and no mipmaps. The image is in
/// spheremap's orientation (row 0 at the top = t = 1); GL's texel row 0 (t = 0) is its last
/// row. Texel centres at (i + ½)/W, as GL.
pub struct Texture<'a> {
    pub image: &'a Image,
    pub wrap: Wrap,
}

impl Texture<'_> {
    fn texel(&self, i: i64, n: usize) -> usize {
        match self.wrap {
            Wrap::ClampToEdge => i.clamp(0, n as i64 - 1) as usize,
            Wrap::Repeat => i.rem_euclid(n as i64) as usize,
        }
    }

    /// GL_LINEAR at (s, t): the first three channels (one channel is grey). NaN in, 0 out.
    pub fn sample(&self, st: [f64; 2], out: &mut [f32]) {
        let img = self.image;
        if !(st[0].is_finite() && st[1].is_finite()) {
            out[..3].fill(0.0);
            return;
        }
        let u = st[0] * img.width as f64 - 0.5;
        let v = (1.0 - st[1]) * img.height as f64 - 0.5; // image rows, down
        let (i0, j0) = (u.floor(), v.floor());
        let (fu, fv) = ((u - i0) as f32, (v - j0) as f32);
        let (i0, j0) = (i0 as i64, j0 as i64);
        let xs = [self.texel(i0, img.width), self.texel(i0 + 1, img.width)];
        let ys = [self.texel(j0, img.height), self.texel(j0 + 1, img.height)];
        let w = [
            (1.0 - fu) * (1.0 - fv),
            fu * (1.0 - fv),
            (1.0 - fu) * fv,
            fu * fv,
        ];
        let c = img.channels;
        let mut acc = [0f32; 3];
        for (k, (x, y)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
            let p = &img.data[(ys[y] * img.width + xs[x]) * c..][..c];
            for (ch, a) in acc.iter_mut().enumerate() {
                *a += w[k] * p[if c >= 3 { ch } else { 0 }];
            }
        }
        out[..3].copy_from_slice(&acc);
    }
}

/// Shades one sample from its interpolated attributes.
pub(crate) struct Shader<'a> {
    mode: Mode,
    texture: Option<&'a Texture<'a>>,
    sampler: Option<Sampler<'a>>,
    eye_to_world: Mat3,
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

impl<'a> Shader<'a> {
    pub(crate) fn new(mode: Mode, env: Env<'a>, cam: &GlCamera, _v: &Vertices) -> Self {
        let (texture, sampler) = match env {
            Env::Texture(t) => (Some(t), None),
            Env::Map(m) => (None, Some(Sampler::new(m))),
            Env::None => (None, None),
        };
        Shader {
            mode,
            texture,
            sampler,
            eye_to_world: cam.eye_to_world(),
        }
    }

    pub(crate) fn is_error(&self) -> bool {
        self.mode == Mode::Error
    }

    /// The per-pixel reflection vector in eye space (unit).
    fn reflection(a: &[f64; NA]) -> [f64; 3] {
        let u = unit([a[0], a[1], a[2]]);
        let n = unit([a[3], a[4], a[5]]);
        reflect(u, n)
    }

    pub(crate) fn shade(&self, a: &[f64; NA], out: &mut [f32]) {
        let st = [a[6], a[7]];
        match self.mode {
            Mode::PerVertex => self.texture.expect("checked").sample(st, out),
            Mode::PerPixel => {
                let r = Self::reflection(a);
                if let Some(t) = self.texture {
                    t.sample(dir_to_st(r, Singular::Center), out);
                } else if let Some(s) = &self.sampler {
                    let m = &self.eye_to_world;
                    let d: [f32; 3] = std::array::from_fn(|i| {
                        (m[i][0] * r[0] + m[i][1] * r[1] + m[i][2] * r[2]) as f32
                    });
                    let mut v = [0f32; crate::trace::generate::MAX_CHANNELS];
                    if d.iter().all(|x| x.is_finite()) {
                        s.sample(d, &mut v);
                    }
                    for ch in 0..3 {
                        out[ch] = v[if s.channels() >= 3 { ch } else { 0 }];
                    }
                }
            }
            Mode::Matcap(variant) => {
                let uv = matcap_uv(
                    [a[3], a[4], a[5]],
                    Some([a[0], a[1], a[2]]),
                    variant,
                    variant.default_scale(),
                );
                self.texture.expect("checked").sample(uv, out);
            }
            Mode::Normals => {
                let n = unit([a[3], a[4], a[5]]);
                for ch in 0..3 {
                    out[ch] = if n[ch].is_finite() {
                        (0.5 * n[ch] + 0.5) as f32
                    } else {
                        0.0
                    };
                }
            }
            Mode::Error => {
                let r = Self::reflection(a);
                out[0] = match st_to_dir(st) {
                    Some(d) => {
                        let c = (d[0] * r[0] + d[1] * r[1] + d[2] * r[2]).clamp(-1.0, 1.0);
                        if c.is_finite() {
                            c.acos().to_degrees() as f32
                        } else {
                            0.0
                        }
                    }
                    None => 0.0,
                };
            }
        }
    }
}

/// A perceptual heat colour (linear RGB) for `x` in [0, 1]: dark blue → purple → orange →
/// pale yellow (inferno-like control points, interpolated in sRGB and decoded).
pub fn heat_colour(x: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 6] = [
        [0.001, 0.000, 0.014],
        [0.258, 0.039, 0.406],
        [0.578, 0.148, 0.404],
        [0.865, 0.317, 0.226],
        [0.988, 0.645, 0.040],
        [0.988, 0.998, 0.645],
    ];
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let f = x * (STOPS.len() - 1) as f32;
    let i = (f.floor() as usize).min(STOPS.len() - 2);
    let t = f - i as f32;
    std::array::from_fn(|k| {
        let s = STOPS[i][k] + t * (STOPS[i + 1][k] - STOPS[i][k]);
        crate::images::codec::srgb_to_linear(s)
    })
}
