//! Golden images of the rasterizer: small renders of the bundled teapot in every mode, compared
//! with the files in tests/golden/ (EXR, linear float). After an intended change, re-bless them:
//! `SPHEREMAP_BLESS=1 cargo test -p spheremap --test golden`, look at the new files, commit.

use spheremap::images::codec::{read_image, write_image, WriteOptions};

use spheremap::images::Image;
use spheremap::jobs::render::{render, Env, GlCamera, Mode, RenderOptions, Texture, Wrap};
use spheremap::mappings::matcap::MatcapVariant;
use std::path::PathBuf;

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn check(name: &str, img: &Image) {
    let path = golden_dir().join(format!("{name}.exr"));
    if std::env::var("SPHEREMAP_BLESS").as_deref() == Ok("1") {
        write_image(&path, img, &WriteOptions::default()).unwrap();
        eprintln!("blessed {}", path.display());
        return;
    }
    let want = read_image(&path, &Default::default()).unwrap_or_else(|e| {
        panic!("{e}: no golden image; bless with SPHEREMAP_BLESS=1 cargo test -p spheremap --test golden")
    });
    assert_eq!(
        (want.width, want.height, want.channels),
        (img.width, img.height, img.channels),
        "{name}"
    );
    let worst = img
        .data
        .iter()
        .zip(&want.data)
        .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
        .fold(0f32, f32::max);
    assert!(
        worst < 1e-4,
        "{name}: differs from the golden image by {worst} (re-bless if intended)"
    );
}

fn sphere_map() -> Image {
    let hdri = spheremap::demo::apartment().unwrap();
    let src = spheremap::resample::EnvMap::new(
        spheremap::Mapping::parse("latlong", None).unwrap(),
        &hdri,
        "hdri",
    )
    .unwrap();
    let sphere = spheremap::Mapping::parse("sphere", None).unwrap();
    // One lookup per texel: the goldens test the rasterizer, so their input is kept to the
    // conversion engine's simplest, most stable path (its filtered paths have tests of their own).
    let one = spheremap::resample::ResampleOptions {
        samples: 1,
        ..Default::default()
    };
    spheremap::resample::resample(&src, sphere, 128, 128, &one, None)
        .unwrap()
        .0
}

#[test]
fn teapot_in_every_mode() {
    let mesh = spheremap::demo::teapot().unwrap();
    let cam = GlCamera::look_at(
        [10.0, 14.0, 36.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        35.0,
        1.0,
        100.0,
        64,
        48,
    )
    .unwrap();
    let map = sphere_map();
    let tex = Texture {
        image: &map,
        wrap: Wrap::ClampToEdge,
    };
    let matcap_img = read_image(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/matcap_0177.webp"),
        &Default::default(),
    )
    .unwrap();
    let matcap = Texture {
        image: &matcap_img,
        wrap: Wrap::ClampToEdge,
    };
    let cases: [(&str, Mode, Env, u32); 6] = [
        ("per_vertex", Mode::PerVertex, Env::Texture(&tex), 1),
        ("per_pixel", Mode::PerPixel, Env::Texture(&tex), 1),
        ("per_pixel_aa", Mode::PerPixel, Env::Texture(&tex), 3),
        (
            "matcap",
            Mode::Matcap(MatcapVariant::Perspective),
            Env::Texture(&matcap),
            2,
        ),
        ("normals", Mode::Normals, Env::None, 2),
        ("error", Mode::Error, Env::None, 2),
    ];
    for (name, mode, env, aa) in cases {
        let opts = RenderOptions {
            mode,
            background: [0.1, 0.2, 0.3],
            aa,
            ..RenderOptions::default()
        };
        let (img, _) = render(&mesh, &cam, env, &opts).unwrap();
        check(name, &img);
    }
}
