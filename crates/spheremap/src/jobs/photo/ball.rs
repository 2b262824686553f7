//! Where a direction of the environment shows on a photo of a mirror ball, for the two camera
//! models.
//!
//! Both give the direction `d` in the **view frame** of the shot: the viewer at the camera
//! looking at the ball's centre (−Z) with the camera's up (+Y) — the frame of the sphere map
//! the photo turns into.
//!
//! ## Orthographic (the classic assumption)
//!
//! The camera is infinitely far: every pixel's ray is −Z.  The ball point that reflects `d`
//! toward the camera has the normal half-way between them, `n = (d + Z)/‖d + Z‖`, and lies at
//! `(cx + r n_x, cy − r n_y)` on the photo (the GL sphere map formula: a cropped orthographic
//! ball photo *is* the sphere map).  Every direction but exactly −Z is seen.
//!
//! ## Perspective (a camera at a finite distance)
//!
//! ```text
//!                 e2 ▲        P (normal at angle φ from e1)
//!                    │      ╱ ╲  d (reflected, angle α from e1)
//!                    │  ·╱·    ╲
//!            ball O ●───────────────────────────► e1 ─── camera C at distance D
//!                     R = 1                            (C − P at angle γ from e1)
//! ```
//!
//! The ball has radius 1 and its centre is at distance `D` from the camera: the ball's
//! silhouette is a cone of half-angle β with `sin β = 1/D`, found from the photo (the rim's
//! points, back-projected through the pinhole, fitted by a cone: `r·q = 1`, `q = a/cos β`).
//! For a direction `d` at angle α from `e1` (the direction from the ball toward the camera),
//! the reflecting point lies in the plane of `e1` and `d`; the law of reflection says the
//! normal bisects `d` and the direction to the camera: `2φ = α + γ(φ)`, with
//! `γ(φ) = atan2(−sin φ, D − cos φ)` — Alhazen's problem, solved here by a safeguarded Newton
//! iteration on `[0, π/2 − β]` (monotone there; the orthographic answer `φ = α/2` starts it).
//! Then `P` is projected through the pinhole.
//!
//! **What a finite-distance photo cannot see**: at the rim the camera's ray grazes the ball and
//! goes on unreflected, at angle β from the axis; so reflected directions reach `α = π − β`
//! and no further.  The cone of half-angle β straight behind the ball (`sin β = R/D`, e.g.
//! 5.7° for a ball 10 radii away) is hidden by the ball itself; near it the photo's sampling
//! degenerates (the incidence cosine `cos(φ − γ)` → 0), which the confidence mask reports.

use super::circle::{solve3, Circle};
use crate::base::error::{Error, Result};
use crate::base::vec::dot;
use crate::frame::view::{self, Mat3, IDENTITY};
use crate::trace::camera::{Camera, Projection};

/// The camera model of a mirror-ball photo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BallModel {
    Orthographic,
    /// A pinhole camera with this horizontal field of view (degrees) across the photo.
    Perspective {
        hfov_deg: f64,
    },
}

/// A mirror ball located in a photo.
#[derive(Clone, Copy, Debug)]
pub struct BallGeometry {
    pub model: BallModel,
    /// The ball's outline on the photo (for the perspective model: the circle through the
    /// cone's points nearest and farthest from the image centre, for reports).
    pub circle: Circle,
    /// Perspective: the photo's camera, the unit axis to the ball's centre (camera frame), the
    /// distance in ball radii, and the view frame → camera frame rotation.
    camera: Option<Camera>,
    pub axis: [f64; 3],
    pub distance: f64,
    view_to_camera: Mat3,
}

/// Where a direction shows: the pixel and how well it is sampled there (the cosine of the
/// camera ray's incidence on the ball, 1 at the centre, 0 at the grazing rim).
#[derive(Clone, Copy, Debug)]
pub struct Located {
    pub pixel: [f64; 2],
    pub quality: f64,
}

fn mat_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

impl BallGeometry {
    /// The orthographic model for a ball outlined by `circle`.
    pub fn orthographic(circle: Circle) -> Result<BallGeometry> {
        if !(circle.r > 0.0 && circle.cx.is_finite() && circle.cy.is_finite()) {
            return Err(Error::param("circle", "the radius must be positive"));
        }
        Ok(BallGeometry {
            model: BallModel::Orthographic,
            circle,
            camera: None,
            axis: [0.0, 0.0, -1.0],
            distance: f64::INFINITY,
            view_to_camera: IDENTITY,
        })
    }

