#![allow(clippy::needless_range_loop)]
//! The conversion engine: furnace, energy, conventions chained through every pair, seams,
//! views, anti-aliasing, and f32 against f64.

use spheremap::frame::view;
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::{
    resample, resample_into, EnvMap, Filter, Outside, Precision, ResampleOptions, Taps,
};

mod common;
use common::max_diff;

fn mappings() -> Vec<Mapping> {
    [
        ("sphere", None),
        ("sphere", Some("skylibs")),
        ("latlong", None),
        ("latlong", Some("pbrt")),
        ("cube", None),
        ("cube", Some("d3d")),
        ("angular", None),
        ("paraboloid", None),
        ("octahedral", None),
    ]
    .iter()
    .map(|(n, p)| Mapping::parse(n, *p).unwrap())
    .collect()
}

/// A canvas of `m` with size `n` whose texels hold f(direction at the texel centre); 0 off the map.
fn fill(m: Mapping, n: usize, c: usize, f: impl Fn([f64; 3]) -> Vec<f64>) -> Image {
    let (w, h) = m.canvas(n);
    let mut img = Image::new(w, h, c);
    for y in 0..h {
        for x in 0..w {
            let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
            if let Some(d) = m.uv_to_dir(uv) {
                let v = f(d);
                for k in 0..c {
                    img.pixel_mut(x, y)[k] = v[k] as f32;
                }
            }
        }
    }
    img
}

fn nm(m: &Mapping) -> String {
    format!("{}:{}", m.name(), m.preset_name())
}

/// The one direction a disc source squeezes into its whole rim, if any.
fn singular(m: &Mapping) -> Option<[f64; 3]> {
    match m {
        Mapping::Sphere(p) => Some(p.from_eye([0.0, 0.0, -1.0])),
        Mapping::Angular => Some([0.0, 0.0, 1.0]),
        _ => None,
    }
}

fn convert(src: Mapping, img: &Image, dst: Mapping, n: usize, o: &ResampleOptions) -> Image {
    let e = EnvMap::new(src, img, "src").unwrap();
    let (w, h) = dst.canvas(n);
    resample(&e, dst, w, h, o, None).unwrap().0
}

fn opts(samples: u32) -> ResampleOptions {
    ResampleOptions {
        samples,
        ..Default::default()
    }
}

#[test]
fn furnace_every_pair_every_filter() {
    for src in mappings() {
        let img = fill(src, 24, 3, |_| vec![0.25, 1.0, 4.0]);
        for dst in mappings() {
            for (samples, filter) in [
                (1, Filter::Box),
                (4, Filter::Box),
                (9, Filter::Tent),
                (4, Filter::Gaussian),
            ] {
                let o = ResampleOptions {
                    samples,
                    filter,
                    ..Default::default()
                };
                let out = convert(src, &img, dst, 16, &o);
                for (i, v) in out.data.chunks(3).enumerate() {
                    let ok = (v[0] / 0.25 - 1.0).abs() < 1e-5
                        && (v[1] - 1.0).abs() < 1e-5
                        && (v[2] / 4.0 - 1.0).abs() < 1e-5;
                    assert!(
                        ok,
                        "{} -> {} samples {samples} {filter:?}: texel {i} = {v:?}",
                        nm(&src),
                        nm(&dst)
                    );
                }
            }
        }
    }
}

#[test]
fn black_outside_is_black_and_rims_are_partial() {
    let img = fill(Mapping::parse("latlong", None).unwrap(), 32, 1, |_| {
        vec![1.0]
    });
    let o = ResampleOptions {
        outside: Outside::Black,
        ..Default::default()
    };
    let out = convert(
        Mapping::parse("latlong", None).unwrap(),
        &img,
        Mapping::parse("sphere", None).unwrap(),
        32,
        &o,
    );
    assert_eq!(out.pixel(0, 0)[0], 0.0);
    assert_eq!(out.pixel(16, 16)[0], 1.0);
    // A texel the rim cuts holds its covered fraction: (27, 4) and its mirror images, whose
    // centres lie just outside the rim (r = 1.0165), so that it cuts them near the middle.
    // (Not the top texel (16, 0): the rim leaves ~2 % of it outside, which four samples
    // may all miss.)
    for (x, y) in [(27, 4), (4, 4), (27, 27), (4, 27)] {
        let rim = out.pixel(x, y)[0];
        assert!(rim > 0.0 && rim < 1.0, "({x}, {y}): {rim}");
    }
}

