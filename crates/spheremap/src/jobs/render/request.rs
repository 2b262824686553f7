//! A render as one request: [`RenderRequest`] holds what `spheremap render` and `analyze`, and
//! Python's `render` and `analyze`, take for the camera and the shading — by name, as users give
//! it (serde-readable, unknown keys refused) — and turns it into the rasterizer's camera and
//! options with the core's parsers and defaults.

use super::{gl_sphere_for, GlCamera, Mode, ModeName, RenderOptions, Wrap};
use crate::base::error::{Error, Result};
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use crate::mappings::matcap::MatcapVariant;
use serde::{Deserialize, Serialize};

/// A camera looking at a mesh, as `gluLookAt` and `gluPerspective` take it, and its image's
/// size: what `render` and `analyze` share.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CameraRequest {
    /// The camera as `gluLookAt` takes it (each defaulting to a framing of the mesh), or the
    /// three at once as `lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ`.
    pub eye: Option<[f64; 3]>,
    pub target: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    pub camera: Option<String>,
    /// `gluPerspective`: the vertical field of view in degrees, the planes (default: around the
    /// mesh's bounding sphere).
    pub fovy: f64,
    pub near: Option<f64>,
    pub far: Option<f64>,
    /// The image in pixels.
    pub width: usize,
    pub height: usize,
}

impl Default for CameraRequest {
    fn default() -> Self {
        CameraRequest {
            eye: None,
            target: None,
            up: None,
            camera: None,
            fovy: 40.0,
            near: None,
            far: None,
            width: 512,
            height: 512,
        }
    }
}

/// The camera and shading of a render.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderRequest {
    /// per-vertex, per-pixel, matcap, normals or error.
    pub mode: ModeName,
    /// The MatCap lookup of `matcap` mode: classic, threejs or perspective.
    pub matcap_variant: MatcapVariant,
    /// The camera (`eye`, `target`, `up`, `camera`, `fovy`, `near`, `far`) and the image's
    /// `width` and `height`.
    #[serde(flatten)]
    pub view: CameraRequest,
    /// Linear RGB where no triangle is.
    pub background: [f32; 3],
    /// K × K samples per pixel.
    pub aa: u32,
    /// Sub-pixel bits of the rasterizer's vertex snapping: 8 (llvmpipe) or down to 1.
    pub subpixel_bits: u32,
    /// Texture wrap of a sphere map or MatCap: clamp-to-edge or repeat.
    pub wrap: Wrap,
}

impl Default for RenderRequest {
    fn default() -> Self {
        RenderRequest {
            mode: ModeName::PerPixel,
            matcap_variant: MatcapVariant::Classic,
            view: CameraRequest::default(),
            background: [0.0; 3],
            aa: 1,
            subpixel_bits: super::SUB_BITS,
            wrap: Wrap::ClampToEdge,
        }
    }
}

impl RenderRequest {
    /// The shading mode (a MatCap mode with its variant).
    pub fn mode(&self) -> Mode {
        Mode::of(self.mode, self.matcap_variant)
    }

    /// The rasterizer's options (mode, background, anti-aliasing).
    pub fn options(&self) -> Result<RenderOptions> {
        Ok(RenderOptions {
            mode: self.mode(),
            background: self.background,
            aa: self.aa,
            subpixel_bits: self.subpixel_bits,
        })
    }

    /// The camera for a mesh of `positions` ([`CameraRequest::camera`]).
    pub fn camera(&self, positions: &[[f32; 3]]) -> Result<GlCamera> {
        self.view.camera(positions)
    }

    /// The environment as the modes read it: a sphere map in another preset than GL's is
    /// resampled into the GL sphere map texgen addresses ([`gl_sphere_for`]); anything else is
    /// returned as it is.  `what` names the map in errors.
    pub fn environment(
        &self,
        mapping: Mapping,
        image: Option<Image>,
        what: &str,
    ) -> Result<(Mapping, Option<Image>)> {
        let Some(img) = image else {
            return Ok((mapping, None));
        };
        Ok(match gl_sphere_for(self.mode(), mapping, &img, what)? {
            Some(gl) => (Mapping::parse("sphere", None)?, Some(gl)),
            None => (mapping, Some(img)),
        })
    }
}

impl CameraRequest {
    /// The camera for a mesh of `positions`: what is given, the rest framing the mesh.
    pub fn camera(&self, positions: &[[f32; 3]]) -> Result<GlCamera> {
        let (eye, target, up) = match &self.camera {
            Some(spec) => {
                if self.eye.is_some() || self.target.is_some() || self.up.is_some() {
                    return Err(Error::param(
                        "camera",
                        "give camera or eye/target/up, not both",
                    ));
                }
                let v = spec
                    .strip_prefix("lookat:")
                    .map(|r| crate::base::parse::parse_numbers(r, "camera"))
                    .transpose()?
                    .filter(|v| v.len() == 9)
                    .ok_or_else(|| {
                        Error::param(
                            "camera",
                            format!("{spec:?}: expected lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ"),
                        )
                    })?;
                (
                    Some([v[0], v[1], v[2]]),
                    Some([v[3], v[4], v[5]]),
                    Some([v[6], v[7], v[8]]),
                )
            }
            None => (self.eye, self.target, self.up),
        };
        GlCamera::framing(
            positions,
            eye,
            target,
            up,
            self.fovy,
            self.near,
            self.far,
            (self.width, self.height),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_names_and_the_camera_spec() {
        let r = RenderRequest::default();
        assert_eq!(r.mode(), Mode::PerPixel);
        assert_eq!(r.options().unwrap().aa, 1);
        let tri = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let spec = CameraRequest {
            camera: Some("lookat:0,0,5,0,0,0,0,1,0".into()),
            ..Default::default()
        };
        let given = CameraRequest {
            eye: Some([0.0, 0.0, 5.0]),
            target: Some([0.0; 3]),
            up: Some([0.0, 1.0, 0.0]),
            ..Default::default()
        };
        assert_eq!(
            spec.camera(&tri).unwrap().modelview,
            given.camera(&tri).unwrap().modelview
        );
        let both = CameraRequest {
            eye: Some([0.0, 0.0, 5.0]),
            ..spec.clone()
        };
        assert!(both
            .camera(&tri)
            .unwrap_err()
            .to_string()
            .starts_with("camera: "));
        let e = serde_json::from_str::<RenderRequest>(r#"{"mode": "wireframe"}"#)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("mode: unknown mode \"wireframe\""), "{e}");
    }
}
