//! Environment maps in files: the naming of six cube faces (patterns and named files), how a
//! conversion's positional paths split into input and output, and writes that leave nothing
//! behind when any file fails.
mod common;
use spheremap::frame::view::IDENTITY;
use spheremap::images::codec::{NonFinite, ReadOptions, WriteOptions};
use spheremap::images::cube_layout::face_paths;
use spheremap::images::envmap::{
    check_nonfinite_env, read_env_files, split_paths, write_env_files, EnvFiles,
};
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

#[test]
fn every_face_token_names_the_six_faces_in_gl_order() {
    let gl = ["px", "nx", "py", "ny", "pz", "nz"];
    assert_eq!(
        face_paths("a/{face}.exr").unwrap(),
        gl.map(|f| format!("a/{f}.exr"))
    );
    assert_eq!(
        face_paths("sky_{posx}.png").unwrap(),
        ["posx", "negx", "posy", "negy", "posz", "negz"].map(|f| format!("sky_{f}.png"))
    );
    // LearnOpenGL's order onto GL_TEXTURE_CUBE_MAP_POSITIVE_X + i: front is +Z.
    assert_eq!(
        face_paths("{side}.jpg").unwrap(),
        ["right", "left", "top", "bottom", "front", "back"].map(|f| format!("{f}.jpg"))
    );
    assert_eq!(face_paths("f{index}.hdr").unwrap()[4], "f4.hdr");
    // Two tokens: each replaced by its own scheme's name.
    assert_eq!(face_paths("{index}_{face}.exr").unwrap()[3], "3_ny.exr");
    assert_eq!(face_paths("plain.exr"), None);
    assert_eq!(face_paths("{faces}.exr"), None);
}

#[test]
fn positional_paths_split_into_input_and_output() {
    let two = strings(&["in.exr", "out.exr"]);
    assert_eq!(
        split_paths(&two, false, false).unwrap(),
        (
            EnvFiles::One("in.exr".into()),
            EnvFiles::One("out.exr".into())
        )
    );
    // A pattern is six faces, and keeps its name.
    let (i, o) = split_paths(&strings(&["f_{face}.exr", "out.exr"]), true, false).unwrap();
    assert_eq!(i.paths().len(), 6);
    assert_eq!(i.label(), "f_{face}.exr");
    assert_eq!(o, EnvFiles::One("out.exr".into()));
    let six = ["r.png", "l.png", "t.png", "b.png", "f.png", "k.png"];
    let mut seven = strings(&six);
    seven.push("out.exr".into());
    let (i, o) = split_paths(&seven, true, false).unwrap();
    assert_eq!(i.paths(), strings(&six));
    assert_eq!(i.label(), six.join(","));
    assert_eq!(i.first(), "r.png");
    assert_eq!(o.paths(), ["out.exr"]);
    let mut seven_out = vec!["in.exr".to_string()];
    seven_out.extend(strings(&six));
    let (i, o) = split_paths(&seven_out, false, true).unwrap();
    assert_eq!(
        (i.paths(), o.paths()),
        (strings(&["in.exr"]), strings(&six))
    );
    let mut twelve = strings(&six);
    twelve.extend(six.iter().map(|s| format!("o_{s}")));
    let (i, o) = split_paths(&twelve, true, true).unwrap();
    assert_eq!(
        (i.paths()[5].as_str(), o.paths()[0].as_str()),
        ("k.png", "o_r.png")
    );
    let err = |p: &[String], s, d| split_paths(p, s, d).unwrap_err().to_string();
    assert!(err(&seven, true, true).contains("ambiguous"));
    assert!(err(&seven, false, false).contains("got 7 paths; expected IN OUT"));
    assert!(err(&twelve, true, false).contains("got 12 paths"));
    assert!(err(&strings(&["a.exr", "b.exr", "c.exr"]), false, true).contains("got 3 paths"));
    let mut twice = vec!["in.exr".to_string()];
    twice.extend(strings(&[
        "a.exr", "b.exr", "c.exr", "a.exr", "e.exr", "f.exr",
    ]));
    assert!(err(&twice, false, true).contains("a.exr: named for two cube faces"));
}

