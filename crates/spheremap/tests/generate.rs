//! The ray-traced generator: analytic scenes with known answers, determinism, convergence,
//! the environment-map and closure sources, the cube-face route, scene files.

use spheremap::images::Image;
use spheremap::resample::{self, EnvMap, Outside, Precision, ResampleOptions};
use spheremap::trace::generate::{
    generate, generate_all, planned_rays, EnvSource, FnSource, GenerateOptions, RaySource,
};
use spheremap::trace::scene::{
    self, Environment, Light, Material, SceneBuilder, Shading, TriangleInput,
};
use spheremap::Mapping;

const SPHERE: Mapping = Mapping::Sphere(&spheremap::PRESETS[0]);

/// The world direction of a canvas point of a sphere map made with `rot`.
fn world_dir(rot: &[[f64; 3]; 3], n: usize, px: f64, py: f64) -> Option<[f64; 3]> {
    let d = SPHERE.uv_to_dir([px / n as f64, py / n as f64])?;
    Some([0, 1, 2].map(|i| rot[i][0] * d[0] + rot[i][1] * d[1] + rot[i][2] * d[2]))
}

fn opts(samples: u32) -> GenerateOptions {
    GenerateOptions {
        samples,
        ..GenerateOptions::default()
    }
}

fn views() -> Vec<[[f64; 3]; 3]> {
    vec![
        resample::IDENTITY,
        spheremap::frame::view::look_up([0.3, -0.5, -1.0], [0.0, 1.0, 0.0]).unwrap(),
        spheremap::frame::view::look_up([1.0, 0.2, 0.1], [0.1, 0.3, 1.0]).unwrap(),
    ]
}

/// Inside the octant sphere, one ray per texel returns exactly its octant's colour.
#[test]
fn octant_sphere_one_ray_is_exact() {
    let sc = scene::octant_sphere_scene(10.0, 6);
    let n = 128;
    for rot in views() {
        let o = GenerateOptions {
            rotation: rot,
            ..opts(1)
        };
        let (img, rep) = generate(SPHERE, n, n, &sc, &o, None).unwrap();
        assert_eq!(rep.max_texel_samples, 1);
        let mut checked = 0;
        for y in 0..n {
            for x in 0..n {
                let Some(d) = world_dir(&rot, n, x as f64 + 0.5, y as f64 + 0.5) else {
                    continue;
                };
                if d.iter().any(|v| v.abs() < 1e-4) {
                    continue;
                }
                let want = scene::octant_colour(d.map(|v| v as f32));
                assert_eq!(img.pixel(x, y), &want[..], "texel ({x},{y}) dir {d:?}");
                checked += 1;
            }
        }
        assert!(checked > 12_000, "{checked}");
        assert_eq!(rep.texels, checked as u64 + rep.texels - checked as u64);
    }
}

/// With many rays, a texel whose whole footprint lies in one octant is exactly that colour;
/// a texel across a boundary is a mixture of the two sides.
#[test]
fn octant_sphere_box_filter_is_exact_inside_and_mixes_at_edges() {
    let sc = scene::octant_sphere_scene(10.0, 6);
    let n = 96;
    let rot = views()[1];
    let o = GenerateOptions {
        rotation: rot,
        ..opts(16)
    };
    let (img, rep) = generate(SPHERE, n, n, &sc, &o, None).unwrap();
    assert!(rep.max_texel_samples > 16, "the rim must get more rays");
    let (mut inside, mut mixed) = (0, 0);
    for y in 0..n {
        for x in 0..n {
            // The octants seen at a 9×9 grid over the texel.
            let mut seen = std::collections::HashSet::new();
            let mut all_on = true;
            for j in 0..9 {
                for i in 0..9 {
                    let (px, py) = (x as f64 + i as f64 / 8.0, y as f64 + j as f64 / 8.0);
                    match world_dir(&rot, n, px, py) {
                        Some(d) => {
                            seen.insert(d.map(|v| v > 0.0));
                        }
                        None => all_on = false,
                    }
                }
            }
            if !all_on {
                continue;
            }
            let px = img.pixel(x, y);
            if seen.len() == 1 {
                let d = world_dir(&rot, n, x as f64 + 0.5, y as f64 + 0.5).unwrap();
                let want = scene::octant_colour(d.map(|v| v as f32));
                for c in 0..3 {
                    assert!((px[c] - want[c]).abs() < 1e-6, "({x},{y}) {px:?} {want:?}");
                }
                inside += 1;
            } else {
                // Each channel lies between ¼ and 1 and is not both-sided at once.
                assert!(px.iter().all(|&v| (0.25 - 1e-6..=1.0 + 1e-6).contains(&v)));
                mixed += 1;
            }
        }
    }
    assert!(inside > 5000 && mixed > 200, "{inside} {mixed}");
}

