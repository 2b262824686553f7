//! Criterion benchmarks of the conversion engine: the jobs J1–J4 and the real-time path.
//! `cargo bench -p spheremap --bench resample`.  Goals on 2 cores: J1 ≤ 6 ms, J2 ≤ 5 ms,
//! J3 ≤ 8 ms, J4 ≤ 50 ms, cube 6×256² → sphere 512² ≤ 2 ms.

use criterion::{criterion_group, criterion_main, Criterion};
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::{resample, EnvMap, ResampleOptions};
use std::time::Duration;

fn noise(w: usize, h: usize, c: usize) -> Image {
    let mut img = Image::new(w, h, c);
    let mut x = 0x9E3779B97F4A7C15u64;
    for v in img.data.iter_mut() {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        *v = (x >> 40) as f32 / (1u64 << 24) as f32;
    }
    img
}

fn job(c: &mut Criterion, name: &str, src: &str, img: &Image, dst: &str, n: usize, samples: u32) {
    job_max(
        c,
        name,
        src,
        img,
        dst,
        n,
        samples,
        ResampleOptions::default().max_samples,
    )
}

#[allow(clippy::too_many_arguments)]
fn job_max(
    c: &mut Criterion,
    name: &str,
    src: &str,
    img: &Image,
    dst: &str,
    n: usize,
    samples: u32,
    max_samples: u32,
) {
    let sm = Mapping::parse(src, None).unwrap();
    let dm = Mapping::parse(dst, None).unwrap();
    let e = EnvMap::new(sm, img, "src").unwrap();
    let (w, h) = dm.canvas(n);
    let o = ResampleOptions {
        samples,
        max_samples,
        ..Default::default()
    };
    c.bench_function(name, |b| {
        b.iter(|| resample(&e, dm, w, h, &o, None).unwrap())
    });
}

fn bench(c: &mut Criterion) {
    let ll = noise(2048, 1024, 3);
    let cube512 = noise(512, 6 * 512, 3);
    let cube256 = noise(256, 6 * 256, 3);
    let sphere = noise(1024, 1024, 3);
    job(
        c,
        "J1_latlong2048_to_sphere1024_s1",
        "latlong",
        &ll,
        "sphere",
        1024,
        1,
    );
    job(
        c,
        "J2_cube512_to_sphere1024_s1",
        "cube",
        &cube512,
        "sphere",
        1024,
        1,
    );
    job(
        c,
        "J3_sphere1024_to_latlong2048_s1",
        "sphere",
        &sphere,
        "latlong",
        1024,
        1,
    );
    // 16 samples in every texel (the prefiltered levels cover wider footprints).
    job_max(
        c,
        "J4_latlong2048_to_sphere1024_s16",
        "latlong",
        &ll,
        "sphere",
        1024,
        16,
        16,
    );
    // 16 samples and more where the footprint asks (up to the default max_samples).
    job(
        c,
        "J4_adaptive_latlong2048_to_sphere1024_s16",
        "latlong",
        &ll,
        "sphere",
        1024,
        16,
    );
    job(
        c,
        "RT_cube256_to_sphere512_s1",
        "cube",
        &cube256,
        "sphere",
        512,
        1,
    );
    job(
        c,
        "default_latlong2048_to_sphere1024_s4",
        "latlong",
        &ll,
        "sphere",
        1024,
        4,
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_millis(500));
    targets = bench
}
criterion_main!(benches);
