//! `spheremap demo`: the main job on embedded data, no user files needed.
//!
//! Writes into a directory: the direction chart as a sphere map (PNG and EXR), and the bundled
//! Utah teapot with GL_SPHERE_MAP texgen applied (OBJ with `vt` + MTL pointing at the chart, and
//! the raw (s,t) as CSV), for a viewer at (0, 12, 40) looking at the teapot's centre; and the
//! bundled CC0 HDRI (Poly Haven's apartment, 512×256 lat-long) converted into the sphere map of
//! that viewer (EXR, linear; PNG, sRGB) with the default footprint filter and gutter; the
//! teapot drawn with that sphere map per vertex (as OpenGL) and per pixel, with the error heat
//! map, in one contact sheet; a physically exact MatCap of the HDRI (GGX, roughness 0.5) for
//! the same viewer.

use crate::base::error::{Error, Result};
use crate::base::files;
use crate::base::parse::look_at;
use crate::jobs::chart::direction_chart;
use crate::mappings::texgen::{sphere_texgen, ModelviewState, TexgenOptions};
use crate::mesh::write::write_obj_with_uv;
use crate::mesh::{parse_obj, Mesh};
use std::path::{Path, PathBuf};

/// The Utah teapot (public domain; npm package `teapot` 1.0.0), 792 vertices, no normals.
pub const TEAPOT_OBJ: &str = include_str!("../data/teapot.obj");

/// A CC0 lat-long HDRI (Poly Haven via npm `@pmndrs/assets` 1.7.0, 512×256, DWAB EXR).
pub const APARTMENT_EXR: &[u8] = include_bytes!("../data/apartment.exr");

/// The bundled HDRI, decoded.
pub fn apartment() -> Result<crate::images::Image> {
    crate::images::codec::decode(
        Path::new("apartment.exr (bundled)"),
        APARTMENT_EXR,
        &Default::default(),
    )
}

/// Camera of the demo, as `gluLookAt` arguments.
pub const DEMO_EYE: [f64; 3] = [0.0, 12.0, 40.0];
pub const DEMO_TARGET: [f64; 3] = [0.0, 0.0, 0.0];
pub const DEMO_UP: [f64; 3] = [0.0, 1.0, 0.0];

/// The bundled teapot.
pub fn teapot() -> Result<Mesh> {
    parse_obj("teapot.obj (bundled)", TEAPOT_OBJ)
}

/// What the demo wrote.
#[derive(Debug)]
pub struct DemoReport {
    pub files: Vec<PathBuf>,
    pub vertices: usize,
    pub nan_texcoords: usize,
}

