//! Scene files: OBJ + MTL (tobj) and glTF 2.0 (gltf; .gltf with its buffers, or .glb).
//!
//! * OBJ/MTL: `Ke` → emission, `Kd` → diffuse (absent: 0.8 grey, or 0 when the material
//!   emits or is a mirror), `map_Kd` → diffuse texture (sRGB-decoded, relative to the MTL's
//!   folder).  The illumination model `illum` (see [`IllumModel`]):
//!   - `0` (colour on, ambient off): unlit, the constant colour `Kd` (× `map_Kd`) plus `Ke`,
//!     whatever the lights, the environment and the neighbours;
//!   - `1` (colour and ambient on) and no `illum`: diffuse only (`Ks` ignored);
//!   - `2` (highlight on): diffuse plus the lights' highlights, colour `Ks`, exponent `Ns`
//!     (normalised Blinn–Phong);
//!   - `3` to `9` (reflection on; glass, refraction and Fresnel variants): as `2`, plus a
//!     perfect mirror of colour `Ks` (1 when absent).  Refraction and transparency (`4`, `6`,
//!     `7`, `9`) and the Fresnel weighting (`5`, `7`) are not drawn: such a material is drawn
//!     as `3`, with a warning naming it;
//!   - `10` (shadow matte) is drawn as `1`, with a warning.
//!
//!   Faces without a material get the default (diffuse 0.8 grey).  `vt` v is flipped
//!   to the top-row convention.  A missing MTL file is an error (it names the file).
//! * glTF: the default scene's nodes with their world transforms; `emissiveFactor` ×
//!   `KHR_materials_emissive_strength` → emission; `baseColorFactor` × `baseColorTexture` →
//!   diffuse, times (1 − metallic); metallic ≥ 0.99 with roughness ≤ 0.01 → a mirror of the
//!   base colour.  `KHR_materials_unlit` → unlit (the base colour × texture plus the
//!   emission, as MTL `illum 0`).  `KHR_lights_punctual`: point and directional lights (colour × intensity);
//!   spot lights are treated as point lights (cone ignored).  Triangle primitives only;
//!   Draco-compressed files are not supported.

use super::{Environment, Light, Material, Scene, SceneBuilder, TriangleInput};
use crate::base::error::{Error, Result};
use crate::images::codec::{self, ReadOptions};
use crate::images::Image;
use crate::mesh::precheck_gltf;
use std::path::Path;

impl Scene {
    /// Loads an OBJ (+MTL) or glTF 2.0 (.gltf/.glb) file (chosen by content, else extension);
    /// the environment is black until set.
    pub fn load(path: &Path) -> Result<Scene> {
        load(path)
    }

    /// A scene from bytes: glTF JSON (buffers as data: URIs), GLB, or OBJ (no MTL); `name`
    /// is used in messages.
    pub fn load_bytes(name: &str, bytes: &[u8]) -> Result<Scene> {
        load_bytes(name, bytes)
    }

    /// A scene from OBJ text in memory and, optionally, the text of its MTL file.
    pub fn load_obj_bytes(name: &str, obj: &[u8], mtl: Option<&[u8]>) -> Result<Scene> {
        load_obj_bytes(name, obj, mtl)
    }
}

pub(super) fn load(path: &Path) -> Result<Scene> {
    let bytes = crate::base::files::read_file(path)?;
    let b =
        crate::mesh::read_by_format(path, &bytes, "scene", || load_gltf(path), || load_obj(path))?;
    b.build(Environment::Constant([0.0; 3]), &path.display().to_string())
}

