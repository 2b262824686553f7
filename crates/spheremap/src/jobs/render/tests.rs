use super::*;
use crate::mappings::matcap::MatcapVariant;
use crate::mesh::Mesh;

/// A quad in the plane z = 0 spanning [-1, 1]², two triangles, normals +Z.
fn quad() -> Mesh {
    Mesh {
        positions: vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        normals: vec![[0.0, 0.0, 1.0]; 4],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        normals_from_file: true,
    }
}

/// A UV sphere of radius 1 with exact normals (also used by the analyze tests).
pub(crate) fn uv_sphere(rings: usize, segments: usize) -> Mesh {
    let mut m = Mesh {
        positions: vec![],
        normals: vec![],
        triangles: vec![],
        normals_from_file: true,
    };
    for i in 0..=rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..=segments {
            let ph = std::f64::consts::TAU * j as f64 / segments as f64;
            let p = [th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()].map(|v| v as f32);
            m.positions.push(p);
            m.normals.push(p);
        }
    }
    let row = segments as u32 + 1;
    for i in 0..rings as u32 {
        for j in 0..segments as u32 {
            let a = i * row + j;
            m.triangles.push([a, a + row, a + 1]);
            m.triangles.push([a + 1, a + row, a + row + 1]);
        }
    }
    m
}

/// The camera on +Z at distance `d` looking at the origin, fovy chosen so that the square
/// [-1, 1]² at z = 0 spans exactly the middle `frac` of the image height.
fn cam(d: f64, frac: f64, w: usize, h: usize) -> GlCamera {
    let fovy = 2.0 * (1.0 / (d * frac)).atan().to_degrees();
    GlCamera::look_at(
        [0.0, 0.0, d],
        [0.0; 3],
        [0.0, 1.0, 0.0],
        fovy,
        0.1,
        100.0,
        w,
        h,
    )
    .unwrap()
}

#[test]
fn glu_matrices() {
    let c = GlCamera::look_at(
        [1.0, 2.0, 3.0],
        [1.0, 2.0, 0.0],
        [0.0, 1.0, 0.0],
        90.0,
        1.0,
        3.0,
        200,
        100,
    )
    .unwrap();
    // Looking down -Z from (1, 2, 3): the modelview is a translation.
    assert_eq!(c.modelview[0], [1.0, 0.0, 0.0, -1.0]);
    assert_eq!(c.modelview[2], [0.0, 0.0, 1.0, -3.0]);
    // gluPerspective(90°, 2, 1, 3).
    assert!((c.projection[0][0] - 0.5).abs() < 1e-15 && (c.projection[1][1] - 1.0).abs() < 1e-15);
    assert_eq!(c.projection[2][2], -2.0);
    assert_eq!(c.projection[2][3], -3.0);
    assert_eq!(c.projection[3], [0.0, 0.0, -1.0, 0.0]);
}

#[test]
fn flat_quad_covers_exactly_its_pixels() {
    // The quad spans exactly the middle half of a 64² image: pixels 16..48 on both axes, its
    // edges on pixel boundaries, so no sample centre is on an edge.
    let (w, h) = (64, 64);
    let c = cam(5.0, 0.5, w, h);
    for aa in [1, 2, 4] {
        let opts = RenderOptions {
            mode: Mode::Normals,
            background: [0.0, 0.0, 0.0],
            aa,
            ..RenderOptions::default()
        };
        let (img, stats) = render(&quad(), &c, Env::None, &opts).unwrap();
        assert_eq!(stats.covered_pixels, 32 * 32, "aa {aa}");
        for y in 0..h {
            for x in 0..w {
                let inside = (16..48).contains(&x) && (16..48).contains(&y);
                let want = if inside { [0.5, 0.5, 1.0] } else { [0.0; 3] };
                let p = img.pixel(x, y);
                for k in 0..3 {
                    assert!((p[k] - want[k]).abs() < 1e-6, "aa {aa} ({x},{y}) {p:?}");
                }
            }
        }
    }
}

#[test]
fn shared_diagonal_has_no_gap_and_partial_pixels_average() {
    // A quad whose edges cut pixels in half: with 4x4 samples the edge pixels are half covered.
    let (w, h) = (64, 64);
    let c = cam(5.0, 0.5 * 33.0 / 32.0, w, h); // spans 33 pixels: edges through pixel middles
    let opts = RenderOptions {
        mode: Mode::Normals,
        background: [0.0; 3],
        aa: 4,
        ..RenderOptions::default()
    };
    let (img, _) = render(&quad(), &c, Env::None, &opts).unwrap();
    // Interior (including the diagonal): fully covered.
    for y in 17..47 {
        for x in 17..47 {
            assert!((img.pixel(x, y)[2] - 1.0).abs() < 1e-6, "({x},{y})");
        }
    }
    // The left edge column (x = 15.5 .. 16): half of pixel 15.
    let v = img.pixel(15, 32)[2];
    assert!((v - 0.5).abs() < 1e-6, "{v}");
}