/// An emissive floor under the eye: a texel sees it exactly when its reflected direction
/// points down — for the default view, exactly the lower half of the disc (R_y = 2 n_z b).
#[test]
fn emissive_floor_is_seen_by_the_lower_half() {
    let floor = [0.9f32, 0.5, 0.1];
    let sky = [0.1f32, 0.2, 0.7];
    let sc = scene::floor_scene(-1.0, 1e5, floor, sky);
    let n = 128;
    for rot in views() {
        for samples in [1, 16] {
            let o = GenerateOptions {
                rotation: rot,
                ..opts(samples)
            };
            let (img, _) = generate(SPHERE, n, n, &sc, &o, None).unwrap();
            let mut counted = [0, 0];
            for y in 0..n {
                for x in 0..n {
                    // The world directions' y over the texel (a 5×5 grid).
                    let mut ys = Vec::new();
                    for j in 0..5 {
                        for i in 0..5 {
                            let (px, py) = (x as f64 + i as f64 / 4.0, y as f64 + j as f64 / 4.0);
                            if let Some(d) = world_dir(&rot, n, px, py) {
                                ys.push(d[1]);
                            }
                        }
                    }
                    let Some(dc) = world_dir(&rot, n, x as f64 + 0.5, y as f64 + 0.5) else {
                        continue;
                    };
                    let (lo, hi) = if samples == 1 {
                        (dc[1], dc[1])
                    } else if ys.len() == 25 {
                        (
                            ys.iter().cloned().fold(1.0, f64::min),
                            ys.iter().cloned().fold(-1.0, f64::max),
                        )
                    } else {
                        continue;
                    };
                    let px = img.pixel(x, y);
                    if hi < -1e-3 {
                        assert_eq!(px, &floor[..], "({x},{y})");
                        counted[0] += 1;
                    } else if lo > 1e-3 {
                        assert_eq!(px, &sky[..], "({x},{y})");
                        counted[1] += 1;
                    }
                    if rot == resample::IDENTITY && samples == 1 {
                        // Closed form: lower half ⇔ floor.
                        assert_eq!(dc[1] < 0.0, y >= n / 2);
                    }
                }
            }
            assert!(counted[0] > 3000 && counted[1] > 3000, "{counted:?}");
        }
    }
}

#[test]
fn deterministic_for_a_seed_and_parallel() {
    let sc = scene::demo_scene();
    let o = GenerateOptions {
        pos: [0.0, 1.0, 0.0],
        ..opts(9)
    };
    let a = generate(SPHERE, 64, 64, &sc, &o, None).unwrap().0;
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| generate(SPHERE, 64, 64, &sc, &o, None).unwrap().0);
    assert_eq!(a, b);
    let c = generate(SPHERE, 64, 64, &sc, &GenerateOptions { seed: 7, ..o }, None)
        .unwrap()
        .0;
    assert_ne!(a, c);
}

/// A source that takes several rows a call makes the same image as one row a call, with
/// footprint samples, on a disc mapping (rows that miss the map, texels skipped) and with a
/// last call of fewer rows.
#[test]
fn rows_per_call_leaves_the_image_unchanged() {
    struct Rows<'a>(&'a scene::Scene, usize);
    impl RaySource for Rows<'_> {
        fn channels(&self) -> usize {
            self.0.channels()
        }
        fn trace(&self, o: &[[f32; 3]], d: &[[f32; 3]], out: &mut [f32]) -> spheremap::Result<()> {
            self.0.trace(o, d, out)
        }
        fn rows_per_call(&self) -> usize {
            self.1
        }
    }
    let sc = scene::demo_scene();
    for samples in [1, 4] {
        let o = GenerateOptions {
            pos: [0.0, 1.0, 0.0],
            ..opts(samples)
        };
        let a = generate(SPHERE, 37, 37, &Rows(&sc, 1), &o, None).unwrap();
        for rows in [3, 4, 37, 100] {
            let b = generate(SPHERE, 37, 37, &Rows(&sc, rows), &o, None).unwrap();
            assert_eq!(a.0, b.0, "{rows} rows a call, {samples} samples");
            assert_eq!(a.1.rays, b.1.rays);
            assert_eq!(a.1.texels, b.1.texels);
        }
    }
}

