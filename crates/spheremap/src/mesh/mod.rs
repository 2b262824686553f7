//! Triangle meshes from OBJ (tobj) and glTF 2.0 (gltf), flattened into one vertex list.
//!
//! * OBJ: faces triangulated; when the file has normals, vertices are split so each
//!   (position, normal, texcoord) triple is one vertex (`tobj` `single_index`).
//! * glTF/GLB: every mesh instance of the default scene (or of all nodes when there is no
//!   scene), with its node's world transform applied (normals by the inverse transpose).
//!   Triangles only; Draco-compressed files are not supported.
//! * Missing normals are computed: angle-weighted vertex normals (each face's unit normal
//!   weighted by the face's angle at the vertex), welding vertices at identical positions.

use crate::base::error::{Error, Result};
use std::path::Path;

pub mod write;

#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// True when the normals came from the file; false when [`vertex_normals`] made them.
    pub normals_from_file: bool,
}

/// The two kinds of mesh and scene file read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// glTF 2.0: JSON (.gltf) or binary (.glb).
    Gltf,
    /// Wavefront OBJ (with its MTL).
    Obj,
}

/// What a mesh or scene file holds: by its content first (the GLB magic, or JSON: glTF; OBJ
/// statements), else by its extension; `None` when neither tells.  The one rule for meshes
/// and scenes.
pub fn mesh_format(path: &Path, bytes: &[u8]) -> Option<MeshFormat> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let json = bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{');
    if bytes.starts_with(b"glTF") || json || ext == "gltf" || ext == "glb" {
        Some(MeshFormat::Gltf)
    } else if ext == "obj" || looks_like_obj(bytes) {
        Some(MeshFormat::Obj)
    } else {
        None
    }
}

/// Reads the file at `path` (its `bytes`) with the reader [`mesh_format`] chooses: `gltf`
/// after [`precheck_gltf`] and under [`crate::base::error::guard_parser`], or `obj`; `what` ("mesh",
/// "scene") names the file in the error when neither fits.  The one dispatch of meshes and
/// scenes.
pub(crate) fn read_by_format<T>(
    path: &Path,
    bytes: &[u8],
    what: &str,
    gltf: impl FnOnce() -> Result<T>,
    obj: impl FnOnce() -> Result<T>,
) -> Result<T> {
    match mesh_format(path, bytes) {
        Some(MeshFormat::Gltf) => {
            precheck_gltf(path, bytes)?;
            crate::base::error::guard_parser(path, "glTF", gltf)
        }
        Some(MeshFormat::Obj) => obj(),
        None => Err(Error::unsupported(
            format!("{what} file {}", path.display()),
            "expected an OBJ, glTF (.gltf) or GLB file",
        )),
    }
}

/// Loads a mesh, choosing the reader by [`mesh_format`].
pub fn load_mesh(path: &Path) -> Result<Mesh> {
    let bytes = crate::base::files::read_file(path)?;
    let mesh = read_by_format(path, &bytes, "mesh", || load_gltf(path), || load_obj(path))?;
    validate(path, &mesh)?;
    Ok(mesh)
}

/// Parses OBJ text (no MTL) from memory; `name` is used in messages.
pub fn parse_obj(name: &str, text: &str) -> Result<Mesh> {
    let mut reader = std::io::Cursor::new(text.as_bytes());
    let (models, _) = crate::base::error::guard_parser(Path::new(name), "OBJ", || {
        tobj::load_obj_buf(&mut reader, &obj_options(), |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .map_err(|e| Error::data(name, format!("cannot parse OBJ: {e}")))
    })?;
    let mesh = from_obj_models(name, models)?;
    validate(Path::new(name), &mesh)?;
    Ok(mesh)
}

pub(crate) fn looks_like_obj(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    std::str::from_utf8(head)
        .map(|s| {
            s.lines()
                .any(|l| l.starts_with("v ") || l.starts_with("f "))
        })
        .unwrap_or(false)
}

pub(crate) fn obj_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    }
}

/// What tobj reads from an OBJ file and its MTL files (the materials' own error kept apart:
/// a missing MTL is the caller's call).
pub(crate) type ObjContents = (
    Vec<tobj::Model>,
    std::result::Result<Vec<tobj::Material>, tobj::LoadError>,
);

/// Reads an OBJ file (and its MTL files) with tobj, which panics on some malformed MTL lines
/// ("Kd 1 2", found by the fuzzer): guarded.
pub(crate) fn read_obj_file(path: &Path) -> Result<ObjContents> {
    crate::base::error::guard_parser(path, "OBJ/MTL", || {
        tobj::load_obj(path, &obj_options())
            .map_err(|e| Error::data(path, format!("cannot read OBJ: {e}")))
    })
}

fn load_obj(path: &Path) -> Result<Mesh> {
    let (models, _materials) = read_obj_file(path)?;
    from_obj_models(&path.display().to_string(), models)
}

