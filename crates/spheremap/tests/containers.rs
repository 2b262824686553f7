//! KTX2 and DDS files spheremap writes, opened by readers it did not write (the `ktx2` and
//! `ddsfile` crates): the header fields, the data format descriptor, the key/value data, every
//! level, and the cube faces where each format's specification puts them, pinned by directions.

use spheremap::images::codec::{read_texture, write_texture, ReadOptions, WriteOptions};
use spheremap::images::container::Texture;
use spheremap::images::Image;
use spheremap::jobs::env_job::EnvJob;
use spheremap::jobs::prefilter::PrefilterRequest;

/// A lat-long map whose radiance is 2 + the direction (x, y, z), in the default preset.
fn direction_map(w: usize, h: usize) -> Image {
    let m = spheremap::mappings::mapping::Mapping::parse("latlong", None).unwrap();
    let mut img = Image::new(w, h, 3);
    for j in 0..h {
        for i in 0..w {
            let uv = [(i as f64 + 0.5) / w as f64, (j as f64 + 0.5) / h as f64];
            let d = m.uv_to_dir(uv).unwrap();
            let p = img.pixel_mut(i, j);
            for k in 0..3 {
                p[k] = (2.0 + d[k]) as f32;
            }
        }
    }
    img
}

/// The direction of texel (i, j) of face `face` of F, from the cube-map table of the OpenGL 4.6
/// specification (Table 8.19), which KTX, Vulkan and Direct3D share: faces +X, −X, +Y, −Y, +Z,
/// −Z; s = (sc/|ma| + 1)/2 to the right, t = (tc/|ma| + 1)/2 down (row 0 is t = 0).
fn spec_direction(face: usize, i: usize, j: usize, f: usize) -> [f64; 3] {
    let sc = 2.0 * (i as f64 + 0.5) / f as f64 - 1.0;
    let tc = 2.0 * (j as f64 + 0.5) / f as f64 - 1.0;
    let d = match face {
        0 => [1.0, -tc, -sc],
        1 => [-1.0, -tc, sc],
        2 => [sc, 1.0, tc],
        3 => [sc, -1.0, -tc],
        4 => [sc, -tc, 1.0],
        _ => [-sc, -tc, -1.0],
    };
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|v| v / l)
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("spheremap-containers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn f16s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(2)
        .map(|c| exr::prelude::f16::from_le_bytes([c[0], c[1]]).to_f32())
        .collect()
}

fn f32s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

/// The mirror level of a cube chain from the direction map: faces of F, `levels` levels.
fn cube_chain(f: usize, levels: usize) -> Vec<Image> {
    let req = PrefilterRequest {
        size: Some(f),
        levels: Some(levels),
        samples: 1,
        ..Default::default()
    };
    req.run_image(&direction_map(256, 128), None)
        .unwrap()
        .into_iter()
        .map(|(i, _)| i)
        .collect()
}

/// Checks RGBA texels `px` of face `face` (F×F, row-major) against 2 + the spec's directions.
fn check_face(px: &[f32], face: usize, f: usize, tol: f64, what: &str) {
    let mut worst: f64 = 0.0;
    for j in 0..f {
        for i in 0..f {
            let d = spec_direction(face, i, j, f);
            let p = &px[(j * f + i) * 4..][..4];
            for k in 0..3 {
                worst = worst.max((p[k] as f64 - 2.0 - d[k]).abs());
            }
            assert_eq!(p[3], 1.0, "{what}: alpha");
        }
    }
    assert!(
        worst < tol,
        "{what}: face {face} is {worst} off the spec's directions"
    );
}

