//! The photo's horizontal field of view: from flags, else from its EXIF data.
//!
//! Order (the first that applies wins; what the user says overrides the file):
//!
//! 1. `--fov DEG` — the horizontal field of view across the photo as stored.
//! 2. `--focal MM --sensor MM` — `hfov = 2 atan(sensor / 2 focal)`, sensor = its width.
//! 3. EXIF `FocalLengthIn35mmFilm` — 35 mm equivalence is defined on the diagonal
//!    (43.27 mm), so `tan(diag/2) = 21.635 / f35` and `tan(hfov/2) = tan(diag/2) · W / √(W² + H²)`.
//! 4. EXIF `FocalLength` with `--sensor MM`.
//!
//! Photos from phones and most cameras carry (3).  EXIF orientation is not applied: the photo
//! is used as its pixels are stored.

use crate::base::error::{Error, Result};

/// Where the field of view came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovSource {
    Flag,
    FocalAndSensor,
    Exif35mm,
    ExifFocalAndSensor,
}

impl FovSource {
    pub fn describe(self) -> &'static str {
        match self {
            FovSource::Flag => "given field of view",
            FovSource::FocalAndSensor => "given focal length and sensor width",
            FovSource::Exif35mm => "EXIF 35 mm equivalent focal length",
            FovSource::ExifFocalAndSensor => "EXIF focal length and given sensor width",
        }
    }
}

/// (FocalLengthIn35mmFilm, FocalLength in mm) from a file's bytes, when it has EXIF data.
fn exif_focals(bytes: &[u8]) -> (Option<f64>, Option<f64>) {
    // The EXIF reader is given untrusted bytes: a panic in it becomes "no EXIF".
    let r = crate::base::error::guard_parser(std::path::Path::new("photo"), "EXIF", || {
        let exif = exif::Reader::new()
            .read_from_container(&mut std::io::Cursor::new(bytes))
            .map_err(|e| Error::data("photo", e.to_string()))?;
        let f35 = exif
            .get_field(exif::Tag::FocalLengthIn35mmFilm, exif::In::PRIMARY)
            .and_then(|f| f.value.get_uint(0))
            .map(|v| v as f64)
            .filter(|&v| v > 0.0);
        let f = exif
            .get_field(exif::Tag::FocalLength, exif::In::PRIMARY)
            .and_then(|f| match &f.value {
                exif::Value::Rational(v) => v.first().map(|r| r.to_f64()),
                _ => None,
            })
            .filter(|v| *v > 0.0 && v.is_finite());
        Ok((f35, f))
    });
    r.unwrap_or((None, None))
}

fn check_mm(name: &str, v: f64) -> Result<f64> {
    if v > 0.0 && v < 1e4 {
        Ok(v)
    } else {
        Err(Error::param(name, format!("{v} mm: must be positive")))
    }
}

/// A photo's horizontal field of view in degrees, checked: in (0°, 180°).
pub fn check_fov(f: f64) -> Result<f64> {
    if f > 0.0 && f < 180.0 {
        Ok(f)
    } else {
        Err(Error::param("fov", format!("{f}°: must be in (0°, 180°)")))
    }
}

/// The horizontal field of view in degrees of a `width`×`height` photo (see the module docs);
/// `bytes` are the photo file's bytes for EXIF.
pub fn exif_hfov(
    fov_deg: Option<f64>,
    focal_mm: Option<f64>,
    sensor_mm: Option<f64>,
    bytes: Option<&[u8]>,
    width: usize,
    height: usize,
) -> Result<(f64, FovSource)> {
    if let Some(f) = fov_deg {
        return Ok((check_fov(f)?, FovSource::Flag));
    }
    let sensor = sensor_mm.map(|s| check_mm("sensor", s)).transpose()?;
    let hfov = |focal: f64, sensor: f64| 2.0 * (0.5 * sensor / focal).atan().to_degrees();
    if let Some(f) = focal_mm {
        let f = check_mm("focal", f)?;
        let s = sensor.ok_or_else(|| {
            Error::param("sensor", "--focal needs the sensor width (--sensor MM)")
        })?;
        return Ok((hfov(f, s), FovSource::FocalAndSensor));
    }
    let (f35, f) = bytes.map(exif_focals).unwrap_or((None, None));
    if let Some(f35) = f35 {
        let (w, h) = (width as f64, height as f64);
        let t = 21.635 / f35 * w / w.hypot(h);
        return Ok((2.0 * t.atan().to_degrees(), FovSource::Exif35mm));
    }
    if let (Some(f), Some(s)) = (f, sensor) {
        return Ok((hfov(f, s), FovSource::ExifFocalAndSensor));
    }
    Err(Error::param(
        "fov",
        "the photo's field of view is unknown (no usable EXIF focal length): give --fov DEG, \
         or --focal MM --sensor MM, or --orthographic",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_and_errors() {
        assert_eq!(
            exif_hfov(Some(40.0), None, None, None, 10, 10).unwrap(),
            (40.0, FovSource::Flag)
        );
        let (f, s) = exif_hfov(None, Some(18.0), Some(36.0), None, 10, 10).unwrap();
        assert!((f - 90.0).abs() < 1e-12 && s == FovSource::FocalAndSensor);
        assert!(exif_hfov(None, Some(18.0), None, None, 10, 10).is_err());
        assert!(exif_hfov(None, None, None, None, 10, 10).is_err());
        assert!(exif_hfov(None, None, None, Some(b"not an image"), 10, 10).is_err());
        assert!(exif_hfov(Some(180.0), None, None, None, 10, 10).is_err());
    }
}
