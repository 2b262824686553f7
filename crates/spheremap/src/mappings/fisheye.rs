//! Fisheye lens models: the angle θ of a ray from the optical axis ↔ its distance r from the
//! optical centre on the image (used by `from-fisheye` and the camera render).
//!
//! ```text
//!   model          r(θ) / f                         θ_max
//!   equidistant    θ                                 any
//!   equisolid      2 sin(θ/2)                        π (r increases up to 180° off-axis)
//!   stereographic  2 tan(θ/2)                        < π
//!   orthographic   sin θ                             π/2
//!   polynomial     θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)   (OpenCV's fisheye model)
//! ```
//!
//! Image convention (as everywhere in spheremap): continuous pixel coordinates, (0, 0) the
//! top-left corner, pixel centres at i + ½, y down.  The camera looks down its −Z with +Y up
//! (our eye space), so a pixel right of the centre sees +X and one above it sees +Y.
//! `fov_deg` is the full angle across the image circle of radius `radius_px`: f is chosen so
//! that r(fov/2) = radius_px.

use crate::base::error::{Error, Result};

crate::base::named::named_enum! {
    /// The names of [`LensModel`].
    pub enum LensName: "lens model" as "model" {
        Equidistant = "equidistant",
        Equisolid = "equisolid",
        Stereographic = "stereographic",
        Orthographic = "orthographic",
        Polynomial = "polynomial",
    }
}

/// How a lens maps the off-axis angle to the image radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LensModel {
    Equidistant,
    Equisolid,
    Stereographic,
    Orthographic,
    /// OpenCV's fisheye model: r/f = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸).
    Polynomial([f64; 4]),
}

impl LensModel {
    /// A model by name (`polynomial` takes `k`).
    pub fn parse(name: &str, k: [f64; 4]) -> Result<LensModel> {
        Ok(match LensName::parse(name)? {
            LensName::Equidistant => LensModel::Equidistant,
            LensName::Equisolid => LensModel::Equisolid,
            LensName::Stereographic => LensModel::Stereographic,
            LensName::Orthographic => LensModel::Orthographic,
            LensName::Polynomial => LensModel::Polynomial(k),
        })
    }

    /// The largest off-axis angle the model can image.
    pub fn theta_limit(&self) -> f64 {
        use std::f64::consts::{FRAC_PI_2, PI};
        match self {
            LensModel::Equidistant | LensModel::Polynomial(_) => PI,
            LensModel::Equisolid => PI,
            LensModel::Stereographic => PI - 1e-9,
            LensModel::Orthographic => FRAC_PI_2,
        }
    }

    /// r/f for an off-axis angle θ.
    pub fn radius(&self, theta: f64) -> f64 {
        match self {
            LensModel::Equidistant => theta,
            LensModel::Equisolid => 2.0 * (0.5 * theta).sin(),
            LensModel::Stereographic => 2.0 * (0.5 * theta).tan(),
            LensModel::Orthographic => theta.sin(),
            LensModel::Polynomial(k) => {
                let t2 = theta * theta;
                theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
            }
        }
    }

    /// θ for r/f (`None` past what the lens images).
    pub fn theta(&self, r: f64) -> Option<f64> {
        if !(r >= 0.0) {
            return None;
        }
        let t = match self {
            LensModel::Equidistant => r,
            LensModel::Equisolid => {
                if r > 2.0 {
                    return None;
                }
                2.0 * (0.5 * r).asin()
            }
            LensModel::Stereographic => 2.0 * (0.5 * r).atan(),
            LensModel::Orthographic => {
                if r > 1.0 {
                    return None;
                }
                r.asin()
            }
            LensModel::Polynomial(_) => {
                // Newton from the equidistant guess; the polynomial must stay increasing.
                let mut t = r.min(self.theta_limit());
                for _ in 0..50 {
                    let h = 1e-7;
                    let f = self.radius(t) - r;
                    let df = (self.radius(t + h) - self.radius(t - h)) / (2.0 * h);
                    if !(df > 0.0) {
                        return None;
                    }
                    let step = f / df;
                    t = (t - step).clamp(0.0, self.theta_limit());
                    if step.abs() < 1e-14 {
                        break;
                    }
                }
                if (self.radius(t) - r).abs() > 1e-9 * r.max(1.0) {
                    return None;
                }
                t
            }
        };
        (t <= self.theta_limit()).then_some(t)
    }
}

/// A fisheye image: model, field of view across the image circle, centre and circle radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub model: LensModel,
    /// Full field of view across the image circle, degrees.
    pub fov_deg: f64,
    /// Optical centre, continuous pixel coordinates.
    pub centre: [f64; 2],
    /// Radius of the image circle in pixels (where θ = fov/2).
    pub radius_px: f64,
}

