//! `spheremap analyze`: a thin layer over `spheremap::jobs::analyze`.

use crate::camera_args::CameraArgs;
use crate::job::JobFlags;
use anyhow::Context;
use spheremap::images::codec::{read_image, write_image, ReadOptions};
use spheremap::images::draw;
use spheremap::jobs::analyze::{self, figure};
use spheremap::jobs::render::{self, Env, Mode, RenderOptions};
use spheremap::mappings::mapping::Mapping;
use spheremap::mesh::load_mesh;
use std::path::Path;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// An environment map whose mapping (--mapping) and size are analysed.
    map: Option<String>,
    /// The mapping: sphere (default), latlong, cube, angular, paraboloid, octahedral.
    #[arg(long, default_value = "sphere", value_parser = crate::names::core("mapping"))]
    mapping: String,
    /// Its preset.
    #[arg(long)]
    preset: Option<String>,
    /// Canvas size N without MAP (sphere N×N, latlong 2N×N, cube faces N×N...).
    #[arg(long, default_value_t = 256)]
    size: usize,
    /// A mesh: per-vertex interpolation error, triangles over --threshold, tessellation advice.
    #[arg(long)]
    mesh: Option<String>,
    #[command(flatten)]
    camera: CameraArgs,
    /// Size of the mesh's error heat map.
    #[arg(long, num_args = 2, value_names = ["W", "H"], default_values_t = [512, 512])]
    view_size: Vec<usize>,
    /// Error threshold in degrees for the triangle list and the tessellation advice.
    #[arg(long, default_value_t = 1.0)]
    threshold: f64,
    /// The figure (PNG/JPEG; panels with colour bars and legends).
    #[arg(short = 'o', long)]
    output: String,
    #[command(flatten)]
    job: JobFlags,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mapping = Mapping::parse(&a.mapping, a.preset.as_deref()).context("--mapping/--preset")?;
    let inputs: Vec<&String> = a.map.iter().collect();
    a.job.refuse_overwrite(&inputs, &[&a.output])?;
    let (w, h) = match &a.map {
        Some(path) => {
            let img = read_image(Path::new(path), &ReadOptions::default())?;
            mapping
                .size_of(img.width, img.height, "map")
                .with_context(|| path.clone())?;
            (img.width, img.height)
        }
        None => analyze::canvas(mapping, "size", a.size)?,
    };
    let maps = analyze::mapping_maps(mapping, w, h)?;
    let mut summary = maps.summary(mapping);
    let (sa, an, re) = (
        summary.solid_angle_sr,
        summary.anisotropy,
        summary.resolution_deg,
    );
    let mut panels = vec![figure::mapping_figure(&maps, mapping.name())];
    let mut lines = vec![format!(
        "{} {w}x{h}: texel solid angle {}..{} sr (max/min {:.3}), anisotropy up to {:.3}, \
         coarsest step {:.4}..{:.4} deg/texel",
        mapping.name(),
        figure::num(sa.min),
        figure::num(sa.max),
        sa.max / sa.min,
        an.max,
        re.min,
        re.max
    )];
    if let Some(path) = &a.mesh {
        let mesh = load_mesh(Path::new(path))?;
        let cam = a
            .camera
            .request((a.view_size[0], a.view_size[1]))
            .camera(&mesh.positions)
            .with_context(|| path.clone())?;
        let (err, heat) = analyze::mesh_report(&mesh, &cam, a.threshold)?;
        let m = err.summary(Some(path), &heat);
        lines.push(format!(
            "{path}: {} of {} triangles in view over {}°; split each edge in {} \
             ({} triangles) or adaptively ({} triangles); {} cannot get under it (they reflect \
             toward the sphere map's rim)",
            m.over,
            m.in_view,
            a.threshold,
            m.uniform_split,
            m.triangles_after_uniform,
            m.triangles_after_adaptive,
            m.unfixable
        ));
        summary.mesh = Some(m);
        let deg: Vec<f64> = heat
            .data
            .chunks_exact(2)
            .map(|p| if p[1] > 0.0 { p[0] as f64 } else { f64::NAN })
            .collect();
        let top = (2.0 * a.threshold).max(1e-6);
        // Clipped at twice the threshold (NaN, no surface, stays NaN).
        panels.push(figure::panel(
            &deg.iter()
                .map(|v| if *v > top { top } else { *v })
                .collect::<Vec<_>>(),
            heat.width,
            heat.height,
            0.0,
            top,
            false,
            &format!(
                "per-vertex vs per-pixel lookup angle (threshold {}°)",
                a.threshold
            ),
            "deg",
        ));
        let normals_opts = RenderOptions {
            mode: Mode::Normals,
            ..Default::default()
        };
        let (normals, _) = render::render(&mesh, &cam, Env::None, &normals_opts)?;
        let ids = render::triangle_ids(&mesh, &cam)?;
        panels.push(figure::triangles_panel(&ids, &normals, &err));
    }
    let sheet = if panels.len() == 1 {
        panels.pop().unwrap()
    } else {
        let items: Vec<_> = panels.iter().map(|p| (p, String::new())).collect();
        draw::contact_sheet(&items, 1, [0.02; 3], [0.9; 3])
    };
    write_image(Path::new(&a.output), &sheet, &a.job.write_options(false))?;
    if a.job.json {
        let mut json = serde_json::to_value(&summary)?;
        json["output"] = a.output.clone().into();
        crate::out(&format!("{json}\n"));
    } else if !a.job.quiet {
        for l in lines {
            eprintln!("{l}");
        }
        eprintln!("-> {}", a.output);
    }
    Ok(())
}
