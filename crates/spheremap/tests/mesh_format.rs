//! Meshes and scenes share one rule for what a file holds (content first, then extension).

use spheremap::mesh::{load_mesh, mesh_format, MeshFormat};
use spheremap::trace::scene::Scene;
use std::path::Path;

mod common;
use common::GLTF_TRIANGLE;

#[test]
fn meshes_and_scenes_tell_a_file_by_its_content_alike() {
    let dir = std::env::temp_dir().join(format!("spheremap-mesh-format-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    // glTF JSON under names that say nothing, or the wrong thing; OBJ likewise.
    for (name, text, want) in [
        ("tri.gltf", GLTF_TRIANGLE, MeshFormat::Gltf),
        ("tri.txt", GLTF_TRIANGLE, MeshFormat::Gltf),
        ("tri.obj", GLTF_TRIANGLE, MeshFormat::Gltf),
        ("tri.obj", obj, MeshFormat::Obj),
        ("tri.mesh", obj, MeshFormat::Obj),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, format!("\n  {text}")).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(mesh_format(&p, &bytes), Some(want), "{name}");
        let mesh = load_mesh(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(mesh.triangles.len(), 1, "{name}");
        Scene::load(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    assert_eq!(mesh_format(Path::new("x.dat"), b"\x00\x01binary"), None);
    std::fs::remove_dir_all(&dir).unwrap();
}