/// Energy: Σ L·Ω is preserved by the box filter when shrinking, every pair.  The environment's
/// integral is known: ∫(1 + 0.8x + 0.5y² + 0.3 sin 3z) dω = 4π(1 + 1/6).
#[test]
fn energy_is_preserved_when_shrinking() {
    let f = |d: [f64; 3]| vec![1.0 + 0.8 * d[0] + 0.5 * d[1] * d[1] + 0.3 * (3.0 * d[2]).sin()];
    let ea = 4.0 * std::f64::consts::PI * (1.0 + 1.0 / 6.0);
    for src in mappings() {
        let img = fill(src, 96, 1, f);
        for dst in mappings() {
            let out = convert(src, &img, dst, 24, &opts(16));
            let (w, h) = (out.width, out.height);
            let eb: f64 = dst
                .solid_angles(w, h)
                .iter()
                .zip(&out.data)
                .map(|(o, v)| o * *v as f64)
                .sum();
            let rel = (eb - ea).abs() / ea;
            assert!(
                rel < 2e-3,
                "{} -> {}: {ea} vs {eb} ({rel:.2e})",
                nm(&src),
                nm(&dst)
            );
        }
    }
}

/// Conventions chain through every pair: a map whose texels hold their own direction comes out
/// holding the destination texel's direction (up to bilinear interpolation error).
#[test]
fn directions_survive_every_pair() {
    for src in mappings() {
        let img = fill(src, 128, 3, |d| d.to_vec());
        for dst in mappings() {
            let out = convert(src, &img, dst, 16, &opts(1));
            let (w, h) = (out.width, out.height);
            let mut worst = 0.0f64;
            for y in 0..h {
                for x in 0..w {
                    let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
                    let Some(d) = dst.uv_to_dir(uv) else { continue };
                    let v = out.pixel(x, y);
                    let l = ((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) as f64).sqrt();
                    let dot = (0..3).map(|k| v[k] as f64 * d[k]).sum::<f64>() / l;
                    // A disc source squeezes one direction into its whole rim: there bilinear
                    // interpolation mixes far-apart directions (the ring 25° around it is the
                    // outer 1.5% of the disc's radius).  Skip it.
                    let ang = dot.clamp(-1.0, 1.0).acos().to_degrees();
                    let near_singular = singular(&src).is_some_and(|q| {
                        (0..3).map(|k| q[k] * d[k]).sum::<f64>() > 25f64.to_radians().cos()
                    });
                    if !near_singular {
                        worst = worst.max(ang);
                    }
                }
            }
            assert!(
                worst < 2.0,
                "{} -> {}: worst {worst:.3}°",
                nm(&src),
                nm(&dst)
            );
        }
    }
}

#[test]
fn views_rotate_the_output() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let sp = Mapping::parse("sphere", None).unwrap();
    let img = fill(ll, 128, 3, |d| d.to_vec());
    // Looking along +X: the sphere map's centre shows the direction back at the viewer, −X.
    let rot = view::look_up([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]).unwrap();
    let o = ResampleOptions {
        samples: 1,
        rotation: rot,
        ..Default::default()
    };
    let out = convert(ll, &img, sp, 64, &o);
    let c = out.pixel(32, 32);
    assert!(c[0] < -0.99, "{c:?}");
    // And +Z (the eye's right) sits at s ≈ 0.854, the middle row.
    let r = out.pixel(54, 32);
    assert!(r[2] > 0.97, "{r:?}");
}

