//! The size limits every reader checks a file's header against before it allocates pixels
//! (their values: `base::limits`).

use crate::base::error::{Error, Result};
use crate::base::limits::{max_pixels, IMAGE_SIDE};
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
    /// [`IMAGE_SIDE`] on a side and [`max_pixels`] pixels (`SPHEREMAP_MAX_PIXELS` overrides
    /// the total for every front end).
    fn default() -> Self {
        Limits {
            max_width: IMAGE_SIDE,
            max_height: IMAGE_SIDE,
            max_pixels: max_pixels(),
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
