//! Encoded textures (BC6H, RGB9E5, Zstandard-supercompressed KTX2): the files round-trip
//! through spheremap, independent readers (image-rs's `dds` decoder, the `ktx2` parser) read
//! them as spheremap does, and the levels keep their light.

use spheremap::images::codec::{encode_texture, WriteOptions};
use spheremap::images::compress::{texel_weights, Encoding, LevelCompression};
use spheremap::images::container::{decode, Texture};
use spheremap::images::format::Format;
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::energy::{add_sun, LightCheck, Moments};
use spheremap::resample::{resample, EnvMap, ResampleOptions, IDENTITY};
use std::path::Path;

const CUBE_NOTE: &str = "mapping=cube preset=gl layout=vstrip";

fn hdri(name: &str) -> Image {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../testdata/hdri")
        .join(name);
    spheremap::images::codec::read_image(&p, &Default::default()).unwrap()
}

/// A cube chain of `levels` levels from face `size`, each level resampled from `src`.
fn cube_chain(src: &Image, size: usize, levels: usize) -> Texture {
    let ll = Mapping::parse("latlong", None).unwrap();
    let cube = Mapping::parse("cube", None).unwrap();
    let env = EnvMap::new(ll, src, "src").unwrap();
    Texture {
        cube: true,
        levels: (0..levels)
            .map(|i| {
                let (w, h) = cube.canvas((size >> i).max(1));
                resample(&env, cube, w, h, &ResampleOptions::default(), None)
                    .unwrap()
                    .0
            })
            .collect(),
    }
}

fn encode(
    tex: &Texture,
    format: Format,
    e: Encoding,
    zstd: Option<i32>,
    note: &str,
) -> (Vec<u8>, Option<Vec<LevelCompression>>) {
    let opts = WriteOptions {
        encode: e,
        zstd,
        ..Default::default()
    };
    let name = if format == Format::Ktx2 {
        "t.ktx2"
    } else {
        "t.dds"
    };
    encode_texture(Path::new(name), tex, format, &opts, Some(note)).unwrap()
}

/// Per channel power Σ L·Ω of a cube level (face stack).
fn cube_power(img: &Image) -> [f64; 3] {
    let n = img.width;
    let w = texel_weights(None, true, n, n);
    let mut p = [0.0; 3];
    for (i, px) in img.data.chunks_exact(img.channels).enumerate() {
        for k in 0..3 {
            p[k] += px[k.min(img.channels - 1)] as f64 * w[i % (n * n)];
        }
    }
    p
}

/// An image clamped to [0, max].
fn clamp_image(img: &Image, max: f32) -> Image {
    let mut i = img.clone();
    for v in &mut i.data {
        *v = v.clamp(0.0, max);
    }
    i
}

/// A bundled HDRI, with a sun of `sun` = (diameter in degrees, share of the power) added.
fn with_sun(name: &str, sun: Option<(f64, f64)>) -> Image {
    let mut src = hdri(name);
    if let Some((deg, f)) = sun {
        let ll = Mapping::parse("latlong", None).unwrap();
        add_sun(&mut src, ll, [0.35, 0.6, -0.72], deg, f).unwrap();
    }
    src
}

/// The SH9 irradiance error of cube level `got` against `want`.
fn sh9_error(want: &Image, got: &Image) -> f64 {
    let cube = Mapping::parse("cube", None).unwrap();
    LightCheck::compare(
        &Moments::of(&EnvMap::new(cube, want, "u").unwrap(), &IDENTITY),
        &Moments::of(&EnvMap::new(cube, got, "c").unwrap(), &IDENTITY),
    )
    .irradiance_error
    .unwrap()
}

#[test]
fn encoded_cubes_round_trip_through_ktx2_zstd_and_dds() {
    let tex = cube_chain(&hdri("studio.exr"), 32, 6);
    for e in [Encoding::Bc6h, Encoding::Rgb9e5] {
        let (k, rep) = encode(&tex, Format::Ktx2, e, None, CUBE_NOTE);
        let (kz, _) = encode(&tex, Format::Ktx2, e, Some(12), CUBE_NOTE);
        let (d, _) = encode(&tex, Format::Dds, e, None, CUBE_NOTE);
        assert_eq!(rep.as_ref().unwrap().len(), 6);
        // RGB9E5 compresses a little; BC6H blocks hardly do (Zstandard's frame costs a few
        // bytes).
        if e == Encoding::Rgb9e5 {
            assert!(
                kz.len() < k.len(),
                "{e:?}: zstd {} vs {}",
                kz.len(),
                k.len()
            );
        } else {
            assert!(
                kz.len() < k.len() + 64,
                "{e:?}: zstd {} vs {}",
                kz.len(),
                k.len()
            );
        }
        let lim = Default::default();
        let a = decode(Path::new("t.ktx2"), &k, &lim).unwrap();
        let b = decode(Path::new("z.ktx2"), &kz, &lim).unwrap();
        let c = decode(Path::new("t.dds"), &d, &lim).unwrap();
        assert!(a.cube && c.cube);
        assert_eq!(a, b, "{e:?}: zstd changes nothing but the size");
        assert_eq!(a, c, "{e:?}: KTX2 and DDS hold the same texels");
        for (l, src) in a.levels.iter().zip(&tex.levels) {
            assert_eq!((l.width, l.height, l.channels), (src.width, src.height, 3));
            assert!(l.data.iter().all(|v| v.is_finite() && *v >= 0.0));
        }
        // Sizes: BC6H 16 bytes per 4×4 block (a level under 4 texels takes one block), RGB9E5
        // 4 bytes per texel.
        let raw: usize = (0..6)
            .map(|i| {
                let n = (32usize >> i).max(1);
                6 * match e {
                    Encoding::Bc6h => n.div_ceil(4).pow(2) * 16,
                    _ => n * n * 4,
                }
            })
            .sum();
        assert!(
            k.len() > raw && k.len() < raw + 1024,
            "{e:?}: {} bytes",
            k.len()
        );
    }
}