/// A whole-canvas source (all rays listed, evaluated at once, put in place) makes the same
/// image, bit for bit, as the same function fired batch by batch: on a cube, a lat-long and a
/// sphere map (rows off the disc, the gutter filled or black), turned, with f32 and f64
/// directions; it refuses footprint samples.
#[test]
fn whole_canvas_sources_make_the_same_image() {
    let colour = |d: [f32; 3]| {
        [
            d[0] * 0.5 + 0.5,
            d[1] * d[2] + 2.0,
            (3.0 * d[0]).sin().abs(),
        ]
    };
    let rot = views()[1];
    let cube = Mapping::parse("cube", None).unwrap();
    let latlong = Mapping::parse("latlong", None).unwrap();
    for (m, w, h, outside, precision) in [
        (cube, 8, 48, Outside::Gutter, Precision::F32),
        (latlong, 32, 16, Outside::Gutter, Precision::F64),
        (SPHERE, 37, 37, Outside::Gutter, Precision::F32),
        (SPHERE, 36, 36, Outside::Black, Precision::F64),
    ] {
        let o = GenerateOptions {
            rotation: rot,
            outside,
            precision,
            ..opts(1)
        };
        let each = FnSource::new(3, |_: [f32; 3], d: [f32; 3], out: &mut [f32]| {
            out.copy_from_slice(&colour(d))
        });
        let (a, ra) = generate(m, w, h, &each, &o, None).unwrap();
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let eval = |dirs: &[[f32; 3]]| -> spheremap::Result<Vec<f32>> {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            Ok(dirs.iter().flat_map(|&d| colour(d)).collect())
        };
        let (b, rb) = generate_all(m, w, h, 3, &eval, 0, &o, None).unwrap();
        assert_eq!(a, b, "{}", m.name());
        assert_eq!(ra, rb);
        assert_eq!(calls.into_inner(), 1);
        // A wrong number of values is refused.
        let short =
            |dirs: &[[f32; 3]]| -> spheremap::Result<Vec<f32>> { Ok(vec![0.0; dirs.len()]) };
        let e = generate_all(m, w, h, 3, &short, 0, &o, None).unwrap_err();
        assert!(e.to_string().contains("eval"), "{e}");
    }
    let eval = |dirs: &[[f32; 3]]| -> spheremap::Result<Vec<f32>> { Ok(vec![0.0; dirs.len()]) };
    let e = generate_all(SPHERE, 8, 8, 1, &eval, 0, &opts(4), None).unwrap_err();
    assert!(e.to_string().contains("samples"), "{e}");
}

/// The rays counted from the sample rules are the rays fired (with the black outside, the
/// samples off the disc are dropped: no more than counted), and a canvas refused by
/// `generate` is refused by the count.
#[test]
fn planned_rays_are_the_rays_fired() {
    let rot = views()[2];
    let cube = Mapping::parse("cube", None).unwrap();
    let angular = Mapping::parse("angular", None).unwrap();
    let source = FnSource::new(1, |_: [f32; 3], d: [f32; 3], out: &mut [f32]| out[0] = d[0]);
    for (m, w, h) in [(SPHERE, 33, 33), (angular, 20, 20), (cube, 6, 36)] {
        for samples in [1, 4, 9] {
            for (outside, precision) in [
                (Outside::Gutter, Precision::F32),
                (Outside::Black, Precision::F64),
            ] {
                let o = GenerateOptions {
                    rotation: rot,
                    outside,
                    precision,
                    max_samples: 64,
                    ..opts(samples)
                };
                let planned = planned_rays(m, w, h, 1, &o).unwrap();
                let (_, r) = generate(m, w, h, &source, &o, None).unwrap();
                let what = format!("{} {w}x{h} samples {samples} {outside:?}", m.name());
                if outside == Outside::Black && m.has_outside() && samples > 1 {
                    assert!(r.rays < planned, "{what}: {} of {planned}", r.rays);
                } else {
                    assert_eq!(r.rays, planned, "{what}");
                }
                // Stretched texels (the disc's rim) take more than `samples`.
                if m == SPHERE && samples > 1 {
                    assert!(planned > r.texels * samples as u64, "{what}");
                }
            }
        }
    }
    for bad in [0, 1 << 20] {
        let e = planned_rays(SPHERE, bad, bad, 1, &opts(4)).unwrap_err();
        assert!(e.to_string().contains("size"), "{e}");
    }
}

