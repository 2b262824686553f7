//! Every preset pinned to concrete pixels for ±X, ±Y, ±Z (64×64 image; (0,0) = top-left corner
//! of row 0).  c = 64 · 1/(2√2): the axis directions sit at radius 1/√2 of the disc.

use spheremap::frame::conventions::{
    pixel_to_st, st_to_pixel, texel_center, RowOrder, Singular, SpherePreset,
};

const N: usize = 64;
const C: f64 = 22.627416997969522; // 64 / (2 sqrt 2)
const NAN: (f64, f64) = (f64::NAN, f64::NAN);
const AXES: [[f64; 3]; 6] = [
    [1., 0., 0.],
    [-1., 0., 0.],
    [0., 1., 0.],
    [0., -1., 0.],
    [0., 0., 1.],
    [0., 0., -1.],
];

fn check(preset: &str, want: [(f64, f64); 6]) {
    let p = SpherePreset::by_name(preset).unwrap();
    for (d, w) in AXES.iter().zip(want) {
        let (x, y) = p.dir_to_pixel(*d, N, Singular::Nan);
        if w.0.is_nan() {
            assert!(
                x.is_nan() && y.is_nan(),
                "{preset} {d:?}: want the rim (NaN), got ({x}, {y})"
            );
        } else {
            assert!(
                (x - w.0).abs() < 1e-9 && (y - w.1).abs() < 1e-9,
                "{preset} {d:?}: want {w:?}, got ({x}, {y})"
            );
            // And back: the pixel maps to the direction.
            let back = p.pixel_to_dir(x, y, N).unwrap();
            for k in 0..3 {
                assert!(
                    (back[k] - d[k]).abs() < 1e-9,
                    "{preset} {d:?}: back {back:?}"
                );
            }
        }
    }
}

//                         +X             -X             +Y             -Y             +Z          -Z
#[test]
fn gl() {
    check(
        "gl",
        [
            (32. + C, 32.),
            (32. - C, 32.),
            (32., 32. - C),
            (32., 32. + C),
            (32., 32.),
            NAN,
        ],
    );
}
#[test]
fn mirror_ball_photo_is_gl() {
    check(
        "mirror-ball-photo",
        [
            (32. + C, 32.),
            (32. - C, 32.),
            (32., 32. - C),
            (32., 32. + C),
            (32., 32.),
            NAN,
        ],
    );
}
#[test]
fn gl_upload_order() {
    check(
        "gl-upload",
        [
            (32. + C, 32.),
            (32. - C, 32.),
            (32., 32. + C),
            (32., 32. - C),
            (32., 32.),
            NAN,
        ],
    );
}
#[test]
fn d3d() {
    // D3D view space: +Z forward, so its +Z is the rim and its -Z the centre.
    check(
        "d3d",
        [
            (32. + C, 32.),
            (32. - C, 32.),
            (32., 32. - C),
            (32., 32. + C),
            NAN,
            (32., 32.),
        ],
    );
    let p = SpherePreset::by_name("d3d").unwrap();
    assert_eq!(p.st_to_uv(0.25, 0.75), (0.25, 0.25));
}
#[test]
fn skylibs() {
    // Centre -Z (forward), rim +Z, +Y at the top, +X right.
    check(
        "skylibs",
        [
            (32. + C, 32.),
            (32. - C, 32.),
            (32., 32. - C),
            (32., 32. + C),
            NAN,
            (32., 32.),
        ],
    );
}
#[test]
fn blender_mirrorball() {
    // Blender Z-up: +Z up in the image, the viewer at -Y (centre), +Y straight ahead (rim).
    check(
        "blender-mirrorball",
        [
            (32. + C, 32.),
            (32. - C, 32.),
            NAN,
            (32., 32.),
            (32., 32. - C),
            (32., 32. + C),
        ],
    );
}

/// Blender Cycles `mirrorball_to_direction` (intern/cycles/kernel/geom/... ), transcribed:
/// dir.x = 2u − 1, dir.z = 2v − 1, dir.y = −√(1 − x² − z²), I = (0,−1,0), result 2(dir·I)dir − I.
/// Blender's image v = 0 is the bottom row.
#[test]
fn blender_preset_matches_cycles_formula() {
    let p = SpherePreset::by_name("blender-mirrorball").unwrap();
    for i in 0..40 {
        for j in 0..40 {
            let (u, v) = ((i as f64 + 0.5) / 40.0, (j as f64 + 0.5) / 40.0);
            let (x, z) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            if x * x + z * z > 1.0 {
                assert!(p.pixel_to_dir(u * 64.0, (1.0 - v) * 64.0, 64).is_none());
                continue;
            }
            let dir = [x, -(1.0 - x * x - z * z).sqrt(), z];
            let i_ = [0.0, -1.0, 0.0];
            let k = 2.0 * (dir[0] * i_[0] + dir[1] * i_[1] + dir[2] * i_[2]);
            let want = [k * dir[0] - i_[0], k * dir[1] - i_[1], k * dir[2] - i_[2]];
            let got = p.pixel_to_dir(u * 64.0, (1.0 - v) * 64.0, 64).unwrap();
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-12,
                    "u={u} v={v}: {got:?} vs {want:?}"
                );
            }
        }
    }
}

#[test]
fn texel_centres_and_pixels() {
    assert_eq!(texel_center(0, 4), 0.125);
    assert_eq!(texel_center(3, 4), 0.875);
    // Pixel centre of row 0 in a file is t = 1 - 1/(2n); in GL upload order t = 1/(2n).
    assert_eq!(
        pixel_to_st(0.5, 0.5, 4, 4, RowOrder::TopIsT1),
        (0.125, 0.875)
    );
    assert_eq!(
        pixel_to_st(0.5, 0.5, 4, 4, RowOrder::TopIsT0),
        (0.125, 0.125)
    );
    assert_eq!(
        st_to_pixel(0.125, 0.875, 4, 4, RowOrder::TopIsT1),
        (0.5, 0.5)
    );
}

#[test]
fn unknown_preset_names_the_argument() {
    let e = SpherePreset::by_name("cycles").unwrap_err().to_string();
    assert!(e.starts_with("preset: unknown preset \"cycles\""), "{e}");
}