#[test]
fn independent_readers_agree_with_spheremap() {
    let tex = cube_chain(&hdri("park.exr"), 16, 5);
    let lim = Default::default();
    for e in [Encoding::Bc6h, Encoding::Rgb9e5] {
        // image-rs's DDS decoder, surface by surface (face by face, each with its mips).
        let (d, _) = encode(&tex, Format::Dds, e, None, CUBE_NOTE);
        let ours = decode(Path::new("t.dds"), &d, &lim).unwrap();
        let mut dec = dds::Decoder::new(std::io::Cursor::new(&d)).unwrap();
        let want = match e {
            Encoding::Bc6h => dds::Format::BC6H_UF16,
            _ => dds::Format::R9G9B9E5_SHAREDEXP,
        };
        assert_eq!(dec.format(), want);
        assert!(dec.layout().is_cube_map());
        for f in 0..6 {
            for (i, l) in ours.levels.iter().enumerate() {
                let n = l.width;
                let mut buf = vec![0u8; n * n * 12];
                let view = dds::ImageViewMut::new(
                    &mut buf,
                    dds::Size::new(n as u32, n as u32),
                    dds::ColorFormat::RGB_F32,
                )
                .unwrap();
                dec.read_surface(view).unwrap();
                let theirs: Vec<f32> = buf
                    .chunks_exact(4)
                    .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
                    .collect();
                let mine = &l.data[f * n * n * 3..(f + 1) * n * n * 3];
                assert_eq!(mine, &theirs[..], "{e:?} face {f} level {i}");
            }
        }
        // The ktx2 crate's parser: format, supercompression, levels that inflate to the
        // texels spheremap reads.
        let (kz, _) = encode(&tex, Format::Ktx2, e, Some(5), CUBE_NOTE);
        let r = ktx2::Reader::new(&kz[..]).unwrap();
        let h = r.header();
        let fmt = match e {
            Encoding::Bc6h => ktx2::Format::BC6H_UFLOAT_BLOCK,
            _ => ktx2::Format::E5B9G9R9_UFLOAT_PACK32,
        };
        assert_eq!(h.format, Some(fmt));
        assert_eq!(
            h.supercompression_scheme,
            Some(ktx2::SupercompressionScheme::Zstandard)
        );
        assert_eq!((h.face_count, h.level_count, h.pixel_width), (6, 5, 16));
        let (dd, _) = encode(&tex, Format::Dds, e, None, CUBE_NOTE);
        for (i, level) in r.levels().enumerate() {
            let raw = zstd::bulk::decompress(level.data, 1 << 20).unwrap();
            assert_eq!(raw.len() as u64, level.uncompressed_byte_length);
            // The same bytes DDS stores for that level's faces (DDS: after its 148-byte
            // header, face by face, each with its mip chain).
            let surface = |j: usize| {
                let m = (16usize >> j).max(1);
                match e {
                    Encoding::Bc6h => m.div_ceil(4).pow(2) * 16,
                    _ => m * m * 4,
                }
            };
            let face = raw.len() / 6;
            assert_eq!(face, surface(i));
            for f in 0..6 {
                let at = 148
                    + f * (0..5).map(surface).sum::<usize>()
                    + (0..i).map(surface).sum::<usize>();
                assert_eq!(
                    &raw[f * face..(f + 1) * face],
                    &dd[at..at + face],
                    "{e:?} level {i} face {f}"
                );
            }
        }
    }
}