#[test]
fn f32_fast_path_matches_f64_reference() {
    let f = |d: [f64; 3]| vec![(4.0 * d[0]).sin() + d[1], (3.0 * d[2]).cos(), d[0] * d[1]];
    for (src, dst) in [
        ("latlong", "sphere"),
        ("cube", "sphere"),
        ("sphere", "latlong"),
        ("octahedral", "paraboloid"),
    ] {
        let (src, dst) = (
            Mapping::parse(src, None).unwrap(),
            Mapping::parse(dst, None).unwrap(),
        );
        let img = fill(src, 64, 3, f);
        // (8, 1024): adaptive strata; (16, 16): prefiltered levels at the rim; tent and
        // black: weighted samples and lanes off the disc, through the same vectorized chunks.
        let (bx, gutter) = (Filter::Box, Outside::Gutter);
        for (samples, max_samples, filter, outside) in [
            (1, 1024, bx, gutter),
            (8, 1024, bx, gutter),
            (16, 16, bx, gutter),
            (4, 1024, Filter::Tent, Outside::Black),
            (9, 9, Filter::Gaussian, gutter),
        ] {
            let o = ResampleOptions {
                samples,
                max_samples,
                filter,
                outside,
                ..Default::default()
            };
            let a = convert(src, &img, dst, 48, &o);
            let b = convert(
                src,
                &img,
                dst,
                48,
                &ResampleOptions {
                    precision: Precision::F64,
                    ..o
                },
            );
            let (mut worst, mut at) = (0.0f32, 0);
            for (i, (x, y)) in a.data.iter().zip(&b.data).enumerate() {
                if (x - y).abs() > worst {
                    (worst, at) = ((x - y).abs(), i / 3);
                }
            }
            assert!(
                worst < 2e-3,
                "{} -> {} samples {samples} {filter:?} {outside:?}: {worst} at texel ({}, {})",
                nm(&src),
                nm(&dst),
                at % a.width,
                at / a.width
            );
        }
    }
}

/// The f32 path takes the very samples of the f64 reference: on a source that varies fast
/// within an output texel's footprint, a sample moved within its stratum moves the texel's
/// value by far more than 1e-3, and the two paths' arithmetic differs by far less.  Odd and
/// even canvases (the jitter's mirror symmetry has a middle texel on odd ones), the default
/// view (where the filtered path folds the canvas's mirrors) and a turned one, the common
/// strata grid and adaptive strata, lat-long and sphere-map destinations.
#[test]
fn f32_and_f64_take_the_same_samples() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let f = |d: [f64; 3]| {
        let (u, v) = (d[2].atan2(d[0]), d[1].acos());
        vec![
            (9.0 * u).sin() * (11.0 * v).cos() + 1.0,
            (13.0 * u + 7.0 * v).cos(),
        ]
    };
    let img = fill(ll, 128, 2, f);
    let turned = view::look_up([0.3, 0.2, -1.0], [0.0, 1.0, 0.0]).unwrap();
    for dst in ["sphere", "latlong"] {
        let dst = Mapping::parse(dst, None).unwrap();
        for n in [31, 32] {
            for rotation in [view::IDENTITY, turned] {
                for (samples, max_samples) in [(16, 16), (4, 1024), (9, 9)] {
                    let o = ResampleOptions {
                        samples,
                        max_samples,
                        rotation,
                        ..Default::default()
                    };
                    let a = convert(ll, &img, dst, n, &o);
                    let r = ResampleOptions {
                        precision: Precision::F64,
                        ..o
                    };
                    let b = convert(ll, &img, dst, n, &r);
                    let worst = max_diff(&a, &b);
                    let what = format!("{} {n} {samples}/{max_samples}", nm(&dst));
                    assert!(
                        worst < 1e-3,
                        "{what} turned {}: {worst}",
                        rotation != view::IDENTITY
                    );
                }
            }
        }
    }
}