fn from_obj_models(name: &str, models: Vec<tobj::Model>) -> Result<Mesh> {
    let mut mesh = Mesh::default();
    let mut all_have_normals = true;
    for model in &models {
        let m = &model.mesh;
        let nv = m.positions.len() / 3;
        if m.normals.len() != m.positions.len() {
            all_have_normals = false;
        }
        let base = mesh.positions.len() as u32;
        mesh.positions
            .extend(m.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        if m.normals.len() == m.positions.len() {
            mesh.normals
                .extend(m.normals.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        }
        for tri in m.indices.chunks_exact(3) {
            if tri.iter().any(|&i| i as usize >= nv) {
                return Err(Error::data(
                    name,
                    format!("face index out of range in object {:?}", model.name),
                ));
            }
            mesh.triangles
                .push([base + tri[0], base + tri[1], base + tri[2]]);
        }
    }
    if all_have_normals && !mesh.positions.is_empty() {
        mesh.normals_from_file = true;
    } else {
        mesh.normals = vertex_normals(&mesh.positions, &mesh.triangles);
    }
    Ok(mesh)
}

/// Every node of the default scene (or of the first, or all nodes when there is none) with
/// its world transform.  Node graphs are trees by the glTF spec; each node is visited once, so
/// a malformed file with a cycle or a shared child cannot make this loop or explode.
pub(crate) fn gltf_world_nodes(doc: &gltf::Document) -> Vec<(gltf::Node<'_>, glam::Mat4)> {
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => doc.nodes().collect(),
    };
    let mut seen = vec![false; doc.nodes().len()];
    let mut out = Vec::new();
    let mut stack: Vec<(gltf::Node, glam::Mat4)> = roots
        .into_iter()
        .map(|n| (n, glam::Mat4::IDENTITY))
        .collect();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            continue;
        }
        let world = parent * glam::Mat4::from_cols_array_2d(&node.transform().matrix());
        for child in node.children() {
            stack.push((child, world));
        }
        out.push((node, world));
    }
    out
}

/// One triangle primitive of a glTF mesh, in world space (normals by the inverse transpose);
/// normals and texture coordinates only when the file gives one per vertex.
pub(crate) struct GltfPrimitive {
    pub positions: Vec<[f32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    /// Read by the scene loader (textured materials).
    #[cfg_attr(not(feature = "scene"), allow(dead_code))]
    pub uvs: Option<Vec<[f32; 2]>>,
    pub triangles: Vec<[u32; 3]>,
}

/// Reads a primitive placed by `world`; `None` for non-triangle primitives or ones without
/// positions; an error for an index out of range.
pub(crate) fn read_gltf_primitive(
    path: &Path,
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    world: glam::Mat4,
) -> Result<Option<GltfPrimitive>> {
    if prim.mode() != gltf::mesh::Mode::Triangles {
        return Ok(None);
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let Some(pos) = reader.read_positions() else {
        return Ok(None);
    };
    let positions: Vec<[f32; 3]> = pos
        .map(|p| world.transform_point3(p.into()).to_array())
        .collect();
    let nv = positions.len();
    let nmat = glam::Mat3::from_mat4(world).inverse().transpose();
    let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(|ns| {
        ns.map(|n| (nmat * glam::Vec3::from(n)).normalize_or_zero().to_array())
            .collect()
    });
    let uvs: Option<Vec<[f32; 2]>> = reader.read_tex_coords(0).map(|t| t.into_f32().collect());
    let idx: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..nv as u32).collect(),
    };
    let triangles: Vec<[u32; 3]> = idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    if triangles.iter().flatten().any(|&i| i as usize >= nv) {
        return Err(Error::data(path, "glTF index out of range"));
    }
    Ok(Some(GltfPrimitive {
        normals: normals.filter(|n| n.len() == nv),
        uvs: uvs.filter(|u| u.len() == nv),
        positions,
        triangles,
    }))
}

fn load_gltf(path: &Path) -> Result<Mesh> {
    let (doc, buffers, _images) =
        gltf::import(path).map_err(|e| Error::data(path, format!("cannot read glTF: {e}")))?;
    let mut mesh = Mesh::default();
    let mut all_have_normals = true;
    for (node, world) in gltf_world_nodes(&doc) {
        let Some(m) = node.mesh() else { continue };
        for prim in m.primitives() {
            let Some(p) = read_gltf_primitive(path, &prim, &buffers, world)? else {
                continue;
            };
            let base = mesh.positions.len() as u32;
            match p.normals {
                Some(ns) => mesh.normals.extend(ns),
                None => all_have_normals = false,
            }
            mesh.positions.extend(p.positions);
            mesh.triangles
                .extend(p.triangles.iter().map(|t| t.map(|i| base + i)));
        }
    }
    if all_have_normals && mesh.normals.len() == mesh.positions.len() && !mesh.positions.is_empty()
    {
        mesh.normals_from_file = true;
    } else {
        mesh.normals = vertex_normals(&mesh.positions, &mesh.triangles);
    }
    Ok(mesh)
}

fn validate(path: &Path, mesh: &Mesh) -> Result<()> {
    if mesh.positions.is_empty() {
        return Err(Error::data(path, "the mesh has no vertices"));
    }
    if let Some(i) = mesh
        .positions
        .iter()
        .position(|p| p.iter().any(|v| !v.is_finite()))
    {
        return Err(Error::data(
            path,
            format!("vertex {i} has a non-finite coordinate"),
        ));
    }
    Ok(())
}

