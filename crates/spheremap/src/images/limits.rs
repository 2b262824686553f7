//! The size limits every reader checks a file's header against before it allocates pixels.

use crate::base::error::{Error, Result};
use std::path::Path;

/// Size limits checked against a file's header before its pixels are allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    pub max_width: usize,
    pub max_height: usize,
    /// Width × height.
    pub max_pixels: usize,
}

impl Default for Limits {
    /// 65,536 on a side and 2²⁸ pixels (4 GiB as float RGBA); `SPHEREMAP_MAX_PIXELS` (a
    /// pixel count) overrides the total for every front end.
    fn default() -> Self {
        let max_pixels = std::env::var("SPHEREMAP_MAX_PIXELS")
            .ok()
            .and_then(|s| s.trim().parse::<usize>().ok())
            .filter(|&n| n > 0)
            .unwrap_or(1 << 28);
        Limits {
            max_width: 1 << 16,
            max_height: 1 << 16,
            max_pixels,
        }
    }
}

impl Limits {
    pub(crate) fn check(&self, path: &Path, w: usize, h: usize) -> Result<()> {
        if w == 0 || h == 0 {
            return Err(Error::data(
                path,
                format!("the header gives an empty image ({w}x{h})"),
            ));
        }
        if w > self.max_width || h > self.max_height || w.saturating_mul(h) > self.max_pixels {
            return Err(Error::limit(
                path.display().to_string(),
                format!(
                    "the header claims {w}x{h} pixels, over the limit ({}x{}, {} pixels in all)",
                    self.max_width, self.max_height, self.max_pixels
                ),
            ));
        }
        Ok(())
    }
}