/// A 2-px checkerboard lat-long (1024×512) and the rms difference, over the disc of a 32²
/// sphere map, of a conversion of it from a brute-force 4096-sample reference.
#[test]
fn integer_shrinks_and_pole_edges_agree_in_both_precisions() {
    // A lat-long shrunk 16× and 64× (integer ratios: footprints of exactly 16 or 64 texels)
    // whose bottom texel edges lie on the south pole: the strata counts and the levels must
    // not depend on rounding, so f32 and f64 sample alike. Fine detail makes any difference
    // in where they sample show.
    let ll = Mapping::parse("latlong", None).unwrap();
    let img = fill(ll, 256, 3, |d| {
        let h = (97.0 * d[0] + 31.0 * d[1]).sin() * (71.0 * d[2] + 13.0 * d[1]).cos();
        vec![h, (53.0 * d[1]).sin(), d[0] * (89.0 * d[2]).sin()]
    });
    for (n, samples, max_samples) in [(16, 4, 4096), (16, 4, 1024), (4, 4, 4), (4, 4, 4096)] {
        let o = ResampleOptions {
            samples,
            max_samples,
            ..Default::default()
        };
        let a = convert(ll, &img, ll, n, &o);
        let b = convert(
            ll,
            &img,
            ll,
            n,
            &ResampleOptions {
                precision: Precision::F64,
                ..o
            },
        );
        let worst = max_diff(&a, &b);
        assert!(
            worst < 1e-4,
            "size {n}, samples {samples}/{max_samples}: {worst}"
        );
    }
}

fn checkerboard_vs_reference() -> (Image, impl Fn(&Image) -> f64) {
    let ll = Mapping::parse("latlong", None).unwrap();
    let sp = Mapping::parse("sphere", None).unwrap();
    let (w, h) = (1024, 512);
    let mut img = Image::new(w, h, 1);
    for y in 0..h {
        for x in 0..w {
            img.data[y * w + x] = ((x / 2 + y / 2) % 2) as f32;
        }
    }
    let reference = convert(
        ll,
        &img,
        sp,
        32,
        &ResampleOptions {
            samples: 4096,
            max_samples: 4096,
            ..Default::default()
        },
    );
    let rms = move |o: &Image| {
        let (mut e, mut n) = (0.0f64, 0);
        for y in 0..32 {
            for x in 0..32 {
                let (a, b) = (x as f64 - 15.5, y as f64 - 15.5);
                if a.hypot(b) < 15.0 {
                    e += (o.pixel(x, y)[0] - reference.pixel(x, y)[0]).powi(2) as f64;
                    n += 1;
                }
            }
        }
        (e / n as f64).sqrt()
    };
    (img, rms)
}

/// A fine checkerboard shrunk into a small sphere map: one sample per texel aliases, the
/// adaptive default does not (it agrees with a brute-force 64×64-sample reference).
#[test]
fn adaptive_sampling_does_not_alias() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let sp = Mapping::parse("sphere", None).unwrap();
    let (img, err) = checkerboard_vs_reference();
    let one = err(&convert(ll, &img, sp, 32, &opts(1)));
    let adaptive = err(&convert(ll, &img, sp, 32, &ResampleOptions::default()));
    assert!(one > 0.2, "one sample should alias: rms {one}");
    assert!(
        adaptive < 0.03,
        "adaptive rms {adaptive} (one sample: {one})"
    );
}

