use proptest::prelude::*;
use spheremap::mappings::matcap::{matcap_uv, MatcapVariant};
use spheremap::mappings::texgen::{
    sphere_texgen, sphere_texgen_f64, ModelviewState, NormalMode, TexgenOptions,
};
use spheremap::Singular;

fn run(
    p: &[f32],
    pw: usize,
    n: &[f32],
    m: [[f64; 4]; 4],
    opts: TexgenOptions,
) -> (Vec<f32>, Vec<f64>) {
    let mv = ModelviewState::new(m).unwrap();
    let mut a = vec![0.0f32; 2 * n.len() / 3];
    let mut b = vec![0.0f64; a.len()];
    sphere_texgen(p, pw, n, &mv, opts, &mut a).unwrap();
    sphere_texgen_f64(p, pw, n, &mv, opts, &mut b).unwrap();
    (a, b)
}

const ID: [[f64; 4]; 4] = [
    [1., 0., 0., 0.],
    [0., 1., 0., 0.],
    [0., 0., 1., 0.],
    [0., 0., 0., 1.],
];

proptest! {
    /// f32 fast path vs f64 reference on well-conditioned vertices (r away from (0,0,-1)).
    #[test]
    fn f32_tracks_f64(v in proptest::collection::vec(-3.0f32..3.0, 6), a in -3.0f64..3.0, sx in 0.3f64..3.0,
                      mode in 0usize..3) {
        let (c, s) = (a.cos(), a.sin());
        let m = [[c * sx, -s, 0.0, 0.1], [s * sx, c, 0.0, -0.2], [0.0, 0.0, 1.5, -8.0], [0.0, 0.0, 0.0, 1.0]];
        let opts = TexgenOptions { normalize: [NormalMode::On, NormalMode::Off, NormalMode::Rescale][mode], singular: Singular::Nan };
        let (p, n) = (&v[..3], &v[3..]);
        prop_assume!(n.iter().map(|x| x * x).sum::<f32>() > 0.01);
        let (f, d) = run(p, 3, n, m, opts);
        let rho = ((d[0] - 0.5).powi(2) + (d[1] - 0.5).powi(2)).sqrt();
        prop_assume!(rho < 0.49);
        for k in 0..2 { prop_assert!((f[k] as f64 - d[k]).abs() < 1e-5, "{f:?} vs {d:?}"); }
    }
}

#[test]
fn singular_patterns_nan_and_center() {
    // r = (0,0,-1), zero normal (normalize on), vertex at the eye.
    let p = [0.0, 0.0, -5.0, 0.3, 0.2, -4.0, 0.0, 0.0, 0.0];
    let n = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
    let (f, d) = run(&p, 3, &n, ID, TexgenOptions::default());
    assert!(f.iter().all(|v| v.is_nan()), "{f:?}");
    assert!(d.iter().all(|v| v.is_nan()), "{d:?}");
    let center = TexgenOptions {
        singular: Singular::Center,
        ..Default::default()
    };
    let (f, d) = run(&p, 3, &n, ID, center);
    // Legacy Mesa: m = 0 and the vertex at the eye give (½,½); a zero normal normalizes to zero,
    // so r = u, as with GL_NORMALIZE off.
    let off_zero = run(
        &p[3..6],
        3,
        &n[3..6],
        ID,
        TexgenOptions {
            normalize: NormalMode::Off,
            ..Default::default()
        },
    )
    .0;
    assert_eq!(f, vec![0.5, 0.5, off_zero[0], off_zero[1], 0.5, 0.5]);
    assert_eq!(
        d.iter().map(|v| *v as f32).collect::<Vec<_>>()[..2],
        [0.5, 0.5]
    );
    // Zero normal without GL_NORMALIZE: r = u, finite (as GL).
    let off = TexgenOptions {
        normalize: NormalMode::Off,
        ..Default::default()
    };
    let (f, _) = run(&p[3..6], 3, &n[3..6], ID, off);
    assert!(f.iter().all(|v| v.is_finite()));
    // Non-finite input propagates.
    let (f, _) = run(
        &[f32::NAN, 0.0, -1.0],
        3,
        &[0.0, 0.0, 1.0],
        ID,
        TexgenOptions::default(),
    );
    assert!(f.iter().all(|v| v.is_nan()));
}