#[test]
fn rgb9e5_keeps_every_level_s_power_and_sh9() {
    // Maps with a small sun holding half the power, and without.
    for (name, sun) in [("studio.exr", None), ("sky.exr", Some((1.0, 0.5)))] {
        let src = with_sun(name, sun);
        let tex = cube_chain(&src, 64, 7);
        let (k, rep) = encode(&tex, Format::Ktx2, Encoding::Rgb9e5, None, CUBE_NOTE);
        let back = decode(Path::new("t.ktx2"), &k, &Default::default()).unwrap();
        // Against the level as it is (the bundled HDRIs' negative lobes folded, not clamped).
        let want = &tex;
        for (i, (l, w)) in back.levels.iter().zip(&want.levels).enumerate() {
            let (p, q) = (cube_power(l), cube_power(w));
            for k in 0..3 {
                assert!(
                    (p[k] / q[k] - 1.0).abs() < 5e-3,
                    "{name} level {i}: {p:?} vs {q:?}"
                );
                let r = rep.as_ref().unwrap()[i].power_error[k];
                assert!(
                    (r - (p[k] / q[k] - 1.0)).abs() < 1e-6,
                    "the report is the file's (up to the fold's f32 rounding)"
                );
            }
            let sh9 = sh9_error(w, l);
            assert!(sh9 < 0.01, "{name} level {i}: SH9 {sh9}");
        }
    }
}

#[test]
fn negative_lobes_beside_a_sun_keep_their_place_in_the_light() {
    // park.exr's sun (11,800) rings with blue lobes down to −1,876, as a resize leaves them;
    // its 256² and 128² cube levels keep lobes whose clamping would add 10 % and 5 % of the
    // blue power and move the SH9 irradiance by 44 % and 23 %.
    // An unsigned format cannot hold them: clamped to 0 they would add percents of the blue
    // power and move the irradiance; folded into their neighbours, the encoded levels keep
    // the source's power (within 0.5 %) and SH9 irradiance (within 1 %) against the source as
    // it is, negative lobes included.
    let tex = cube_chain(&hdri("park.exr"), 256, 2);
    for (i, l) in tex.levels.iter().enumerate() {
        // What clamping would do: the test can fail.
        let (p, q) = (cube_power(l), cube_power(&clamp_image(l, f32::MAX)));
        let clamp_gain = worst(&std::array::from_fn(|k| q[k] / p[k] - 1.0));
        assert!(clamp_gain > 0.02, "level {i}: clamping adds {clamp_gain}");
        assert!(sh9_error(l, &clamp_image(l, f32::MAX)) > 0.05);
    }
    for e in [Encoding::Bc6h, Encoding::Rgb9e5] {
        let (k, rep) = encode(&tex, Format::Ktx2, e, None, CUBE_NOTE);
        let back = decode(Path::new("t.ktx2"), &k, &Default::default()).unwrap();
        for (i, ((l, w), r)) in back
            .levels
            .iter()
            .zip(&tex.levels)
            .zip(rep.unwrap())
            .enumerate()
        {
            let (p, q) = (cube_power(l), cube_power(w));
            let err = worst(&std::array::from_fn(|c| p[c] / q[c] - 1.0));
            let sh9 = sh9_error(w, l);
            assert!(
                r.clamped > 0 && r.range_loss.iter().all(|x| x.abs() < 1e-6),
                "{r:?}"
            );
            assert!(
                err < 5e-3 && sh9 < 0.01,
                "{e:?} level {i}: power {err}, SH9 {sh9}"
            );
            assert!(l.data.iter().all(|v| v.is_finite() && *v >= 0.0));
        }
    }
}

#[test]
fn radiance_hdr_and_rgbd_move_negative_values_light_into_their_neighbours() {
    // A lat-long with a bright texel ringed by a negative lobe: Radiance HDR and RGBD hold no
    // negative value, and keep the map's power by taking the lobe from its neighbours.
    use spheremap::images::codec::{decode as decode_image, encode_with_note, ReadOptions};
    let ll = Mapping::parse("latlong", None).unwrap();
    let mut img = Image::new(16, 8, 3);
    img.data.fill(1.0);
    img.pixel_mut(5, 3).copy_from_slice(&[100.0, 80.0, 60.0]);
    img.pixel_mut(6, 3).copy_from_slice(&[-20.0, -10.0, 1.0]);
    let w = texel_weights(Some(ll), false, 16, 8);
    let power = |i: &Image| -> [f64; 3] {
        let mut p = [0.0; 3];
        for (t, px) in i.data.chunks_exact(3).enumerate() {
            (0..3).for_each(|k| p[k] += px[k] as f64 * w[t]);
        }
        p
    };
    let note = "mapping=latlong preset=blender";
    for (name, format, encode) in [
        ("o.hdr", Format::Hdr, Encoding::Float),
        ("o.png", Format::Png, Encoding::Rgbd),
    ] {
        let opts = WriteOptions {
            encode,
            ..Default::default()
        };
        let bytes = encode_with_note(Path::new(name), &img, format, &opts, Some(note)).unwrap();
        // (the PNG's note names its packing: read back unpacked)
        let back = decode_image(Path::new(name), &bytes, &ReadOptions::default()).unwrap();
        assert!(back.data.iter().all(|v| *v >= 0.0));
        let (p, q) = (power(&back), power(&img));
        // Both formats round each texel (8-bit mantissas): within 1 %; clamping the lobe to
        // 0 would add about 12 % of the red power.
        let err = worst(&std::array::from_fn(|k| p[k] / q[k] - 1.0));
        assert!(err < 1e-2, "{name}: {p:?} vs {q:?}");
        assert!(
            back.pixel(6, 3)[0] < 0.5 && back.pixel(5, 3)[0] < 95.0,
            "{name}"
        );
    }
}

