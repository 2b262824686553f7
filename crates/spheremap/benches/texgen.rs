//! Criterion benchmarks of the kernels.  `cargo bench -p spheremap --bench texgen`.
//! J5 (the goal): 1M-vertex GL_SPHERE_MAP texgen, f32 path, 2 cores: <= 1.5 ms.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use spheremap::texgen::{sphere_texgen, sphere_texgen_f64, ModelviewState, NormalMode, TexgenOptions};

fn data(n: usize) -> (Vec<f32>, Vec<f32>) {
    // A cheap deterministic generator (no rand dependency): xorshift.
    let mut x = 0x9E3779B97F4A7C15u64;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let p = (0..3 * n).map(|_| next()).collect();
    let q = (0..3 * n).map(|_| next()).collect();
    (p, q)
}

fn bench(c: &mut Criterion) {
    let n = 1_000_000;
    let (p, q) = data(n);
    let m = [[0.9, 0.1, 0.0, 0.2], [-0.1, 0.9, 0.2, 0.0], [0.0, -0.2, 1.1, -5.0], [0.0, 0.0, 0.0, 1.0]];
    let mv = ModelviewState::new(m).unwrap();
    let mut out = vec![0.0f32; 2 * n];
    let mut g = c.benchmark_group("texgen_1M");
    g.throughput(Throughput::Elements(n as u64));
    for mode in [NormalMode::On, NormalMode::Off, NormalMode::Rescale] {
        let opts = TexgenOptions { normalize: mode, ..Default::default() };
        g.bench_with_input(BenchmarkId::new("f32", format!("{mode:?}")), &opts, |b, o| {
            b.iter(|| sphere_texgen(&p, 3, &q, &mv, *o, &mut out).unwrap())
        });
    }
    g.sample_size(10);
    let mut out64 = vec![0.0f64; 2 * n];
    g.bench_function("f64_reference_On", |b| {
        b.iter(|| sphere_texgen_f64(&p, 3, &q, &mv, TexgenOptions::default(), &mut out64).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
