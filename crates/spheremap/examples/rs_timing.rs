//! Quick timing of one conversion (development aid): `cargo run --release --example rs_timing -- SRC W H DST N SAMPLES`.
use spheremap::image_io::Image;
use spheremap::mapping::Mapping;
use spheremap::resample::{resample, EnvMap, ResampleOptions};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (w, h): (usize, usize) = (a[2].parse().unwrap(), a[3].parse().unwrap());
    let n: usize = a[5].parse().unwrap();
    let samples: u32 = a[6].parse().unwrap();
    let mut img = Image::new(w, h, 3);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = (i % 97) as f32 / 97.0;
    }
    let sm = Mapping::parse(&a[1], None).unwrap();
    let dm = Mapping::parse(&a[4], None).unwrap();
    let e = EnvMap::new(sm, &img, "src").unwrap();
    let (dw, dh) = dm.canvas(n);
    let o = ResampleOptions {
        samples,
        ..Default::default()
    };
    let mut best = f64::MAX;
    for _ in 0..15 {
        let t = Instant::now();
        let r = resample(&e, dm, dw, dh, &o, None).unwrap();
        best = best.min(t.elapsed().as_secs_f64());
        std::hint::black_box(r);
    }
    println!(
        "{} {}x{} -> {} {}: best {:.2} ms",
        a[1],
        w,
        h,
        a[4],
        n,
        best * 1e3
    );
}
