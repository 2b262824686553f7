//! Quick timing of one conversion (development aid):
//! `cargo run --release --example rs_timing -- SRC W H DST N SAMPLES [MAX_SAMPLES [REPS]]`.
//! Prints the best and the median of REPS runs (default 15), each into a reused buffer
//! (`resample_into`) and, for comparison, with a fresh result (`resample`).
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::{resample, resample_into, EnvMap, ResampleOptions};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (w, h): (usize, usize) = (a[2].parse().unwrap(), a[3].parse().unwrap());
    let n: usize = a[5].parse().unwrap();
    let samples: u32 = a[6].parse().unwrap();
    let max_samples: u32 = a.get(7).map_or(1024, |v| v.parse().unwrap());
    let reps: usize = a.get(8).map_or(15, |v| v.parse().unwrap());
    let mut img = Image::new(w, h, 3);
    let mut x = 0x9E3779B97F4A7C15u64;
    for v in img.data.iter_mut() {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        *v = (x >> 40) as f32 / (1u64 << 24) as f32;
    }
    let sm = Mapping::parse(&a[1], None).unwrap();
    let dm = Mapping::parse(&a[4], None).unwrap();
    let e = EnvMap::new(sm, &img, "src").unwrap();
    let (dw, dh) = dm.canvas(n);
    let o = ResampleOptions {
        samples,
        max_samples,
        ..Default::default()
    };
    let stats = |mut t: Vec<f64>| {
        t.sort_by(|a, b| a.partial_cmp(b).unwrap());
        (t[0] * 1e3, t[t.len() / 2] * 1e3)
    };
    let mut buf = vec![0f32; dw * dh * 3];
    let mut into = vec![];
    let mut fresh = vec![];
    for _ in 0..reps {
        let t = Instant::now();
        resample_into(&e, dm, dw, dh, &o, None, &mut buf).unwrap();
        into.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let r = resample(&e, dm, dw, dh, &o, None).unwrap();
        fresh.push(t.elapsed().as_secs_f64());
        std::hint::black_box(r);
    }
    let (bi, mi) = stats(into);
    let (bf, mf) = stats(fresh);
    println!(
        "{} {w}x{h} -> {} {n} s{samples}/{max_samples}: into best {bi:.2} med {mi:.2} ms; fresh best {bf:.2} med {mf:.2} ms",
        a[1], a[4],
    );
}
