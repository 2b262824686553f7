//! Accuracy of the MatCap bake against a brute-force reference: every texel of the lat-long
//! environment (halved to keep the reference cheap) split into KS×KS points with the map's
//! bilinear radiance and exact solid angles, summed in f64 for each MatCap texel centre.  PSNR
//! after x/(1+x) and sRGB, over the disc and per ring (centre to rim).
//!
//! The reference must resolve the lobe: its points are at most α/2 apart (KS = 4, or
//! ⌈2π/(H α)⌉ for a map H texels high when that is more: 8 at roughness 0.08, 20 at 0.05).
//! Fewer leave the reference, not the bake, wrong at the rim, where a grazing view thins the
//! lobe (at roughness 0.065, KS = 4 reads 36 dB, 8 55 dB, 12 and 16 68 dB).
//!
//! Usage: cargo run --release -p spheremap --example matcap_accuracy -- HDRI.exr [...]
//! `SUN=1` adds a one-texel sun holding a quarter of the map's energy; `TOL=…` overrides the
//! tree's tolerance; `ONLY=0.15` bakes only the materials whose name ends so; `N` (32) is the
//! MatCap's size and `KS` overrides the reference's points per texel axis; `STRIDE` (1) compares
//! every so many texels; `TABLE=1` / `TABLE=0` forces the grid of normals on / off (unset:
//! the bake's own choice).
use rayon::prelude::*;
use spheremap::images::codec::{read_image, ReadOptions};
use spheremap::lighting::brdf::{self, Material};
use spheremap::lighting::matcap::{self, Bake};
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::{EnvMap, Outside, IDENTITY};