/// The mappings without an outside cover their canvas: every texel centre has a direction
/// (the generator fires one ray at each without asking).
#[test]
fn mappings_without_an_outside_have_every_centre_on_the_map() {
    for name in ["cube", "latlong", "octahedral"] {
        let m = Mapping::parse(name, None).unwrap();
        assert!(!m.has_outside());
        let mut canvases = 0;
        for (w, h) in [
            (1, 6),
            (7, 42),
            (64, 384),
            (10, 5),
            (64, 32),
            (9, 9),
            (33, 33),
        ] {
            let Ok(_) = m.size_of(w, h, "size") else {
                continue;
            };
            canvases += 1;
            for y in 0..h {
                for x in 0..w {
                    let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
                    assert!(m.uv_to_dir(uv).is_some(), "{name} {w}x{h} ({x}, {y})");
                }
            }
        }
        assert!(canvases >= 2, "{name}: {canvases} canvases tried");
    }
}

fn rms(a: &Image, b: &Image) -> f64 {
    let s: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum();
    (s / a.data.len() as f64).sqrt()
}

/// The error against a many-ray reference shrinks as rays are added.
#[test]
fn converges_as_samples_grow() {
    let sc = scene::octant_sphere_scene(10.0, 4);
    let rot = views()[2];
    let run = |s: u32, seed: u64| {
        let o = GenerateOptions {
            rotation: rot,
            seed,
            max_samples: 4096,
            ..opts(s)
        };
        generate(SPHERE, 64, 64, &sc, &o, None).unwrap().0
    };
    let reference = run(1024, 99);
    let errs: Vec<f64> = [1, 4, 16, 64]
        .iter()
        .map(|&s| rms(&run(s, 1), &reference))
        .collect();
    for w in errs.windows(2) {
        assert!(w[1] < 0.8 * w[0], "{errs:?}");
    }
    assert!(errs[3] < 0.25 * errs[0], "{errs:?}");
}

