//! Criterion benchmarks of the kernels.  `cargo bench -p spheremap --bench texgen`.
//! J5 (the goal): 1M-vertex GL_SPHERE_MAP texgen, f32 path, 2 cores: <= 1.5 ms.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use spheremap::mappings::texgen::{
    sphere_texgen, sphere_texgen_f64, ModelviewState, NormalMode, TexgenOptions,
};

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
    let m = [
        [0.9, 0.1, 0.0, 0.2],
        [-0.1, 0.9, 0.2, 0.0],
        [0.0, -0.2, 1.1, -5.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let mv = ModelviewState::new(m).unwrap();
    let mut out = vec![0.0f32; 2 * n];
    let mut g = c.benchmark_group("texgen_1M");
    g.throughput(Throughput::Elements(n as u64));
    for mode in [NormalMode::On, NormalMode::Off, NormalMode::Rescale] {
        let opts = TexgenOptions {
            normalize: mode,
            ..Default::default()
        };
        g.bench_with_input(
            BenchmarkId::new("f32", format!("{mode:?}")),
            &opts,
            |b, o| b.iter(|| sphere_texgen(&p, 3, &q, &mv, *o, &mut out).unwrap()),
        );
    }
    // The memory floor on this machine: the same traffic (read 24 B, write 8 B per vertex) with
    // trivial arithmetic, same threading.
    g.bench_function("floor_same_traffic", |b| {
        use rayon::prelude::*;
        b.iter(|| {
            out.par_chunks_mut(2 * 16384)
                .enumerate()
                .for_each(|(k, o)| {
                    let base = k * 16384;
                    for (i, st) in o.chunks_exact_mut(2).enumerate() {
                        let j = 3 * (base + i);
                        st[0] = p[j] + q[j] + p[j + 2];
                        st[1] = p[j + 1] + q[j + 1] + q[j + 2];
                    }
                })
        })
    });
    g.finish();

    // Arithmetic alone: 50K vertices (1.6 MB) stay in L2, one call runs on one thread.
    let mut g = c.benchmark_group("texgen_50k_in_cache");
    let n_small = 50_000;
    g.throughput(Throughput::Elements(n_small as u64));
    let mut out_small = vec![0.0f32; 2 * n_small];
    for mode in [NormalMode::On, NormalMode::Off] {
        let opts = TexgenOptions {
            normalize: mode,
            ..Default::default()
        };
        g.bench_with_input(
            BenchmarkId::new("f32", format!("{mode:?}")),
            &opts,
            |b, o| {
                b.iter(|| {
                    sphere_texgen(
                        &p[..3 * n_small],
                        3,
                        &q[..3 * n_small],
                        &mv,
                        *o,
                        &mut out_small,
                    )
                    .unwrap()
                })
            },
        );
    }
    g.finish();

    let mut g = c.benchmark_group("texgen_1M");
    g.sample_size(10);
    let mut out64 = vec![0.0f64; 2 * n];
    g.bench_function("f64_reference_On", |b| {
        b.iter(|| sphere_texgen_f64(&p, 3, &q, &mv, TexgenOptions::default(), &mut out64).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