impl Lens {
    /// Checks the parameters.
    pub fn new(model: LensModel, fov_deg: f64, centre: [f64; 2], radius_px: f64) -> Result<Lens> {
        let half = 0.5 * fov_deg.to_radians();
        if !(fov_deg > 0.0 && half <= model.theta_limit() + 1e-12) {
            return Err(Error::param(
                "fov",
                format!(
                    "{fov_deg}° is out of range for this lens (0, {:.0}°]",
                    2.0 * model.theta_limit().to_degrees()
                ),
            ));
        }
        if !(radius_px > 0.0 && radius_px.is_finite()) {
            return Err(Error::param("radius", "must be positive and finite"));
        }
        if !centre.iter().all(|v| v.is_finite()) {
            return Err(Error::param("centre", "must be finite"));
        }
        if !(model.radius(half) > 0.0) {
            return Err(Error::param("fov", "the lens maps it to radius 0"));
        }
        Ok(Lens {
            model,
            fov_deg,
            centre,
            radius_px,
        })
    }

    /// Pixels per unit of r/f.
    fn focal_px(&self) -> f64 {
        self.radius_px / self.model.radius(0.5 * self.fov_deg.to_radians())
    }

    /// The camera-frame direction seen at a continuous pixel position (`None` outside the
    /// image circle).
    pub fn pixel_to_dir(&self, p: [f64; 2]) -> Option<[f64; 3]> {
        let (dx, dy) = (p[0] - self.centre[0], self.centre[1] - p[1]);
        let r = dx.hypot(dy);
        if r > self.radius_px {
            return None;
        }
        let theta = self.model.theta(r / self.focal_px())?;
        let (s, c) = theta.sin_cos();
        if r == 0.0 {
            return Some([0.0, 0.0, -1.0]);
        }
        Some([s * dx / r, s * dy / r, -c])
    }

    /// The continuous pixel position of a camera-frame direction (`None` outside the field of
    /// view).
    pub fn dir_to_pixel(&self, d: [f64; 3]) -> Option<[f64; 2]> {
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if !(l > 0.0) {
            return None;
        }
        let rho = d[0].hypot(d[1]);
        let theta = rho.atan2(-d[2]);
        if theta > 0.5 * self.fov_deg.to_radians() + 1e-12 {
            return None;
        }
        let r = self.model.radius(theta) * self.focal_px();
        if rho == 0.0 {
            return Some(self.centre);
        }
        Some([
            self.centre[0] + r * d[0] / rho,
            self.centre[1] - r * d[1] / rho,
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn models() -> Vec<LensModel> {
        vec![
            LensModel::Equidistant,
            LensModel::Equisolid,
            LensModel::Stereographic,
            LensModel::Orthographic,
            LensModel::Polynomial([-0.01, 0.002, 0.0, 0.0]),
        ]
    }

    #[test]
    fn radius_and_theta_are_inverse() {
        for m in models() {
            for i in 0..=100 {
                let t = m.theta_limit().min(3.0) * i as f64 / 100.0;
                let back = m.theta(m.radius(t)).unwrap();
                assert!((back - t).abs() < 1e-9, "{m:?} {t} {back}");
            }
        }
    }

    #[test]
    fn pixels_and_directions_round_trip_and_pin_the_axes() {
        for m in models() {
            let fov = if m == LensModel::Orthographic {
                180.0
            } else {
                190.0
            };
            let lens = Lens::new(m, fov, [512.0, 500.0], 480.0).unwrap();
            // The centre sees -Z; right of it +X; above it +Y.
            let c = lens.pixel_to_dir([512.0, 500.0]).unwrap();
            assert_eq!(c, [0.0, 0.0, -1.0]);
            let right = lens.pixel_to_dir([900.0, 500.0]).unwrap();
            assert!(right[0] > 0.0 && right[1].abs() < 1e-12);
            let up = lens.pixel_to_dir([512.0, 100.0]).unwrap();
            assert!(up[1] > 0.0 && up[0].abs() < 1e-12);
            // The rim of the image circle is at fov/2.
            let rim = lens.pixel_to_dir([512.0 + 480.0, 500.0]).unwrap();
            let theta = rim[0].hypot(rim[1]).atan2(-rim[2]);
            assert!((theta - 0.5 * fov.to_radians()).abs() < 1e-9, "{m:?}");
            assert!(lens.pixel_to_dir([512.0 + 481.0, 500.0]).is_none());
            for j in 0..20 {
                for i in 0..20 {
                    let p = [40.0 + 48.0 * i as f64, 30.0 + 48.0 * j as f64];
                    if let Some(d) = lens.pixel_to_dir(p) {
                        let q = lens.dir_to_pixel(d).unwrap();
                        assert!(
                            (q[0] - p[0]).abs() < 1e-7 && (q[1] - p[1]).abs() < 1e-7,
                            "{m:?} {p:?} {q:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn parameters_are_checked() {
        assert!(Lens::new(LensModel::Orthographic, 200.0, [0.0; 2], 10.0).is_err());
        assert!(Lens::new(LensModel::Equidistant, 0.0, [0.0; 2], 10.0).is_err());
        assert!(Lens::new(LensModel::Equidistant, 180.0, [0.0; 2], -1.0).is_err());
        let e = LensModel::parse("fishy", [0.0; 4]).unwrap_err();
        assert!(e.to_string().starts_with("model:"), "{e}");
    }
}