#[test]
fn sphere_normals_match_the_analytic_sphere() {
    let (w, h) = (96, 96);
    let c = cam(4.0, 0.6, w, h);
    let opts = RenderOptions {
        mode: Mode::Normals,
        ..Default::default()
    };
    let (img, _) = render(&uv_sphere(64, 128), &c, Env::None, &opts).unwrap();
    // Ray through each pixel centre against the true sphere.
    let p = &c.projection;
    let mut worst = 0f64;
    let mut hits = 0;
    for y in 0..h {
        for x in 0..w {
            let nx = (x as f64 + 0.5) / w as f64 * 2.0 - 1.0;
            let ny = 1.0 - (y as f64 + 0.5) / h as f64 * 2.0;
            let d = unit([nx / p[0][0], ny / p[1][1], -1.0]).unwrap();
            let o = [0.0, 0.0, 4.0];
            let b = dot(o, d);
            let disc = b * b - (dot(o, o) - 1.0);
            if disc < 0.05 {
                continue; // miss or near the silhouette
            }
            let t = -b - disc.sqrt();
            let n = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
            let got = img.pixel(x, y);
            let e = (0..3)
                .map(|k| (got[k] as f64 - (0.5 * n[k] + 0.5)).abs())
                .fold(0.0, f64::max);
            worst = worst.max(e);
            hits += 1;
        }
    }
    assert!(hits > 1500, "{hits}");
    assert!(worst < 0.01, "worst normal error {worst}");
}

#[test]
fn per_vertex_error_shrinks_with_tessellation_and_per_pixel_is_exact_on_a_constant_env() {
    let (w, h) = (64, 64);
    let c = cam(4.0, 0.6, w, h);
    let mean_err = |rings: usize| {
        let opts = RenderOptions {
            mode: Mode::Error,
            ..Default::default()
        };
        let (img, s) = render(&uv_sphere(rings, 2 * rings), &c, Env::None, &opts).unwrap();
        img.data.chunks(2).map(|v| v[0] as f64).sum::<f64>() / s.covered_pixels as f64
    };
    let (coarse, fine) = (mean_err(8), mean_err(32));
    assert!(coarse > 4.0 * fine && fine > 0.0, "{coarse} {fine}");
    // Per-pixel with an HDR constant environment: exactly that value (no tone mapping).
    let env = Image {
        width: 4,
        height: 4,
        channels: 3,
        data: [5.0f32, 0.25, 2.0].repeat(16),
    };
    let tex = Texture {
        image: &env,
        wrap: Wrap::ClampToEdge,
    };
    let opts = RenderOptions {
        mode: Mode::PerPixel,
        background: [-1.0; 3],
        aa: 1,
        ..RenderOptions::default()
    };
    let (img, _) = render(&uv_sphere(16, 32), &c, Env::Texture(&tex), &opts).unwrap();
    let want = [5.0f32, 0.25, 2.0];
    let close = |p: &[f32]| (0..3).all(|k| (p[k] - want[k]).abs() <= 1e-6 * want[k]);
    assert!(img.data.chunks(3).all(|p| close(p) || p == [-1.0; 3]));
    assert!(img.data.chunks(3).filter(|p| close(p)).count() > 1000);
    // MatCap and per-vertex need a texture; per-pixel an environment.
    for mode in [
        Mode::PerVertex,
        Mode::Matcap(MatcapVariant::Classic),
        Mode::PerPixel,
    ] {
        let o = RenderOptions {
            mode,
            ..Default::default()
        };
        assert!(render(&quad(), &c, Env::None, &o).is_err());
    }
}

#[test]
fn texture_lookup_is_gl_linear() {
    // 2x2 texture, rows top (t = 1) to bottom.
    let img = Image {
        width: 2,
        height: 2,
        channels: 1,
        data: vec![0.0, 1.0, 2.0, 3.0],
    };
    let t = Texture {
        image: &img,
        wrap: Wrap::ClampToEdge,
    };
    let mut o = [0f32; 3];
    t.sample([0.25, 0.75], &mut o); // the top-left texel centre
    assert_eq!(o, [0.0; 3]);
    t.sample([0.75, 0.25], &mut o); // bottom-right
    assert_eq!(o, [3.0; 3]);
    t.sample([0.5, 0.5], &mut o); // the middle: the mean
    assert_eq!(o, [1.5; 3]);
    t.sample([0.0, 1.0], &mut o); // clamped corner
    assert_eq!(o, [0.0; 3]);
    let r = Texture {
        image: &img,
        wrap: Wrap::Repeat,
    };
    r.sample([0.0, 0.75], &mut o); // half-way between texel 1 (wrapped) and 0 on the top row
    assert_eq!(o, [0.5; 3]);
}