#[test]
fn normal_off_is_not_normalized_like_gl() {
    // A uniformly scaled modelview shrinks the transformed normal: GL (normalize off) reflects
    // with the short normal, which differs from the normalized result.
    let mut m = ID;
    (0..3).for_each(|i| m[i][i] = 2.0);
    m[2][3] = -5.0;
    let p = [0.3, 0.2, 0.0];
    let l = (0.05f32 + 1.0).sqrt();
    let n = [0.2 / l, 0.1 / l, 1.0 / l];
    let on = run(&p, 3, &n, m, TexgenOptions::default()).0;
    let off = run(
        &p,
        3,
        &n,
        m,
        TexgenOptions {
            normalize: NormalMode::Off,
            ..Default::default()
        },
    )
    .0;
    let rescale = run(
        &p,
        3,
        &n,
        m,
        TexgenOptions {
            normalize: NormalMode::Rescale,
            ..Default::default()
        },
    )
    .0;
    assert!((on[0] - off[0]).abs() > 1e-3, "{on:?} {off:?}");
    // For a uniform scale, GL_RESCALE_NORMAL restores a unit normal's length, like GL_NORMALIZE.
    assert!((on[0] - rescale[0]).abs() < 1e-6 && (on[1] - rescale[1]).abs() < 1e-6);
}

#[test]
fn positions_with_w_and_errors() {
    let (a, _) = run(
        &[0.1, 0.2, -3.0, 1.0],
        4,
        &[0.0, 0.0, 1.0],
        ID,
        TexgenOptions::default(),
    );
    let (b, _) = run(
        &[0.1, 0.2, -3.0],
        3,
        &[0.0, 0.0, 1.0],
        ID,
        TexgenOptions::default(),
    );
    assert_eq!(a, b);
    let mv = ModelviewState::new(ID).unwrap();
    let mut out = vec![0.0f32; 2];
    let e = sphere_texgen(
        &[0.0f32; 3],
        3,
        &[0.0f32; 6],
        &mv,
        TexgenOptions::default(),
        &mut out,
    )
    .unwrap_err();
    assert!(e.to_string().starts_with("normals:"), "{e}");
    let e = sphere_texgen(
        &[0.0f32; 5],
        5,
        &[0.0f32; 3],
        &mv,
        TexgenOptions::default(),
        &mut out,
    )
    .unwrap_err();
    assert!(e.to_string().starts_with("positions:"), "{e}");
}

#[test]
fn matcap_variants() {
    let uv = matcap_uv([0.0f64, 0.0, 1.0], None, MatcapVariant::Classic, 0.5);
    assert_eq!(uv, [0.5, 0.5]);
    // Perspective: the normal facing the viewer maps to the centre wherever the point is.
    let p = [2.0f64, -1.0, -4.0];
    let l = (4.0f64 + 1.0 + 16.0).sqrt();
    let uv = matcap_uv(
        [-p[0] / l, -p[1] / l, -p[2] / l],
        Some(p),
        MatcapVariant::Perspective,
        0.5,
    );
    assert!(
        (uv[0] - 0.5).abs() < 1e-12 && (uv[1] - 0.5).abs() < 1e-12,
        "{uv:?}"
    );
    // Behind the viewer on the axis: undefined.
    assert!(matcap_uv(
        [0.0f64, 0.0, 1.0],
        Some([0.0, 0.0, 2.0]),
        MatcapVariant::Perspective,
        0.5
    )[0]
    .is_nan());
    assert!(matcap_uv([0.0f64, 0.0, 0.0], None, MatcapVariant::Classic, 0.5)[0].is_nan());
}
