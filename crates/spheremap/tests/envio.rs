//! Environment maps in files: the naming of six cube faces (patterns and named files), how a
//! conversion's positional paths split into input and output, and writes that leave nothing
//! behind when any file fails.
use spheremap::cube::face_paths;
use spheremap::envio::{
    check_nonfinite_env, read_env_files, split_paths, write_env_files, EnvFiles,
};
use spheremap::image_io::{Image, NonFinite, ReadOptions, WriteOptions};
use spheremap::mapping::Mapping;

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
    let dir = tempdir();
    let cube = Mapping::parse("cube", None).unwrap();
    let names = ["right", "left", "top", "bottom", "front", "back"];
    let faces = EnvFiles::Faces {
        files: names.map(|n| dir.join(format!("{n}.exr")).display().to_string()),
        pattern: None,
    };
    let img = stack(8);
    let wopts = WriteOptions::default();
    write_env_files(&faces, cube, &img, None, &wopts).unwrap();
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
        let e = write_env_files(&bad, cube, &img, None, &wopts)
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

fn tempdir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!(
        "spheremap-envio-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