    /// The perspective model from points on the ball's outline in a `width`×`height` photo
    /// taken with horizontal field of view `hfov_deg`.
    pub fn perspective(
        outline: &[[f64; 2]],
        hfov_deg: f64,
        width: usize,
        height: usize,
    ) -> Result<BallGeometry> {
        let camera = Camera::new(
            Projection::Perspective { hfov_deg },
            [0.0; 3],
            IDENTITY,
            width,
            height,
        )?;
        // Cone fit: unit rays r_k on the silhouette satisfy r_k · a = cos β; least squares
        // for q = a / cos β in r_k · q = 1.
        let mut m = [[0f64; 3]; 3];
        let mut b = [0f64; 3];
        for p in outline {
            let r = camera
                .pixel_to_camera_dir(*p)
                .ok_or_else(|| Error::param("circle", "outline point off the camera"))?;
            for i in 0..3 {
                for j in 0..3 {
                    m[i][j] += r[i] * r[j];
                }
                b[i] += r[i];
            }
        }
        let q = solve3(m, b)
            .ok_or_else(|| Error::data("image", "the ball's outline does not fix a cone"))?;
        let lq = dot(q, q).sqrt();
        let cos_beta = 1.0 / lq;
        if !(cos_beta > 0.0 && cos_beta < 1.0) {
            return Err(Error::data(
                "image",
                "the ball's outline does not fit a sphere seen through this field of view",
            ));
        }
        let axis = q.map(|v| v / lq);
        if !(axis[2] < 0.0) {
            return Err(Error::data(
                "image",
                "the ball's centre is behind the camera",
            ));
        }
        let sin_beta = (1.0 - cos_beta * cos_beta).sqrt();
        let view_to_camera = view::look_up(axis, [0.0, 1.0, 0.0])?;
        // For the report: the circle through the silhouette's points nearest to and farthest
        // from the image centre (the ends of the outline ellipse's major axis: its centre and
        // semi-major axis; on the optical axis, the outline circle itself).
        let (b1, b2) = (
            [0, 1, 2].map(|i| view_to_camera[i][0]),
            [0, 1, 2].map(|i| view_to_camera[i][1]),
        );
        // The azimuth (in the cone's frame) of the optical axis's part across the cone's axis:
        // the silhouette's point there is the one nearest the image centre.
        let toward_centre = {
            let o = [0.0, 0.0, -1.0];
            let k = dot(o, axis);
            let w = [0, 1, 2].map(|i| o[i] - k * axis[i]);
            dot(w, b2).atan2(dot(w, b1))
        };
        let rim = |t: f64| {
            let d = [0, 1, 2]
                .map(|i| axis[i] * cos_beta + sin_beta * (t.cos() * b1[i] + t.sin() * b2[i]));
            camera.camera_dir_to_pixel(d)
        };
        let (near, far) = (
            rim(toward_centre),
            rim(toward_centre + std::f64::consts::PI),
        );
        let circle = match (near, far) {
            (Some(p), Some(q)) => Circle {
                cx: 0.5 * (p[0] + q[0]),
                cy: 0.5 * (p[1] + q[1]),
                r: 0.5 * (p[0] - q[0]).hypot(p[1] - q[1]),
            },
            _ => {
                let c = camera
                    .camera_dir_to_pixel(axis)
                    .expect("the axis is in front of the camera");
                let p = rim(0.0).unwrap_or(c);
                Circle {
                    cx: c[0],
                    cy: c[1],
                    r: (p[0] - c[0]).hypot(p[1] - c[1]),
                }
            }
        };
        Ok(BallGeometry {
            model: BallModel::Perspective { hfov_deg },
            circle,
            camera: Some(camera),
            axis,
            distance: 1.0 / sin_beta,
            view_to_camera,
        })
    }

    /// Half-angle (radians) of the cone behind the ball that the photo cannot see (0 for the
    /// orthographic model).
    pub fn blind_half_angle(&self) -> f64 {
        if self.distance.is_finite() {
            (1.0 / self.distance).asin()
        } else {
            0.0
        }
    }

    /// The view frame → camera frame rotation (identity for the orthographic model).
    pub fn view_to_camera(&self) -> Mat3 {
        self.view_to_camera
    }

    /// Where the unit view-frame direction `d` shows on the photo (`None` if it does not).
    pub fn locate(&self, d: [f64; 3]) -> Option<Located> {
        match self.camera {
            None => {
                let h = [d[0], d[1], d[2] + 1.0];
                let l = dot(h, h).sqrt();
                if !(l > 1e-9) {
                    return None;
                }
                let n = h.map(|v| v / l);
                Some(Located {
                    pixel: [
                        self.circle.cx + self.circle.r * n[0],
                        self.circle.cy - self.circle.r * n[1],
                    ],
                    quality: n[2],
                })
            }
            Some(cam) => {
                let dist = self.distance;
                let beta = (1.0 / dist).asin();
                let alpha = d[2].clamp(-1.0, 1.0).acos();
                if alpha > std::f64::consts::PI - beta {
                    return None;
                }
                let rho = d[0].hypot(d[1]);
                let e2 = if rho > 1e-15 {
                    [d[0] / rho, d[1] / rho]
                } else {
                    [1.0, 0.0]
                };
                let phi = solve_phi(alpha, dist)?;
                let (s, c) = phi.sin_cos();
                let gamma = (-s).atan2(dist - c);
                let p = [s * e2[0], s * e2[1], c - dist];
                let pixel = cam.camera_dir_to_pixel(mat_vec(&self.view_to_camera, p))?;
                Some(Located {
                    pixel,
                    quality: (phi - gamma).cos().max(0.0),
                })
            }
        }
    }
}

