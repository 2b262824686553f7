//! Criterion benchmarks of the lighting kernels.  `cargo bench -p spheremap --bench lighting`.
//! Goal (2 cores): SH9 of a 2048×1024 lat-long ≤ 5 ms.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use spheremap::images::Image;
use spheremap::lighting::sh::Sh9;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::{EnvMap, IDENTITY};

fn bench(c: &mut Criterion) {
    let (w, h) = (2048, 1024);
    let mut x = 0x9E3779B97F4A7C15u64;
    let data = (0..w * h * 3)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect();
    let img = Image {
        width: w,
        height: h,
        channels: 3,
        data,
    };
    let m = Mapping::parse("latlong", None).unwrap();
    let env = EnvMap::new(m, &img, "env").unwrap();
    let mut g = c.benchmark_group("sh9_2048x1024");
    g.throughput(Throughput::Elements((w * h) as u64));
    g.bench_function("moments", |b| {
        b.iter(|| Sh9::project(&env, &IDENTITY).unwrap())
    });
    g.bench_function("reference_f64", |b| {
        b.iter(|| Sh9::project_reference(&env, &IDENTITY).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
