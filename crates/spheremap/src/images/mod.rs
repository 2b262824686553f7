//! Layer 3, images: the [`Image`] type, the codecs, the map note a file carries, cube-map file
//! layouts, environment maps in files, tone mapping and text drawn into figures.
//!
//! This module holds the type every image layer shares; it imports nothing from its children.

pub mod bc6h;
pub mod codec;
pub mod compress;
pub mod container;
pub mod cube_layout;
pub mod draw;
pub mod envmap;
pub mod fold;
pub mod format;
pub mod info;
pub mod limits;
pub mod note;
pub mod tonemap;

/// A linear float image, row 0 at the top, `channels` interleaved values per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: Vec<f32>,
}

impl Image {
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        Image {
            width,
            height,
            channels,
            data: vec![0.0; width * height * channels],
        }
    }
    #[inline]
    pub fn pixel_mut(&mut self, x: usize, y: usize) -> &mut [f32] {
        let i = (y * self.width + x) * self.channels;
        &mut self.data[i..i + self.channels]
    }
    #[inline]
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }
    /// Channel names, by count: Y; Y,A; R,G,B; R,G,B,A.
    pub fn channel_names(&self) -> &'static [&'static str] {
        match self.channels {
            1 => &["Y"],
            2 => &["Y", "A"],
            3 => &["R", "G", "B"],
            _ => &["R", "G", "B", "A"],
        }
    }
}
