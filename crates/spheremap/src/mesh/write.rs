//! Meshes out: OBJ with the texgen result as `vt`.

use super::Mesh;
use crate::base::error::Result;
use crate::base::files::{atomic_write, io_err};
use std::io::Write;
use std::path::Path;

/// Writes a mesh as OBJ with one `vt` per vertex (the texgen result) and `vn` normals.
/// `mtl`: optional (material library file name, material name) to reference.
pub fn write_obj_with_uv(
    path: &Path,
    mesh: &Mesh,
    uv: &[f32],
    mtl: Option<(&str, &str)>,
) -> Result<()> {
    assert_eq!(uv.len(), 2 * mesh.positions.len());
    atomic_write(path, |f| {
        let mut w = std::io::BufWriter::new(f);
        let e = io_err(path);
        writeln!(
            w,
            "# written by spheremap {}: vt = GL_SPHERE_MAP texgen (s,t)",
            env!("CARGO_PKG_VERSION")
        )
        .map_err(&e)?;
        if let Some((lib, _)) = mtl {
            writeln!(w, "mtllib {lib}").map_err(&e)?;
        }
        for p in &mesh.positions {
            writeln!(w, "v {:?} {:?} {:?}", p[0], p[1], p[2]).map_err(&e)?;
        }
        for st in uv.chunks_exact(2) {
            // NaN (singular) texcoords would break OBJ readers: write the centre and say so.
            let (s, t) = if st[0].is_finite() && st[1].is_finite() {
                (st[0], st[1])
            } else {
                (0.5, 0.5)
            };
            writeln!(w, "vt {s:?} {t:?}").map_err(&e)?;
        }
        for n in &mesh.normals {
            writeln!(w, "vn {:?} {:?} {:?}", n[0], n[1], n[2]).map_err(&e)?;
        }
        if let Some((_, name)) = mtl {
            writeln!(w, "usemtl {name}").map_err(&e)?;
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| i + 1);
            writeln!(w, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}").map_err(&e)?;
        }
        w.flush().map_err(&e)
    })
}
