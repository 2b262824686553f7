//! Cameras: which ray each pixel of a photo sees — to render a preview of a scene (perspective
//! or fisheye), to make test photos of a mirror ball, and to read real photos back
//! ([`crate::jobs::photo`]).
//!
//! ```text
//!   image (continuous pixel coordinates)          camera frame (our eye space)
//!   (0,0)──────────────► x                               +Y
//!     │   ·  ·  ·                                         │
//!     │   · (W/2,H/2) = principal point                   │
//!     │   ·  ·  ·                                         └──── +X
//!     ▼ y                                                /
//!                                                      +Z   (the camera looks down −Z)
//! ```
//!
//! Pixel centres are at i + ½; a pixel right of the centre sees +X, one above it sees +Y.
//!
//! * **Perspective** (pinhole): `f = (W/2) / tan(hfov/2)` pixels, square pixels, the principal
//!   point at the image centre; pixel (x, y) sees `((x − W/2)/f, (H/2 − y)/f, −1)`.  `hfov` is
//!   the horizontal field of view (what `--fov` means for a photo); `gluPerspective`'s `fovy`
//!   is `2 atan(tan(hfov/2) · H/W)`.
//! * **Fisheye**: a [`Lens`] (model, field of view, centre, circle radius).
//!
//! A camera's `rotation` takes its frame to the world (`world = R · camera`, the columns are
//! its axes, [`crate::frame::view::look_up`]), `eye` is where it stands.

use crate::base::error::{Error, Result};
use crate::frame::view::{self, Mat3};
use crate::images::Image;
use crate::mappings::fisheye::Lens;
use crate::resample::{jitter, Progress};
use crate::trace::generate::RaySource;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// How pixels map to directions in the camera frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Pinhole with this horizontal field of view in degrees (0 < hfov < 180).
    Perspective {
        hfov_deg: f64,
    },
    Fisheye(Lens),
}

/// The report of `spheremap preview --json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PreviewReport {
    pub output: String,
    pub width: usize,
    pub height: usize,
    /// Rays per pixel.
    pub samples: u32,
    /// The focal length in pixels (`None` for a fisheye).
    pub focal_px: Option<f64>,
    pub seconds: f64,
    /// What writing the image lost.
    #[serde(flatten)]
    pub losses: crate::images::codec::LossCounts,
}

/// A photo of a scene as `spheremap preview` and Python's `Scene.preview` ask for it: the camera
/// as `gluLookAt` places it, its lens, the image and the rays.  `Default` gives every
/// documented default; `eye` and `target` are required.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PreviewRequest {
    pub eye: Option<[f64; 3]>,
    pub target: Option<[f64; 3]>,
    pub up: [f64; 3],
    /// The horizontal field of view in degrees; with a fisheye `lens`, the field across its
    /// image circle, which fills the shorter side.
    pub fov: f64,
    pub lens: Option<crate::mappings::fisheye::LensName>,
    pub width: usize,
    pub height: usize,
    /// Rays per pixel (a jittered grid; 1: through the pixel centre) and their seed.
    pub samples: u32,
    pub seed: u64,
    /// Refuse an image needing more bytes than this (`None`: the default limit).
    pub max_memory: Option<u64>,
}

impl Default for PreviewRequest {
    fn default() -> Self {
        PreviewRequest {
            eye: None,
            target: None,
            up: [0.0, 1.0, 0.0],
            fov: 40.0,
            lens: None,
            width: 640,
            height: 480,
            samples: 16,
            seed: 0,
            max_memory: None,
        }
    }
}

impl PreviewRequest {
    /// The camera, every field checked (errors name it).
    pub fn camera(&self) -> Result<Camera> {
        use crate::base::limits;
        use crate::mappings::fisheye::{LensModel, LensName};
        let eye = self.eye.ok_or_else(|| Error::param("eye", "required"))?;
        let target = self
            .target
            .ok_or_else(|| Error::param("target", "required"))?;
        let (w, h) = (self.width, self.height);
        let projection = match self.lens {
            None => Projection::Perspective { hfov_deg: self.fov },
            Some(LensName::Polynomial) => {
                return Err(Error::param(
                    "lens",
                    "the polynomial model needs coefficients: preview takes equidistant, \
                     equisolid, stereographic or orthographic",
                ))
            }
            Some(m) => Projection::Fisheye(Lens::new(
                LensModel::parse(m.name(), [0.0; 4])?,
                self.fov,
                [0.5 * w as f64, 0.5 * h as f64],
                0.5 * w.min(h) as f64,
            )?),
        };
        let cam = Camera::look_at(projection, eye, target, self.up, w, h)?;
        limits::check_range("samples", self.samples, 1, limits::PREVIEW_SAMPLES)?;
        let max = self.max_memory.unwrap_or_else(limits::default_max_memory);
        limits::check_memory("size", 2 * (w as u128 * h as u128 * 4 * 4), max)?;
        Ok(cam)
    }
}