/// The largest |error| over the channels.
fn worst(e: &[f64; 3]) -> f64 {
    e.iter().fold(0f64, |a, x| a.max(x.abs()))
}

#[test]
fn bc6h_repair_keeps_every_level_s_power_and_sh9() {
    // Each level's power against the uncompressed level's, down to faces of one texel: within
    // 0.5 % per channel, and its SH9 irradiance within 1 % for faces of 8² and more, where the
    // encoder alone is off by up to 13 %; on a studio and on a sky with a 1° sun holding half
    // the power.
    for (name, sun) in [("studio.exr", None), ("sky.exr", Some((1.0, 0.5)))] {
        let src = with_sun(name, sun);
        let tex = cube_chain(&src, 64, 7);
        let (k, rep) = encode(&tex, Format::Ktx2, Encoding::Bc6h, None, CUBE_NOTE);
        let rep = rep.unwrap();
        let back = decode(Path::new("t.ktx2"), &k, &Default::default()).unwrap();
        // Against the level as it is (the bundled HDRIs' negative lobes folded, not clamped).
        let want = &tex;
        let mut worst_alone = 0f64;
        for (i, ((l, w), r)) in back.levels.iter().zip(&want.levels).zip(&rep).enumerate() {
            let (p, q) = (cube_power(l), cube_power(w));
            for k in 0..3 {
                let err = p[k] / q[k] - 1.0;
                assert!(
                    (err - r.power_error[k]).abs() < 1e-6,
                    "the report is the file's (up to the fold's f32 rounding)"
                );
            }
            assert!(worst(&r.power_error) < 5e-3, "{name} level {i}: {r:?}");
            // A face of one block (4² and 2²) holds the block's power, not where in the block
            // it sits: its SH9 misses by up to 3 % (measured: 1.1–2.7 %).
            let sh_bound = if l.width >= 8 { 0.01 } else { 0.03 };
            let sh9 = sh9_error(w, l);
            assert!(sh9 < sh_bound, "{name} level {i}: SH9 {sh9}");
            worst_alone = worst_alone.max(worst(&r.power_error_unrepaired));
            assert!(r.rmsle < 0.1, "{name} level {i}: {r:?}");
            assert!(l.data.iter().all(|v| v.is_finite() && *v >= 0.0));
        }
        assert!(
            worst_alone > 5e-3,
            "{name}: the encoder alone leaks here ({worst_alone})"
        );
    }
}

#[test]
fn out_of_range_values_are_clamped_with_their_power_stated_and_nan_refused() {
    let mut img = Image::new(8, 4, 3);
    img.data.fill(1.0);
    img.data[..3].fill(2e5); // a white texel beyond the range
    img.data[(3 * 8 + 7) * 3 + 1] = -1.0; // G negative, at the far corner
    let tex = Texture {
        cube: false,
        levels: vec![img.clone()],
    };
    for e in [Encoding::Bc6h, Encoding::Rgb9e5] {
        let (_, rep) = encode(
            &tex,
            Format::Ktx2,
            e,
            None,
            "mapping=latlong preset=blender",
        );
        // Both values' light is moved into their neighbours: the power holds.
        let r = &rep.unwrap()[0];
        assert_eq!(r.clamped, 4);
        assert!(r.range_loss.iter().all(|l| l.abs() < 1e-6), "{r:?}");
        assert!(worst(&r.power_error) < 5e-3, "{r:?}");
        // A map at the top of the range everywhere: no neighbour can take the excess, so it
        // is clamped and the power it loses stated.
        let mut full = Image::new(8, 4, 3);
        full.data.fill(65000.0);
        full.data[0] = 2e5;
        let (_, rep) = encode(
            &Texture {
                cube: false,
                levels: vec![full],
            },
            Format::Ktx2,
            e,
            None,
            "mapping=latlong preset=blender",
        );
        let r = &rep.unwrap()[0];
        assert_eq!(r.clamped, 1, "{r:?}");
        assert!(r.range_loss[0] < -0.01 && r.range_loss[1] == 0.0, "{r:?}");
    }
    let mut bad = img;
    bad.data[7] = f32::NAN;
    let err = encode_texture(
        Path::new("o.ktx2"),
        &Texture {
            cube: false,
            levels: vec![bad],
        },
        Format::Ktx2,
        &WriteOptions {
            encode: Encoding::Bc6h,
            ..Default::default()
        },
        None,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("NaN") && err.contains("o.ktx2"), "{err}");
    // Options the format has no place for.
    let t = Texture {
        cube: false,
        levels: vec![Image::new(4, 4, 3)],
    };
    let opts = |encode, zstd| WriteOptions {
        encode,
        zstd,
        ..Default::default()
    };
    let e = |f, o: WriteOptions| {
        encode_texture(Path::new("o.x"), &t, f, &o, None)
            .unwrap_err()
            .to_string()
    };
    assert!(e(Format::Dds, opts(Encoding::Float, Some(3))).contains("KTX2 only"));
    assert!(e(Format::Ktx2, opts(Encoding::Float, Some(30))).contains("1 to 22"));
    let exr = spheremap::images::codec::encode(
        Path::new("o.exr"),
        &Image::new(4, 4, 3),
        Format::Exr,
        &opts(Encoding::Bc6h, None),
    )
    .unwrap_err()
    .to_string();
    assert!(exr.contains("KTX2 or DDS"), "{exr}");
}