/// Solves `2φ − α − γ(φ) = 0` on `[0, π/2 − β]` (see the module docs).
fn solve_phi(alpha: f64, dist: f64) -> Option<f64> {
    let hi_limit = (1.0 / dist).acos();
    let (mut lo, mut hi) = (0.0, hi_limit);
    let g = |phi: f64| {
        let (s, c) = phi.sin_cos();
        let gamma = (-s).atan2(dist - c);
        let den = s * s + (dist - c) * (dist - c);
        (2.0 * phi - alpha - gamma, 2.0 - (1.0 - dist * c) / den)
    };
    let mut phi = (0.5 * alpha).min(hi_limit);
    for _ in 0..60 {
        let (v, dv) = g(phi);
        if v.abs() < 1e-14 {
            return Some(phi);
        }
        if v > 0.0 {
            hi = phi;
        } else {
            lo = phi;
        }
        let next = phi - v / dv;
        phi = if next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo < 1e-15 {
            break;
        }
    }
    Some(phi)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reflect(i: [f64; 3], n: [f64; 3]) -> [f64; 3] {
        let k = 2.0 * dot(i, n);
        [i[0] - k * n[0], i[1] - k * n[1], i[2] - k * n[2]]
    }

    /// Forward-traces camera rays at a perspective ball and checks that `locate` of each
    /// reflected direction lands on the pixel the ray came from.
    #[test]
    fn perspective_locate_inverts_the_forward_trace() {
        let (w, h, fov) = (400usize, 300usize, 40.0);
        let cam = Camera::new(
            Projection::Perspective { hfov_deg: fov },
            [0.0; 3],
            IDENTITY,
            w,
            h,
        )
        .unwrap();
        // Ball of radius 1 at distance 6, off-centre.
        let centre = {
            let a = [0.15f64, -0.1, -1.0];
            let l = dot(a, a).sqrt();
            a.map(|v| 6.0 * v / l)
        };
        // Outline: rays tangent to the sphere.
        let axis = centre.map(|v| v / 6.0);
        let beta = (1.0f64 / 6.0).asin();
        let (b1, b2) = {
            let u = view::look_up(axis, [0.0, 1.0, 0.0]).unwrap();
            ([u[0][0], u[1][0], u[2][0]], [u[0][1], u[1][1], u[2][1]])
        };
        let outline: Vec<[f64; 2]> = (0..64)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 64.0;
                let r = [0, 1, 2].map(|i| {
                    axis[i] * beta.cos() + beta.sin() * (t.cos() * b1[i] + t.sin() * b2[i])
                });
                cam.camera_dir_to_pixel(r).unwrap()
            })
            .collect();
        let g = BallGeometry::perspective(&outline, fov, w, h).unwrap();
        assert!((g.distance - 6.0).abs() < 1e-9, "{}", g.distance);
        let vtc = g.view_to_camera();
        for &(px, py) in &[
            (200.0, 150.0),
            (230.0, 140.0),
            (215.0, 190.0),
            (180.5, 170.25),
        ] {
            let r = cam.pixel_to_camera_dir([px, py]).unwrap();
            // Hit the sphere.
            let b = dot(r, centre);
            let disc = b * b - (dot(centre, centre) - 1.0);
            if disc < 0.0 {
                continue;
            }
            let t = b - disc.sqrt();
            let p = r.map(|v| v * t);
            let n = [0, 1, 2].map(|i| p[i] - centre[i]);
            let out = reflect(r, n);
            // camera → view: transpose.
            let dv =
                [0, 1, 2].map(|j| vtc[0][j] * out[0] + vtc[1][j] * out[1] + vtc[2][j] * out[2]);
            let loc = g.locate(dv).expect("seen");
            assert!(
                (loc.pixel[0] - px).abs() < 1e-6 && (loc.pixel[1] - py).abs() < 1e-6,
                "{:?} vs ({px}, {py})",
                loc.pixel
            );
        }
        // The blind cone straight behind the ball.
        assert!(g.locate([0.0, 0.0, -1.0]).is_none());
        let just_seen = [0.0, (beta + 1e-3).sin(), -(beta + 1e-3).cos()];
        assert!(g.locate(just_seen).is_some());
        assert!((g.blind_half_angle() - beta).abs() < 1e-12);
    }

    #[test]
    fn orthographic_is_the_sphere_map() {
        let g = BallGeometry::orthographic(Circle {
            cx: 100.0,
            cy: 80.0,
            r: 50.0,
        })
        .unwrap();
        // Toward the camera: the centre. +X: the right edge at 45° normal.
        let c = g.locate([0.0, 0.0, 1.0]).unwrap();
        assert_eq!(c.pixel, [100.0, 80.0]);
        let x = g.locate([1.0, 0.0, 0.0]).unwrap();
        assert!((x.pixel[0] - (100.0 + 50.0 * 0.5f64.sqrt())).abs() < 1e-12);
        let y = g.locate([0.0, 1.0, 0.0]).unwrap();
        assert!(y.pixel[1] < 80.0);
        assert!(g.locate([0.0, 0.0, -1.0]).is_none());
    }
}
