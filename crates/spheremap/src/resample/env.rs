//! An environment map in memory: a mapping and its canvas, checked against each other.

use crate::base::error::{Error, Result};
use crate::images::Image;
use crate::mappings::mapping::Mapping;

/// An environment map in memory: a mapping and its canvas.
#[derive(Clone, Copy, Debug)]
pub struct EnvMap<'a> {
    pub mapping: Mapping,
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: &'a [f32],
}

impl<'a> EnvMap<'a> {
    /// Checks the canvas shape against the mapping (`what` names the input in errors).
    pub fn new(mapping: Mapping, img: &'a Image, what: &str) -> Result<Self> {
        Self::from_slice(
            mapping,
            img.width,
            img.height,
            img.channels,
            &img.data,
            what,
        )
    }

    /// The same over borrowed texels (row 0 at the top, channels interleaved), with no copy.
    pub fn from_slice(
        mapping: Mapping,
        width: usize,
        height: usize,
        channels: usize,
        data: &'a [f32],
        what: &str,
    ) -> Result<Self> {
        mapping.size_of(width, height, what)?;
        if !(1..=4).contains(&channels) {
            return Err(Error::data(
                what,
                format!("{channels} channels; 1 to 4 are supported"),
            ));
        }
        if data.len() != width * height * channels {
            return Err(Error::data(
                what,
                format!("{} values for {width}×{height}×{channels}", data.len()),
            ));
        }
        Ok(EnvMap {
            mapping,
            width,
            height,
            channels,
            data,
        })
    }
}