#[test]
fn outside_the_disc_gutter_or_black() {
    let sc = scene::octant_sphere_scene(10.0, 4);
    let n = 64;
    for samples in [1, 4] {
        let (g, _) = generate(SPHERE, n, n, &sc, &opts(samples), None).unwrap();
        let o = GenerateOptions {
            outside: Outside::Black,
            ..opts(samples)
        };
        let (b, _) = generate(SPHERE, n, n, &sc, &o, None).unwrap();
        // Corners: black vs the mirrored map (never 0: every octant is at least ¼).
        assert_eq!(b.pixel(0, 0), &[0.0; 3]);
        assert!(
            g.pixel(0, 0).iter().all(|&v| v >= 0.25 - 1e-6),
            "{:?}",
            g.pixel(0, 0)
        );
        // A texel wholly off the disc holds the map's value at the radial mirror image of its
        // centre across the rim (ρ' = 2 − ρ), looked up bilinearly (texel centres at i + ½).
        for (x, y) in [
            (0usize, 0usize),
            (0, 10),
            (10, 0),
            (n - 1, n - 1),
            (n - 1, 5),
        ] {
            let c = 0.5 * n as f64;
            let d = [x as f64 + 0.5 - c, y as f64 + 0.5 - c];
            let rho = d[0].hypot(d[1]) / c;
            assert!(
                rho > 1.0 + 1.5 / c,
                "({x}, {y}) must be wholly off the disc"
            );
            let k = (2.0 - rho) / rho;
            let (px, py) = (c + d[0] * k - 0.5, c + d[1] * k - 0.5);
            let (x0, y0) = (px.floor() as usize, py.floor() as usize);
            let (fx, fy) = ((px - x0 as f64) as f32, (py - y0 as f64) as f32);
            for ch in 0..3 {
                let at = |i: usize, j: usize| g.pixel(i, j)[ch];
                let want = (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x0 + 1, y0))
                    + fy * ((1.0 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
                let got = g.pixel(x, y)[ch];
                assert!(
                    (got - want).abs() < 1e-5,
                    "({x}, {y}) channel {ch}: {got} vs {want}"
                );
            }
            assert_eq!(b.pixel(x, y), &[0.0; 3]);
        }
        // Texels well inside the disc agree between the two.
        assert_eq!(g.pixel(n / 2, n / 2), b.pixel(n / 2, n / 2));
    }
}

/// The environment-map source gives what the conversion engine gives for one centre sample,
/// and a closure source works.
#[test]
fn environment_and_closure_sources() {
    // A smooth lat-long environment.
    let (w, h) = (128, 64);
    let mut ll = Image::new(w, h, 3);
    for y in 0..h {
        for x in 0..w {
            let p = ll.pixel_mut(x, y);
            // Smooth and periodic in u (no seam to land on either side of).
            p[0] = 0.5 + 0.5 * (std::f32::consts::TAU * (x as f32 + 0.5) / w as f32).cos();
            p[1] = y as f32 / h as f32;
            p[2] = 0.5;
        }
    }
    let lat = Mapping::parse("latlong", None).unwrap();
    let env = EnvMap::new(lat, &ll, "env").unwrap();
    let src = EnvSource::new(&env, resample::IDENTITY);
    let (a, _) = generate(SPHERE, 64, 64, &src, &opts(1), None).unwrap();
    let ro = ResampleOptions {
        samples: 1,
        ..ResampleOptions::default()
    };
    let (b, _) = resample::resample(&env, SPHERE, 64, 64, &ro, None).unwrap();
    // Inside the disc (outside, the two gutters are made differently: from the source by the
    // engine, from the finished map by the generator).
    let mut worst = 0f32;
    for y in 0..64 {
        for x in 0..64 {
            if SPHERE
                .uv_to_dir([(x as f64 + 0.5) / 64.0, (y as f64 + 0.5) / 64.0])
                .is_some()
            {
                for c in 0..3 {
                    worst = worst.max((a.pixel(x, y)[c] - b.pixel(x, y)[c]).abs());
                }
            }
        }
    }
    assert!(worst < 1e-4, "{worst}");

    let f = FnSource::new(1, |_o: [f32; 3], d: [f32; 3], out: &mut [f32]| {
        out[0] = d[2]
    });
    let (img, _) = generate(SPHERE, 32, 32, &f, &opts(1), None).unwrap();
    // The centre texel reflects back toward the viewer: +Z.
    assert!(img.pixel(16, 16)[0] > 0.99);
}

/// The two-step route — ray-trace the six cube faces at `pos`, then convert — against the
/// direct generation.  They agree except where the cube faces' resolution shows (sharp
/// edges are softened by the two resamplings).
#[test]
fn cube_face_route_matches_direct_generation() {
    let sc = scene::demo_scene();
    let pos = [0.0, 1.0, 0.0];
    let n = 128;
    let o = GenerateOptions { pos, ..opts(16) };
    let (direct, _) = generate(SPHERE, n, n, &sc, &o, None).unwrap();
    let cube = Mapping::parse("cube", None).unwrap();
    let f = 128;
    let (faces, _) = generate(cube, f, 6 * f, &sc, &o, None).unwrap();
    let env = EnvMap::new(cube, &faces, "faces").unwrap();
    let (two_step, _) =
        resample::resample(&env, SPHERE, n, n, &ResampleOptions::default(), None).unwrap();
    let psnr = psnr_in_disc(&direct, &two_step, n);
    eprintln!("direct vs cube-face route: {psnr:.1} dB");
    assert!(psnr > 30.0, "{psnr}");
}

fn psnr_in_disc(a: &Image, b: &Image, n: usize) -> f64 {
    let (mut s, mut k, mut peak) = (0.0, 0, 0f64);
    for y in 0..n {
        for x in 0..n {
            if SPHERE
                .uv_to_dir([(x as f64 + 0.5) / n as f64, (y as f64 + 0.5) / n as f64])
                .is_none()
            {
                continue;
            }
            for c in 0..3 {
                let (p, q) = (a.pixel(x, y)[c] as f64, b.pixel(x, y)[c] as f64);
                s += (p - q).powi(2);
                peak = peak.max(p);
                k += 1;
            }
        }
    }
    10.0 * (peak * peak / (s / k as f64)).log10()
}

#[test]
fn f32_and_f64_directions_agree() {
    let sc = scene::octant_sphere_scene(10.0, 4);
    let a = generate(SPHERE, 64, 64, &sc, &opts(4), None).unwrap().0;
    let o = GenerateOptions {
        precision: Precision::F64,
        ..opts(4)
    };
    let b = generate(SPHERE, 64, 64, &sc, &o, None).unwrap().0;
    let differ = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| (*x - *y).abs() > 1e-5)
        .count();
    // Only rays within float rounding of an octant boundary may land differently.
    assert!(differ < a.data.len() / 500, "{differ}");
}

