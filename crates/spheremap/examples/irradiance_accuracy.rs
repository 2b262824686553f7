//! Accuracy and speed of the cosine integral ([`spheremap::lighting::cosine`]) against a
//! brute-force sum over the map's texels (f64, each texel at its centre with its exact solid
//! angle: what the tree sums), at 2,000 normals spread over the sphere.  Errors are relative
//! to π L̄'s brightness (the mean of the channels).
//!
//! Usage: cargo run --release -p spheremap --example irradiance_accuracy -- HDRI.exr [...]
//! `SUN=1` adds a one-texel sun holding a fifth of the energy; `FACES=16,32,64` the leaves'
//! faces to try; `REPS=5` how many times the build and the 128² cube are timed (the fastest is
//! printed): by batches of four rows, and all at once (antipodal texels by one integral).
use rayon::prelude::*;
use spheremap::images::codec::{read_image, ReadOptions};
use spheremap::lighting::cosine::CosineTree;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::{EnvMap, IDENTITY};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let faces: Vec<usize> = std::env::var("FACES")
        .unwrap_or("16,32,64".into())
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let ll = Mapping::parse("latlong", None).unwrap();
    let sun = std::env::var("SUN").is_ok();
    let reps: usize = std::env::var("REPS").map_or(5, |v| v.parse().unwrap());
    for path in &args {
        let mut img = read_image(std::path::Path::new(path), &ReadOptions::default()).unwrap();
        let (w, h, c) = (img.width, img.height, img.channels);
        for v in img.data.iter_mut() {
            *v = v.max(0.0);
        }
        if sun {
            let total: f64 = (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .map(|(x, y)| {
                    img.data[(y * w + x) * c + 1] as f64 * ll.texel_solid_angle(x, y, w, h)
                })
                .sum();
            let (x, y) = (w / 3 + 1, h / 4 + 1);
            let add = (0.25 * total / ll.texel_solid_angle(x, y, w, h)) as f32;
            for q in 0..3.min(c) {
                img.data[(y * w + x) * c + q] += add;
            }
        }
        // The brute force's points.
        let pts: Vec<([f64; 3], [f64; 3])> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let dw = ll.texel_solid_angle(x, y, w, h);
                let d = ll
                    .uv_to_dir([(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64])
                    .unwrap();
                let p = &img.data[(y * w + x) * c..];
                let l = [0, 1, 2].map(|q| p[q.min(c - 1)] as f64 * dw);
                (d, l)
            })
            .collect();
        let omega: f64 = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| ll.texel_solid_angle(x, y, w, h))
            .sum();
        let mean: f64 = pts
            .iter()
            .map(|(_, l)| (l[0] + l[1] + l[2]) / 3.0)
            .sum::<f64>()
            / omega;
        let scale = std::f64::consts::PI * mean;
        let n = 2000;
        let normals: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = i as f64 * 2.399963229728653;
                [r * phi.cos(), z, r * phi.sin()]
            })
            .collect();
        let want: Vec<[f64; 3]> = normals
            .par_iter()
            .map(|nn| {
                let mut e = [0.0; 3];
                for (d, l) in &pts {
                    let t = nn[0] * d[0] + nn[1] * d[1] + nn[2] * d[2];
                    if t > 0.0 {
                        for q in 0..3 {
                            e[q] += l[q] * t;
                        }
                    }
                }
                e
            })
            .collect();
        let env = EnvMap {
            mapping: ll,
            width: w,
            height: h,
            channels: c,
            data: &img.data,
        };
        if std::env::var("TREE").is_ok() {
            use spheremap::lighting::envtree::{CutRule, EnvTree, Lobe};
            let t0 = std::time::Instant::now();
            let tree = EnvTree::build(&env, IDENTITY, 64).unwrap();
            let rule = CutRule::default();
            let got: Vec<[f64; 3]> = normals
                .par_iter()
                .map(|nn| {
                    let lobe = Lobe::new(
                        spheremap::lighting::brdf::Material::Lambert,
                        *nn,
                        *nn,
                        rule,
                        tree.mean_brightness(),
                    );
                    let r = tree.residual(&lobe);
                    [0, 1, 2].map(|q| std::f64::consts::PI * (tree.mean[q] + r[q]))
                })
                .collect();
            let t = t0.elapsed().as_secs_f64();
            let (mut worst, mut sum) = (0.0f64, 0.0);
            for (g, wv) in got.iter().zip(&want) {
                for q in 0..3 {
                    let e = (g[q] - wv[q]).abs() / scale;
                    worst = worst.max(e);
                    sum += e / 3.0;
                }
            }
            println!(
                "{path} tree (face 64, tol 1e-5): worst {worst:.2e} mean {:.2e}; {:.0} ms for {n} normals",
                sum / n as f64,
                t * 1e3
            );
        }
        for &face in &faces {
            let mut tb = f64::INFINITY;
            let mut tree = None;
            for _ in 0..reps {
                let t0 = std::time::Instant::now();
                tree = Some(CosineTree::build(&env, IDENTITY, face).unwrap());
                tb = tb.min(t0.elapsed().as_secs_f64());
            }
            let tree = tree.unwrap();
            let mut got = vec![[0.0; 3]; n];
            tree.irradiance(&normals, &mut got);
            let (mut worst, mut sum) = (0.0f64, 0.0);
            let mut at = 0;
            for (i, (g, wv)) in got.iter().zip(&want).enumerate() {
                for q in 0..3 {
                    let e = (g[q] - wv[q]).abs() / scale;
                    if e > worst {
                        at = i;
                    }
                    worst = worst.max(e);
                    sum += e / 3.0;
                }
            }
            if std::env::var("WHERE").is_ok() {
                // The brightest point and the worst normal's angle to it.
                let b = pts
                    .iter()
                    .max_by(|a, b| a.1[1].partial_cmp(&b.1[1]).unwrap())
                    .unwrap();
                let nn = normals[at];
                let cosang = nn[0] * b.0[0] + nn[1] * b.0[1] + nn[2] * b.0[2];
                println!(
                    "  worst at {:?}: got {:?} want {:?}; n·(brightest) {cosang:.4}",
                    nn, got[at], want[at]
                );
            }
            // Speed: a 128² cube's normals, four rows of 128 a call (as the prefilter's
            // canvas hands them over).
            let cube = Mapping::parse("cube", None).unwrap();
            let f = 128;
            let dirs: Vec<[f64; 3]> = (0..6 * f * f)
                .map(|k| {
                    let (x, y) = (k % f, k / f);
                    spheremap::base::vec::normalize(
                        cube.uv_to_dir([
                            (x as f64 + 0.5) / f as f64,
                            (y as f64 + 0.5) / (6 * f) as f64,
                        ])
                        .unwrap(),
                    )
                })
                .collect();
            let mut out = vec![[0.0; 3]; dirs.len()];
            let te = (0..reps)
                .map(|_| {
                    let t1 = std::time::Instant::now();
                    out.par_chunks_mut(4 * f)
                        .zip(dirs.par_chunks(4 * f))
                        .for_each(|(o, d)| tree.irradiance(d, o));
                    t1.elapsed().as_secs_f64()
                })
                .fold(f64::INFINITY, f64::min);
            println!(
                "{path} {}x{h}{} face {face}: worst {worst:.2e} mean {:.2e} (of π L̄); build {:.1} ms, 128² cube {:.1} ms",
                w,
                if sun { " +sun" } else { "" },
                sum / n as f64,
                tb * 1e3,
                te * 1e3
            );
            // The whole cube at once: antipodal texels by one integral.
            let mut all = Vec::new();
            let ta = (0..reps)
                .map(|_| {
                    let t1 = std::time::Instant::now();
                    all = tree.irradiance_all(&dirs);
                    t1.elapsed().as_secs_f64()
                })
                .fold(f64::INFINITY, f64::min);
            let apart = all
                .iter()
                .zip(&out)
                .flat_map(|(a, b)| (0..3).map(move |q| (a[q] - b[q]).abs() / scale))
                .fold(0.0, f64::max);
            // The 2,000 normals and their antipodes at once, against the brute force.
            let mut both = normals.clone();
            both.extend(normals.iter().map(|n| n.map(|v| -v)));
            let got = tree.irradiance_all(&both);
            let mut worst_all = 0.0f64;
            for (i, g) in got.iter().enumerate() {
                let nn = both[i];
                let mut wv = want[i % n];
                if i >= n {
                    // E(−n) brute force.
                    wv = [0.0; 3];
                    for (d, l) in &pts {
                        let t = nn[0] * d[0] + nn[1] * d[1] + nn[2] * d[2];
                        if t > 0.0 {
                            for q in 0..3 {
                                wv[q] += l[q] * t;
                            }
                        }
                    }
                }
                for q in 0..3 {
                    worst_all = worst_all.max((g[q] - wv[q]).abs() / scale);
                }
            }
            println!(
                "  all at once: 128² cube {:.1} ms, within {apart:.1e} of the batches; ±normals worst {worst_all:.2e}",
                ta * 1e3
            );
        }
    }
}
