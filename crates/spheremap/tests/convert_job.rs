//! The conversion request (`jobs::convert::ConvertJob`): its defaults, its rules (the source's
//! mapping and view from a file's note, the output that keeps the source's without `to`, the
//! view flags that exclude each other), and that running it is the engine's result.

mod common;

use spheremap::images::codec::{read_image, write_image_with_note, ReadOptions, WriteOptions};
use spheremap::images::note::MapNote;
use spheremap::jobs::convert::ConvertJob;
use spheremap::resample::{resample, EnvMap, ResampleOptions};
use spheremap::Mapping;

#[test]
fn a_request_reads_from_json_with_every_default_and_refuses_unknown_keys() {
    let job: ConvertJob = serde_json::from_str("{}").unwrap();
    assert_eq!(job, ConvertJob::default());
    assert_eq!(
        (job.samples, job.filter.name(), job.taps.name()),
        (4, "box", "bilinear")
    );
    let job: ConvertJob = serde_json::from_str(
        r#"{"from": "latlong", "to": "sphere", "size": 64, "look": [1, 0, 0]}"#,
    )
    .unwrap();
    assert_eq!(job.look, Some([1.0, 0.0, 0.0]));
    // The source's fields are spelled src, src_preset, …; from, from_preset, … and env_format,
    // env_preset, … are the same fields.
    for spelling in [
        r#"{"src": "sphere", "src_preset": "skylibs", "src_look": [1, 0, 0], "src_up": [0, 0, 1]}"#,
        r#"{"from": "sphere", "from_preset": "skylibs", "from_look": [1, 0, 0], "from_up": [0, 0, 1]}"#,
        r#"{"env_format": "sphere", "env_preset": "skylibs", "env_look": [1, 0, 0], "env_up": [0, 0, 1]}"#,
    ] {
        let job: ConvertJob = serde_json::from_str(spelling).unwrap();
        assert_eq!(job.source.src.as_deref(), Some("sphere"), "{spelling}");
        assert_eq!(
            job.source.src_preset.as_deref(),
            Some("skylibs"),
            "{spelling}"
        );
        assert_eq!(job.source.src_look, Some([1.0, 0.0, 0.0]), "{spelling}");
        assert_eq!(job.source.src_up, Some([0.0, 0.0, 1.0]), "{spelling}");
    }
    let written = serde_json::to_value(&job).unwrap();
    assert_eq!(written["src"], "latlong");
    assert!(written.get("from").is_none());
    let e =
        serde_json::from_str::<ConvertJob>(r#"{"src": "sphere", "from": "latlong"}"#).unwrap_err();
    assert!(e.to_string().contains("duplicate field `src`"), "{e}");
    let e = serde_json::from_str::<ConvertJob>(r#"{"form": "latlong"}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field `form`"), "{e}");
    // Names are read as the core's enums (aliases too) and refused as they are read.
    let job: ConvertJob = serde_json::from_str(r#"{"filter": "triangle"}"#).unwrap();
    assert_eq!(job.filter, spheremap::resample::Filter::Tent);
    let e = serde_json::from_str::<ConvertJob>(r#"{"filter": "lanczos"}"#).unwrap_err();
    assert!(
        e.to_string().starts_with(
            "filter: unknown filter \"lanczos\"; expected one of: box, tent, gaussian"
        ),
        "{e}"
    );
}

#[test]
fn the_rules_name_what_they_refuse() {
    let job = ConvertJob {
        source: spheremap::jobs::source::Source {
            src: Some("latlong".into()),
            ..Default::default()
        },
        to: Some("sphere".into()),
        look: Some([1.0, 0.0, 0.0]),
        yaw: Some(30.0),
        ..Default::default()
    };
    let e = job.resolve(None, "in.exr").unwrap_err().to_string();
    assert!(e.starts_with("look: ") && e.contains("not both"), "{e}");
    let job = ConvertJob {
        source: spheremap::jobs::source::Source {
            src: Some("latlong".into()),
            ..Default::default()
        },
        up: Some([0.0, 1.0, 0.0]),
        ..Default::default()
    };
    assert!(job
        .resolve(None, "in.exr")
        .unwrap_err()
        .to_string()
        .starts_with("up: "));
    let e = ConvertJob::default()
        .resolve(None, "in.exr")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("src: in.exr records no mapping"), "{e}");
    let job = ConvertJob {
        source: spheremap::jobs::source::Source {
            src: Some("latlong".into()),
            ..Default::default()
        },
        to: Some("globe".into()),
        ..Default::default()
    };
    assert!(job
        .resolve(None, "in.exr")
        .unwrap_err()
        .to_string()
        .starts_with("to: "));
}

#[test]
fn a_note_supplies_the_source_and_without_to_the_output_keeps_it() {
    let note = MapNote::parse("mapping=sphere preset=skylibs look=1,0,0 up=0,1,0").unwrap();
    let r = ConvertJob::default()
        .resolve(Some(&note), "in.exr")
        .unwrap();
    assert_eq!((r.src.name(), r.src.preset_name()), ("sphere", "skylibs"));
    assert_eq!((r.dst.name(), r.dst.preset_name()), ("sphere", "skylibs"));
    assert!(r.same && r.notice.is_none());
    assert_eq!(
        (r.from_look, r.from_up),
        (Some([1.0, 0.0, 0.0]), Some([0.0, 1.0, 0.0]))
    );
    // The same view on both sides: no turn.
    assert_eq!(r.rotation, spheremap::resample::IDENTITY);
    // Read as another mapping: converted as given, with a notice, the note's view not applied.
    let job = ConvertJob {
        source: spheremap::jobs::source::Source {
            src: Some("angular".into()),
            ..Default::default()
        },
        to: Some("latlong".into()),
        ..Default::default()
    };
    let r = job.resolve(Some(&note), "in.exr").unwrap();
    assert_eq!(r.src.name(), "angular");
    assert_eq!(r.from_look, None);
    assert!(r
        .notice
        .unwrap()
        .contains("records mapping sphere (preset skylibs)"));
}

#[test]
fn running_a_request_is_the_engines_result() {
    let img = common::apartment();
    let job = ConvertJob {
        source: spheremap::jobs::source::Source {
            src: Some("latlong".into()),
            ..Default::default()
        },
        to: Some("sphere".into()),
        size: Some(48),
        look: Some([0.3, 0.2, -1.0]),
        ..Default::default()
    };
    let (got, r, _) = job.run_image(&img, None, None).unwrap();
    let env = EnvMap::new(Mapping::parse("latlong", None).unwrap(), &img, "image").unwrap();
    let opts = ResampleOptions {
        rotation: r.rotation,
        ..Default::default()
    };
    let (want, _) = resample(&env, r.dst, 48, 48, &opts, None).unwrap();
    assert_eq!(got.unwrap().data, want.data);
    // Into a caller's buffer: the same values.
    let mut buf = vec![0f32; 48 * 48 * img.channels];
    job.run_image(&img, None, Some(&mut buf)).unwrap();
    assert_eq!(buf, want.data);
}

#[test]
fn files_in_files_out_with_a_report_and_no_overwrite() {
    let d = common::tempdir("convert_job");
    let src = d.join("sky.exr");
    let img = common::apartment();
    let note = MapNote {
        mapping: Mapping::parse("latlong", None).unwrap(),
        layout: None,
        face: None,
        view: None,
    };
    write_image_with_note(&src, &img, &WriteOptions::default(), Some(&note.text())).unwrap();
    let out = d.join("sky_cube_{face}.png");
    let job = ConvertJob {
        to: Some("cube".into()),
        size: Some(16),
        ..Default::default()
    };
    let paths = [src.display().to_string(), out.display().to_string()];
    let report = job.run_files(&paths, None).unwrap();
    assert_eq!(
        (report.from, report.to, report.size),
        ("latlong", "cube", 16)
    );
    assert_eq!(report.output.len(), 6);
    let face = read_image(
        std::path::Path::new(&report.output[4]),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!((face.width, face.height), (16, 16));
    let json = serde_json::to_value(&report).unwrap();
    for key in [
        "input",
        "inputs",
        "output",
        "from_look",
        "lookups",
        "seconds",
        "clipped",
        "clamped_half",
    ] {
        assert!(json.get(key).is_some(), "{key}");
    }
    // The output is the input: refused, nothing written.
    let before = std::fs::read(&src).unwrap();
    let same = [src.display().to_string(), src.display().to_string()];
    let e = ConvertJob::default()
        .run_files(&same, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("overwrite the input"), "{e}");
    assert_eq!(std::fs::read(&src).unwrap(), before);
}
