use proptest::prelude::*;
use spheremap::frame::conventions::Singular;
use spheremap::mappings::sphere::{
    dir_to_st, reflect, solid_angle_map, st_to_dir, texel_solid_angle,
};
use std::f64::consts::PI;

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

proptest! {
    #[test]
    fn dir_st_dir_round_trip(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
        prop_assume!(x * x + y * y + z * z > 1e-6);
        let d = unit([x, y, z]);
        prop_assume!(x * x + y * y > 1e-12 || d[2] > 0.0);
        let st = dir_to_st(d, Singular::Nan);
        prop_assert!((0.0..=1.0).contains(&st[0]) && (0.0..=1.0).contains(&st[1]));
        let back = st_to_dir(st).unwrap();
        // The inverse loses accuracy only in proportion to the map's own stretch at the rim.
        let tol = 1e-12 / (1.0 + d[2]).max(1e-4);
        for k in 0..3 { prop_assert!((back[k] - d[k]).abs() < tol.max(1e-12), "{d:?} -> {st:?} -> {back:?}"); }
    }

    #[test]
    fn st_dir_st_round_trip(s in 0.0f64..1.0, t in 0.0f64..1.0) {
        let (x, y) = (2.0 * s - 1.0, 2.0 * t - 1.0);
        match st_to_dir([s, t]) {
            None => prop_assert!(x * x + y * y > 1.0),
            Some(d) => {
                prop_assume!(x * x + y * y < 1.0 - 1e-9);
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                prop_assert!((l - 1.0).abs() < 1e-14);
                let st = dir_to_st(d, Singular::Nan);
                prop_assert!((st[0] - s).abs() < 1e-9 && (st[1] - t).abs() < 1e-9, "{s},{t} -> {d:?} -> {st:?}");
            }
        }
    }

    /// The f32 path agrees with the f64 reference to a few f32 ulps of the disc coordinate.
    #[test]
    fn f32_matches_f64(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
        prop_assume!(x * x + y * y + z * z > 1e-4);
        let d = unit([x, y, z]);
        prop_assume!(d[2] > -0.9999);
        let a = dir_to_st(d, Singular::Nan);
        let b = dir_to_st(d.map(|v| v as f32), Singular::Nan);
        for k in 0..2 { prop_assert!((a[k] - b[k] as f64).abs() < 4e-7, "{d:?}: {a:?} vs {b:?}"); }
        let s = [a[0] as f32, a[1] as f32];
        if let (Some(p), Some(q)) = (st_to_dir(a), st_to_dir(s)) {
            let err: f64 = (0..3).map(|k| (p[k] - q[k] as f64).powi(2)).sum::<f64>().sqrt();
            // |dr/dst| grows like 1/sqrt(1 - d) toward the rim.
            let rho2 = (2.0 * a[0] - 1.0).powi(2) + (2.0 * a[1] - 1.0).powi(2);
            prop_assert!(err < 2e-6 / (1.0 - rho2).sqrt().max(1e-3), "{a:?}: {err}");
        }
    }

    /// Reflection keeps length for unit n, and reflecting twice is the identity.
    #[test]
    fn reflect_involution(ux in -1.0f64..1.0, uy in -1.0f64..1.0, uz in -1.0f64..1.0,
                          nx in -1.0f64..1.0, ny in -1.0f64..1.0, nz in -1.0f64..1.0) {
        prop_assume!(nx * nx + ny * ny + nz * nz > 1e-3);
        let n = unit([nx, ny, nz]);
        let u = [ux, uy, uz];
        let r = reflect(reflect(u, n), n);
        for k in 0..3 { prop_assert!((r[k] - u[k]).abs() < 1e-12); }
    }
}