/// The same checkerboard with the samples capped (`max_samples = samples`): the prefiltered
/// levels take over where the samples cannot cover the footprint, and the result still does
/// not alias. (Less sharp than supersampling: a box pyramid read trilinearly.)
#[test]
fn prefiltered_levels_do_not_alias() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let sp = Mapping::parse("sphere", None).unwrap();
    let (img, rms) = checkerboard_vs_reference();
    for s in [4, 16] {
        let o = ResampleOptions {
            samples: s,
            max_samples: s,
            ..Default::default()
        };
        let (out, report) = spheremap::resample::resample(
            &EnvMap::new(ll, &img, "src").unwrap(),
            sp,
            32,
            32,
            &o,
            None,
        )
        .unwrap();
        assert_eq!(report.max_texel_samples, s);
        let e = rms(&out);
        eprintln!("samples {s}: rms {e}");
        assert!(e < 0.03, "samples {s}: rms {e}");
    }
}

#[test]
fn deterministic_for_a_seed() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let img = fill(ll, 64, 1, |d| vec![(9.0 * d[0]).sin()]);
    let sp = Mapping::parse("sphere", None).unwrap();
    let a = convert(ll, &img, sp, 32, &opts(8));
    let b = convert(ll, &img, sp, 32, &opts(8));
    assert_eq!(a.data, b.data);
    let c = convert(ll, &img, sp, 32, &ResampleOptions { seed: 7, ..opts(8) });
    assert_ne!(a.data, c.data);
}

#[test]
fn resample_into_writes_every_value_of_the_same_result() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let img = fill(ll, 64, 3, |d| {
        vec![d[0] + 2.0, d[1] * d[2], (5.0 * d[2]).cos()]
    });
    let e = EnvMap::new(ll, &img, "src").unwrap();
    for dst in mappings() {
        let (w, h) = dst.canvas(16);
        for o in [
            opts(1),
            opts(4),
            ResampleOptions {
                precision: Precision::F64,
                ..opts(4)
            },
        ] {
            let (want, r1) = resample(&e, dst, w, h, &o, None).unwrap();
            // NaN first: a value left unwritten would show.
            let mut buf = vec![f32::NAN; w * h * 3];
            let r2 = resample_into(&e, dst, w, h, &o, None, &mut buf).unwrap();
            assert_eq!(buf, want.data, "{}", nm(&dst));
            assert_eq!(r1, r2);
        }
    }
    let sp = Mapping::parse("sphere", None).unwrap();
    let mut short = vec![0.0f32; 16 * 16 * 3 - 1];
    let err = resample_into(&e, sp, 16, 16, &opts(1), None, &mut short)
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("out:"), "{err}");
}

#[test]
fn bad_parameters_are_named() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let img = fill(ll, 8, 1, |_| vec![1.0]);
    let e = EnvMap::new(ll, &img, "src").unwrap();
    let sp = Mapping::parse("sphere", None).unwrap();
    let err = resample(&e, sp, 8, 9, &opts(1), None)
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("size:"), "{err}");
    let err = resample(&e, sp, 8, 8, &opts(0), None)
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("samples:"), "{err}");
    let bad = ResampleOptions {
        rotation: [[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        ..opts(1)
    };
    let err = resample(&e, sp, 8, 8, &bad, None).unwrap_err().to_string();
    assert!(err.starts_with("rotation:"), "{err}");
    let sq = Image::new(8, 8, 1);
    let err = EnvMap::new(Mapping::parse("cube", None).unwrap(), &sq, "in.exr")
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("in.exr: a cube map is"), "{err}");
}