fn srgb(x: f64) -> f64 {
    let x = (x / (1.0 + x)).clamp(0.0, 1.0);
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

fn rule() -> spheremap::lighting::envtree::CutRule {
    let mut r = spheremap::lighting::envtree::CutRule::default();
    let get = |k: &str, d: f64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    r.tol = get("TOL", r.tol);
    r.far = get("FAR", r.far);
    r.broad = get("BROAD", r.broad);
    r
}

#[allow(clippy::needless_range_loop)]
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let var = |k: &str, d: usize| -> usize {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let n = var("N", 32);
    let stride = var("STRIDE", 1);
    let ll = Mapping::parse("latlong", None).unwrap();
    for path in &args {
        let full = read_image(std::path::Path::new(path), &ReadOptions::default()).unwrap();
        // 2×2 box down to a quarter (the reference's cost).
        let (fw, fh, fc) = (full.width, full.height, full.channels);
        let mut img = spheremap::images::Image::new(fw / 2, fh / 2, fc);
        for y in 0..fh / 2 {
            for x in 0..fw / 2 {
                for q in 0..fc {
                    img.data[(y * (fw / 2) + x) * fc + q] = (0..4)
                        .map(|t| full.data[((2 * y + t / 2) * fw + 2 * x + t % 2) * fc + q])
                        .sum::<f32>()
                        / 4.0;
                }
            }
        }
        for v in img.data.iter_mut() {
            *v = v.max(0.0);
        }
        for sun in [std::env::var("SUN").is_ok()] {
            let mut env = img.clone();
            let (w, h, c) = (env.width, env.height, env.channels);
            if sun {
                // A sun of one texel holding a fifth of the energy (plus what it had).
                let total: f64 = (0..h)
                    .map(|y| {
                        (0..w)
                            .map(|x| {
                                env.data[(y * w + x) * c + 1] as f64
                                    * ll.texel_solid_angle(x, y, w, h)
                            })
                            .sum::<f64>()
                    })
                    .sum();
                let (sx, sy) = (w * 3 / 8 + 1, h / 3 + 1);
                let dw = ll.texel_solid_angle(sx, sy, w, h);
                for k in 0..3 {
                    env.data[(sy * w + sx) * c + k] += (0.25 * total / dw) as f32;
                }
            }
            let e = EnvMap::new(ll, &env, "env").unwrap();
            for (name, mat) in [
                ("lambert", Material::Lambert),
                ("ggx 1.0", Material::Ggx { alpha: 1.0 }),
                ("ggx 0.6", Material::Ggx { alpha: 0.36 }),
                ("ggx 0.5", Material::Ggx { alpha: 0.25 }),
                ("ggx 0.25", Material::Ggx { alpha: 0.0625 }),
                ("ggx 0.15", Material::Ggx { alpha: 0.0225 }),
                ("ggx 0.12", Material::Ggx { alpha: 0.0144 }),
                ("ggx 0.08", Material::Ggx { alpha: 0.0064 }),
                ("ggx 0.065", Material::Ggx { alpha: 0.004225 }),
                ("ggx 0.05", Material::Ggx { alpha: 0.0025 }),
            ] {
                if std::env::var("ONLY").is_ok_and(|o| !name.ends_with(&o)) {
                    continue;
                }
                let alpha = match mat {
                    Material::Ggx { alpha } => alpha,
                    Material::Lambert => 1.0,
                };
                // Brute-force table of env texels.
                let auto = (2.0 * std::f64::consts::PI / (h as f64 * alpha)).ceil() as usize;
                let ks = var("KS", auto.max(4));
                let e0 = EnvMap::new(ll, &env, "env").unwrap();
                let smp = spheremap::resample::Sampler::new(&e0);
                let texels: Vec<([f64; 3], [f64; 3])> = (0..h * ks)
                    .flat_map(|y| (0..w * ks).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        let d = ll
                            .uv_to_dir([
                                (x as f64 + 0.5) / (w * ks) as f64,
                                (y as f64 + 0.5) / (h * ks) as f64,
                            ])
                            .unwrap();
                        let dw = ll.texel_solid_angle(x, y, w * ks, h * ks);
                        let mut p = [0f32; 4];
                        smp.sample(d.map(|v| v as f32), &mut p);
                        (d, [p[0] as f64 * dw, p[1] as f64 * dw, p[2] as f64 * dw])
                    })
                    .collect();
                let b = Bake {
                    material: mat,
                    albedo: [1.0; 3],
                    size: n,
                    view: IDENTITY,
                    world_to_env: IDENTITY,
                    samples: 1,
                    max_samples: 1,
                    seed: 0,
                    outside: Outside::Gutter,
                    max_memory: u64::MAX,
                    rule: rule(),
                    normal_table: std::env::var("TABLE").ok().map(|t| t != "0"),
                };
                let t0 = std::time::Instant::now();
                let (out, rep) = matcap::bake(&e, &b, None).unwrap();
                let dt = t0.elapsed().as_secs_f64();
                let v = [0.0, 0.0, 1.0];
                let errs: Vec<(f64, usize)> = (0..n * n)
                    .into_par_iter()
                    .filter(|k| k % stride == 0)
                    .filter_map(|k| {
                        let (i, j) = (k % n, k / n);
                        let x = 2.0 * (i as f64 + 0.5) / n as f64 - 1.0;
                        let y = 2.0 * (1.0 - (j as f64 + 0.5) / n as f64) - 1.0;
                        let r2 = x * x + y * y;
                        if r2 >= 1.0 {
                            return None;
                        }
                        let nn = [x, y, (1.0 - r2).sqrt()];
                        let mut acc = [0.0; 3];
                        for (d, p) in &texels {
                            let g = brdf::eval_cos(mat, nn, v, *d);
                            if g != 0.0 {
                                for q in 0..3 {
                                    acc[q] += g * p[q];
                                }
                            }
                        }
                        let mut se = 0.0;
                        for q in 0..3 {
                            let a = srgb(out.data[k * out.channels + q] as f64);
                            let bb = srgb(acc[q]);
                            se += (a - bb) * (a - bb);
                        }
                        if std::env::var("XWORST").is_ok() && se > 1e-4 {
                            eprintln!(
                                "texel {i},{j} n {nn:?} got {:?} want {acc:?}",
                                &out.data[k * out.channels..][..3]
                            );
                        }
                        Some((se, ((r2.sqrt() * 4.0) as usize).min(3)))
                    })
                    .collect();
                let (se, cnt) = errs.iter().fold((0.0, 0), |a, b| (a.0 + b.0, a.1 + 3));
                let psnr = -10.0 * (se / cnt as f64).log10();
                let ring: Vec<String> = (0..4)
                    .map(|q| {
                        let (s, c) = errs
                            .iter()
                            .filter(|e| e.1 == q)
                            .fold((0.0, 0), |a, b| (a.0 + b.0, a.1 + 3));
                        format!("{:.1}", -10.0 * (s / c.max(1) as f64).log10())
                    })
                    .collect();
                println!("   rings (centre..rim): {}", ring.join(" "));
                println!(
                    "{path} sun={sun} {name}: PSNR {psnr:.1} dB  ({:?}, {:.3} s, {} integrals; reference {ks}×{ks} points per texel)",
                    rep.method, dt, rep.integrals
                );
            }
        }
    }
}