#[test]
fn centre_rim_and_outside() {
    assert_eq!(dir_to_st([0.0, 0.0, 1.0], Singular::Nan), [0.5, 0.5]);
    assert!(dir_to_st([0.0f64, 0.0, -1.0], Singular::Nan)[0].is_nan());
    assert_eq!(dir_to_st([0.0, 0.0, -3.0], Singular::Center), [0.5, 0.5]);
    assert!(dir_to_st([0.0f64, 0.0, 0.0], Singular::Center)[0].is_nan());
    assert!(dir_to_st([f64::NAN, 0.0, 1.0], Singular::Center)[0].is_nan());
    assert!(dir_to_st([f64::INFINITY, 0.0, 1.0], Singular::Nan)[0].is_nan());
    // Every point of the rim is (0,0,-1).
    for k in 0..360 {
        let a = (k as f64).to_radians();
        let r = 0.5 * (1.0 - 1e-15);
        let d = st_to_dir([0.5 + r * a.cos(), 0.5 + r * a.sin()]).unwrap();
        assert!(
            d[0].abs() < 1e-6 && d[1].abs() < 1e-6 && (d[2] + 1.0).abs() < 1e-12,
            "{d:?}"
        );
    }
    // Just off -Z lands just inside the rim, on the side of its x/y (no cancellation).
    let st = dir_to_st([1e-9f64, 0.0, -1.0], Singular::Nan);
    assert!(
        (st[0] - 1.0).abs() < 1e-15 && (st[1] - 0.5).abs() < 1e-15,
        "{st:?}"
    );
    assert!(st_to_dir([0.0, 0.0]).is_none());
    assert!(st_to_dir([1.0, 1.0]).is_none());
    assert!(st_to_dir([f64::NAN, 0.5]).is_none());
}

#[test]
fn solid_angles_sum_to_4pi_and_interior_is_16_over_n2() {
    for n in [1usize, 2, 3, 7, 64, 255, 512] {
        let m = solid_angle_map(n);
        let sum: f64 = m.iter().sum();
        assert!((sum - 4.0 * PI).abs() < 1e-9, "n={n}: {sum}");
        let full = 16.0 / (n * n) as f64;
        for row in 0..n {
            for col in 0..n {
                // A texel wholly inside the disc: its farthest corner within radius 1.
                let f = |i: usize| {
                    let a = (2.0 * i as f64 / n as f64 - 1.0).abs();
                    let b = (2.0 * (i + 1) as f64 / n as f64 - 1.0).abs();
                    a.max(b)
                };
                let v = m[row * n + col];
                if f(col).powi(2) + f(row).powi(2) <= 1.0 {
                    assert!(
                        (v - full).abs() < 1e-15 * full.max(1.0),
                        "n={n} ({col},{row}): {v}"
                    );
                }
                assert!(v >= 0.0 && v <= full * (1.0 + 1e-12));
            }
        }
    }
    // Symmetric under the flips that presets apply.
    assert_eq!(texel_solid_angle(3, 10, 64), texel_solid_angle(60, 10, 64));
    assert_eq!(texel_solid_angle(3, 10, 64), texel_solid_angle(3, 53, 64));
}

#[test]
fn solid_angle_matches_brute_force_at_the_rim() {
    // Monte Carlo-free check: integrate the Jacobian |dω/dsdt| = 16 on a fine grid inside the
    // disc, for a rim texel.
    let n = 16;
    let (col, row) = (14usize, 4usize);
    let k = 2000;
    let mut inside = 0usize;
    for a in 0..k {
        for b in 0..k {
            let s = (col as f64 + (a as f64 + 0.5) / k as f64) / n as f64;
            let t = (row as f64 + (b as f64 + 0.5) / k as f64) / n as f64;
            if st_to_dir([s, t]).is_some() {
                inside += 1;
            }
        }
    }
    let brute = 16.0 * inside as f64 / (k * k) as f64 / (n * n) as f64;
    let exact = texel_solid_angle(col, row, n);
    assert!((brute - exact).abs() < 1e-5, "{brute} vs {exact}");
    assert!(exact > 0.0 && exact < 16.0 / 256.0);
}
