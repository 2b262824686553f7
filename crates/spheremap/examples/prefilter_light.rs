//! How much light each prefiltered level keeps: every level's power Σ L·dω against the
//! source's (the GGX kernels are normalised, so each level should hold it), per HDRI.
//!
//! Usage: cargo run --release -p spheremap --example prefilter_light -- HDRI.exr [...]
//! `SIZE=256` level 0's face; `LEVELS` (default: the prefilter's); `SAMPLES=1` spatial samples per texel;
//! `RMAP=threejs` the roughness map; `TO=octahedral` the output mapping;
//! `SUN=1,0.5` inserts a sun of that diameter (degrees) holding that fraction of the power.
use spheremap::images::codec::{read_image, ReadOptions};
use spheremap::jobs::prefilter::PrefilterRequest;
use spheremap::mappings::mapping::Mapping;
use spheremap::resample::energy::add_sun;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let env_num = |k: &str, d: usize| std::env::var(k).map_or(d, |v| v.parse().unwrap());
    let (size, samples) = (env_num("SIZE", 256), env_num("SAMPLES", 1));
    let levels: Option<usize> = std::env::var("LEVELS").ok().map(|v| v.parse().unwrap());
    let sun: Option<(f64, f64)> = std::env::var("SUN").ok().map(|v| {
        let p: Vec<f64> = v.split(',').map(|x| x.parse().unwrap()).collect();
        (p[0], p[1])
    });
    let ll = Mapping::parse("latlong", None).unwrap();
    println!("map | level | roughness | power error (worst channel) | s");
    for path in &args {
        let mut img = read_image(std::path::Path::new(path), &ReadOptions::default()).unwrap();
        if let Some((deg, f)) = sun {
            add_sun(&mut img, ll, [0.35, 0.6, -0.72], deg, f).unwrap();
        }
        let req = PrefilterRequest {
            size: Some(size),
            levels,
            samples: samples as u32,
            roughness_map: spheremap::lighting::prefilter::RoughnessMap::parse_as(
                &std::env::var("RMAP").unwrap_or("filament".into()),
                "RMAP",
            )
            .unwrap(),
            to: std::env::var("TO").unwrap_or("cube".into()),
            ..Default::default()
        };
        let name = std::path::Path::new(path)
            .file_stem()
            .unwrap()
            .to_string_lossy();
        for (_, rep) in req.run_image(&img, None).unwrap() {
            println!(
                "{name} | {} | {:.3} | {:+.4} % | {:.3}",
                rep.level,
                rep.roughness.unwrap_or(0.0),
                100.0 * rep.light.worst_signed_power_error(),
                rep.seconds
            );
        }
    }
}
