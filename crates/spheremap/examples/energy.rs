//! How much light conversions keep: the output's power Σ L·dω and SH9 irradiance against the
//! source's ([`spheremap::resample::energy`]), for every mapping at several sizes, with the
//! peaks integrated (the default) and with the sampled filter alone.
//!
//! Usage: cargo run --release -p spheremap --example energy -- HDRI.exr [...]
//! `SCALE=2` enlarges each lat-long by texel duplication first (power unchanged);
//! `SUN=1,0.5` inserts a sun of that angular diameter (degrees) holding that fraction of the
//! map's power (covering texels by 8×8 points); `SIZES=16,64,256,1024` the output sizes;
//! `TO=cube,sphere,latlong,octahedral,angular,paraboloid` the output mappings.
use spheremap::images::codec::{read_image, ReadOptions};
use spheremap::images::Image;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::energy::{add_sun, LightCheck, Moments};
use spheremap::resample::{resample, EnvMap, ResampleOptions, IDENTITY};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let ll = Mapping::parse("latlong", None).unwrap();
    let scale: usize = std::env::var("SCALE").map_or(1, |v| v.parse().unwrap());
    let sizes: Vec<usize> = std::env::var("SIZES")
        .unwrap_or("16,64,256,1024".into())
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let to =
        std::env::var("TO").unwrap_or("cube,sphere,latlong,octahedral,angular,paraboloid".into());
    let sun: Option<(f64, f64)> = std::env::var("SUN").ok().map(|v| {
        let p: Vec<f64> = v.split(',').map(|x| x.parse().unwrap()).collect();
        (p[0], p[1])
    });
    println!("map | to | size | peaks | power error (worst channel) | SH9 irradiance error | sampled alone: power | SH9 | s (peaks / alone)");
    for path in &args {
        let src = read_image(std::path::Path::new(path), &ReadOptions::default()).unwrap();
        let (w, h, c) = (src.width * scale, src.height * scale, src.channels);
        let mut img = Image::new(w, h, c);
        for y in 0..h {
            for x in 0..w {
                let i = ((y / scale) * src.width + x / scale) * c;
                img.data[(y * w + x) * c..][..c].copy_from_slice(&src.data[i..i + c]);
            }
        }
        if let Some((deg, f)) = sun {
            let d = [0.35f64, 0.6, -0.72];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            add_sun(&mut img, ll, d.map(|x| x / l), deg, f).unwrap();
        }
        let env = EnvMap::new(ll, &img, "map").unwrap();
        let source = Moments::of(&env, &IDENTITY);
        let name = std::path::Path::new(path)
            .file_stem()
            .unwrap()
            .to_string_lossy();
        for m in to.split(',') {
            let dst = Mapping::parse(m, None).unwrap();
            for &n in &sizes {
                let (dw, dh) = dst.canvas(n);
                let mut row = Vec::new();
                let mut secs = Vec::new();
                let mut peaks = 0;
                for conserve in [true, false] {
                    let o = ResampleOptions {
                        conserve,
                        samples: std::env::var("SAMPLES").map_or(4, |v| v.parse().unwrap()),
                        ..Default::default()
                    };
                    let t = std::time::Instant::now();
                    let (out, r) = resample(&env, dst, dw, dh, &o, None).unwrap();
                    secs.push(t.elapsed().as_secs_f64());
                    if conserve {
                        peaks = r.peak_texels;
                    }
                    let oe = EnvMap::new(dst, &out, "out").unwrap();
                    let check = LightCheck::compare(&source, &Moments::of(&oe, &o.rotation));
                    let worst = check.worst_signed_power_error();
                    row.push(format!(
                        "{:+.3} % | {:.2} %",
                        100.0 * worst,
                        100.0 * check.irradiance_error.unwrap_or(f64::NAN)
                    ));
                }
                println!(
                    "{name} {w}x{h} | {m} | {n} | {peaks} | {} | {} | {:.3} / {:.3}",
                    row[0], row[1], secs[0], secs[1]
                );
            }
        }
    }
}