/// A camera: projection, pose and image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub projection: Projection,
    pub eye: [f64; 3],
    /// Camera frame → world.
    pub rotation: Mat3,
    pub width: usize,
    pub height: usize,
}

impl Camera {
    /// A camera at `eye` looking at `target` with `up`, as `gluLookAt`.
    pub fn look_at(
        projection: Projection,
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        width: usize,
        height: usize,
    ) -> Result<Camera> {
        if !eye.iter().chain(&target).all(|v| v.is_finite()) {
            return Err(Error::param("eye", "eye and target must be finite"));
        }
        let look = [0, 1, 2].map(|i| target[i] - eye[i]);
        let rotation = view::look_up(look, up)?;
        Camera::new(projection, eye, rotation, width, height)
    }

    /// A camera from its pose.
    pub fn new(
        projection: Projection,
        eye: [f64; 3],
        rotation: Mat3,
        width: usize,
        height: usize,
    ) -> Result<Camera> {
        crate::base::limits::check_sides(width, height, crate::base::limits::CAMERA_SIDE)?;
        if let Projection::Perspective { hfov_deg } = projection {
            if !(hfov_deg > 0.0 && hfov_deg < 180.0) {
                return Err(Error::param(
                    "fov",
                    format!("{hfov_deg}°: a perspective field of view must be in (0°, 180°)"),
                ));
            }
        }
        Ok(Camera {
            projection,
            eye,
            rotation,
            width,
            height,
        })
    }

    /// The report of `spheremap preview --json` for an image this camera took with `samples`
    /// rays per pixel into `output`, in `seconds`, writing which lost `losses`.
    pub fn report(
        &self,
        output: &str,
        samples: u32,
        seconds: f64,
        losses: crate::images::codec::LossCounts,
    ) -> PreviewReport {
        PreviewReport {
            output: output.to_string(),
            width: self.width,
            height: self.height,
            samples,
            focal_px: self.focal_px(),
            seconds,
            losses,
        }
    }

    /// Focal length in pixels of a perspective camera.
    pub fn focal_px(&self) -> Option<f64> {
        match self.projection {
            Projection::Perspective { hfov_deg } => {
                Some(0.5 * self.width as f64 / (0.5 * hfov_deg.to_radians()).tan())
            }
            Projection::Fisheye(_) => None,
        }
    }

    /// The unit camera-frame direction seen at a continuous pixel position (`None` where the
    /// lens sees nothing).
    pub fn pixel_to_camera_dir(&self, p: [f64; 2]) -> Option<[f64; 3]> {
        match self.projection {
            Projection::Perspective { .. } => {
                let f = self.focal_px()?;
                let v = [
                    (p[0] - 0.5 * self.width as f64) / f,
                    (0.5 * self.height as f64 - p[1]) / f,
                    -1.0,
                ];
                let l = (v[0] * v[0] + v[1] * v[1] + 1.0).sqrt();
                Some(v.map(|c| c / l))
            }
            Projection::Fisheye(lens) => lens.pixel_to_dir(p),
        }
    }

    /// Where a camera-frame direction lands on the image (`None` behind a perspective camera
    /// or outside a fisheye's field of view; the position may lie outside the image).
    pub fn camera_dir_to_pixel(&self, d: [f64; 3]) -> Option<[f64; 2]> {
        match self.projection {
            Projection::Perspective { .. } => {
                if !(d[2] < 0.0) {
                    return None;
                }
                let f = self.focal_px()?;
                Some([
                    0.5 * self.width as f64 + f * d[0] / -d[2],
                    0.5 * self.height as f64 - f * d[1] / -d[2],
                ])
            }
            Projection::Fisheye(lens) => lens.dir_to_pixel(d),
        }
    }

