use spheremap::images::codec::{
    decode, encode, inspect, read_image, srgb_to_linear, write_image, Limits, ReadOptions,
    WriteOptions,
};
use spheremap::images::format::Format;
use spheremap::images::Image;
use std::path::Path;

mod common;
use common::{max_diff, testdata};

fn ramp(w: usize, h: usize, c: usize) -> Image {
    let mut img = Image::new(w, h, c);
    for y in 0..h {
        for x in 0..w {
            for k in 0..c {
                img.pixel_mut(x, y)[k] =
                    (x as f32 + 0.37 * y as f32 + k as f32 * 0.11) / (w + h) as f32;
            }
        }
    }
    img
}

fn round_trip(img: &Image, fmt: Format, opts: &WriteOptions, ropts: &ReadOptions) -> Image {
    let p = Path::new("mem");
    let bytes = encode(p, img, fmt, opts).unwrap();
    assert_eq!(Format::sniff(&bytes), Some(fmt));
    decode(p, &bytes, ropts).unwrap()
}

#[test]
fn exr_float_is_exact_and_half_is_close() {
    for c in [1, 2, 3, 4] {
        let mut img = ramp(37, 11, c);
        img.data[5] = -0.25; // negative values survive
        img.data[7] = 1000.0; // HDR values survive
        let back = round_trip(
            &img,
            Format::Exr,
            &WriteOptions::default(),
            &ReadOptions::default(),
        );
        assert_eq!(back, img, "{c} channels");
        let half = round_trip(
            &img,
            Format::Exr,
            &WriteOptions {
                half: true,
                ..Default::default()
            },
            &ReadOptions::default(),
        );
        for (x, y) in img.data.iter().zip(&half.data) {
            assert!((x - y).abs() <= x.abs() * 1e-3 + 1e-4, "{x} vs {y}");
        }
    }
}

#[test]
fn pfm_is_exact_and_bottom_up() {
    for c in [1, 3] {
        let img = ramp(9, 5, c);
        assert_eq!(
            round_trip(
                &img,
                Format::Pfm,
                &WriteOptions::default(),
                &ReadOptions::default()
            ),
            img
        );
    }
    // Rows are stored bottom-up: the first stored row is the image's last row.
    let bytes = b"Pf\n2 2\n-1.0\n\x00\x00\x80\x3f\x00\x00\x00\x40\x00\x00\x40\x40\x00\x00\x80\x40";
    let img = decode(Path::new("m.pfm"), bytes, &ReadOptions::default()).unwrap();
    assert_eq!(img.data, vec![3.0, 4.0, 1.0, 2.0]);
}

#[test]
fn hdr_within_rgbe_precision() {
    let mut img = ramp(16, 8, 3);
    img.data[0] = 50.0;
    let back = round_trip(
        &img,
        Format::Hdr,
        &WriteOptions::default(),
        &ReadOptions::default(),
    );
    // RGBE: one shared exponent per pixel, so the error is relative to the pixel's largest value.
    for (a, b) in img.data.chunks_exact(3).zip(back.data.chunks_exact(3)) {
        let m = a.iter().fold(0.0f32, |m, v| m.max(*v));
        for (x, y) in a.iter().zip(b) {
            assert!(
                (x - y).abs() <= m / 128.0 + 1e-6,
                "{x} vs {y} (pixel max {m})"
            );
        }
    }
}

#[test]
fn png_srgb_8_and_16_bit_and_alpha_is_linear() {
    let img = ramp(20, 10, 4);
    let b8 = round_trip(
        &img,
        Format::Png,
        &WriteOptions::default(),
        &ReadOptions::default(),
    );
    // 8-bit sRGB quantisation: at most half a code in encoded space.
    let rgb = |i: &(usize, (&f32, &f32))| i.0 % 4 != 3;
    let err8 = img
        .data
        .iter()
        .zip(&b8.data)
        .enumerate()
        .filter(rgb)
        .map(|(_, p)| p)
        .map(|(x, y)| {
            (spheremap::images::codec::linear_to_srgb(*x)
                - spheremap::images::codec::linear_to_srgb(*y))
            .abs()
        })
        .fold(0.0, f32::max);
    assert!(err8 <= 0.5 / 255.0 + 1e-6, "{err8}");
    let b16 = round_trip(
        &img,
        Format::Png,
        &WriteOptions {
            png16: true,
            ..Default::default()
        },
        &ReadOptions::default(),
    );
    assert!(max_diff(&img, &b16) < 1e-4);
    // Alpha (channel 3) is stored without the sRGB curve.
    let bytes = encode(
        Path::new("a.png"),
        &img,
        Format::Png,
        &WriteOptions::default(),
    )
    .unwrap();
    let raw = decode(
        Path::new("a.png"),
        &bytes,
        &ReadOptions {
            linear: true,
            ..Default::default()
        },
    )
    .unwrap();
    for (x, y) in img
        .data
        .iter()
        .skip(3)
        .step_by(4)
        .zip(raw.data.iter().skip(3).step_by(4))
    {
        assert!((x - y).abs() <= 0.5 / 255.0 + 1e-6);
    }
    // linear: no transfer curve either way.
    let lin = round_trip(
        &img,
        Format::Png,
        &WriteOptions {
            linear: true,
            ..Default::default()
        },
        &ReadOptions {
            linear: true,
            ..Default::default()
        },
    );
    assert!(max_diff(&img, &lin) <= 0.5 / 255.0 + 1e-6);
    assert!((srgb_to_linear(0.5) - 0.21404114).abs() < 1e-6);
}

