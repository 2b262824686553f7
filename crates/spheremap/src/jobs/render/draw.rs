//! Drawing a mesh: the vertex stage (eye space, GL_SPHERE_MAP texgen, clip space), then the
//! rasterizer and the shader; and the visibility pass alone.

use super::{
    raster, shade, unit, Env, GlCamera, Mode, RenderOptions, RenderStats, Vertices, SUB_BITS,
};
use crate::base::error::{Error, Result};
use crate::images::Image;
use crate::mappings::texgen::{self, ModelviewState, NormalMode, TexgenOptions};
use crate::mesh::Mesh;

fn mul4(m: &[[f64; 4]; 4], p: [f64; 4]) -> [f64; 4] {
    std::array::from_fn(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] * p[3])
}

fn vertex_stage(mesh: &Mesh, cam: &GlCamera) -> Result<Vertices> {
    let mv = ModelviewState::new(cam.modelview)?;
    let n = mesh.positions.len();
    let mut st = vec![0f32; 2 * n];
    texgen::sphere_texgen(
        mesh.positions.as_flattened(),
        3,
        mesh.normals.as_flattened(),
        &mv,
        TexgenOptions {
            normalize: NormalMode::On,
            singular: crate::frame::conventions::Singular::Center,
        },
        &mut st,
    )?;
    let mut v = Vertices {
        eye: Vec::with_capacity(n),
        normal: Vec::with_capacity(n),
        st: st.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        clip: Vec::with_capacity(n),
    };
    for (p, nn) in mesh.positions.iter().zip(&mesh.normals) {
        let e = mul4(&cam.modelview, [p[0] as f64, p[1] as f64, p[2] as f64, 1.0]);
        let e3 = [e[0], e[1], e[2]];
        let nm = &mv.normal_matrix;
        let ne: [f64; 3] = std::array::from_fn(|i| {
            nm[i][0] * nn[0] as f64 + nm[i][1] * nn[1] as f64 + nm[i][2] * nn[2] as f64
        });
        v.eye.push(e3);
        v.normal.push(unit(ne).unwrap_or([0.0; 3]));
        v.clip
            .push(mul4(&cam.projection, [e3[0], e3[1], e3[2], 1.0]));
    }
    Ok(v)
}

/// Draws `mesh` seen by `cam` in `opts.mode`, looking up `env`. Returns the image ((H, W, 3)
/// linear colour, or (H, W, 2) degrees and coverage for `Error`) and what was drawn.
pub fn render(
    mesh: &Mesh,
    cam: &GlCamera,
    env: Env,
    opts: &RenderOptions,
) -> Result<(Image, RenderStats)> {
    if opts.aa == 0 || opts.aa > 16 {
        return Err(Error::param("aa", format!("{}: must be 1..=16", opts.aa)));
    }
    raster::check_subpixel_bits(opts.subpixel_bits)?;
    match (opts.mode, env) {
        (Mode::PerVertex | Mode::Matcap(_), Env::Texture(_)) => {}
        (Mode::PerVertex | Mode::Matcap(_), _) => {
            return Err(Error::param(
                "env",
                "per-vertex and matcap need a sphere map or MatCap image",
            ))
        }
        (Mode::PerPixel, Env::None) => {
            return Err(Error::param("env", "per-pixel needs an environment map"))
        }
        _ => {}
    }
    if mesh.positions.len() != mesh.normals.len() {
        return Err(Error::param("mesh", "needs one normal per vertex"));
    }
    let verts = vertex_stage(mesh, cam)?;
    let tris = raster::setup(
        &mesh.triangles,
        &verts,
        cam.width,
        cam.height,
        opts.subpixel_bits,
    )?;
    let shader = shade::Shader::new(opts.mode, env, cam, &verts);
    let (img, covered) = raster::draw(&tris, &shader, cam.width, cam.height, opts)?;
    Ok((
        img,
        RenderStats {
            triangles: tris.len(),
            covered_pixels: covered,
        },
    ))
}

/// Per pixel (row-major, row 0 at the top), the index of the mesh triangle seen through the
/// pixel centre, `u32::MAX` where none: the visibility pass of [`render`] with one sample.
pub fn triangle_ids(mesh: &Mesh, cam: &GlCamera) -> Result<Vec<u32>> {
    if mesh.positions.len() != mesh.normals.len() {
        return Err(Error::param("mesh", "needs one normal per vertex"));
    }
    let verts = vertex_stage(mesh, cam)?;
    let tris = raster::setup(&mesh.triangles, &verts, cam.width, cam.height, SUB_BITS)?;
    Ok(raster::triangle_ids(&tris, cam.width, cam.height))
}