    /// The world ray (origin, unit direction) through a continuous pixel position.
    pub fn pixel_ray(&self, p: [f64; 2]) -> Option<([f64; 3], [f64; 3])> {
        let c = self.pixel_to_camera_dir(p)?;
        let r = &self.rotation;
        Some((
            self.eye,
            [0, 1, 2].map(|i| r[i][0] * c[0] + r[i][1] * c[1] + r[i][2] * c[2]),
        ))
    }

    /// Where a world point lands on the image.
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        let v = [0, 1, 2].map(|i| p[i] - self.eye[i]);
        let r = &self.rotation;
        // camera = Rᵀ · world
        let c = [0, 1, 2].map(|j| r[0][j] * v[0] + r[1][j] * v[1] + r[2][j] * v[2]);
        self.camera_dir_to_pixel(c)
    }
}

/// Renders what `camera` sees of `source` (a scene, an environment map, ...): `samples` rays
/// per pixel on a jittered √S × √S grid (1 = one ray through the pixel centre), box-filtered.
/// Pixels the lens does not cover (outside a fisheye's circle) are 0 with `coverage` 0; the
/// image gets one more channel, the covered fraction of the pixel, when `coverage_channel`.
pub fn render(
    camera: &Camera,
    source: &dyn RaySource,
    samples: u32,
    seed: u64,
    coverage_channel: bool,
    progress: Option<&Progress>,
) -> Result<Image> {
    crate::base::limits::check_range("samples", samples, 1, crate::base::limits::PREVIEW_SAMPLES)?;
    let sc = source.channels();
    let oc = sc + coverage_channel as usize;
    let (w, h) = (camera.width, camera.height);
    let n = (samples as f64).sqrt().ceil() as usize;
    let n = if samples == 1 { 1 } else { n };
    if let Some(p) = progress {
        p.total.store(h, Ordering::Relaxed);
    }
    let failed = AtomicBool::new(false);
    let mut data = vec![0f32; w * h * oc];
    let rows: Vec<Result<()>> = data
        .par_chunks_mut(w * oc)
        .enumerate()
        .map(|(y, row)| {
            if failed.load(Ordering::Relaxed) {
                return Ok(());
            }
            if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
                failed.store(true, Ordering::Relaxed);
                return Err(Error::cancelled("render"));
            }
            let mut origins = Vec::with_capacity(w * n * n);
            let mut dirs = Vec::with_capacity(w * n * n);
            let mut owner = Vec::with_capacity(w * n * n);
            for x in 0..w {
                for k in 0..n * n {
                    let (a, b) = if n == 1 {
                        (0.5, 0.5)
                    } else {
                        let (jx, jy) = jitter(seed, x as u64, y as u64, k as u64);
                        (
                            ((k % n) as f64 + jx) / n as f64,
                            ((k / n) as f64 + jy) / n as f64,
                        )
                    };
                    if let Some((o, d)) = camera.pixel_ray([x as f64 + a, y as f64 + b]) {
                        origins.push(o.map(|v| v as f32));
                        dirs.push(d.map(|v| v as f32));
                        owner.push(x);
                    }
                }
            }
            let mut vals = vec![0f32; dirs.len() * sc];
            source.trace(&origins, &dirs, &mut vals)?;
            let scale = 1.0 / (n * n) as f32;
            for (i, &x) in owner.iter().enumerate() {
                let px = &mut row[x * oc..(x + 1) * oc];
                for c in 0..sc {
                    px[c] += vals[i * sc + c] * scale;
                }
                if coverage_channel {
                    px[sc] += scale;
                }
            }
            if let Some(p) = progress {
                p.done.fetch_add(1, Ordering::Relaxed);
            }
            Ok(())
        })
        .collect();
    for r in rows {
        r?;
    }
    Ok(Image {
        width: w,
        height: h,
        channels: oc,
        data,
    })
}

#[cfg(test)]
mod tests {