/// Direct light: a diffuse floor under a point light: L = ρ/π · I / d² straight below it;
/// a directional light with an occluder casts a shadow.
#[test]
fn direct_light_and_shadow() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material {
        diffuse: [0.5; 3],
        ..Material::default()
    });
    let quad = |b: &mut SceneBuilder, y: f32, e: f32| {
        let c = [[-e, y, -e], [e, y, -e], [e, y, e], [-e, y, e]];
        for t in [[0, 1, 2], [0, 2, 3]] {
            b.add_triangle(TriangleInput {
                positions: t.map(|i| c[i]),
                material: m,
                ..Default::default()
            });
        }
    };
    quad(&mut b, 0.0, 10.0);
    b.add_light(Light::Point {
        position: [0.0, 2.0, 0.0],
        intensity: [8.0, 8.0, 8.0],
    });
    let mut sc = b.build(Environment::Constant([0.0; 3]), "test").unwrap();
    sc.options.indirect_samples = 0;
    let l = sc.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]);
    let want = 0.5 / std::f32::consts::PI * 8.0 / 4.0;
    assert!((l[0] - want).abs() < 1e-4 * want, "{l:?} {want}");
    // Emission-only shading ignores the light.
    sc.options.shading = Shading::Emission;
    assert_eq!(sc.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]), [0.0; 3]);

    // Sun from straight above, a small occluder at y = 1 over the origin.
    let mut b = SceneBuilder::new();
    let m2 = b.add_material(Material {
        diffuse: [0.5; 3],
        ..Material::default()
    });
    let _ = m2;
    b.materials[0].diffuse = [0.5; 3];
    quad(&mut b, 0.0, 10.0);
    quad(&mut b, 1.0, 0.5);
    b.add_light(Light::Directional {
        direction: [0.0, -1.0, 0.0],
        irradiance: [3.0; 3],
    });
    let mut sc = b.build(Environment::Constant([0.0; 3]), "test").unwrap();
    sc.options.indirect_samples = 0;
    let lit = sc.radiance([3.0, 2.0, 0.0], [0.0, -1.0, 0.0]);
    let shadow = sc.radiance([0.0, 0.5, 0.0], [0.0, -1.0, 0.0]);
    assert!(
        (lit[0] - 0.5 / std::f32::consts::PI * 3.0).abs() < 1e-4,
        "{lit:?}"
    );
    assert_eq!(shadow, [0.0; 3]);
}

/// A mirror shows what it reflects (times its colour); the environment on a miss.
#[test]
fn mirror_and_environment() {
    let mut b = SceneBuilder::new();
    let mirror = b.add_material(Material {
        diffuse: [0.0; 3],
        mirror: [0.5, 0.25, 1.0],
        ..Material::default()
    });
    let e = 5.0;
    let c = [[-e, 0.0, -e], [e, 0.0, -e], [e, 0.0, e], [-e, 0.0, e]];
    for t in [[0, 1, 2], [0, 2, 3]] {
        b.add_triangle(TriangleInput {
            positions: t.map(|i| c[i]),
            material: mirror,
            ..Default::default()
        });
    }
    let sc = b
        .build(Environment::Constant([2.0, 2.0, 2.0]), "test")
        .unwrap();
    assert_eq!(
        sc.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]),
        [1.0, 0.5, 2.0]
    );
    assert_eq!(sc.radiance([0.0, 1.0, 0.0], [0.0, 1.0, 0.0]), [2.0; 3]);
}

#[test]
fn errors_are_named() {
    let sc = scene::octant_sphere_scene(1.0, 1);
    let e = generate(SPHERE, 16, 16, &sc, &opts(0), None).unwrap_err();
    assert!(e.to_string().starts_with("samples:"), "{e}");
    let o = GenerateOptions {
        pos: [f32::NAN, 0.0, 0.0],
        ..opts(1)
    };
    let e = generate(SPHERE, 16, 16, &sc, &o, None).unwrap_err();
    assert!(e.to_string().starts_with("pos:"), "{e}");
    let e = generate(SPHERE, 16, 8, &sc, &opts(1), None).unwrap_err();
    assert!(e.to_string().starts_with("size:"), "{e}");
    // A source that fails stops the run with its error.
    struct Failing;
    impl RaySource for Failing {
        fn channels(&self) -> usize {
            3
        }
        fn trace(&self, _: &[[f32; 3]], _: &[[f32; 3]], _: &mut [f32]) -> spheremap::Result<()> {
            Err(spheremap::Error::param("fire_ray", "went wrong"))
        }
    }
    let e = generate(SPHERE, 16, 16, &Failing, &opts(1), None).unwrap_err();
    assert_eq!(e.to_string(), "fire_ray: went wrong");
}

