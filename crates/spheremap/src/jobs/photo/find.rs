//! Finding a mirror ball in a perspective photo: candidate circles from the edge detector
//! ([`super::circle`]), each fitted by the model of the rim ([`super::rim`]) and scored.

use super::ball::BallGeometry;
use super::circle::{coarse, coarse_circles, planes, refine, Circle, CircleFit, CANDIDATES, RAYS};
use crate::base::error::{Error, Result};
use crate::images::Image;

/// Below this confidence (how much of the rim confirms the fit) a perspective photo's ball is
/// not taken as found.
pub const MIN_CONFIDENCE: f64 = 0.5;

/// Finds the ball in a perspective photo of horizontal field of view `hfov_deg`: candidate
/// circles from Hough votes over centre and radius and over the centre alone, each pulled in by
/// the edge fit and then fitted by the model of the rim ([`super::rim`]), and scored by how much
/// of the rim confirms it (0 when the fitted reflectance is none a mirror ball has); the best
/// wins, and the search ends early at a confidence of 0.8.  An error naming the best candidate's
/// circle, confidence and reflectance when none reaches [`MIN_CONFIDENCE`].
pub fn find_ball_perspective(img: &Image, hfov_deg: f64) -> Result<CircleFit> {
    use crate::trace::camera::{Camera, Projection};
    super::exif::check_fov(hfov_deg)?;
    let (lin, log) = planes(img)?;
    let camera = Camera::new(
        Projection::Perspective { hfov_deg },
        [0.0; 3],
        crate::frame::view::IDENTITY,
        img.width,
        img.height,
    )?;
    // Clipped highlights: the largest value, when a noticeable number of pixels share it.
    let max = lin.v.iter().copied().fold(0f32, f32::max);
    let at_max = lin.v.iter().filter(|&&v| v >= 0.999 * max).count();
    let clip = (max > 0.0 && at_max * 2000 > lin.v.len()).then_some(0.999 * max);
    let photo = super::rim::Photo {
        lum: &lin,
        camera: &camera,
        clip,
        scale: 1.0,
    };
    // The half-size copy the rim model's scans start on: the same camera at half the focal
    // length (the principal point of an odd-sized photo moves by ¼ px there, which the scans
    // at full resolution take up).
    let half = lin.half();
    let f_half = 0.25 * img.width as f64 / (0.5 * hfov_deg.to_radians()).tan();
    let camera_half = Camera::new(
        Projection::Perspective {
            hfov_deg: 2.0 * (0.5 * half.w as f64 / f_half).atan().to_degrees(),
        },
        [0.0; 3],
        crate::frame::view::IDENTITY,
        half.w,
        half.h,
    )?;
    let coarse_photo = super::rim::Photo {
        lum: &half,
        camera: &camera_half,
        clip: clip.map(|c| c * 0.999),
        scale: 2.0,
    };
    // The best fit so far, with its score: its confidence, or 0 where its reflectance is none a
    // mirror has.
    let mut best: Option<(super::rim::RimFit, f64)> = None;
    let mut tried = 0;
    let mut starts: Vec<Circle> = Vec::new();
    let mut cands = coarse_circles(&log);
    for c in coarse(&log).unwrap_or_default() {
        if cands.len() >= 2 * CANDIDATES {
            break;
        }
        cands.push(c);
    }
    for cand in cands {
        if best.as_ref().is_some_and(|b| b.1 >= SURE) {
            break;
        }
        // The edge fit first (it pulls a coarse circle to within a few pixels), else the
        // candidate as it is.
        let start = match refine(&log, &lin, cand).ok() {
            Some(f) if (f.circle.r - cand.r).abs() < 0.2 * cand.r => f.circle,
            _ => cand,
        };
        // Candidates that the edge fit took to the same circle are fitted once.
        if starts
            .iter()
            .any(|s| (s.cx - start.cx).hypot(s.cy - start.cy) + (s.r - start.r).abs() < 1.0)
        {
            continue;
        }
        starts.push(start);
        let outline: Vec<[f64; 2]> = (0..64)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 64.0;
                [start.cx + start.r * t.cos(), start.cy + start.r * t.sin()]
            })
            .collect();
        let Ok(g) = BallGeometry::perspective(&outline, hfov_deg, img.width, img.height) else {
            continue;
        };
        tried += 1;
        if let Some(f) = super::rim::fit(&photo, &coarse_photo, g.axis, (1.0 / g.distance).asin()) {
            let plausible = (REFLECTANCE.0..=REFLECTANCE.1).contains(&f.reflectance);
            let score = if plausible { f.confidence } else { 0.0 };
            if best
                .as_ref()
                .is_none_or(|b| score > b.1 || (b.1 == 0.0 && f.confidence > b.0.confidence))
            {
                best = Some((f, score));
            }
        }
    }
    let Some((f, _)) = best.as_ref().filter(|b| b.1 >= MIN_CONFIDENCE) else {
        let why = match &best {
            Some((f, _)) => format!(
                "the best of {tried} candidate circles, {}, had {:.0} % of its rim confirmed and \
                 a reflectance of {:.2}; a ball needs {:.0} % and {}–{}",
                BallGeometry::perspective(
                    &super::rim::outline(&camera, f, RAYS),
                    hfov_deg,
                    img.width,
                    img.height
                )
                .map_or("unknown".into(), |g| format!(
                    "({:.1}, {:.1}, {:.1})",
                    g.circle.cx, g.circle.cy, g.circle.r
                )),
                100.0 * f.confidence,
                f.reflectance,
                100.0 * MIN_CONFIDENCE,
                REFLECTANCE.0,
                REFLECTANCE.1
            ),
            None => format!("none of {tried} candidate circles could be fitted"),
        };
        return Err(Error::data(
            "image",
            format!("no mirror ball found ({why}); pass --circle CX CY R"),
        ));
    };
    let points = super::rim::outline(&camera, f, RAYS);
    let g = BallGeometry::perspective(&points, hfov_deg, img.width, img.height)?;
    Ok(CircleFit {
        circle: g.circle,
        rms: f.rms,
        points,
        confidence: f.confidence,
        reflectance: Some(f.reflectance),
        uncertainty: Some(f.uncertainty),
    })
}

/// The reflectances a fitted rim may show.  A mirror ball's is 0.5–0.95 (rising towards 1 at
/// grazing angles) and the fit's estimate scatters by some 0.2; an estimate outside this range
/// means the fit has split the rim's pixels between the ball's reflection and the free shape of
/// what lies beyond the photo (see [`super::rim`]) wrongly, or that the circle is no ball's rim.
const REFLECTANCE: (f64, f64) = (0.3, 1.25);
/// A candidate this confident ends the search.
const SURE: f64 = 0.8;