/// A scene from bytes in memory (glTF JSON with embedded data: URIs, GLB, or OBJ without
/// MTL); `name` is used in messages.  What the fuzzers drive.
pub(super) fn load_bytes(name: &str, bytes: &[u8]) -> Result<Scene> {
    // No extension to go by: glTF when the content says so, else OBJ.
    let gltf =
        crate::mesh::mesh_format(Path::new(""), bytes) == Some(crate::mesh::MeshFormat::Gltf);
    let b = if gltf {
        precheck_gltf(Path::new(name), bytes)?;
        crate::base::error::guard_parser(Path::new(name), "glTF", || {
            let (doc, buffers, images) = gltf::import_slice(bytes)
                .map_err(|e| Error::data(name, format!("cannot read glTF: {e}")))?;
            from_gltf(Path::new(name), doc, buffers, images)
        })?
    } else {
        return load_obj_bytes(name, bytes, None);
    };
    b.build(Environment::Constant([0.0; 3]), name)
}

/// An OBJ in memory with the text of its MTL file (any `mtllib` resolves to it); texture
/// names are looked up relative to the working directory.
pub(super) fn load_obj_bytes(name: &str, obj: &[u8], mtl: Option<&[u8]>) -> Result<Scene> {
    let mut reader = std::io::Cursor::new(obj);
    let (models, materials) = crate::base::error::guard_parser(Path::new(name), "OBJ/MTL", || {
        tobj::load_obj_buf(&mut reader, &crate::mesh::obj_options(), |_| match mtl {
            Some(m) => tobj::load_mtl_buf(&mut std::io::Cursor::new(m)),
            None => Err(tobj::LoadError::OpenFileFailed),
        })
        .map_err(|e| Error::data(name, format!("cannot read OBJ: {e}")))
    })?;
    let mtls = match (materials, mtl) {
        (Ok(m), _) => m,
        (Err(_), None) => Vec::new(),
        (Err(e), Some(_)) => {
            return Err(Error::data(name, format!("cannot read its MTL: {e}")));
        }
    };
    from_obj(Path::new(name), models, mtls, Path::new("."))?
        .build(Environment::Constant([0.0; 3]), name)
}

fn load_obj(path: &Path) -> Result<SceneBuilder> {
    let (models, materials) = crate::mesh::read_obj_file(path)?;
    let mtls = match materials {
        Ok(m) => m,
        // tobj reports a file without mtllib as an error too.
        Err(tobj::LoadError::OpenFileFailed) if !mentions_mtllib(path) => Vec::new(),
        Err(e) => {
            return Err(Error::data(path, format!("cannot read its MTL file: {e}")));
        }
    };
    from_obj(path, models, mtls, path.parent().unwrap_or(Path::new(".")))
}

/// What the renderer draws for an MTL illumination model (the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IllumModel {
    /// `illum 0`: the constant colour `Kd` (+ `Ke`), unlit.
    Constant,
    /// `illum 1`, `10`, or none: diffuse.
    Diffuse,
    /// `illum 2`: diffuse plus the lights' highlights (`Ks`, `Ns`).
    Highlight,
    /// `illum 3` to `9`: as `Highlight`, plus a perfect mirror of colour `Ks`.
    Reflection,
}

impl IllumModel {
    /// The model drawn for an MTL `illum` value (`None`: no `illum` line).
    pub fn of(illum: Option<u8>) -> IllumModel {
        match illum {
            Some(0) => IllumModel::Constant,
            Some(2) => IllumModel::Highlight,
            Some(3..=9) => IllumModel::Reflection,
            _ => IllumModel::Diffuse,
        }
    }
}

/// For an `illum` value the renderer draws only approximately, what it draws instead.
fn illum_approximation(illum: Option<u8>) -> Option<&'static str> {
    match illum? {
        4 | 6 | 9 => Some("transparency and refraction are not drawn: drawn as illum 3, a mirror"),
        5 => Some("Fresnel reflection is not drawn: drawn as illum 3, a mirror of colour Ks"),
        7 => Some(
            "refraction and Fresnel reflection are not drawn: drawn as illum 3, a mirror of \
             colour Ks",
        ),
        8 => Some("drawn as illum 3: the mirror is ray traced"),
        10 => Some("shadow matte is not drawn: drawn as illum 1, diffuse"),
        v if v > 10 => Some("not an MTL illumination model: drawn as illum 1, diffuse"),
        _ => None,
    }
}