/// A floor quad at y = 0 (normal +Y) of material `M` from `mtl`, with `extra` OBJ lines after
/// it (more geometry, other materials).
fn floor_scene(mtl: &str, extra: &str) -> scene::Scene {
    let obj = format!(
        "mtllib m.mtl\nv -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\nvn 0 1 0\nusemtl M\n\
         f 1//1 3//1 2//1\nf 1//1 4//1 3//1\n{extra}"
    );
    scene::Scene::load_obj_bytes("floor.obj", obj.as_bytes(), Some(mtl.as_bytes())).unwrap()
}

/// The MTL illumination models: `illum 0` is the constant colour Kd + Ke whatever lights,
/// environment and glowing neighbours surround it; `1` is diffuse (Ks ignored); `2` adds the
/// lights' normalised Blinn–Phong highlights; `3` and up add a mirror of colour Ks.
#[test]
fn mtl_illumination_models() {
    // A glowing ceiling at y = 2 (its cosine rays reach it), a point light below it, and a
    // bright environment: none of it may reach an illum 0 floor.
    let ceiling = "v -10 2 -10\nv 10 2 -10\nv 10 2 10\nv -10 2 10\nusemtl Glow\nf 5 6 7\nf 5 7 8\n";
    let glow = "newmtl Glow\nKe 5 5 5\nKd 0 0 0\n";
    let unlit = format!("newmtl M\nillum 0\nKd 0.3 0.4 0.5\nKe 0.1 0.1 0.1\nKs 1 1 1\n{glow}");
    let mut sc = floor_scene(&unlit, ceiling);
    sc.environment = Environment::Constant([3.0; 3]);
    sc.lights.push(Light::Point {
        position: [0.0, 1.5, 0.0],
        intensity: [10.0; 3],
    });
    sc.options.indirect_samples = 16;
    let l = sc.radiance([0.3, 1.0, 0.2], [0.0, -1.0, 0.0]);
    assert_eq!(l, [0.4, 0.5, 0.6], "illum 0 is the constant Kd + Ke");
    // The same floor as illum 1 gains the ceiling's light (the test above is not vacuous).
    let lit = floor_scene(&unlit.replace("illum 0", "illum 1"), ceiling);
    let mut lit = lit;
    lit.options.indirect_samples = 16;
    assert!(lit.radiance([0.3, 1.0, 0.2], [0.0, -1.0, 0.0])[0] > 0.5);

    // illum 1 ignores Ks; illum 2 adds the highlight, exactly: a sun from straight above seen
    // from straight above has n·h = 1, so L = Kd/π E + Ks (s + 8)/(8π) E.
    let sun = Light::Directional {
        direction: [0.0, -1.0, 0.0],
        irradiance: [3.0; 3],
    };
    let radiance = |illum: u32| {
        let mut sc = floor_scene(
            &format!("newmtl M\nillum {illum}\nKd 0.2 0.2 0.2\nKs 0.5 0.25 0.0\nNs 20\n"),
            "",
        );
        sc.lights.push(sun);
        sc.options.indirect_samples = 0;
        sc.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0])
    };
    let pi = std::f32::consts::PI;
    let diffuse = 0.2 / pi * 3.0;
    let l1 = radiance(1);
    assert!(l1.iter().all(|v| (v - diffuse).abs() < 1e-6), "{l1:?}");
    let l2 = radiance(2);
    for (k, ks) in [0.5f32, 0.25, 0.0].into_iter().enumerate() {
        let want = diffuse + ks * 28.0 / (8.0 * pi) * 3.0;
        assert!(
            (l2[k] - want).abs() < 1e-5 * want.max(1.0),
            "{l2:?} {k} {want}"
        );
    }
    // Away from the mirror direction the highlight falls as (n·h)^s.
    let mut sc = floor_scene("newmtl M\nillum 2\nKd 0 0 0\nKs 1 1 1\nNs 20\n", "");
    sc.lights.push(sun);
    sc.options.indirect_samples = 0;
    let v = [0.6f32, 0.8, 0.0]; // toward the viewer
    let l = sc.radiance([0.6, 0.8, 0.0], [-0.6, -0.8, 0.0]);
    let h = [v[0], v[1] + 1.0, 0.0];
    let nh = h[1] / (h[0] * h[0] + h[1] * h[1]).sqrt();
    let want = 28.0 / (8.0 * pi) * 3.0 * nh.powf(20.0);
    assert!((l[0] - want).abs() < 1e-5, "{l:?} {want}");

    // illum 3 and up: a mirror of colour Ks (the environment seen in it), plus the highlight.
    for illum in [3, 4, 5, 6, 7, 8, 9] {
        let mut sc = floor_scene(
            &format!("newmtl M\nillum {illum}\nKd 0 0 0\nKs 0.5 0.25 1\nNs 20\n"),
            "",
        );
        sc.environment = Environment::Constant([2.0; 3]);
        assert_eq!(
            sc.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]),
            [1.0, 0.5, 2.0],
            "illum {illum}"
        );
    }
    // illum 10 (shadow matte) is drawn diffuse.
    let mut sc = floor_scene("newmtl M\nillum 10\nKd 0.2 0.2 0.2\nKs 1 1 1\n", "");
    sc.lights.push(sun);
    sc.options.indirect_samples = 0;
    let l = sc.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]);
    assert!((l[0] - diffuse).abs() < 1e-6, "{l:?}");
}