#[test]
fn a_2d_map_is_weighed_by_its_mapping_s_solid_angles() {
    // A lat-long's texels near the poles hold little solid angle: its power is Σ L·Ω with the
    // lat-long's Ω, which the report's errors are relative to.
    let src = hdri("sky.exr");
    let ll = Mapping::parse("latlong", None).unwrap();
    let env = EnvMap::new(ll, &src, "src").unwrap();
    let (img, _) = resample(&env, ll, 128, 64, &ResampleOptions::default(), None).unwrap();
    let tex = Texture {
        cube: false,
        levels: vec![img.clone()],
    };
    let (k, rep) = encode(
        &tex,
        Format::Ktx2,
        Encoding::Bc6h,
        Some(3),
        "mapping=latlong preset=blender",
    );
    let back = decode(Path::new("t.ktx2"), &k, &Default::default()).unwrap();
    let w = texel_weights(Some(ll), false, 128, 64);
    let pw = |i: &Image| {
        let mut p = [0.0; 3];
        for (t, px) in i.data.chunks_exact(3).enumerate() {
            for k in 0..3 {
                p[k] += px[k] as f64 * w[t];
            }
        }
        p
    };
    let (p, q) = (pw(&back.levels[0]), pw(&img));
    let r = &rep.unwrap()[0];
    for k in 0..3 {
        assert!(((p[k] / q[k] - 1.0) - r.power_error[k]).abs() < 1e-6);
    }
    assert!(worst(&r.power_error) < 1e-2, "{r:?}");
    assert!(
        worst(&r.power_error) <= worst(&r.power_error_unrepaired) + 1e-3,
        "{r:?}"
    );
}

#[test]
fn rgbd_and_rgbm_pack_as_babylon_and_three_read_them() {
    use spheremap::images::compress::{rgbd_pack, rgbd_unpack, rgbm_pack, rgbm_unpack};
    // Babylon.js's toRGBD: D = floor(max(255 / max, 1)) / 255, rgb = (rgb · D)^(1/2.2).
    assert_eq!(rgbd_pack([1.0, 0.5, 0.25]), [255, 186, 136, 255]);
    assert_eq!(rgbd_pack([100.0, 50.0, 0.0]), [228, 167, 0, 2]);
    assert_eq!(rgbd_pack([0.01, 0.02, 0.03]), [31, 43, 52, 255]);
    // fromRGBD: rgb^2.2 / D.
    let back = rgbd_unpack([228, 167, 0, 2]);
    assert!(
        (back[0] - 127.5 * (228f32 / 255.0).powf(2.2)).abs() < 1e-3,
        "{back:?}"
    );
    // three.js's RGBM (RGBMLoader reads r · a · maxRange): M = ceil(max / 7 · 255).
    assert_eq!(rgbm_pack([1.0, 0.5, 0.25], 7.0), [251, 126, 63, 37]);
    assert_eq!(
        rgbm_unpack([251, 126, 63, 37], 7.0)[0],
        251.0 / 255.0 * (37.0 / 255.0) * 7.0
    );
    assert_eq!(rgbm_pack([0.0; 3], 7.0), [0; 4]);
}