/// The two ways to the prefiltered levels: a small source builds its whole pyramid; under a
/// tight `max_memory` the footprint pre-pass builds only the rows its texels read (so those
/// levels are partial: the tap-row tables, not the plain layout).  Same result, both
/// precisions.
#[test]
fn partial_levels_give_the_whole_pyramids_result() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let img = fill(ll, 256, 3, |d| {
        vec![
            (9.0 * d[0]).sin() * (7.0 * d[1]).cos(),
            d[2],
            (5.0 * d[1]).sin(),
        ]
    });
    let e = EnvMap::new(ll, &img, "src").unwrap();
    for precision in [Precision::F32, Precision::F64] {
        let o = ResampleOptions {
            samples: 16,
            max_samples: 16,
            // Tipped on its side: only the texels that see the source's poles (whose
            // columns crowd together) read its deeper levels, from its top and bottom rows.
            rotation: view::look_up([0.0, -1.0, 0.0], [0.0, 0.0, -1.0]).unwrap(),
            precision,
            ..Default::default()
        };
        let run = |m: Mapping, n: usize, max_memory: u64| {
            let (w, h) = m.canvas(n);
            resample(&e, m, w, h, &ResampleOptions { max_memory, ..o }, None)
        };
        // The smallest budget a job runs in, less its output's share (twice the output).
        let least = |m: Mapping, n: usize| {
            let (w, h) = m.canvas(n);
            let out = 2 * (w * h * 3 * 4) as u64;
            let (mut lo, mut hi) = (out, out + (64 << 20));
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if run(m, n, mid).is_ok() {
                    hi = mid
                } else {
                    lo = mid
                }
            }
            (hi, hi - out)
        };
        // A 32× shrink reads every row of the deep levels: the whole pyramid.
        let (_, whole) = least(ll, 8);
        let (budget, part) = least(ll, 128);
        assert!(
            part < whole * 9 / 10,
            "{precision:?}: the pre-pass kept {part} bytes of the pyramid's {whole}"
        );
        let full = run(ll, 128, u64::MAX).unwrap().0;
        let partial = run(ll, 128, budget).unwrap().0;
        let worst = full
            .data
            .iter()
            .zip(&partial.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst == 0.0, "{precision:?}: {worst}");
    }
}

/// Texels whose samples are a texel apart up to the strata count's slack (a footprint of
/// 2.0005 texels across two strata) read level 0 only: with the default adaptive sampling,
/// a lat-long → sphere-map conversion builds only the level-1 rows the sphere map's rim reads,
/// not the whole level (a whole level there costs 1.24× input + output at 8192×4096 → 4096²).
#[test]
fn footprints_a_hair_over_an_integer_build_no_levels() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let sp = Mapping::parse("sphere", None).unwrap();
    let img = fill(ll, 512, 3, |d| vec![d[0], d[1], d[2]]);
    let e = EnvMap::new(ll, &img, "src").unwrap();
    let n = 512;
    let out = 2 * (n * n * 3 * 4) as u64;
    let run = |max_memory: u64| {
        let o = ResampleOptions {
            max_memory,
            ..Default::default()
        };
        resample(&e, sp, n, n, &o, None)
    };
    // The smallest budget the job runs in, less its output's share.
    let (mut lo, mut hi) = (out, out + (64 << 20));
    while hi - lo > 4096 {
        let mid = (lo + hi) / 2;
        if run(mid).is_ok() {
            hi = mid
        } else {
            lo = mid
        }
    }
    let level1 = ((img.width / 2) * (img.height / 2) * 3 * 4) as u64;
    assert!(
        hi - out < level1 / 2,
        "levels {} of level 1's {level1}",
        hi - out
    );
}

