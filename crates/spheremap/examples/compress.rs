//! What compressed textures do to the light: each HDRI turned into a cube with its mip chain
//! (each level resampled from the source, light kept), encoded as BC6H and RGB9E5 (KTX2, with
//! the lighting repair), and per level the power error of the decoded texels against the
//! uncompressed level before and after the repair, the RMSLE, the blocks repaired, the SH9
//! irradiance error (in units of the level's mean irradiance) and the time.
//!
//! Usage: cargo run --release -p spheremap --example compress -- HDRI.exr [...]
//! `SIZE=256` the cube's face size; `LEVELS=6`; `ENCODE=bc6h,rgb9e5`; `SUN=1,0.5` inserts a
//! sun of that diameter (degrees) holding that fraction of the power.
use spheremap::images::codec::{encode_texture, read_image, ReadOptions, WriteOptions};
use spheremap::images::compress::Encoding;
use spheremap::images::container::{decode, Texture};
use spheremap::images::format::Format;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::energy::{add_sun, LightCheck, Moments};
use spheremap::resample::{resample, EnvMap, ResampleOptions, IDENTITY};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let env_num = |k: &str, d: usize| std::env::var(k).map_or(d, |v| v.parse().unwrap());
    let (size, levels) = (env_num("SIZE", 256), env_num("LEVELS", 6));
    let encodings = std::env::var("ENCODE").unwrap_or("bc6h,rgb9e5".into());
    let sun: Option<(f64, f64)> = std::env::var("SUN").ok().map(|v| {
        let p: Vec<f64> = v.split(',').map(|x| x.parse().unwrap()).collect();
        (p[0], p[1])
    });
    let ll = Mapping::parse("latlong", None).unwrap();
    let cube = Mapping::parse("cube", None).unwrap();
    println!("map | encoding | level | power error: encoder alone (worst channel) | repaired | blocks repaired | RMSLE: encoder alone | repaired | SH9 irradiance error | s (whole chain)");
    for path in &args {
        let mut img = read_image(std::path::Path::new(path), &ReadOptions::default()).unwrap();
        if let Some((deg, f)) = sun {
            add_sun(&mut img, ll, [0.35, 0.6, -0.72], deg, f).unwrap();
        }
        let env = EnvMap::new(ll, &img, "map").unwrap();
        let tex = Texture {
            cube: true,
            levels: (0..levels)
                .map(|i| {
                    let n = (size >> i).max(1);
                    let (w, h) = cube.canvas(n);
                    resample(&env, cube, w, h, &ResampleOptions::default(), None)
                        .unwrap()
                        .0
                })
                .collect(),
        };
        let name = std::path::Path::new(path)
            .file_stem()
            .unwrap()
            .to_string_lossy();
        for e in encodings.split(',') {
            let opts = WriteOptions {
                encode: Encoding::parse_as(e, "ENCODE").unwrap(),
                ..Default::default()
            };
            let t0 = std::time::Instant::now();
            let (bytes, report) = encode_texture(
                std::path::Path::new("x.ktx2"),
                &tex,
                Format::Ktx2,
                &opts,
                Some("mapping=cube preset=gl layout=vstrip"),
            )
            .unwrap();
            let secs = t0.elapsed().as_secs_f64();
            let back = decode(std::path::Path::new("x.ktx2"), &bytes, &Default::default()).unwrap();
            let sh9 = |i: usize| {
                let m = |img| Moments::of(&EnvMap::new(cube, img, "m").unwrap(), &IDENTITY);
                LightCheck::compare(&m(&tex.levels[i]), &m(&back.levels[i]))
                    .irradiance_error
                    .unwrap()
            };
            let worst = |v: &[f64; 3]| {
                v.iter()
                    .fold(0f64, |a, &x| if x.abs() > a.abs() { x } else { a })
            };
            for (i, l) in report.unwrap().iter().enumerate() {
                println!(
                    "{name} | {e} | {i} | {:+.4} % | {:+.4} % | {}/{} | {:.4} | {:.4} | {:.3} % | {secs:.3}",
                    100.0 * worst(&l.power_error_unrepaired),
                    100.0 * worst(&l.power_error),
                    l.repaired,
                    l.blocks,
                    l.rmsle_unrepaired,
                    l.rmsle,
                    100.0 * sh9(i)
                );
            }
        }
    }
}