#[test]
fn packed_pngs_round_trip_and_keep_the_light_within_their_range() {
    use spheremap::images::codec::{read_image, write_image_with_note};
    let ll = Mapping::parse("latlong", None).unwrap();
    let src = hdri("city.exr");
    let env = EnvMap::new(ll, &src, "src").unwrap();
    let (img, _) = resample(&env, ll, 256, 128, &ResampleOptions::default(), None).unwrap();
    let dir = std::env::temp_dir().join(format!("spheremap_packed_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let note = "mapping=latlong preset=blender";
    let w = texel_weights(Some(ll), false, 256, 128);
    let power = |i: &Image, max: f32| {
        let mut p = [0.0; 3];
        for (t, px) in i.data.chunks_exact(i.channels).enumerate() {
            for k in 0..3 {
                p[k] += px[k].clamp(0.0, max) as f64 * w[t];
            }
        }
        p
    };
    for (e, range) in [(Encoding::Rgbd, 255.0), (Encoding::Rgbm, 7.0)] {
        // Scaled into the packing's range: what is left is the 8-bit quantisation.
        let peak = img.data.iter().copied().fold(0f32, f32::max);
        let mut scaled = img.clone();
        for v in &mut scaled.data {
            *v = v.max(0.0) * (0.9 * range / peak);
        }
        let path = dir.join(format!("m_{}.png", e.name()));
        let opts = WriteOptions {
            encode: e,
            ..Default::default()
        };
        write_image_with_note(&path, &scaled, &opts, Some(note)).unwrap();
        let back = read_image(&path, &Default::default()).unwrap();
        assert_eq!((back.width, back.height, back.channels), (256, 128, 3));
        let (p, q) = (power(&back, f32::MAX), power(&scaled, range));
        for k in 0..3 {
            assert!((p[k] / q[k] - 1.0).abs() < 5e-3, "{e:?}: {p:?} vs {q:?}");
        }
        let note_back = spheremap::images::note::read_file(&path).unwrap().unwrap();
        assert!(
            note_back.contains("mapping=latlong") && note_back.contains(e.name()),
            "{note_back}"
        );
        // Anywhere but PNG, the packing is refused.
        let err = spheremap::images::codec::write_image(&dir.join("x.exr"), &scaled, &opts)
            .unwrap_err()
            .to_string();
        assert!(err.contains("written in PNG"), "{err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A UASTC HDR 4x4 cube (faces of 16², 2 levels, Zstandard) written by spheremap with Basis
/// Universal 2.50's encoder: read without the encoder.
const UASTC_CUBE: &str = "uastc_hdr_cube.ktx2";

#[test]
fn uastc_hdr_files_are_read_without_the_encoder() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../testdata")
        .join(UASTC_CUBE);
    let tex = spheremap::images::codec::read_texture(&p, &Default::default()).unwrap();
    assert!(tex.cube);
    assert_eq!(tex.levels.len(), 2);
    assert_eq!(
        (
            tex.levels[0].width,
            tex.levels[0].height,
            tex.levels[0].channels
        ),
        (16, 96, 3)
    );
    assert!(tex
        .levels
        .iter()
        .all(|l| l.data.iter().all(|v| v.is_finite() && *v >= 0.0)));
    // What the file holds: the studio HDRI's cube (to UASTC HDR's precision: its encoder
    // alone misses the power of these small levels by up to 11 %).
    let want = cube_chain(&hdri("studio.exr"), 16, 2);
    for (l, w) in tex.levels.iter().zip(&want.levels) {
        let w = clamp_image(w, 65216.0);
        let (p, q) = (cube_power(l), cube_power(&w));
        for k in 0..3 {
            assert!((p[k] / q[k] - 1.0).abs() < 0.15, "{p:?} vs {q:?}");
        }
        let n = l.data.len() as f64;
        let rmsle = (l
            .data
            .iter()
            .zip(&w.data)
            .map(|(a, b)| ((*a as f64).ln_1p() - (*b as f64).ln_1p()).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        assert!(rmsle < 0.05, "{rmsle}");
    }
}

#[cfg(not(feature = "basisu"))]
#[test]
fn without_the_basisu_feature_the_encoder_is_refused_by_name() {
    let tex = cube_chain(&hdri("studio.exr"), 8, 1);
    let opts = WriteOptions {
        encode: Encoding::UastcHdr4x4,
        ..Default::default()
    };
    let err = encode_texture(
        Path::new("u.ktx2"),
        &tex,
        Format::Ktx2,
        &opts,
        Some(CUBE_NOTE),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("basisu") && err.contains("libclang"), "{err}");
}

#[cfg(feature = "basisu")]
#[test]
fn uastc_and_astc_hdr_round_trip_and_basis_universal_s_own_transcoder_agrees() {
    use basisu_c_sys::extra::{
        basisu_transcoder_init, BasisuTranscoder, ChannelType, SupportedTextureCompression,
    };
    basisu_transcoder_init();
    if std::env::var("SPHEREMAP_UPDATE_TESTDATA").is_ok() {
        let small = cube_chain(&hdri("studio.exr"), 16, 2);
        let (k, _) = encode(
            &small,
            Format::Ktx2,
            Encoding::UastcHdr4x4,
            Some(19),
            CUBE_NOTE,
        );
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../testdata")
            .join(UASTC_CUBE);
        std::fs::write(p, k).unwrap();
    }
    let tex = cube_chain(&hdri("studio.exr"), 32, 6);
    for e in [Encoding::UastcHdr4x4, Encoding::AstcHdr6x6] {
        for zstd in [None, Some(9)] {
            let (k, rep) = encode(&tex, Format::Ktx2, e, zstd, CUBE_NOTE);
            let rep = rep.unwrap();
            let ours = decode(Path::new("u.ktx2"), &k, &Default::default()).unwrap();
            assert!(ours.cube && ours.levels.len() == 6);
            // The ktx2 crate's parser.
            let r = ktx2::Reader::new(&k[..]).unwrap();
            let fmt = match e {
                Encoding::UastcHdr4x4 => ktx2::Format::ASTC_4x4_SFLOAT_BLOCK,
                _ => ktx2::Format::ASTC_6x6_SFLOAT_BLOCK,
            };
            assert_eq!(r.header().format, Some(fmt));
            assert_eq!(r.header().level_count, 6);
            // Basis Universal's C++ transcoder reads the whole chain to the same half floats
            // as the pure-Rust one spheremap reads with.
            let t =
                BasisuTranscoder::new(&k, SupportedTextureCompression::empty(), ChannelType::Auto)
                    .unwrap();
            let info = t.get_info();
            assert_eq!((info.levels, info.faces, info.width), (6, 6, 32));
            let img = t
                .transcode(
                    Some(basisu_c_sys::TranscodeTargetFormat::RgbaHalf),
                    Some(false),
                )
                .unwrap();
            let mut at = 0;
            for l in &ours.levels {
                for px in l.data.chunks_exact(3) {
                    for (c, v) in px.iter().enumerate() {
                        let h = exr::prelude::f16::from_le_bytes([
                            img.data[at + 2 * c],
                            img.data[at + 2 * c + 1],
                        ]);
                        assert_eq!(h.to_f32(), *v);
                    }
                    at += 8;
                }
            }
            assert_eq!(at, img.data.len());
            for (i, (r, (l, w))) in rep
                .iter()
                .zip(ours.levels.iter().zip(&tex.levels))
                .enumerate()
            {
                let (p, q) = (cube_power(l), cube_power(w));
                for c in 0..3 {
                    assert!(
                        ((p[c] / q[c] - 1.0) - r.power_error[c]).abs() < 1e-6,
                        "the report is the file's"
                    );
                }
                println!(
                    "{e:?} zstd {zstd:?} level {i}: {:?} (alone {:?}) rmsle {:.4}",
                    r.power_error, r.power_error_unrepaired, r.rmsle
                );
                assert!(
                    worst(&r.power_error) <= worst(&r.power_error_unrepaired) + 1e-9,
                    "{r:?}"
                );
            }
        }
    }
}

#[cfg(feature = "basisu")]
#[test]
fn uastc_and_astc_hdr_repair_keeps_every_level_s_power() {
    // Each level's power against the uncompressed level's, down to faces of one texel, where
    // Basis Universal's encoder alone misses by up to 27 %, on a studio and on a sky with a 1°
    // sun holding half the power: UASTC HDR 4x4 within 0.5 % everywhere; ASTC HDR 6x6 within
    // 0.5 % where a face holds 16 blocks or more and within 1 % below (on a face of nine 6×6
    // blocks or fewer a constant block would move its sun's light further than the miss
    // does; measured up to 0.75 %).
    // SH9 irradiance: within 1 % for UASTC HDR 4x4 at faces of 32² and more (measured up to
    // 0.63 %), 2 % at 16² (1.7 %), 15 % below; within 8 % for ASTC HDR 6x6 at faces of 16² and
    // more (measured up to 5.4 %). Basis Universal's C++ transcoder turns the repaired blocks into the BC6H a GPU
    // without ASTC is given (three.js's path on desktop GPUs): UASTC HDR 4x4 within 5 % of the
    // file's power (its own transcoding loss, measured up to 4.4 %).
    use basisu_c_sys::extra::{
        basisu_transcoder_init, BasisuTranscoder, ChannelType, SupportedTextureCompression,
    };
    use spheremap::images::compress::bc6h_decode_block;
    basisu_transcoder_init();
    for (name, sun) in [("studio.exr", None), ("sky.exr", Some((1.0, 0.5)))] {
        let src = with_sun(name, sun);
        let tex = cube_chain(&src, 32, 6);
        for e in [Encoding::UastcHdr4x4, Encoding::AstcHdr6x6] {
            let uastc = e == Encoding::UastcHdr4x4;
            let side = if uastc { 4 } else { 6 };
            let (k, rep) = encode(&tex, Format::Ktx2, e, None, CUBE_NOTE);
            let rep = rep.unwrap();
            let back = decode(Path::new("t.ktx2"), &k, &Default::default()).unwrap();
            // Against the level as it is (the bundled HDRIs' negative lobes folded, not clamped).
            let want = &tex;
            let t =
                BasisuTranscoder::new(&k, SupportedTextureCompression::empty(), ChannelType::Auto)
                    .unwrap();
            let bc6h = t
                .transcode(Some(basisu_c_sys::TranscodeTargetFormat::Bc6H), Some(false))
                .unwrap()
                .data;
            let mut at = 0;
            let mut worst_alone = 0f64;
            for (i, ((l, w), r)) in back.levels.iter().zip(&want.levels).zip(&rep).enumerate() {
                let n = l.width;
                let (p, q) = (cube_power(l), cube_power(w));
                for c in 0..3 {
                    let err = p[c] / q[c] - 1.0;
                    assert!(
                        (err - r.power_error[c]).abs() < 1e-6,
                        "the report is the file's (up to the fold's f32 rounding)"
                    );
                }
                let at_level = format!("{name} {e:?} level {i} ({n}²): {r:?}");
                let many_blocks = n.div_ceil(side).pow(2) >= 16;
                let bound = if uastc || many_blocks { 5e-3 } else { 1e-2 };
                assert!(worst(&r.power_error) < bound, "{at_level}");
                assert!(
                    worst(&r.power_error) <= worst(&r.power_error_unrepaired) + 1e-9,
                    "{at_level}"
                );
                worst_alone = worst_alone.max(worst(&r.power_error_unrepaired));
                let sh9 = sh9_error(w, l);
                let sh_bound = match (uastc, n) {
                    (true, 32..) => 0.01,
                    (true, 16..) => 0.02,
                    (true, _) => 0.15,
                    (false, 16..) => 0.08,
                    (false, _) => f64::INFINITY,
                };
                assert!(sh9 < sh_bound, "{at_level}: SH9 {sh9}");
                assert!(l.data.iter().all(|v| v.is_finite() && *v >= 0.0));
                // The level as BC6H, transcoded by Basis Universal.
                let nb = n.div_ceil(4);
                let mut t = Image::new(n, 6 * n, 3);
                for f in 0..6 {
                    for b in 0..nb * nb {
                        let px = bc6h_decode_block(&bc6h[at..at + 16]);
                        at += 16;
                        for (j, v) in px.iter().enumerate() {
                            let (x, y) = ((b % nb) * 4 + j % 4, (b / nb) * 4 + j / 4);
                            if x < n && y < n {
                                t.pixel_mut(x, f * n + y).copy_from_slice(v);
                            }
                        }
                    }
                }
                assert!(t.data.iter().all(|v| v.is_finite() && *v >= 0.0));
                let tp = cube_power(&t);
                let via_bc6h = worst(&std::array::from_fn(|c| tp[c] / p[c] - 1.0));
                if uastc {
                    assert!(via_bc6h < 0.05, "{at_level}: as BC6H {via_bc6h}");
                }
                println!(
                    "{name} {e:?} level {i} ({n}²): power {:?} (alone {:?}), SH9 {sh9:.4}, \
                     rmsle {:.4} (alone {:.4}), transcoded to BC6H {via_bc6h:.4}",
                    r.power_error, r.power_error_unrepaired, r.rmsle, r.rmsle_unrepaired
                );
            }
            assert_eq!(at, bc6h.len());
            assert!(
                worst_alone > 5e-3,
                "{name} {e:?}: the encoder alone leaks here ({worst_alone})"
            );
        }
    }
}

/// Warnings the core gave, for the tests that look for one.
#[cfg(feature = "basisu")]
static WARNINGS: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

#[cfg(feature = "basisu")]
fn keep_warning(w: &str) {
    WARNINGS.lock().unwrap().push(w.to_string());
}

#[cfg(feature = "basisu")]
#[test]
fn a_level_the_repair_cannot_hold_is_written_with_a_warning_that_states_its_error() {
    use spheremap::images::compress::LEVEL_GOAL;
    // ASTC HDR 6x6 cannot hold a 0.5° sun holding 90 % of the power on a 16² face: its
    // endpoints move the sun's block by several percent (docs/lighting.md).
    let tex = cube_chain(&with_sun("park.exr", Some((0.5, 0.9))), 16, 1);
    spheremap::base::error::set_warning_sink(Some(keep_warning));
    let (_, rep) = encode(&tex, Format::Ktx2, Encoding::AstcHdr6x6, None, CUBE_NOTE);
    let said: Vec<String> = WARNINGS
        .lock()
        .unwrap()
        .iter()
        .filter(|w| w.starts_with("t.ktx2: level 0: astc-hdr-6x6 keeps"))
        .cloned()
        .collect();
    let r = &rep.unwrap()[0];
    assert!(worst(&r.power_error) > LEVEL_GOAL, "{r:?}");
    assert_eq!(said.len(), 1, "{said:?}");
    let pct = format!("{:+.2} %", 100.0 * r.power_error[1]);
    assert!(
        said[0].contains(&pct) && said[0].contains("uastc-hdr-4x4 or bc6h"),
        "{said:?}"
    );
    // BC6H holds the same level.
    let (_, rep) = encode(&tex, Format::Ktx2, Encoding::Bc6h, None, CUBE_NOTE);
    assert!(worst(&rep.unwrap()[0].power_error) <= LEVEL_GOAL);
}
