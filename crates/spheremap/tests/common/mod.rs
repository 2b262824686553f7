//! Helpers shared by the integration tests (`mod common;` in each).
#![allow(dead_code)]

use spheremap::image_io::Image;
use std::path::{Path, PathBuf};

/// A file of the repository's `testdata/`.
pub fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../testdata")
        .join(name)
}

/// The bundled HDRI (Poly Haven's apartment, lat-long), from the copy compiled into the crate.
pub fn apartment() -> Image {
    spheremap::image_io::decode(
        Path::new("apartment.exr"),
        spheremap::demo::APARTMENT_EXR,
        &Default::default(),
    )
    .unwrap()
}

/// The largest difference of two images' values (their shapes must agree).
pub fn max_diff(a: &Image, b: &Image) -> f32 {
    assert_eq!(
        (a.width, a.height, a.channels),
        (b.width, b.height, b.channels)
    );
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}