#[test]
fn cube_ktx2_opened_by_the_ktx2_crate_has_the_faces_where_the_spec_says() {
    let f = 32;
    let levels = cube_chain(f, 3);
    for half in [false, true] {
        let path = tmp(&format!("cube{half}.ktx2"));
        let tex = Texture {
            cube: true,
            levels: levels.clone(),
        };
        let opts = WriteOptions {
            half,
            ..Default::default()
        };
        write_texture(
            &path,
            &tex,
            &opts,
            Some("mapping=cube preset=gl layout=vstrip"),
        )
        .unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let r = ktx2::Reader::new(&bytes[..]).expect("the ktx2 crate reads it");
        let h = r.header();
        let want = if half {
            ktx2::Format::R16G16B16A16_SFLOAT
        } else {
            ktx2::Format::R32G32B32A32_SFLOAT
        };
        assert_eq!(h.format, Some(want));
        assert_eq!((h.pixel_width, h.pixel_height, h.pixel_depth), (32, 32, 0));
        assert_eq!((h.face_count, h.level_count, h.layer_count), (6, 3, 0));
        assert_eq!(h.supercompression_scheme, None);
        let kv: Vec<(String, Vec<u8>)> = r
            .key_value_data()
            .map(|(k, v)| (k.to_string(), v.to_vec()))
            .collect();
        assert!(kv
            .iter()
            .any(|(k, v)| k == "KTXorientation" && v.starts_with(b"rd")));
        assert!(kv.iter().any(|(k, _)| k == "KTXwriter"));
        // The data format descriptor: one basic block, RGBSDA, linear, four float samples.
        let blocks: Vec<_> = r.dfd_blocks().collect();
        assert_eq!(blocks.len(), 1);
        let basic = ktx2::DfdBlockBasic::parse(blocks[0].data).unwrap();
        assert_eq!(basic.header.color_model, Some(ktx2::ColorModel::RGBSDA));
        assert_eq!(
            basic.header.transfer_function,
            Some(ktx2::TransferFunction::Linear)
        );
        assert_eq!(basic.header.bytes_planes[0], if half { 8 } else { 16 });
        let samples: Vec<_> = basic.sample_information().collect();
        assert_eq!(samples.len(), 4);
        assert_eq!(
            samples.iter().map(|s| s.channel_type).collect::<Vec<_>>(),
            vec![0, 1, 2, 15]
        );
        for s in &samples {
            let q = s.channel_type_qualifiers;
            assert!(q.contains(ktx2::ChannelTypeQualifiers::FLOAT));
            assert!(q.contains(ktx2::ChannelTypeQualifiers::SIGNED));
        }
        for (li, level) in r.levels().enumerate() {
            let lf = f >> li;
            let px = if half {
                f16s(level.data)
            } else {
                f32s(level.data)
            };
            assert_eq!(px.len(), 6 * lf * lf * 4, "level {li}");
            if li == 0 {
                for face in 0..6 {
                    check_face(&px[face * lf * lf * 4..], face, lf, 0.02, "ktx2");
                }
            }
            // Every level is what was written.
            let want = &levels[li];
            for (p, w) in px.chunks_exact(4).zip(want.data.chunks_exact(3)) {
                for (a, b) in p.iter().zip(w) {
                    assert!((a - b).abs() <= 1e-3 * b.abs().max(1.0), "level {li}");
                }
            }
        }
    }
}

#[test]
fn cube_dds_opened_by_ddsfile_has_the_faces_where_the_spec_says() {
    let f = 16;
    let levels = cube_chain(f, 2);
    for half in [false, true] {
        let path = tmp(&format!("cube{half}.dds"));
        let tex = Texture {
            cube: true,
            levels: levels.clone(),
        };
        let opts = WriteOptions {
            half,
            ..Default::default()
        };
        write_texture(&path, &tex, &opts, None).unwrap();
        let dds = ddsfile::Dds::read(std::fs::File::open(&path).unwrap()).unwrap();
        let want = if half {
            ddsfile::DxgiFormat::R16G16B16A16_Float
        } else {
            ddsfile::DxgiFormat::R32G32B32A32_Float
        };
        assert_eq!(dds.get_dxgi_format(), Some(want));
        assert_eq!((dds.get_width(), dds.get_height()), (16, 16));
        assert_eq!(dds.get_num_mipmap_levels(), 2);
        let h10 = dds.header10.as_ref().expect("a DX10 header");
        assert!(h10.misc_flag.contains(ddsfile::MiscFlag::TEXTURECUBE));
        assert_eq!(
            h10.resource_dimension,
            ddsfile::D3D10ResourceDimension::Texture2D
        );
        assert!(dds
            .header
            .caps2
            .contains(ddsfile::Caps2::CUBEMAP | ddsfile::Caps2::CUBEMAP_ALLFACES));
        // Face by face, each with its mip chain: the first F×F texels of each face's data are
        // its level 0.
        let tb = if half { 8 } else { 16 };
        let face_bytes = (16 * 16 + 8 * 8) * tb;
        assert_eq!(dds.data.len(), 6 * face_bytes);
        for face in 0..6 {
            let raw = &dds.data[face * face_bytes..][..16 * 16 * tb];
            let px = if half { f16s(raw) } else { f32s(raw) };
            check_face(&px, face, 16, 0.02, "dds");
        }
    }
}

