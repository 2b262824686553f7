//! Dev timing of the generator (not a benchmark; see benches/ and bench/).
use spheremap::trace::generate::{generate, GenerateOptions};
use spheremap::trace::scene::{self, Shading};
use std::time::Instant;
fn main() {
    let mut sc = scene::octant_sphere_scene(10.0, 112);
    sc.options.shading = Shading::Emission;
    eprintln!("triangles {}", sc.triangle_count());
    let m = spheremap::Mapping::parse("sphere", None).unwrap();
    for (s, cap) in [(16, 1024), (16, 16)] {
        let o = GenerateOptions {
            samples: s,
            max_samples: cap,
            ..Default::default()
        };
        for _ in 0..2 {
            let t = Instant::now();
            let (_, r) = generate(m, 512, 512, &sc, &o, None).unwrap();
            let dt = t.elapsed().as_secs_f64();
            eprintln!(
                "s{s} cap{cap}: {:.3} s, rays {} ({:.1}/texel), {:.2} Mrays/s",
                dt,
                r.rays,
                r.rays as f64 / r.texels as f64,
                r.rays as f64 / dt / 1e6
            );
        }
    }
    let sc = scene::demo_scene();
    let o = GenerateOptions {
        samples: 16,
        pos: [0.0, 1.0, 0.0],
        ..Default::default()
    };
    let t = Instant::now();
    let (_, r) = generate(m, 512, 512, &sc, &o, None).unwrap();
    eprintln!(
        "demo full shading: {:.3} s rays {}",
        t.elapsed().as_secs_f64(),
        r.rays
    );
}
