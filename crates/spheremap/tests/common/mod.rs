//! Helpers shared by the integration tests (`mod common;` in each).
#![allow(dead_code)]

use spheremap::images::Image;
use std::path::{Path, PathBuf};

/// A file of the repository's `testdata/`.
pub fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../testdata")
        .join(name)
}

/// The bundled HDRI (Poly Haven's apartment, lat-long), from the copy compiled into the crate.
pub fn apartment() -> Image {
    spheremap::images::codec::decode(
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

/// A glTF 2.0 document (JSON, data embedded): one red emissive triangle 2 units down -Z.
pub const GLTF_TRIANGLE: &str = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
"nodes":[{"mesh":0,"translation":[0,0,-2]}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},
"indices":1,"material":0}]}],"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,0,0,1]},
"emissiveFactor":[1,1,1]}],"buffers":[{"byteLength":42,
"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIA"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#;

/// A fresh temporary directory for one test thread (`tag` names the test file).
pub fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "spheremap-{tag}-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