/// A 6-face stack whose face i holds the value i everywhere (channel k adds k/10).
fn stack(f: usize) -> Image {
    let mut img = Image::new(f, 6 * f, 3);
    for (p, px) in img.data.chunks_mut(3).enumerate() {
        for (k, v) in px.iter_mut().enumerate() {
            *v = (p / (f * f)) as f32 + k as f32 / 10.0;
        }
    }
    img
}

#[test]
fn six_named_faces_round_trip_and_a_failed_one_leaves_none() {
    let dir = common::tempdir("envio");
    let cube = Mapping::parse("cube", None).unwrap();
    let names = ["right", "left", "top", "bottom", "front", "back"];
    let faces = EnvFiles::Faces {
        files: names.map(|n| dir.join(format!("{n}.exr")).display().to_string()),
        pattern: None,
    };
    let img = stack(8);
    let wopts = WriteOptions::default();
    write_env_files(&faces, cube, &img, None, &IDENTITY, &wopts).unwrap();
    let back = read_env_files(&faces, cube, None, &ReadOptions::default()).unwrap();
    assert_eq!(back.data, img.data);
    // The same files through the {side} pattern.
    let pattern = EnvFiles::parse(&dir.join("{side}.exr").display().to_string());
    let back = read_env_files(&pattern, cube, None, &ReadOptions::default()).unwrap();
    assert_eq!(back.data, img.data);

    // The sixth face cannot be written (its directory is missing, or its extension is one
    // spheremap does not write): none of the six appears, and no temporary file is left.
    for last in ["missing/k.exr", "k.webp", "k.txt"] {
        let sub = dir.join(format!("set_{}", last.replace(['/', '.'], "_")));
        std::fs::create_dir(&sub).unwrap();
        let mut files = ["a", "b", "c", "d", "e"]
            .map(|n| sub.join(format!("{n}.exr")).display().to_string())
            .to_vec();
        files.push(sub.join(last).display().to_string());
        let bad = EnvFiles::Faces {
            files: std::array::from_fn(|i| files[i].clone()),
            pattern: None,
        };
        let e = write_env_files(&bad, cube, &img, None, &IDENTITY, &wopts)
            .unwrap_err()
            .to_string();
        assert!(e.contains("k."), "{last}: {e}");
        assert_eq!(
            std::fs::read_dir(&sub).unwrap().count(),
            0,
            "{last}: files left behind"
        );
        if last != "missing/k.exr" {
            // Refused before any work by the same check.
            assert!(bad.check_output(cube).is_err());
        }
    }
    // Six faces are refused for a mapping that is not a cube, by name.
    let sphere = Mapping::parse("sphere", None).unwrap();
    let e = faces.check_output(sphere).unwrap_err().to_string();
    assert!(
        e.contains("six face files, but the output mapping is sphere"),
        "{e}"
    );
    let e = read_env_files(&faces, sphere, None, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("right.exr") && e.contains("input mapping is sphere"),
        "{e}"
    );
}

#[test]
fn a_nan_in_one_face_is_reported_against_that_faces_file() {
    let faces = EnvFiles::Faces {
        files: ["r", "l", "t", "b", "f", "k"].map(|n| format!("{n}.exr")),
        pattern: None,
    };
    let mut img = stack(4);
    // Face 4 (+Z, front.exr), its pixel (1, 2).
    let at = ((4 * 4 + 2) * 4 + 1) * 3;
    img.data[at] = f32::NAN;
    let e = check_nonfinite_env(&mut img.clone(), &faces, NonFinite::Error)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("f.exr:") && e.contains("x=1, y=2"), "{e}");
    check_nonfinite_env(&mut img, &faces, NonFinite::Zero).unwrap();
    assert_eq!(img.data[at], 0.0);
    let one = EnvFiles::One("cross.exr".into());
    img.data[at] = f32::INFINITY;
    let e = check_nonfinite_env(&mut img, &one, NonFinite::Error)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("cross.exr:") && e.contains("y=18"), "{e}");
}

