//! Criterion benches of the ray-traced generator (see BENCHMARKS.md; the side-by-side run
//! against Embree is bench/bench_generate.py).
use criterion::{criterion_group, criterion_main, Criterion};
use spheremap::trace::generate::{generate, GenerateOptions};
use spheremap::trace::scene::{self, Shading};
use spheremap::Mapping;

fn benches(c: &mut Criterion) {
    let sphere = Mapping::parse("sphere", None).unwrap();
    // ~100k triangles all around the eye: every ray hits.
    let mut octants = scene::octant_sphere_scene(10.0, 112);
    octants.options.shading = Shading::Emission;
    let mut g = c.benchmark_group("generate");
    g.sample_size(10);
    g.bench_function("octants100k_512_16rays", |b| {
        let o = GenerateOptions {
            samples: 16,
            max_samples: 16,
            ..Default::default()
        };
        b.iter(|| generate(sphere, 512, 512, &octants, &o, None).unwrap())
    });
    let demo = scene::demo_scene();
    g.bench_function("demo_full_shading_256_s4", |b| {
        let o = GenerateOptions {
            pos: [0.0, 1.0, 0.0],
            ..Default::default()
        };
        b.iter(|| generate(sphere, 256, 256, &demo, &o, None).unwrap())
    });
    g.finish();
}

criterion_group!(all, benches);
criterion_main!(all);