/// The models the renderer only approximates are named in a warning.
#[test]
fn approximated_illumination_models_are_named() {
    static SEEN: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    fn sink(m: &str) {
        SEEN.lock().unwrap().push(m.to_string());
    }
    spheremap::base::error::set_warning_sink(Some(sink));
    let _ = floor_scene("newmtl M\nillum 7\nKs 1 1 1\n", "");
    let _ = floor_scene("newmtl M\nillum 2\nKs 1 1 1\n", "");
    spheremap::base::error::set_warning_sink(None);
    let seen = SEEN.lock().unwrap();
    let ours: Vec<_> = seen.iter().filter(|m| m.starts_with("floor.obj")).collect();
    assert_eq!(ours.len(), 1, "{seen:?}");
    assert!(ours[0].contains("\"M\" asks for illum 7") && ours[0].contains("refraction"));
}

/// glTF's `KHR_materials_unlit` is `illum 0`: the base colour (plus the emission) whatever
/// the lights and the environment.
#[test]
fn gltf_unlit_material_is_its_base_colour() {
    fn base64(bytes: &[u8]) -> String {
        const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in bytes.chunks(3) {
            let n = (c[0] as u32) << 16
                | (*c.get(1).unwrap_or(&0) as u32) << 8
                | *c.get(2).unwrap_or(&0) as u32;
            for k in 0..4 {
                s.push(if k <= c.len() {
                    A[(n >> (18 - 6 * k) & 63) as usize] as char
                } else {
                    '='
                });
            }
        }
        s
    }
    let tri: [f32; 9] = [-10.0, 0.0, -10.0, 0.0, 0.0, 10.0, 10.0, 0.0, -10.0];
    let bytes: Vec<u8> = tri.iter().flat_map(|v| v.to_le_bytes()).collect();
    let gltf = |ext: &str| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},{ext}"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
            "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.2,0.4,0.6,1],"metallicFactor":0}},
              "emissiveFactor":[0.1,0,0]{}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
              "min":[-10,0,-10],"max":[10,0,10]}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}}],
            "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{}"}}]}}"#,
            if ext.is_empty() {
                ""
            } else {
                r#","extensions":{"KHR_materials_unlit":{}}"#
            },
            base64(&bytes)
        )
    };
    let shade = |text: String| {
        let mut sc = scene::Scene::load_bytes("unlit.gltf", text.as_bytes()).unwrap();
        sc.environment = Environment::Constant([3.0; 3]);
        sc.lights.push(Light::Directional {
            direction: [0.0, -1.0, 0.0],
            irradiance: [5.0; 3],
        });
        sc.options.indirect_samples = 8;
        sc.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0])
    };
    let unlit = shade(gltf(r#""extensionsUsed":["KHR_materials_unlit"],"#));
    assert_eq!(unlit, [0.3, 0.4, 0.6]);
    let lit = shade(gltf(""));
    assert!(lit[1] > 0.5, "{lit:?}");
}