/// Every map written through `write_env_files` records its mapping, preset and cube layout or
/// face in the formats that have a place for it; the pixels are those of an untagged file.
#[test]
fn written_maps_record_their_mapping_and_read_back_the_same() {
    use spheremap::images::codec::{decode, encode};
    use spheremap::images::cube_layout::Layout;
    use spheremap::images::format::Format;
    use spheremap::images::note::{self, MapNote};
    let dir = common::tempdir("envio");
    let sky = Mapping::parse("sphere", Some("skylibs")).unwrap();
    let mut img = Image::new(16, 16, 3);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = (i % 97) as f32 / 97.0;
    }
    let ropts = ReadOptions::default();
    // A view that is not the identity: its look/up are recorded and give the view back.
    let (look, up) = ([0.3, -0.2, -1.7], [0.1, 1.0, 0.2]);
    let turned = spheremap::frame::view::look_up(look, up).unwrap();
    for ext in ["exr", "png", "jpg", "hdr", "pfm"] {
        let p = dir.join(format!("s.{ext}")).display().to_string();
        write_env_files(
            &EnvFiles::One(p.clone()),
            sky,
            &img,
            None,
            &turned,
            &WriteOptions::default(),
        )
        .unwrap();
        let got = note::read_file(std::path::Path::new(&p))
            .unwrap()
            .and_then(|t| MapNote::parse(&t));
        if ext == "pfm" {
            assert_eq!(got, None);
        } else {
            let t = got.unwrap_or_else(|| panic!("{ext}: no note"));
            assert_eq!(
                (t.mapping.name(), t.mapping.preset_name()),
                ("sphere", "skylibs"),
                "{ext}"
            );
            assert_eq!((t.layout, t.face), (None, None));
            let (l, u) = t.view.expect("the view is recorded");
            // The same view, to the rounding of look_up's normalizations.
            let back = spheremap::frame::view::look_up(l, u).unwrap();
            let err = (0..9).map(|k| (back[k / 3][k % 3] - turned[k / 3][k % 3]).abs());
            assert!(err.fold(0.0, f64::max) < 1e-14, "{ext}: {back:?}");
            assert_eq!(spheremap::images::envmap::read_note(&p).unwrap(), Some(t));
        }
        // The note changes no pixel: the file decodes as the same image encoded without it.
        let bytes = std::fs::read(&p).unwrap();
        let fmt = Format::sniff(&bytes).unwrap();
        let plain = encode(
            std::path::Path::new(&p),
            &img,
            fmt,
            &WriteOptions::default(),
        )
        .unwrap();
        let a = decode(std::path::Path::new(&p), &bytes, &ropts).unwrap();
        let b = decode(std::path::Path::new(&p), &plain, &ropts).unwrap();
        assert_eq!(a.data, b.data, "{ext}");
        if ext != "exr" && ext != "pfm" {
            assert!(bytes.len() > plain.len(), "{ext}: the note is in the file");
        }
        if ext == "jpg" {
            // JFIF's APP0 still comes right after SOI; the comment follows it.
            assert_eq!(bytes[2..4], [0xff, 0xe0]);
        }
    }
    // A cube in a layout records the layout; six faces record each its face.
    let cube = Mapping::parse("cube", Some("d3d")).unwrap();
    let p = dir.join("c.png").display().to_string();
    write_env_files(
        &EnvFiles::One(p.clone()),
        cube,
        &stack(4),
        Some(Layout::VCross),
        &IDENTITY,
        &WriteOptions::default(),
    )
    .unwrap();
    let t = spheremap::images::envmap::read_note(&p).unwrap().unwrap();
    assert_eq!(t.view, None, "the identity view is not written");
    assert_eq!(
        (t.mapping.preset_name(), t.layout),
        ("d3d", Some(Layout::VCross))
    );
    let pattern = dir.join("f_{face}.hdr").display().to_string();
    let faces = EnvFiles::parse(&pattern);
    write_env_files(
        &faces,
        cube,
        &stack(4),
        None,
        &IDENTITY,
        &WriteOptions::default(),
    )
    .unwrap();
    for (i, f) in faces.paths().iter().enumerate() {
        let t = spheremap::images::envmap::read_note(f).unwrap().unwrap();
        assert_eq!((t.mapping.name(), t.face), ("cube", Some(i)), "{f}");
    }
    assert_eq!(
        spheremap::images::envmap::read_note(&pattern)
            .unwrap()
            .unwrap()
            .face,
        Some(0)
    );
}

