//! Lat-long presets pinned to concrete pixels of a 64×32 image: (x, y) = (u·64, v·32).

use proptest::prelude::*;
use spheremap::mappings::latlong::{LatLongPreset, LATLONG_PRESETS};

const AXES: [([f64; 3], &str); 6] = [
    ([1., 0., 0.], "+X"),
    ([-1., 0., 0.], "-X"),
    ([0., 0., 1.], "+Z"),
    ([0., 0., -1.], "-Z"),
    ([0., 1., 0.], "+Y"),
    ([0., -1., 0.], "-Y"),
];

fn check(preset: &str, columns: [f64; 4]) {
    let p = LatLongPreset::by_name(preset).unwrap();
    for (k, (d, name)) in AXES.iter().enumerate() {
        let [u, v] = p.dir_to_uv(*d);
        let (x, y) = (u * 64.0, v * 32.0);
        if k < 4 {
            assert!(
                (x - columns[k]).abs() < 1e-9 && (y - 16.0).abs() < 1e-9,
                "{preset} {name}: ({x}, {y})"
            );
        } else {
            assert_eq!(y, if k == 4 { 0.0 } else { 32.0 }, "{preset} {name}");
        }
    }
}

//                              +X    -X    +Z    -Z
#[test]
fn blender_threejs() {
    check("blender", [32., 0., 48., 16.]);
    check("threejs", [32., 0., 48., 16.]);
}
#[test]
fn skylibs_filament() {
    check("skylibs", [48., 16., 0., 32.]);
    check("filament", [48., 16., 0., 32.]);
}
#[test]
fn mitsuba() {
    check("mitsuba", [16., 48., 32., 0.]);
}
#[test]
fn pbrt() {
    check("pbrt", [0., 32., 16., 48.]);
}

/// The statement of the default: u = ½ + atan2(z, x)/2π, row/H = acos(y)/π.
#[test]
fn default_is_the_stated_formula() {
    let p = LatLongPreset::by_name("blender").unwrap();
    for d in [[0.3f64, 0.4, -0.5], [-0.7, -0.1, 0.2], [0.01, 0.99, 0.02]] {
        let l: f64 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let want = [
            0.5 + f64::atan2(d[2], d[0]) / std::f64::consts::TAU,
            (d[1] / l).acos() / std::f64::consts::PI,
        ];
        let got = p.dir_to_uv(d);
        assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
    }
}

#[test]
fn seam_is_continuous() {
    for p in LATLONG_PRESETS {
        // Two directions a hair apart on either side of the seam map to u ≈ 0 and u ≈ 1 and
        // back to directions a hair apart.
        let seam = p.uv_to_dir([0.0f64, 0.4]).unwrap();
        let a = p.uv_to_dir([1e-9f64, 0.4]).unwrap();
        let b = p.uv_to_dir([1.0f64 - 1e-9, 0.4]).unwrap();
        for k in 0..3 {
            assert!((a[k] - seam[k]).abs() < 1e-8 && (b[k] - seam[k]).abs() < 1e-8);
        }
        assert!(
            p.dir_to_uv(a)[0] < 1e-8 && p.dir_to_uv(b)[0] > 1.0 - 1e-8,
            "{}",
            p.name
        );
    }
}

proptest! {
    #[test]
    fn round_trips(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0, k in 0usize..6) {
        let l = (x * x + y * y + z * z).sqrt();
        prop_assume!(l > 1e-3);
        let d = [x / l, y / l, z / l];
        let p = &LATLONG_PRESETS[k];
        let uv = p.dir_to_uv(d);
        prop_assert!((0.0..1.0).contains(&uv[0]) && (0.0..=1.0).contains(&uv[1]));
        let back = p.uv_to_dir(uv).unwrap();
        for c in 0..3 { prop_assert!((back[c] - d[c]).abs() < 1e-12, "{d:?} {uv:?} {back:?}"); }
    }

    #[test]
    fn uv_round_trips(u in 0.0f64..1.0, v in 0.001f64..0.999, k in 0usize..6) {
        let p = &LATLONG_PRESETS[k];
        let uv = p.dir_to_uv(p.uv_to_dir([u, v]).unwrap());
        let du = (uv[0] - u).abs();
        prop_assert!(du.min(1.0 - du) < 1e-12 && (uv[1] - v).abs() < 1e-12);
    }
}

#[test]
fn degenerate_input() {
    let p = LatLongPreset::by_name("blender").unwrap();
    assert!(p.dir_to_uv([0.0f64, 0.0, 0.0])[0].is_nan());
    assert!(p.dir_to_uv([f64::NAN, 0.0, 1.0])[0].is_nan());
    assert!(p.uv_to_dir([0.5, 1.5]).is_none());
    assert!(p.uv_to_dir([f64::NAN, 0.5]).is_none());
    assert!(LatLongPreset::by_name("maya")
        .unwrap_err()
        .to_string()
        .starts_with("preset:"));
}