#[test]
fn jpeg_round_trip_is_close() {
    let img = ramp(32, 32, 3);
    let back = round_trip(
        &img,
        Format::Jpeg,
        &WriteOptions::default(),
        &ReadOptions::default(),
    );
    assert!(max_diff(&img, &back) < 0.05);
    let e = encode(
        Path::new("x.jpg"),
        &ramp(4, 4, 4),
        Format::Jpeg,
        &WriteOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("alpha"), "{e}");
}

#[test]
fn real_dwab_exr_and_webp() {
    let exr = read_image(&testdata("apartment.exr"), &ReadOptions::default()).unwrap();
    assert_eq!((exr.width, exr.height, exr.channels), (512, 256, 3));
    let neg = exr.data.iter().filter(|v| **v < 0.0).count();
    assert!(neg > 0 && exr.data.iter().all(|v| v.is_finite()));
    let webp = read_image(&testdata("matcap_0177.webp"), &ReadOptions::default()).unwrap();
    assert_eq!((webp.width, webp.height, webp.channels), (512, 512, 3));
    assert!(webp.data.iter().all(|v| (0.0..=1.0).contains(v)));
}

#[test]
fn content_wins_over_extension() {
    let dir = std::env::temp_dir().join(format!("spheremap-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("really_a_png.exr");
    std::fs::write(
        &p,
        encode(&p, &ramp(4, 4, 3), Format::Png, &WriteOptions::default()).unwrap(),
    )
    .unwrap();
    let i = inspect(&p, &ReadOptions::default()).unwrap();
    assert_eq!(i.format, Format::Png);
    assert_eq!(i.extension_mismatch, Some(Format::Exr));
    // write_image goes by extension and writes atomically.
    let out = dir.join("o.pfm");
    write_image(&out, &ramp(3, 2, 3), &WriteOptions::default()).unwrap();
    assert_eq!(
        Format::sniff(&std::fs::read(&out).unwrap()),
        Some(Format::Pfm)
    );
    assert!(write_image(
        &dir.join("o.tiff"),
        &ramp(3, 2, 3),
        &WriteOptions::default()
    )
    .is_err());
    assert!(std::fs::read_dir(&dir).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .ends_with(".tmp")));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn limits_are_checked_before_allocating() {
    let huge = b"PF\n100000 100000\n-1.0\n";
    let e = decode(Path::new("huge.pfm"), huge, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("over the limit") && e.starts_with("huge.pfm"),
        "{e}"
    );
    let small = ReadOptions {
        limits: Limits {
            max_width: 100,
            max_height: 100,
            max_pixels: 10_000,
        },
        ..Default::default()
    };
    let e = read_image(&testdata("apartment.exr"), &small)
        .unwrap_err()
        .to_string();
    assert!(e.contains("512x256") && e.contains("over the limit"), "{e}");
}

#[test]
fn truncated_and_garbage_files_are_data_errors() {
    let good = std::fs::read(testdata("apartment.exr")).unwrap();
    let png = encode(
        Path::new("x.png"),
        &ramp(64, 64, 3),
        Format::Png,
        &WriteOptions::default(),
    )
    .unwrap();
    let webp = std::fs::read(testdata("matcap_0177.webp")).unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("t.exr", good[..good.len() / 3].to_vec()),
        ("t.exr", good[..40].to_vec()),
        ("t.png", png[..png.len() / 2].to_vec()),
        ("t.webp", webp[..webp.len() / 2].to_vec()),
        ("t.pfm", b"PF\n4 4\n-1.0\n\x00\x00".to_vec()),
        ("t.pfm", b"PF\n-4 4\n-1.0\n".to_vec()),
        (
            "t.hdr",
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 10 +X 10\n\x02\x02".to_vec(),
        ),
        ("g.exr", b"this is not an image at all".to_vec()),
        ("e.png", Vec::new()),
    ];
    for (name, bytes) in cases {
        let r = decode(Path::new(name), &bytes, &ReadOptions::default());
        let e = r.expect_err(name).to_string();
        assert!(e.starts_with(name), "{name}: {e}");
    }
}

#[test]
fn all_finite_finds_any_nan_or_inf_in_any_block() {
    use spheremap::images::codec::{all_finite, find_nonfinite};
    // Several parallel blocks (65536 values each) and a ragged end.
    let n = 3 * 65536 + 17;
    let mut v = vec![1.5f32; n];
    v[7] = f32::MAX;
    v[8] = f32::MIN_POSITIVE / 4.0; // subnormal: finite
    assert!(all_finite(&v));
    assert!(all_finite(&[]));
    for (i, bad) in [
        (0, f32::NAN),
        (65536 * 2 + 3, f32::INFINITY),
        (n - 1, f32::NEG_INFINITY),
    ] {
        let mut w = v.clone();
        w[i] = bad;
        assert!(!all_finite(&w), "{i}");
        let img = Image {
            width: n,
            height: 1,
            channels: 1,
            data: w,
        };
        assert_eq!(find_nonfinite(&img), Some((1, i, 0)));
    }
}

/// `info`'s mapping guess on spheremap's own outputs of a real HDRI: a sphere map with the
/// default gutter (whose corners are full) and with black corners is a disc; the octahedral
/// map and one cube face of the same environment, also square with full corners, are not; the
/// other shapes go by their aspect ratio.
#[test]
fn the_mapping_guess_tells_a_guttered_disc_from_a_full_square() {
    use spheremap::images::codec::guess_mapping;
    use spheremap::mappings::mapping::Mapping;
    use spheremap::resample::{resample, EnvMap, Outside, ResampleOptions};
    let ll = read_image(&testdata("apartment.exr"), &ReadOptions::default()).unwrap();
    assert_eq!(guess_mapping(&ll).0, "latlong");
    let src = EnvMap::new(Mapping::parse("latlong", None).unwrap(), &ll, "ll").unwrap();
    let make = |to: &str, w: usize, h: usize, outside: Outside| {
        let o = ResampleOptions {
            outside,
            ..Default::default()
        };
        resample(&src, Mapping::parse(to, None).unwrap(), w, h, &o, None)
            .unwrap()
            .0
    };
    for to in ["sphere", "angular"] {
        for n in [64, 255, 256] {
            let g = make(to, n, n, Outside::Gutter);
            assert_eq!(
                guess_mapping(&g).0,
                "sphere / angular (disc, with a gutter)",
                "{to} {n}"
            );
            let b = make(to, n, n, Outside::Black);
            assert_eq!(
                guess_mapping(&b).0,
                "sphere / mirror ball / angular (disc)",
                "{to} {n}"
            );
        }
    }
    let full = "octahedral or a single cube face";
    for n in [64, 256] {
        assert_eq!(
            guess_mapping(&make("octahedral", n, n, Outside::Gutter)).0,
            full,
            "{n}"
        );
        let cube = make("cube", n, 6 * n, Outside::Gutter);
        assert_eq!(guess_mapping(&cube).0, "cube (strip)");
        for f in 0..6 {
            let mut face = Image::new(n, n, cube.channels);
            let k = n * n * cube.channels;
            face.data.copy_from_slice(&cube.data[f * k..(f + 1) * k]);
            assert_eq!(guess_mapping(&face).0, full, "face {f} at {n}");
        }
    }
    // A gutter spoilt in one corner (a quarter of the points tested) is no longer a gutter.
    let mut g = make("sphere", 256, 256, Outside::Gutter);
    for y in 0..40 {
        for x in 0..40 {
            g.pixel_mut(x, y).iter_mut().for_each(|v| *v = 50.0);
        }
    }
    assert_eq!(guess_mapping(&g).0, full);
    assert_eq!(guess_mapping(&Image::new(40, 30, 3)).0, "cube (cross)");
    assert_eq!(
        guess_mapping(&Image::new(30, 60, 3)).0,
        "dual paraboloid (stacked)"
    );
    assert_eq!(guess_mapping(&Image::new(50, 30, 3)).0, "unknown");
}