#[test]
fn latlong_ktx2_chain_reads_back_through_convert() {
    // A 2D mip chain of a lat-long: row 0 at the top (up), read back by spheremap's reader and
    // by the ktx2 crate.
    let dir = tmp("chain");
    std::fs::create_dir_all(&dir).unwrap();
    let env = dir.join("env.exr");
    let latlong = spheremap::mappings::mapping::Mapping::parse("latlong", None).unwrap();
    let note = format!("mapping=latlong preset={}", latlong.preset_name());
    spheremap::images::codec::write_image_with_note(
        &env,
        &direction_map(128, 64),
        &Default::default(),
        Some(&note),
    )
    .unwrap();
    let out = dir.join("pre.ktx2");
    let req = PrefilterRequest {
        to: "latlong".into(),
        size: Some(32),
        levels: Some(3),
        samples: 1,
        ..Default::default()
    };
    let (rep, _) = req
        .run_files(
            env.to_str().unwrap(),
            out.to_str().unwrap(),
            &Default::default(),
            false,
            None,
        )
        .unwrap();
    assert_eq!(rep.levels.len(), 3);
    let tex = read_texture(&out, &ReadOptions::default()).unwrap();
    assert!(!tex.cube);
    assert_eq!(
        tex.levels
            .iter()
            .map(|l| (l.width, l.height))
            .collect::<Vec<_>>(),
        vec![(64, 32), (32, 16), (16, 8)]
    );
    // The top row is up (+Y): 2 + y ≈ 3 in the green channel.
    let top = tex.levels[0].pixel(32, 0);
    assert!((top[1] - 3.0).abs() < 0.01, "{top:?}");
    let bytes = std::fs::read(&out).unwrap();
    let r = ktx2::Reader::new(&bytes[..]).unwrap();
    assert_eq!(r.header().face_count, 1);
    assert_eq!(r.levels().count(), 3);
    // The note: convert reads the file as the lat-long it is, without --from.
    let note = spheremap::images::envmap::read_note(out.to_str().unwrap())
        .unwrap()
        .unwrap();
    assert_eq!(note.mapping.name(), "latlong");
    // And a cube file reads as a cube's face stack.
    let cube = dir.join("c.dds");
    let req = PrefilterRequest {
        size: Some(8),
        levels: Some(1),
        samples: 1,
        ..Default::default()
    };
    req.run_files(
        env.to_str().unwrap(),
        cube.to_str().unwrap(),
        &Default::default(),
        false,
        None,
    )
    .unwrap();
    let note = spheremap::images::envmap::read_note(cube.to_str().unwrap())
        .unwrap()
        .unwrap();
    assert_eq!(note.mapping.name(), "cube");
    let img = spheremap::images::codec::read_image(&cube, &ReadOptions::default()).unwrap();
    assert_eq!((img.width, img.height, img.channels), (8, 48, 4));
    // A conversion that keeps the cube (its note's layout, the face stack) writes a cube
    // texture again.
    let again = dir.join("again.ktx2");
    let job = spheremap::jobs::convert::ConvertJob {
        size: Some(4),
        ..Default::default()
    };
    job.run_files(
        &[
            cube.to_str().unwrap().to_string(),
            again.to_str().unwrap().to_string(),
        ],
        None,
    )
    .unwrap();
    let tex = read_texture(&again, &ReadOptions::default()).unwrap();
    assert!(tex.cube && tex.levels[0].width == 4);
}