fn from_obj(
    path: &Path,
    models: Vec<tobj::Model>,
    mtls: Vec<tobj::Material>,
    dir: &Path,
) -> Result<SceneBuilder> {
    let mut b = SceneBuilder::new();
    let default = b.add_material(Material {
        name: "default".into(),
        ..Material::default()
    });
    let mut ids = Vec::with_capacity(mtls.len());
    for m in &mtls {
        let emission = m.emissive.unwrap_or([0.0; 3]);
        let emits = emission.iter().any(|&v| v > 0.0);
        let model = IllumModel::of(m.illumination_model);
        if let Some(note) = illum_approximation(m.illumination_model) {
            crate::base::error::warn(&format!(
                "{}: material {:?} asks for illum {} ({note})",
                path.display(),
                m.name,
                m.illumination_model.unwrap_or(0)
            ));
        }
        let mirror_model = model == IllumModel::Reflection;
        let diffuse = m.diffuse.unwrap_or(if emits || mirror_model {
            [0.0; 3]
        } else {
            [0.8; 3]
        });
        let diffuse_texture = match &m.diffuse_texture {
            Some(name) => {
                let tp = dir.join(name);
                Some(b.add_texture(codec::read_image(&tp, &ReadOptions::default())?))
            }
            None => None,
        };
        ids.push(b.add_material(Material {
            name: m.name.clone(),
            emission,
            diffuse,
            diffuse_texture,
            mirror: if mirror_model {
                m.specular.unwrap_or([1.0; 3])
            } else {
                [0.0; 3]
            },
            specular: if matches!(model, IllumModel::Highlight | IllumModel::Reflection) {
                m.specular.unwrap_or([0.0; 3])
            } else {
                [0.0; 3]
            },
            shininess: m.shininess.unwrap_or(0.0),
            unlit: model == IllumModel::Constant,
        }));
    }
    for model in &models {
        let mesh = &model.mesh;
        let nv = mesh.positions.len() / 3;
        let v3 = |a: &[f32], i: usize| [a[3 * i], a[3 * i + 1], a[3 * i + 2]];
        let has_n = mesh.normals.len() == mesh.positions.len();
        let has_uv = mesh.texcoords.len() == 2 * nv;
        let mat = mesh
            .material_id
            .and_then(|i| ids.get(i).copied())
            .unwrap_or(default);
        for t in mesh.indices.chunks_exact(3) {
            let i = [t[0], t[1], t[2]].map(|k| k as usize);
            if i.iter().any(|&k| k >= nv) {
                return Err(Error::data(
                    path,
                    format!("face index out of range in object {:?}", model.name),
                ));
            }
            b.add_triangle(TriangleInput {
                positions: i.map(|k| v3(&mesh.positions, k)),
                normals: has_n.then(|| i.map(|k| v3(&mesh.normals, k))),
                uvs: has_uv
                    .then(|| i.map(|k| [mesh.texcoords[2 * k], 1.0 - mesh.texcoords[2 * k + 1]])),
                material: mat,
            });
        }
    }
    Ok(b)
}

fn mentions_mtllib(path: &Path) -> bool {
    std::fs::read_to_string(path)
        .map(|s| s.lines().any(|l| l.trim_start().starts_with("mtllib")))
        .unwrap_or(false)
}

fn load_gltf(path: &Path) -> Result<SceneBuilder> {
    let (doc, buffers, images) =
        gltf::import(path).map_err(|e| Error::data(path, format!("cannot read glTF: {e}")))?;
    from_gltf(path, doc, buffers, images)
}

