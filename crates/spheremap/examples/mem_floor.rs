//! The memory floor of a one-sample conversion on this machine (development aid):
//! `cargo run --release --example mem_floor -- SRC W H DST N [REPS]`, e.g.
//! `latlong 2048 1024 sphere 1024` for J1.
//!
//! It times, on all threads (rayon, rows split as the engine splits them), back to back as
//! the benchmarks run the jobs:
//!
//! * `sequential`: one read per 64-byte line of the source, in address order — what the
//!   memory system gives a pure stream;
//! * `job order`: the four bilinear taps of every destination texel, in the engine's order
//!   (row by row) with the engine's prefetching (64 texels ahead, four lines per texel), and
//!   no arithmetic (an xor of the values' bits) — the floor for the job's reads in the
//!   order the job makes them (it also reads the precomputed tap indices: 4 bytes a texel);
//! * `sorted`: the same taps sorted by address — the same lines, in the order the memory
//!   system likes best.
//!
//! A conversion that reads its source in the job's order will hardly beat `job order` (which
//! reads 4 bytes of indices a texel more than it does), and `job order` − `sorted` is what
//! that order costs on the machine at hand.
//! The tap positions are the engine's (texel centres, the gutter's radial mirror outside a
//! disc, f64 here), clamped into the canvas; lookups the engine sends the general way
//! (seams, rims) are read here as plain taps too, so the floor is slightly optimistic.
use rayon::prelude::*;
use spheremap::mappings::mapping::Mapping;
use std::time::Instant;

const AHEAD: usize = 64;

/// The top-left tap index (into the source's values) of every destination texel, row-major.
fn taps(
    sm: Mapping,
    sw: usize,
    sh: usize,
    c: usize,
    dm: Mapping,
    dw: usize,
    dh: usize,
) -> Vec<u32> {
    let mut idx = Vec::with_capacity(dw * dh);
    for y in 0..dh {
        for x in 0..dw {
            let mut uv = [(x as f64 + 0.5) / dw as f64, (y as f64 + 0.5) / dh as f64];
            if dm.has_outside() && dm.uv_to_dir(uv).is_none() {
                // The gutter: the radial mirror image across the rim (for a disc canvas).
                let (a, b) = (2.0 * uv[0] - 1.0, 2.0 * uv[1] - 1.0);
                let rho = (a * a + b * b).sqrt();
                let k = (2.0 - rho).clamp(0.0, 1.0 - 1e-6) / rho;
                uv = [(a * k + 1.0) / 2.0, (b * k + 1.0) / 2.0];
            }
            let i = match dm.uv_to_dir(uv) {
                Some(d) => {
                    let [u, v] = sm.dir_to_uv(d);
                    // The top-left tap along one axis of n texels, clamped into the canvas.
                    let tap = |t: f64, n: usize| {
                        let f = (t * n as f64 - 0.5).floor();
                        if f.is_finite() {
                            f.clamp(0.0, (n - 2) as f64) as usize
                        } else {
                            0
                        }
                    };
                    (tap(v, sh) * sw + tap(u, sw)) * c
                }
                None => 0,
            };
            idx.push(i as u32);
        }
    }
    idx
}

#[inline(always)]
fn prefetch(p: *const f32) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: prefetching is a hint; it never faults.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p as *const i8);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Reads the four taps of each index of each row (`w` per row), prefetching as the engine
/// does; xor of their bits (a one-cycle chain, unlike a float sum's four-cycle one).
fn gather(data: &[f32], row: usize, c: usize, idx: &[u32], w: usize) -> u32 {
    idx.par_chunks(w)
        .with_min_len(4)
        .map(|r| {
            let mut acc = 0u32;
            for (x, &i) in r.iter().enumerate() {
                if let Some(&j) = r.get(x + AHEAD) {
                    let p = data.as_ptr().wrapping_add(j as usize);
                    for o in [0, row, 2 * c - 1, row + 2 * c - 1] {
                        prefetch(p.wrapping_add(o));
                    }
                }
                let i = i as usize;
                let v = |k: usize| data[i + k].to_bits();
                acc ^= v(0) ^ v(c) ^ v(row) ^ v(row + c);
            }
            acc
        })
        .reduce(|| 0, |a, b| a ^ b)
}

/// One read per line of `data`, in order.
fn sequential(data: &[f32]) -> u32 {
    data.par_chunks(1 << 16)
        .map(|ch| ch.iter().step_by(16).fold(0, |a, v| a ^ v.to_bits()))
        .reduce(|| 0, |a, b| a ^ b)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!("usage: mem_floor SRC W H DST N [REPS]");
        std::process::exit(2);
    }
    let (sw, sh): (usize, usize) = (a[2].parse().unwrap(), a[3].parse().unwrap());
    let n: usize = a[5].parse().unwrap();
    let reps: usize = a.get(6).map_or(15, |v| v.parse().unwrap());
    let c = 3;
    let sm = Mapping::parse(&a[1], None).unwrap();
    let dm = Mapping::parse(&a[4], None).unwrap();
    sm.size_of(sw, sh, "source").unwrap();
    let (dw, dh) = dm.canvas(n);
    let data: Vec<f32> = (0..sw * sh * c).map(|i| (i % 251) as f32).collect();
    let idx = taps(sm, sw, sh, c, dm, dw, dh);
    let mut sorted = idx.clone();
    sorted.sort_unstable();
    // Back to back, as the benchmarks run the jobs (whatever of the source the caches keep
    // from one run to the next, they keep here too).
    let time = |f: &dyn Fn() -> u32| {
        let mut t = vec![];
        for _ in 0..reps {
            let t0 = Instant::now();
            std::hint::black_box(f());
            t.push(t0.elapsed().as_secs_f64() * 1e3);
        }
        t.sort_by(|a, b| a.partial_cmp(b).unwrap());
        (t[0], t[t.len() / 2])
    };
    let row = sw * c;
    let mb = (data.len() * 4) as f64 / 1e6;
    println!(
        "{} {sw}x{sh} ({mb:.1} MB) -> {} {dw}x{dh}, {} threads, best / median of {reps} (ms):",
        a[1],
        a[4],
        rayon::current_num_threads()
    );
    let (b, m) = time(&|| sequential(&data));
    println!("  sequential  {b:6.2} {m:6.2}");
    let (b, m) = time(&|| gather(&data, row, c, &idx, dw));
    println!("  job order   {b:6.2} {m:6.2}");
    let (b, m) = time(&|| gather(&data, row, c, &sorted, dw));
    println!("  sorted      {b:6.2} {m:6.2}");
}
