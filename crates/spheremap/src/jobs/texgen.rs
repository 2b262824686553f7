//! `spheremap texgen` as one request: [`TexgenRequest`] holds the modelview (as users write
//! it) and GL's normal state, computes `GL_SPHERE_MAP` texture coordinates for a mesh
//! ([`crate::mappings::texgen`]) and writes them (CSV, NPY, or the mesh as OBJ with `vt`).

use crate::base::error::{Error, Result};
use crate::base::{files, parse};
use crate::frame::conventions::Singular;
use crate::mappings::texgen::{sphere_texgen, ModelviewState, NormalMode, TexgenOptions};
use crate::mesh::{self, Mesh};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What texgen computes.  `Default` gives every documented default (the identity modelview).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TexgenRequest {
    /// The 4×4 modelview (eye = M p): 16 numbers, row-major (comma- or space-separated),
    /// `identity`, `lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ` (gluLookAt), or a text file holding one
    /// of these.
    pub modelview: String,
    /// The 16 numbers are in OpenGL's memory order (column-major, as glGetFloatv returns them).
    pub column_major: bool,
    /// GL's normal state: on (GL_NORMALIZE), off, rescale (GL_RESCALE_NORMAL).
    pub normalize: NormalMode,
    /// The result where r = (0, 0, -1): nan (current Mesa) or center (legacy Mesa, Cycles).
    pub singular: Singular,
}

impl Default for TexgenRequest {
    fn default() -> Self {
        TexgenRequest {
            modelview: "identity".into(),
            column_major: false,
            normalize: NormalMode::default(),
            singular: Singular::default(),
        }
    }
}

/// The report of `spheremap texgen --json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TexgenReport {
    pub mesh: String,
    pub output: String,
    pub vertices: usize,
    /// Whether the mesh's file gave its normals (else angle-weighted ones were computed).
    pub normals_from_file: bool,
    /// Vertices whose (s, t) is NaN (r = (0, 0, -1) with `singular` nan); an OBJ holds them as
    /// 0.5 0.5.
    pub singular_vertices: usize,
    /// The modelview had no inverse: the identity's was used for the normals, as GL does.
    pub singular_modelview: bool,
    pub seconds: f64,
}

/// The output formats, by extension.
const OUTPUTS: [&str; 3] = ["csv", "npy", "obj"];

impl TexgenRequest {
    /// The modelview's state (its normal matrix and rescale factor); errors name `modelview`.
    pub fn modelview(&self) -> Result<ModelviewState> {
        let spec = self.modelview.trim();
        let p = Path::new(spec);
        let text = if !spec.starts_with("lookat:") && p.is_file() {
            std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?
        } else {
            spec.to_string()
        };
        ModelviewState::new(parse::parse_matrix4(&text, self.column_major, "modelview")?)
    }

    /// (s, t) per vertex of `mesh` (NaN where singular), as GL computes them in float32.
    pub fn run(&self, mesh: &Mesh) -> Result<(Vec<f32>, ModelviewState)> {
        let mv = self.modelview()?;
        let opts = TexgenOptions {
            normalize: self.normalize,
            singular: self.singular,
        };
        let pos: Vec<f32> = mesh.positions.iter().flatten().copied().collect();
        let nrm: Vec<f32> = mesh.normals.iter().flatten().copied().collect();
        let mut st = vec![0.0f32; 2 * mesh.positions.len()];
        sphere_texgen(&pos, 3, &nrm, &mv, opts, &mut st)?;
        Ok((st, mv))
    }

    /// Reads the mesh at `mesh` (OBJ, glTF, GLB), computes its texture coordinates and writes
    /// them to `output` by its extension: .csv (s,t per vertex), .npy ((N, 2) float32) or .obj
    /// (the mesh with vt = (s, t)); `force` lets the output replace the mesh.
    pub fn run_files(&self, mesh: &Path, output: &Path, force: bool) -> Result<TexgenReport> {
        let t0 = std::time::Instant::now();
        let ext = output
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if !OUTPUTS.contains(&ext.as_str()) {
            return Err(Error::param(
                "output",
                format!(
                    "{}: unknown output extension; use .csv, .npy or .obj",
                    output.display()
                ),
            ));
        }
        let same = matches!((mesh.canonicalize(), output.canonicalize()), (Ok(a), Ok(b)) if a == b);
        if same && !force {
            return Err(Error::param(
                "output",
                format!(
                    "{}: the output would overwrite the input mesh (use --force to allow)",
                    output.display()
                ),
            ));
        }
        let m = mesh::load_mesh(mesh)?;
        let (st, mv) = self.run(&m)?;
        match ext.as_str() {
            "csv" => files::write_csv(output, &["s", "t"], &st)?,
            "npy" => files::write_npy_f32(output, &[m.positions.len(), 2], &st)?,
            _ => mesh::write::write_obj_with_uv(output, &m, &st, None)?,
        }
        Ok(TexgenReport {
            mesh: mesh.display().to_string(),
            output: output.display().to_string(),
            vertices: m.positions.len(),
            normals_from_file: m.normals_from_file,
            singular_vertices: st
                .chunks_exact(2)
                .filter(|p| p[0].is_nan() || p[1].is_nan())
                .count(),
            singular_modelview: mv.singular,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

impl super::Report for TexgenReport {
    fn lines(&self) -> Vec<String> {
        let obj = self.output.to_ascii_lowercase().ends_with(".obj");
        vec![format!(
            "spheremap texgen: {} vertices ({} normals), {} singular (NaN{}), modelview {}-> {}",
            self.vertices,
            if self.normals_from_file {
                "file"
            } else {
                "computed, angle-weighted"
            },
            self.singular_vertices,
            if obj && self.singular_vertices > 0 {
                "; written as 0.5 0.5 in the OBJ"
            } else {
                ""
            },
            if self.singular_modelview {
                "singular (identity inverse used, as GL) "
            } else {
                ""
            },
            self.output
        )]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::Report;

    #[test]
    fn a_mesh_gets_gl_s_coordinates_written_and_reported() {
        let dir = std::env::temp_dir().join(format!("spheremap-texgen-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = dir.join("tri.obj");
        std::fs::write(
            &obj,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n",
        )
        .unwrap();
        let r = TexgenRequest::default();
        let csv = dir.join("st.csv");
        let rep = r.run_files(&obj, &csv, false).unwrap();
        assert_eq!((rep.vertices, rep.normals_from_file), (3, true));
        // Identity modelview, normal +Z: the view direction at the origin is degenerate, at
        // (1,0,0) it is along +X; every (s, t) is finite and in [0, 1].
        let text = std::fs::read_to_string(&csv).unwrap();
        assert_eq!(text.lines().next(), Some("s,t"));
        assert!(rep.lines()[0].starts_with("spheremap texgen: 3 vertices (file normals)"));
        let e = r.run_files(&obj, &dir.join("st.txt"), false).unwrap_err();
        assert!(e.to_string().starts_with("output: "), "{e}");
        let e = r.run_files(&obj, &obj, false).unwrap_err();
        assert!(
            e.to_string().contains("would overwrite the input mesh"),
            "{e}"
        );
        let bad = TexgenRequest {
            modelview: "1,2,3".into(),
            ..Default::default()
        };
        assert!(bad
            .modelview()
            .unwrap_err()
            .to_string()
            .starts_with("modelview: "));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
