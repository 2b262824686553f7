//! The map and render requests (`trace::generate::MapRequest`, `jobs::render::RenderRequest`):
//! they read from JSON with every default, refuse unknown keys, and name the field at fault.

use spheremap::jobs::render::{Mode, RenderRequest};
use spheremap::trace::generate::MapRequest;

#[test]
fn a_map_request_reads_from_json_and_names_its_fields() {
    let r: MapRequest = serde_json::from_str("{}").unwrap();
    assert_eq!(r, MapRequest::default());
    let m = r.resolve().unwrap();
    assert_eq!((m.mapping.name(), m.width, m.height), ("sphere", 512, 512));
    let r: MapRequest = serde_json::from_str(
        r#"{"to": "latlong", "size": 64, "look": [1, 0, 0], "pos": [0, 1, 0]}"#,
    )
    .unwrap();
    let m = r.resolve().unwrap();
    assert_eq!(
        (m.width, m.height, m.options.pos),
        (128, 64, [0.0, 1.0, 0.0])
    );
    // The view written in the map's note is the rotation the rays use.
    assert_eq!(m.view, m.options.rotation);
    assert!(serde_json::from_str::<MapRequest>(r#"{"mapping": "sphere"}"#).is_err());
    for (json, field) in [
        (r#"{"to": "globe"}"#, "to: "),
        (r#"{"to": "latlong", "preset": "nope"}"#, "preset: "),
        (r#"{"layout": "zigzag"}"#, "layout: "),
        (r#"{"size": 0}"#, "size: "),
        (r#"{"filter": "lanczos"}"#, "filter: "),
        (r#"{"up": [0, 1, 0]}"#, "up: "),
        (r#"{"precision": "f16"}"#, "precision: "),
    ] {
        // A name is refused as it is read, any other value when the request resolves.
        let e = match serde_json::from_str::<MapRequest>(json) {
            Err(e) => e.to_string(),
            Ok(r) => r.resolve().unwrap_err().to_string(),
        };
        assert!(e.starts_with(field), "{json}: {e}");
    }
}

#[test]
fn a_render_request_reads_from_json_and_names_its_fields() {
    let r: RenderRequest = serde_json::from_str("{}").unwrap();
    assert_eq!(r, RenderRequest::default());
    let r: RenderRequest = serde_json::from_str(
        r#"{"mode": "matcap", "matcap_variant": "perspective", "width": 64, "height": 32}"#,
    )
    .unwrap();
    assert!(matches!(r.mode(), Mode::Matcap(_)));
    let tri = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let cam = r.camera(&tri).unwrap();
    assert_eq!((cam.width, cam.height), (64, 32));
    assert!(serde_json::from_str::<RenderRequest>(r#"{"size": [64, 32]}"#).is_err());
    let e = serde_json::from_str::<RenderRequest>(r#"{"wrap": "mirror"}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("wrap: unknown wrap \"mirror\"; expected one of: clamp-to-edge, repeat"),
        "{e}"
    );
    let bad: RenderRequest = serde_json::from_str(r#"{"camera": "orbit:3"}"#).unwrap();
    assert!(bad
        .camera(&tri)
        .unwrap_err()
        .to_string()
        .starts_with("camera: "));
}

/// An option several requests take has one default: what the CLI's shared flags and Python's
/// shared keywords show is every request's.
#[test]
fn an_option_shared_by_requests_has_one_default() {
    let ops = [
        "convert",
        "bake-matcap",
        "prefilter",
        "irradiance",
        "render",
        "generate",
    ];
    let all: Vec<(&str, serde_json::Value)> = ops
        .iter()
        .map(|op| (*op, spheremap::jobs::defaults::of(op).unwrap()))
        .collect();
    for key in [
        "max_samples",
        "seed",
        "outside",
        "filter",
        "taps",
        "precision",
        "nonfinite",
        "max_memory",
        "src",
        "src_preset",
        "src_layout",
        "src_look",
        "src_up",
    ] {
        let values: Vec<(&str, &serde_json::Value)> = all
            .iter()
            .filter_map(|(op, d)| d.get(key).map(|v| (*op, v)))
            .collect();
        assert!(!values.is_empty(), "{key}");
        assert!(
            values.iter().all(|(_, v)| *v == values[0].1),
            "{key}: {values:?}"
        );
    }
    assert!(spheremap::jobs::defaults::of("nope").is_none());
}
