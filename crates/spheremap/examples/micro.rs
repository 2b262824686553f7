use std::time::Instant;
fn main() {
    let n = 1_000_000usize;
    let xs: Vec<f32> = (0..n).map(|i| ((i as f32) * 0.001).sin()).collect();
    let ys: Vec<f32> = (0..n).map(|i| ((i as f32) * 0.0013).cos()).collect();
    for _ in 0..3 {
        let t = Instant::now();
        let mut acc = 0.0f32;
        for i in 0..n {
            acc += spheremap::real::atan2_fast(ys[i], xs[i]);
        }
        println!(
            "atan2_fast: {:.2} ns {acc}",
            t.elapsed().as_secs_f64() * 1e9 / n as f64
        );
        let t = Instant::now();
        let mut acc = 0.0f32;
        for i in 0..n {
            acc += ys[i].atan2(xs[i]);
        }
        println!(
            "libm atan2f: {:.2} ns {acc}",
            t.elapsed().as_secs_f64() * 1e9 / n as f64
        );
        let t = Instant::now();
        let mut acc = 0.0f32;
        for i in 0..n {
            acc += (ys[i] * ys[i] + xs[i]).sqrt();
        }
        println!(
            "sqrt: {:.2} ns {acc}",
            t.elapsed().as_secs_f64() * 1e9 / n as f64
        );
    }
}
