//! Figures: text (the public-domain 8×8 bitmap font of `font8x8`), colour bars with a legend,
//! and contact sheets with captions. Images are linear RGB like every image in spheremap.

use crate::images::Image;
use font8x8::UnicodeFonts;

/// Glyph advance in font pixels.
pub const GLYPH: usize = 8;

/// Writes `text` with its top-left corner at (x, y), each font pixel `scale` × `scale`.
/// Characters the font lacks are blank.
pub fn text(img: &mut Image, text: &str, x: i64, y: i64, scale: usize, colour: [f32; 3]) {
    for (k, ch) in text.chars().enumerate() {
        let g = font8x8::BASIC_FONTS
            .get(ch)
            .or_else(|| font8x8::LATIN_FONTS.get(ch))
            .unwrap_or([0; 8]);
        for (gy, bits) in g.iter().enumerate() {
            for gx in 0..8 {
                if bits & (1 << gx) == 0 {
                    continue;
                }
                for sy in 0..scale {
                    for sx in 0..scale {
                        let px = x + ((k * GLYPH + gx) * scale + sx) as i64;
                        let py = y + (gy * scale + sy) as i64;
                        put(img, px, py, colour);
                    }
                }
            }
        }
    }
}

/// Width in pixels of `text` at `scale`.
pub fn text_width(text: &str, scale: usize) -> usize {
    text.chars().count() * GLYPH * scale
}

fn put(img: &mut Image, x: i64, y: i64, c: [f32; 3]) {
    if x >= 0 && y >= 0 && (x as usize) < img.width && (y as usize) < img.height {
        let p = img.pixel_mut(x as usize, y as usize);
        p[..3].copy_from_slice(&c);
    }
}

/// Fills a rectangle.
pub fn rect(img: &mut Image, x: i64, y: i64, w: usize, h: usize, c: [f32; 3]) {
    for yy in 0..h as i64 {
        for xx in 0..w as i64 {
            put(img, x + xx, y + yy, c);
        }
    }
}

/// A horizontal colour bar of `w` × `h` at (x, y), coloured by `colour_of(f)` for f from 0
/// (left) to 1 (right), with `labels` (position 0..1, text) written under it.
#[allow(clippy::too_many_arguments)]
pub fn colour_bar(
    img: &mut Image,
    x: i64,
    y: i64,
    w: usize,
    h: usize,
    colour_of: impl Fn(f32) -> [f32; 3],
    labels: &[(f32, String)],
    ink: [f32; 3],
) {
    for xx in 0..w {
        let c = colour_of((xx as f32 + 0.5) / w as f32);
        rect(img, x + xx as i64, y, 1, h, c);
    }
    for (f, s) in labels {
        let cx = x + (f * w as f32).round() as i64;
        rect(img, cx.min(x + w as i64 - 1), y + h as i64, 1, 4, ink);
        let tw = text_width(s, 1) as i64;
        let tx = (cx - tw / 2).clamp(x - 4, x + w as i64 + 4 - tw);
        text(img, s, tx, y + h as i64 + 6, 1, ink);
    }
}

/// Images side by side in `cols` columns on a `background`, each with its caption above it.
/// Images of other sizes are placed in cells as large as the largest.
pub fn contact_sheet(
    items: &[(&Image, String)],
    cols: usize,
    background: [f32; 3],
    ink: [f32; 3],
) -> Image {
    let cols = cols.max(1);
    let rows = items.len().div_ceil(cols);
    let cw = items.iter().map(|(i, _)| i.width).max().unwrap_or(1);
    let ch = items.iter().map(|(i, _)| i.height).max().unwrap_or(1);
    let (pad, cap) = (8usize, 14usize);
    let (w, h) = (cols * (cw + pad) + pad, rows * (ch + cap + pad) + pad);
    let mut out = Image::new(w, h, 3);
    for p in out.data.chunks_exact_mut(3) {
        p.copy_from_slice(&background);
    }
    for (k, (img, caption)) in items.iter().enumerate() {
        let x0 = pad + (k % cols) * (cw + pad);
        let y0 = pad + (k / cols) * (ch + cap + pad);
        text(&mut out, caption, x0 as i64, y0 as i64, 1, ink);
        for y in 0..img.height {
            for x in 0..img.width {
                let s = img.pixel(x, y);
                let c = if img.channels >= 3 {
                    [s[0], s[1], s[2]]
                } else {
                    [s[0]; 3]
                };
                out.pixel_mut(x0 + x, y0 + cap + y).copy_from_slice(&c);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_and_sheet() {
        let mut img = Image::new(40, 10, 3);
        text(&mut img, "A1°", 0, 0, 1, [1.0; 3]);
        // 'A' and '1' and the degree sign all have ink.
        for k in 0..3 {
            let ink = (0..8)
                .flat_map(|y| (0..8).map(move |x| (x + 8 * k, y)))
                .filter(|&(x, y)| img.pixel(x, y)[0] > 0.0)
                .count();
            assert!(ink > 3, "glyph {k}");
        }
        let a = Image::new(10, 6, 3);
        let b = Image::new(4, 4, 1);
        let s = contact_sheet(&[(&a, "a".into()), (&b, "b".into())], 2, [0.5; 3], [1.0; 3]);
        assert_eq!((s.width, s.height), (2 * 18 + 8, 6 + 14 + 16));
    }
}
