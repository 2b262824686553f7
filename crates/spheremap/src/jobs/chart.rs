//! A labelled direction chart as a sphere map: shows at a glance where every direction lands.
//!
//! Each texel is coloured by its direction `d` (eye frame, see [`crate::frame::conventions`]):
//! `colour = 0.15 + 0.7·(d + 1)/2` (so +X is reddish, +Y greenish, +Z bluish), with a graticule
//! every 15° of latitude (about +Y) and longitude, the equator and the prime meridian (through
//! +Z) drawn stronger, a white dot at ±X, ±Y and +Z labelled with its name, and the rim (the
//! single direction −Z) drawn in orange.  Outside the disc: black.

use crate::frame::conventions::texel_center;
use crate::images::Image;
use crate::mappings::sphere;

/// Renders the chart at `size`×`size`, rows in file order (row 0 = t = 1).
pub fn direction_chart(size: usize) -> Image {
    let mut img = Image::new(size, size, 3);
    let lat_lon = |s: f64, t: f64| -> Option<(f64, f64)> {
        let d = sphere::st_to_dir([s, t])?;
        Some((
            d[1].clamp(-1.0, 1.0).asin().to_degrees(),
            d[0].atan2(d[2]).to_degrees(),
        ))
    };
    let step = 15.0;
    for row in 0..size {
        let t = 1.0 - texel_center(row, size);
        for col in 0..size {
            let s = texel_center(col, size);
            let Some(d) = sphere::st_to_dir([s, t]) else {
                continue;
            };
            let mut c = [
                0.15 + 0.35 * (d[0] + 1.0),
                0.15 + 0.35 * (d[1] + 1.0),
                0.15 + 0.35 * (d[2] + 1.0),
            ];
            // Grid line where the cell index changes between this texel and its right/down
            // neighbour: one texel wide everywhere, whatever the map's local stretch.
            let (lat, lon) = lat_lon(s, t).unwrap();
            let du = 1.0 / size as f64;
            let mut line = 0.0f64;
            for (ns, nt) in [(s + du, t), (s, t - du)] {
                if let Some((lat2, lon2)) = lat_lon(ns, nt) {
                    let (a, b) = ((lat / step).floor(), (lat2 / step).floor());
                    if a != b {
                        line = line.max(if a.max(b) == 0.0 { 1.0 } else { 0.55 });
                    }
                    if (lon - lon2).abs() < 180.0 {
                        let (a, b) = ((lon / step).floor(), (lon2 / step).floor());
                        if a != b {
                            line = line.max(if a.max(b) == 0.0 { 1.0 } else { 0.55 });
                        }
                    }
                }
            }
            for v in c.iter_mut() {
                *v = *v * (1.0 - line) + 0.02 * line;
            }
            // The rim: the last ring of texels.
            let (x, y) = (2.0 * s - 1.0, 2.0 * t - 1.0);
            if (x * x + y * y).sqrt() > 1.0 - 2.0 / size as f64 {
                c = [1.0, 0.45, 0.05];
            }
            img.pixel_mut(col, row)
                .copy_from_slice(&c.map(|v| v as f32));
        }
    }
    let scale = (size / 160).max(1);
    let marks: [([f64; 3], &str); 5] = [
        ([1.0, 0.0, 0.0], "+X"),
        ([-1.0, 0.0, 0.0], "-X"),
        ([0.0, 1.0, 0.0], "+Y"),
        ([0.0, -1.0, 0.0], "-Y"),
        ([0.0, 0.0, 1.0], "+Z"),
    ];
    for (d, label) in marks {
        let [s, t] = sphere::dir_to_st(d, crate::frame::conventions::Singular::Nan);
        let (cx, cy) = (s * size as f64, (1.0 - t) * size as f64);
        let r = 2.5 * scale as f64;
        fill_disc(&mut img, cx, cy, r, [1.0, 1.0, 1.0]);
        let (tx, ty) = (cx + r + scale as f64, cy - 3.5 * scale as f64);
        draw_text(
            &mut img,
            label,
            tx + scale as f64,
            ty + scale as f64,
            scale,
            [0.0, 0.0, 0.0],
        );
        draw_text(&mut img, label, tx, ty, scale, [1.0, 1.0, 1.0]);
    }
    draw_text(
        &mut img,
        "-Z=rim",
        2.0 * scale as f64,
        2.0 * scale as f64,
        scale,
        [1.0, 0.45, 0.05],
    );
    img
}

fn fill_disc(img: &mut Image, cx: f64, cy: f64, r: f64, c: [f32; 3]) {
    let (x0, x1) = (
        (cx - r).floor().max(0.0) as usize,
        ((cx + r).ceil() as usize).min(img.width),
    );
    let (y0, y1) = (
        (cy - r).floor().max(0.0) as usize,
        ((cy + r).ceil() as usize).min(img.height),
    );
    for y in y0..y1 {
        for x in x0..x1 {
            let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
            if dx * dx + dy * dy <= r * r {
                img.pixel_mut(x, y).copy_from_slice(&c);
            }
        }
    }
}

/// 5×7 bitmap glyphs for the few characters the chart needs (one `u8` per row, bit 4 = left).
fn glyph(ch: char) -> [u8; 7] {
    match ch {
        '+' => [0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00],
        '-' => [0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00],
        '=' => [0x00, 0x00, 0x1f, 0x00, 0x1f, 0x00, 0x00],
        'X' => [0x11, 0x11, 0x0a, 0x04, 0x0a, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x0a, 0x04, 0x04, 0x04, 0x04],
        'Z' => [0x1f, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1f],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        'i' => [0x04, 0x00, 0x0c, 0x04, 0x04, 0x04, 0x0e],
        'm' => [0x00, 0x00, 0x1a, 0x15, 0x15, 0x11, 0x11],
        _ => [0; 7],
    }
}

fn draw_text(img: &mut Image, text: &str, x: f64, y: f64, scale: usize, c: [f32; 3]) {
    let (x0, y0) = (x.round() as i64, y.round() as i64);
    for (k, ch) in text.chars().enumerate() {
        let g = glyph(ch);
        for (gy, bits) in g.iter().enumerate() {
            for gx in 0..5 {
                if bits & (0x10 >> gx) == 0 {
                    continue;
                }
                for sy in 0..scale {
                    for sx in 0..scale {
                        let px = x0 + ((k * 6 + gx) * scale + sx) as i64;
                        let py = y0 + (gy * scale + sy) as i64;
                        if px >= 0
                            && py >= 0
                            && (px as usize) < img.width
                            && (py as usize) < img.height
                        {
                            img.pixel_mut(px as usize, py as usize).copy_from_slice(&c);
                        }
                    }
                }
            }
        }
    }
}