pub fn run(outdir: &Path, chart_size: usize) -> Result<DemoReport> {
    std::fs::create_dir_all(outdir).map_err(|e| Error::io(outdir, e))?;
    let mut files = Vec::new();
    let chart = direction_chart(chart_size);
    for name in ["direction_chart.png", "direction_chart.exr"] {
        let p = outdir.join(name);
        crate::images::codec::write_image(&p, &chart, &Default::default())?;
        files.push(p);
    }
    let mesh = teapot()?;
    let mv = ModelviewState::new(look_at(DEMO_EYE, DEMO_TARGET, DEMO_UP, "demo camera")?)?;
    let pos: Vec<f32> = mesh.positions.iter().flatten().copied().collect();
    let nrm: Vec<f32> = mesh.normals.iter().flatten().copied().collect();
    let mut st = vec![0.0f32; 2 * mesh.positions.len()];
    sphere_texgen(&pos, 3, &nrm, &mv, TexgenOptions::default(), &mut st)?;
    let mtl = outdir.join("teapot_spheremap.mtl");
    files::write_text(&mtl, "# spheremap demo: the direction chart as the teapot's texture\nnewmtl chart\nKd 1 1 1\nmap_Kd direction_chart.png\n")?;
    files.push(mtl);
    let obj = outdir.join("teapot_spheremap.obj");
    write_obj_with_uv(&obj, &mesh, &st, Some(("teapot_spheremap.mtl", "chart")))?;
    files.push(obj);
    let csv = outdir.join("teapot_texgen.csv");
    files::write_csv(&csv, &["s", "t"], &st)?;
    files.push(csv);
    // The HDRI as the sphere map of the demo viewer (the eye looks at the target from DEMO_EYE).
    let hdri = apartment()?;
    let src = crate::resample::EnvMap::new(
        crate::mappings::mapping::Mapping::parse("latlong", None)?,
        &hdri,
        "apartment.exr",
    )?;
    let look = [0, 1, 2].map(|k| DEMO_TARGET[k] - DEMO_EYE[k]);
    let view = crate::frame::view::look_up(look, DEMO_UP)?;
    let opts = crate::resample::ResampleOptions {
        rotation: view,
        ..Default::default()
    };
    let sphere = crate::mappings::mapping::Mapping::parse("sphere", None)?;
    let (map, _) = crate::resample::resample(&src, sphere, chart_size, chart_size, &opts, None)?;
    // Written as `convert` writes maps: with the note of their mapping and view (crate::images::note).
    for name in ["apartment_sphere.exr", "apartment_sphere.png"] {
        let p = outdir.join(name);
        let path = p.display().to_string();
        crate::images::envmap::write_env(&path, sphere, &map, None, &view, &Default::default())?;
        files.push(p);
    }
    // A physically exact MatCap of the HDRI for the same viewer: GGX of roughness 0.5.
    let bake = crate::lighting::matcap::Bake {
        material: crate::lighting::brdf::Material::Ggx { alpha: 0.25 },
        albedo: [1.0; 3],
        size: chart_size,
        view,
        world_to_env: crate::frame::view::IDENTITY,
        samples: crate::resample::DEFAULT_SAMPLES,
        max_samples: 1024,
        seed: 0,
        outside: crate::resample::Outside::Gutter,
        max_memory: crate::base::limits::default_max_memory(),
        rule: Default::default(),
        normal_table: None,
    };
    let (matcap, _) = crate::lighting::matcap::bake(&src, &bake, None)?;
    for name in [
        "apartment_matcap_ggx_0.5.exr",
        "apartment_matcap_ggx_0.5.png",
    ] {
        let p = outdir.join(name);
        let path = p.display().to_string();
        crate::images::envmap::write_env(&path, sphere, &matcap, None, &view, &Default::default())?;
        files.push(p);
    }
    // The teapot drawn with that sphere map by the rasterizer, from the demo camera: OpenGL's
    // per-vertex texgen and the per-pixel lookup side by side, with the angle between their
    // lookup directions as a heat map.
    let p = outdir.join("teapot_contact_sheet.png");
    crate::images::codec::write_image(&p, &contact_sheet(&mesh, &map)?, &Default::default())?;
    files.push(p);
    // The built-in scene, ray-traced into the sphere map of an eye at (0, 1, 0) looking
    // down -Z (16 rays per texel, more at the rim).
    let scene = crate::trace::scene::demo_scene();
    let gopts = crate::trace::generate::GenerateOptions {
        samples: 16,
        pos: [0.0, 1.0, 0.0],
        ..Default::default()
    };
    let (traced, _) =
        crate::trace::generate::generate(sphere, chart_size, chart_size, &scene, &gopts, None)?;
    for name in ["raytraced_sphere.exr", "raytraced_sphere.png"] {
        let p = outdir.join(name);
        let path = p.display().to_string();
        let identity = crate::frame::view::IDENTITY;
        crate::images::envmap::write_env(
            &path,
            sphere,
            &traced,
            None,
            &identity,
            &Default::default(),
        )?;
        files.push(p);
    }
    let nan_texcoords = st
        .chunks_exact(2)
        .filter(|p| p[0].is_nan() || p[1].is_nan())
        .count();
    Ok(DemoReport {
        files,
        vertices: mesh.positions.len(),
        nan_texcoords,
    })
}

/// Per-vertex | per-pixel | error heat map of `mesh` with `sphere_map` from the demo camera
/// (320 × 240, 2 × 2 samples per pixel, fovy 30°), captioned, the heat map with its colour bar.
pub fn contact_sheet(
    mesh: &Mesh,
    sphere_map: &crate::images::Image,
) -> Result<crate::images::Image> {
    use crate::jobs::render::{render, Env, GlCamera, Mode, RenderOptions, Texture, Wrap};
    let cam = GlCamera::look_at(DEMO_EYE, DEMO_TARGET, DEMO_UP, 30.0, 1.0, 200.0, 320, 240)?;
    let tex = Texture {
        image: sphere_map,
        wrap: Wrap::ClampToEdge,
    };
    let bg = [0.05, 0.05, 0.06];
    let draw = |mode| {
        let opts = RenderOptions {
            mode,
            background: bg,
            aa: 2,
            ..RenderOptions::default()
        };
        render(mesh, &cam, Env::Texture(&tex), &opts).map(|r| r.0)
    };
    let (vertex, pixel, error) = (
        draw(Mode::PerVertex)?,
        draw(Mode::PerPixel)?,
        draw(Mode::Error)?,
    );
    let top = 5.0;
    let deg: Vec<f64> = error
        .data
        .chunks_exact(2)
        .map(|p| {
            if p[1] > 0.0 {
                (p[0] as f64).min(top)
            } else {
                f64::NAN
            }
        })
        .collect();
    let heat =
        crate::jobs::analyze::figure::panel(&deg, 320, 240, 0.0, top, false, "lookup angle", "deg");
    let items = [
        (&vertex, "per-vertex (OpenGL GL_SPHERE_MAP)".to_string()),
        (&pixel, "per-pixel reflection".to_string()),
        (&heat, "per-vertex vs per-pixel".to_string()),
    ];
    Ok(crate::images::draw::contact_sheet(
        &items, 3, [0.02; 3], [0.9; 3],
    ))
}