#[test]
fn notes_parse_strictly_and_skip_unknown_keys() {
    use spheremap::images::note::MapNote;
    let t = MapNote::parse("mapping=latlong preset=pbrt").unwrap();
    assert_eq!(
        (t.mapping.name(), t.mapping.preset_name()),
        ("latlong", "pbrt")
    );
    assert_eq!(MapNote::parse(&t.text()), Some(t));
    // A key from a later version is skipped; a missing preset is the mapping's own.
    let t = MapNote::parse("mapping=cube preset=gl layout=horizon version=9").unwrap();
    assert_eq!(t.layout.map(|l| l.name()), Some("horizon"));
    assert_eq!(
        MapNote::parse("mapping=sphere")
            .unwrap()
            .mapping
            .preset_name(),
        "gl"
    );
    let t = MapNote::parse("mapping=sphere look=1,0,0 up=0,1,0").unwrap();
    assert_eq!(t.view, Some(([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])));
    assert_eq!(MapNote::parse(&t.text()), Some(t));
    for bad in [
        "mapping=sphere look=1,0,0",
        "mapping=sphere look=1,0 up=0,1,0",
        "mapping=sphere look=0,1,0 up=0,1,0",
        "mapping=sphere look=nan,0,1 up=0,1,0",
    ] {
        assert_eq!(MapNote::parse(bad), None, "{bad:?}");
    }
    for bad in [
        "",
        "preset=gl",
        "mapping=globe",
        "mapping=sphere preset=nope",
        "mapping=cube face=up",
        "hello world",
    ] {
        assert_eq!(MapNote::parse(bad), None, "{bad:?}");
    }
}

/// What a file is read as: each flag given wins; each one absent comes from the file's note
/// (a preset only from a note of the same mapping), else from the default.
#[test]
fn flags_fill_in_from_the_note() {
    use spheremap::images::envmap::mapping_for;
    use spheremap::images::note::MapNote;
    let note = MapNote::parse("mapping=sphere preset=skylibs").unwrap();
    let n = Some(&note);
    let get = |name, preset, rec, default| {
        mapping_for(name, preset, rec, default)
            .unwrap()
            .map(|m| format!("{} {}", m.name(), m.preset_name()))
    };
    assert_eq!(get(None, None, n, None).as_deref(), Some("sphere skylibs"));
    assert_eq!(
        get(Some("sphere"), None, n, None).as_deref(),
        Some("sphere skylibs")
    );
    assert_eq!(
        get(Some("sphere"), Some("gl"), n, None).as_deref(),
        Some("sphere gl")
    );
    assert_eq!(get(None, Some("gl"), n, None).as_deref(), Some("sphere gl"));
    assert_eq!(
        get(Some("latlong"), None, n, None).as_deref(),
        Some("latlong blender")
    );
    assert_eq!(
        get(None, None, None, Some("latlong")).as_deref(),
        Some("latlong blender")
    );
    assert_eq!(
        get(None, Some("pbrt"), None, Some("latlong")).as_deref(),
        Some("latlong pbrt")
    );
    assert_eq!(get(None, None, None, None), None);
    assert!(mapping_for(Some("globe"), None, n, None).is_err());
    assert!(mapping_for(Some("latlong"), Some("skylibs-nope"), n, None).is_err());
}