    #[test]
    fn a_preview_request_checks_every_field() {
        let ok = PreviewRequest {
            eye: Some([0.0, 0.0, 5.0]),
            target: Some([0.0; 3]),
            ..Default::default()
        };
        let cam = ok.camera().unwrap();
        assert_eq!((cam.width, cam.height), (640, 480));
        let fish = PreviewRequest {
            lens: Some(crate::mappings::fisheye::LensName::Equisolid),
            fov: 180.0,
            ..ok.clone()
        };
        assert!(matches!(
            fish.camera().unwrap().projection,
            Projection::Fisheye(_)
        ));
        let refused = |r: PreviewRequest, field: &str| {
            let e = r.camera().expect_err("refused").to_string();
            assert!(e.starts_with(&format!("{field}: ")), "{e}");
        };
        refused(PreviewRequest::default(), "eye");
        refused(
            PreviewRequest {
                target: None,
                ..ok.clone()
            },
            "target",
        );
        refused(
            PreviewRequest {
                samples: 0,
                ..ok.clone()
            },
            "samples",
        );
        refused(
            PreviewRequest {
                lens: Some(crate::mappings::fisheye::LensName::Polynomial),
                ..ok.clone()
            },
            "lens",
        );
        refused(
            PreviewRequest {
                fov: 180.0,
                ..ok.clone()
            },
            "fov",
        );
        refused(
            PreviewRequest {
                max_memory: Some(1000),
                ..ok
            },
            "size",
        );
    }

    use super::*;
    use crate::mappings::fisheye::LensModel;

    #[test]
    fn perspective_pixel_round_trip_and_axes() {
        let cam = Camera::look_at(
            Projection::Perspective { hfov_deg: 60.0 },
            [1.0, 2.0, 3.0],
            [1.0, 2.0, -7.0],
            [0.0, 1.0, 0.0],
            200,
            100,
        )
        .unwrap();
        // The centre sees the target; right sees +X, up sees +Y.
        let (_, d) = cam.pixel_ray([100.0, 50.0]).unwrap();
        assert!((d[2] + 1.0).abs() < 1e-12);
        let (_, d) = cam.pixel_ray([200.0, 50.0]).unwrap();
        assert!((d[0] - 30f64.to_radians().sin()).abs() < 1e-12 && d[0] > 0.0);
        let (_, d) = cam.pixel_ray([100.0, 0.0]).unwrap();
        assert!(d[1] > 0.0);
        for p in [[3.5, 7.25], [150.0, 80.0], [0.0, 0.0]] {
            let (o, d) = cam.pixel_ray(p).unwrap();
            let q = cam.project([o[0] + 5.0 * d[0], o[1] + 5.0 * d[1], o[2] + 5.0 * d[2]]);
            let q = q.unwrap();
            assert!((q[0] - p[0]).abs() < 1e-9 && (q[1] - p[1]).abs() < 1e-9);
        }
    }

    #[test]
    fn fisheye_camera_uses_the_lens() {
        let lens = Lens::new(LensModel::Equisolid, 180.0, [50.0, 50.0], 50.0).unwrap();
        let cam = Camera::new(
            Projection::Fisheye(lens),
            [0.0; 3],
            crate::frame::view::IDENTITY,
            100,
            100,
        )
        .unwrap();
        assert!(cam.pixel_ray([1.0, 1.0]).is_none());
        let (_, d) = cam.pixel_ray([100.0, 50.0]).unwrap();
        assert!((d[0] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn render_constant_source_and_coverage() {
        let lens = Lens::new(LensModel::Equidistant, 180.0, [8.0, 8.0], 8.0).unwrap();
        let cam = Camera::new(
            Projection::Fisheye(lens),
            [0.0; 3],
            crate::frame::view::IDENTITY,
            16,
            16,
        )
        .unwrap();
        let src = crate::trace::generate::FnSource::new(1, |_, _, o: &mut [f32]| o[0] = 2.0);
        let img = render(&cam, &src, 16, 1, true, None).unwrap();
        // Inside the circle: value 2, coverage 1; the corner: nothing.
        assert_eq!(img.pixel(8, 8), &[2.0, 1.0]);
        assert_eq!(img.pixel(0, 0), &[0.0, 0.0]);
        let total: f32 = img.data.chunks(2).map(|p| p[1]).sum();
        let area = std::f32::consts::PI * 64.0;
        assert!((total - area).abs() / area < 0.02, "{total} vs {area}");
        assert!(render(&cam, &src, 0, 1, false, None).is_err());
    }
}