#[test]
fn near_plane_clipping_keeps_the_visible_part() {
    // A long floor quad passing under and behind the camera: must draw without artefacts.
    let floor = Mesh {
        positions: vec![
            [-5.0, -1.0, -50.0],
            [5.0, -1.0, -50.0],
            [5.0, -1.0, 50.0],
            [-5.0, -1.0, 50.0],
        ],
        normals: vec![[0.0, 1.0, 0.0]; 4],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        normals_from_file: true,
    };
    let c = GlCamera::look_at(
        [0.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        [0.0, 1.0, 0.0],
        60.0,
        0.1,
        30.0,
        64,
        64,
    )
    .unwrap();
    let opts = RenderOptions {
        mode: Mode::Normals,
        ..Default::default()
    };
    let (img, s) = render(&floor, &c, Env::None, &opts).unwrap();
    // The lower half of the image sees the floor (normal +Y in eye space: green 1); the upper
    // half does not (the far plane at 30 cuts it before the horizon).
    for x in 0..64 {
        assert!((img.pixel(x, 63)[1] - 1.0).abs() < 1e-6);
        assert_eq!(img.pixel(x, 0), [0.0; 3]);
    }
    assert!(
        s.covered_pixels > 20 * 64 && s.covered_pixels < 32 * 64,
        "{}",
        s.covered_pixels
    );
}

#[test]
fn orbit_turns_about_up() {
    let e = orbit_eye([0.0, 1.0, 5.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], 90.0);
    // +Z turned 90° counter-clockwise about +Y (seen from above) is +X.
    assert!(
        (e[0] - 5.0).abs() < 1e-12 && (e[1] - 1.0).abs() < 1e-12 && e[2].abs() < 1e-12,
        "{e:?}"
    );
    let f = orbit_eye([3.0, 2.0, 1.0], [0.0; 3], [0.0, 0.0, 2.0], 360.0);
    assert!((f[0] - 3.0).abs() < 1e-12 && (f[1] - 2.0).abs() < 1e-12);
}

#[test]
fn triangle_ids_split_the_quad_along_its_diagonal() {
    let c = cam(5.0, 0.5, 64, 64);
    let ids = triangle_ids(&quad(), &c).unwrap();
    // Outside: none. Inside: triangle 0 (vertices 0,1,2: below the diagonal from (-1,-1) to
    // (1,1), i.e. bottom-right in the image) and triangle 1 (top-left).
    assert_eq!(ids[0], u32::MAX);
    assert_eq!(ids[40 * 64 + 44], 0); // lower right
    assert_eq!(ids[20 * 64 + 18], 1); // upper left
    let counts = [0u32, 1].map(|t| ids.iter().filter(|&&i| i == t).count());
    assert_eq!(counts[0] + counts[1], 32 * 32);
    // Pixel centres exactly on the diagonal go to one triangle: 32 of them, to triangle 0 or 1
    // by the top-left rule; the rest split evenly.
    assert_eq!(counts[0].abs_diff(counts[1]), 32);
}

#[test]
fn subpixel_bits_snap_vertices_as_the_gpu_does() {
    // The quad's left and top edges fall at 15.53 pixels, its right and bottom at 48.47. With 8
    // bits they stay there (3976/256 = 15.531, 12408/256 = 48.469): pixel centres 16.5..47.5,
    // 32 × 32 pixels. With 4 bits they snap to 15.5 and 48.5, through pixel centres: the top-left
    // rule keeps column and row 15 and drops 48, 33 × 33 pixels.
    let (w, h) = (64, 64);
    let c = cam(5.0, (32.0 - 15.53) / 32.0, w, h);
    let covered = |bits| {
        let opts = RenderOptions {
            mode: Mode::Normals,
            subpixel_bits: bits,
            ..RenderOptions::default()
        };
        render(&quad(), &c, Env::None, &opts)
            .unwrap()
            .1
            .covered_pixels
    };
    assert_eq!(covered(8), 32 * 32);
    assert_eq!(covered(4), 33 * 33);
    for bad in [0, 9] {
        let opts = RenderOptions {
            mode: Mode::Normals,
            subpixel_bits: bad,
            ..RenderOptions::default()
        };
        let e = render(&quad(), &c, Env::None, &opts)
            .unwrap_err()
            .to_string();
        assert!(e.contains("subpixel_bits"), "{e}");
    }
}