fn from_gltf(
    path: &Path,
    doc: gltf::Document,
    buffers: Vec<gltf::buffer::Data>,
    images: Vec<gltf::image::Data>,
) -> Result<SceneBuilder> {
    let mut b = SceneBuilder::new();
    let default = b.add_material(Material {
        name: "default".into(),
        ..Material::default()
    });
    // Textures are converted once per image, on first use.
    let mut texture_of_image: Vec<Option<usize>> = vec![None; images.len()];
    let mut ids = Vec::new();
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let base = pbr.base_color_factor();
        let (metal, rough) = (pbr.metallic_factor(), pbr.roughness_factor());
        let strength = m.emissive_strength().unwrap_or(1.0);
        let emission = m.emissive_factor().map(|v| v * strength);
        let mut tex = None;
        if let Some(info) = pbr.base_color_texture() {
            let k = info.texture().source().index();
            let data = images
                .get(k)
                .ok_or_else(|| Error::data(path, format!("texture image {k} is missing")))?;
            tex = Some(match texture_of_image[k] {
                Some(t) => t,
                None => {
                    let t = b.add_texture(gltf_image(path, data)?);
                    texture_of_image[k] = Some(t);
                    t
                }
            });
        }
        let rgb = [base[0], base[1], base[2]];
        let unlit = m.unlit();
        let mirror = metal >= 0.99 && rough <= 0.01 && !unlit;
        if unlit {
            ids.push(b.add_material(Material {
                name: m.name().unwrap_or("").to_string(),
                emission,
                diffuse: rgb,
                diffuse_texture: tex,
                unlit: true,
                ..Material::default()
            }));
            continue;
        }
        ids.push(b.add_material(Material {
            name: m.name().unwrap_or("").to_string(),
            emission,
            diffuse: if mirror {
                [0.0; 3]
            } else {
                rgb.map(|v| v * (1.0 - metal))
            },
            diffuse_texture: if mirror { None } else { tex },
            mirror: if mirror { rgb } else { [0.0; 3] },
            ..Material::default()
        }));
    }
    for (node, world) in crate::mesh::gltf_world_nodes(&doc) {
        if let Some(light) = node.light() {
            let c = light.color().map(|v| v * light.intensity());
            b.add_light(match light.kind() {
                gltf::khr_lights_punctual::Kind::Directional => Light::Directional {
                    direction: world
                        .transform_vector3(glam::Vec3::NEG_Z)
                        .normalize_or_zero()
                        .to_array(),
                    irradiance: c,
                },
                _ => Light::Point {
                    position: world.transform_point3(glam::Vec3::ZERO).to_array(),
                    intensity: c,
                },
            });
        }
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            let Some(p) = crate::mesh::read_gltf_primitive(path, &prim, &buffers, world)? else {
                continue;
            };
            let mat = prim
                .material()
                .index()
                .and_then(|i| ids.get(i).copied())
                .unwrap_or(default);
            b.add_mesh(
                &p.positions,
                p.normals.as_deref(),
                p.uvs.as_deref(),
                &p.triangles,
                mat,
            );
        }
    }
    Ok(b)
}

/// A decoded glTF image as a linear float texture (8- and 16-bit data are sRGB).
fn gltf_image(path: &Path, d: &gltf::image::Data) -> Result<Image> {
    use gltf::image::Format as F;
    let (ch, bytes) = match d.format {
        F::R8 => (1, 1),
        F::R8G8 => (2, 1),
        F::R8G8B8 => (3, 1),
        F::R8G8B8A8 => (4, 1),
        F::R16 => (1, 2),
        F::R16G16 => (2, 2),
        F::R16G16B16 => (3, 2),
        F::R16G16B16A16 => (4, 2),
        F::R32G32B32FLOAT => (3, 4),
        F::R32G32B32A32FLOAT => (4, 4),
    };
    let (w, h) = (d.width as usize, d.height as usize);
    if d.pixels.len() != w * h * ch * bytes || w == 0 || h == 0 {
        return Err(Error::data(path, "a texture image has the wrong size"));
    }
    let data: Vec<f32> = match bytes {
        1 => d
            .pixels
            .iter()
            .map(|&v| codec::srgb_to_linear(v as f32 / 255.0))
            .collect(),
        2 => d
            .pixels
            .chunks_exact(2)
            .map(|c| codec::srgb_to_linear(u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0))
            .collect(),
        _ => d
            .pixels
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
    };
    Ok(Image {
        width: w,
        height: h,
        channels: ch,
        data,
    })
}
