//! Tone mapping for display outputs (PNG/JPEG) of HDR renders. Linear outputs (EXR, HDR, PFM)
//! are never tone-mapped.
//!
//! Every operator first scales by the exposure, `x · 2^EV`, then maps each channel:
//!
//! * `clamp`: `min(x, 1)` (the default: an LDR texture renders back to the same values);
//! * `reinhard`: `x / (1 + x)`;
//! * `aces`: Narkowicz's fit of the ACES filmic curve,
//!   `(x (2.51 x + 0.03)) / (x (2.43 x + 0.59) + 0.14)`, clamped to [0, 1].
//!
//! The result is still linear; the image writer applies the sRGB transfer for 8/16-bit files.

use crate::images::Image;

crate::base::named::named_enum! {
    /// A tone-mapping operator (the module's list).
    #[derive(Default)]
    pub enum ToneMap: "operator" as "tonemap" {
        #[default]
        Clamp = "clamp",
        Reinhard = "reinhard",
        Aces = "aces",
    }
}

impl ToneMap {
    /// One value, after the exposure scale.
    pub fn map(self, x: f32) -> f32 {
        let x = x.max(0.0);
        match self {
            ToneMap::Clamp => x.min(1.0),
            ToneMap::Reinhard => x / (1.0 + x),
            ToneMap::Aces => {
                ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
            }
        }
    }
}

/// Applies `exposure` (EV) and `op` to the colour channels of `img` (an alpha 4th channel is
/// left alone).
pub fn tone_map(img: &mut Image, exposure: f32, op: ToneMap) {
    let k = exposure.exp2();
    let c = img.channels;
    let colour = if c == 4 || c == 2 { c - 1 } else { c };
    for px in img.data.chunks_exact_mut(c) {
        for v in &mut px[..colour] {
            *v = op.map(*v * k);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operators() {
        assert_eq!(ToneMap::Clamp.map(0.25), 0.25);
        assert_eq!(ToneMap::Clamp.map(7.0), 1.0);
        assert_eq!(ToneMap::Reinhard.map(1.0), 0.5);
        assert!(ToneMap::Aces.map(0.0) == 0.0 && ToneMap::Aces.map(100.0) == 1.0);
        assert!((ToneMap::Aces.map(0.18) - 0.2665).abs() < 1e-3);
        let mut img = Image {
            width: 1,
            height: 1,
            channels: 4,
            data: vec![0.25, 0.5, 2.0, 0.5],
        };
        tone_map(&mut img, 1.0, ToneMap::Clamp);
        assert_eq!(img.data, vec![0.5, 1.0, 1.0, 0.5]);
        assert!(ToneMap::parse("filmic").is_err());
    }
}