/// Angle-weighted vertex normals: each triangle adds its unit normal times its interior angle
/// at the vertex (Thürmer & Wüthrich 1998), so the result does not depend on how a surface is
/// triangulated.  Vertices at bit-identical positions are welded for the sum (a texture seam
/// does not crease the shading).  Vertices touched by no non-degenerate triangle get (0,0,0).
pub fn vertex_normals(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    use glam::DVec3;
    use std::collections::HashMap;
    let mut group_of = HashMap::with_capacity(positions.len());
    let groups: Vec<usize> = positions
        .iter()
        .map(|p| {
            let next = group_of.len();
            *group_of.entry(p.map(f32::to_bits)).or_insert(next)
        })
        .collect();
    let mut acc = vec![DVec3::ZERO; group_of.len()];
    let p = |i: u32| DVec3::from(positions[i as usize].map(|v| v as f64));
    for tri in triangles {
        let v = [p(tri[0]), p(tri[1]), p(tri[2])];
        let Some(fnrm) = (v[1] - v[0]).cross(v[2] - v[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let (a, b) = (
                (v[(k + 1) % 3] - v[k]).try_normalize(),
                (v[(k + 2) % 3] - v[k]).try_normalize(),
            );
            if let (Some(a), Some(b)) = (a, b) {
                acc[groups[tri[k] as usize]] += fnrm * a.dot(b).clamp(-1.0, 1.0).acos();
            }
        }
    }
    groups
        .iter()
        .map(|&g| acc[g].normalize_or_zero().as_vec3().to_array())
        .collect()
}

/// Checks what the `gltf` crate's own validation indexes without checking (gltf-json 1.4.1
/// panics on a POSITION accessor index out of range — found by our fuzzer), so a malformed
/// file gets a precise error.  The full validation runs afterwards in `gltf::import`, and the
/// reading under [`crate::base::error::guard_parser`] (the crate has more panics on files that pass
/// its validation: an index accessor of floats reaches an `unreachable!`).
pub(crate) fn precheck_gltf(path: &Path, bytes: &[u8]) -> Result<()> {
    let glb;
    let json: &[u8] = if bytes.starts_with(b"glTF") {
        glb = gltf::Glb::from_slice(bytes)
            .map_err(|e| Error::data(path, format!("cannot read GLB: {e}")))?;
        &glb.json
    } else {
        bytes
    };
    let root: gltf::json::Root = gltf::json::deserialize::from_slice(json)
        .map_err(|e| Error::data(path, format!("cannot read glTF: {e}")))?;
    // External buffers and images are read by the gltf crate itself: make sure each is a
    // regular file (a device would be read forever).
    let uris = root
        .buffers
        .iter()
        .filter_map(|b| b.uri.as_deref())
        .chain(root.images.iter().filter_map(|i| i.uri.as_deref()));
    for uri in uris {
        if uri.starts_with("data:") || uri.contains("://") {
            continue;
        }
        let file = path.parent().unwrap_or(Path::new(".")).join(uri);
        if std::fs::metadata(&file).is_ok_and(|m| !m.is_file()) {
            return Err(Error::data(
                path,
                format!("cannot read glTF: {uri:?} is not a regular file"),
            ));
        }
    }
    let n = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (k, p) in mesh.primitives.iter().enumerate() {
            let bad = p.attributes.values().any(|i| i.value() >= n)
                || p.indices.is_some_and(|i| i.value() >= n)
                || p.targets.iter().flatten().any(|t| {
                    [t.positions, t.normals, t.tangents]
                        .iter()
                        .flatten()
                        .any(|i| i.value() >= n)
                });
            if bad {
                return Err(Error::data(
                    path,
                    format!("cannot read glTF: mesh {m} primitive {k} names an accessor beyond the {n} there are"),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube corner: three faces meet at the origin with right angles.  Angle weighting gives
    /// (1,1,1)/√3 however the faces are triangulated; splitting one face in two (so it has two
    /// triangles at the corner) must not pull the normal toward it.
    #[test]
    fn angle_weighted_normals_ignore_triangulation() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 0.0], // splits the z = 0 face
        ];
        // Faces with outward normals -x, -y, -z (toward the cube's outside at the corner).
        let whole = [[0, 3, 2], [0, 1, 3], [0, 2, 1]];
        let split = [[0, 3, 2], [0, 1, 3], [0, 2, 4], [0, 4, 1]];
        for tris in [&whole[..], &split[..]] {
            let n = vertex_normals(&p, tris);
            let k = -1.0 / 3f32.sqrt();
            for c in 0..3 {
                assert!((n[0][c] - k).abs() < 1e-6, "{:?}", n[0]);
            }
        }
        // Bit-identical positions are welded; an unused vertex gets zero.
        let n = vertex_normals(
            &[
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0; 3],
                [5.0; 3],
            ],
            &[[0, 1, 2]],
        );
        assert_eq!(n[0], n[3]);
        assert_eq!(n[4], [0.0; 3]);
    }
}