/// Canvases as small as each mapping allows (1×1 and up; lat-longs of any aspect), every
/// pair, on the one-sample vector path and the filtered path (16 samples and up), both
/// precisions, both outsides, turned and not.  (The prefiltered levels, which these small
/// footprints do not reach, have their own tests above.)  A source of per-channel
/// constants must come out as those constants (black outside: between 0 and them) — a tap
/// read past a row, a plane or the data, or from the wrong channel, would show.
#[test]
fn tiny_canvases_every_pair_every_path() {
    let turned = view::yaw_pitch_roll(0.3, -0.7, 1.1).unwrap();
    let mut jobs = 0;
    for src in mappings() {
        let shapes: Vec<(usize, usize)> = match src {
            Mapping::LatLong(_) => vec![(1, 1), (2, 1), (1, 3), (3, 2), (5, 5)],
            _ => [1, 2, 3, 5].iter().map(|&n| src.canvas(n)).collect(),
        };
        for (sw, sh) in shapes {
            for c in [1, 3, 4] {
                let k = [1.0f32, 2.0, 3.0, 4.0];
                let mut img = Image::new(sw, sh, c);
                for (i, v) in img.data.iter_mut().enumerate() {
                    *v = k[i % c];
                }
                let e = EnvMap::new(src, &img, "src").unwrap();
                for dst in mappings() {
                    for (n, samples) in [(1, 1), (3, 1), (2, 16), (5, 16)] {
                        let (w, h) = dst.canvas(n);
                        for outside in [Outside::Gutter, Outside::Black] {
                            for precision in [Precision::F32, Precision::F64] {
                                for rotation in [spheremap::resample::IDENTITY, turned] {
                                    let o = ResampleOptions {
                                        samples,
                                        max_samples: 64,
                                        outside,
                                        precision,
                                        rotation,
                                        ..Default::default()
                                    };
                                    let out = resample(&e, dst, w, h, &o, None).unwrap().0;
                                    jobs += 1;
                                    for (i, &v) in out.data.iter().enumerate() {
                                        let want = k[i % c];
                                        let ok = match outside {
                                            Outside::Gutter => (v - want).abs() <= 1e-5 * want,
                                            Outside::Black => {
                                                (0.0..=want * (1.0 + 1e-5)).contains(&v)
                                            }
                                        };
                                        assert!(
                                            ok,
                                            "{} {sw}x{sh}x{c} -> {} {w}x{h}, {samples} samples, \
                                             {outside:?}, {precision:?}: value {i} is {v}, not {want}",
                                            nm(&src),
                                            nm(&dst)
                                        );
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(jobs > 10_000, "{jobs}");
}

/// Bicubic taps reconstruct a smooth map far better than bilinear ones where the output is
/// finer than the input (every mapping into every other at twice the size, one centre sample),
/// and the f32 and f64 paths agree.
#[test]
fn bicubic_taps_are_sharper_where_the_output_is_finer() {
    // Smooth, but with enough curvature over a texel for bilinear to show it.
    let f = |d: [f64; 3]| {
        let v = (3.0 * d[0]).sin() * (2.0 * d[1]).cos() + 0.5 * d[2] * d[2];
        vec![v, 1.0 - v, 0.25]
    };
    let n = 32;
    for src in mappings() {
        let img = fill(src, n, 3, f);
        for dst in [
            Mapping::parse("latlong", None).unwrap(),
            Mapping::parse("sphere", None).unwrap(),
            Mapping::parse("cube", None).unwrap(),
        ] {
            let want = fill(dst, 2 * n, 3, f);
            // Texels whose centre is on the map, away from a disc's rim (bilinear there) and the
            // source's singular direction.
            let err = |o: &ResampleOptions| {
                let out = convert(src, &img, dst, 2 * n, o);
                let (w, h) = dst.canvas(2 * n);
                let mut e = Vec::new();
                for y in 0..h {
                    for x in 0..w {
                        let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
                        let Some(d) = dst.uv_to_dir(uv) else { continue };
                        if let Some(s) = singular(&src) {
                            let c = d[0] * s[0] + d[1] * s[1] + d[2] * s[2];
                            if c > 0.0 {
                                continue; // the disc's outer ring, compressed towards its rim
                            }
                        }
                        if src.name() == "paraboloid" && d[2].abs() < 0.3 {
                            continue; // near the paraboloid's rims
                        }
                        e.push((out.pixel(x, y)[0] - want.pixel(x, y)[0]).abs() as f64);
                    }
                }
                let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt();
                (rms, e.len())
            };
            let cubic = ResampleOptions {
                taps: Taps::Bicubic,
                ..opts(1)
            };
            let bil = err(&opts(1));
            let cub = err(&cubic);
            assert!(bil.1 > 100, "{} -> {}", nm(&src), nm(&dst));
            // Measured: an eighth of bilinear's error on the smooth canvases; on the cube's and
            // the octahedral map's, whose canvas is creased where faces meet, a quarter to a half.
            let bound = match src.name() {
                "cube" | "octahedral" => 0.7,
                _ => 0.2,
            };
            assert!(
                cub.0 < bound * bil.0,
                "{} -> {}: bicubic RMS {:.2e} vs bilinear {:.2e}",
                nm(&src),
                nm(&dst),
                cub.0,
                bil.0
            );
            // The f32 path against the f64 reference, with bicubic taps.
            let a = convert(src, &img, dst, 2 * n, &cubic);
            let f64_cubic = ResampleOptions {
                precision: Precision::F64,
                ..cubic
            };
            let b = convert(src, &img, dst, 2 * n, &f64_cubic);
            assert!(max_diff(&a, &b) < 2e-3, "{} -> {}", nm(&src), nm(&dst));
        }
    }
}

/// Bicubic taps read a texel centre exactly (interpolating), never ring past the nearest
/// texels' range (a hard step stays within [0, 1]; a positive map stays positive), and with
/// several samples per texel still conserve a constant map.
#[test]
fn bicubic_taps_interpolate_and_do_not_ring() {
    let ll = Mapping::parse("latlong", None).unwrap();
    let (w, h) = ll.canvas(32);
    let mut img = Image::new(w, h, 1);
    for y in 0..h {
        for x in 0..w {
            img.pixel_mut(x, y)[0] = if (x / 5 + y / 3) % 2 == 0 { 1.0 } else { 0.0 };
        }
    }
    let cub = |samples, n| {
        convert(
            ll,
            &img,
            ll,
            n,
            &ResampleOptions {
                taps: Taps::Bicubic,
                // The taps' own range (keeping the light scales the sampled part by a gain
                // within a fraction of a percent of 1).
                conserve: false,
                ..opts(samples)
            },
        )
    };
    // A one-texel yaw: every output centre lies on an input centre.
    let e = EnvMap::new(ll, &img, "src").unwrap();
    let turn =
        view::conversion_rotation(None, None, Some([360.0 / w as f64, 0.0, 0.0]), None, None)
            .unwrap();
    let o = ResampleOptions {
        taps: Taps::Bicubic,
        rotation: turn,
        ..opts(1)
    };
    let (out, _) = resample(&e, ll, w, h, &o, None).unwrap();
    for y in 0..h {
        for x in 0..w {
            let v = out.pixel(x, y)[0];
            let want = img.pixel((x + 1) % w, y)[0];
            let want2 = img.pixel((x + w - 1) % w, y)[0];
            assert!(
                (v - want).abs() < 1e-4 || (v - want2).abs() < 1e-4,
                "({x}, {y}) {v}"
            );
        }
    }
    for (samples, n) in [(1, 64), (4, 64), (1, 45), (16, 16)] {
        let out = cub(samples, n);
        assert!(
            out.data.iter().all(|v| (0.0..=1.0).contains(v)),
            "{samples} samples, N {n}"
        );
    }
    // A constant map stays constant through the 4×4 weights (they sum to 1).
    let mut one = Image::new(w, h, 1);
    one.data.fill(0.7);
    for dst in mappings() {
        let out = convert(
            ll,
            &one,
            dst,
            24,
            &ResampleOptions {
                taps: Taps::Bicubic,
                ..opts(4)
            },
        );
        let (dw, dh) = dst.canvas(24);
        for y in 0..dh {
            for x in 0..dw {
                let uv = [(x as f64 + 0.5) / dw as f64, (y as f64 + 0.5) / dh as f64];
                if dst.uv_to_dir(uv).is_some() {
                    assert!((out.pixel(x, y)[0] - 0.7).abs() < 1e-5, "{}", nm(&dst));
                }
            }
        }
    }
    assert_eq!(Taps::parse("bicubic").unwrap(), Taps::Bicubic);
    assert!(Taps::parse("lanczos")
        .unwrap_err()
        .to_string()
        .contains("taps"));
}
