use anyhow::{bail, Context};
use spheremap::texgen::{sphere_texgen, ModelviewState, NormalMode, TexgenOptions};
use spheremap::{io, mesh, parse, Singular};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Mesh file: OBJ, glTF (.gltf) or GLB.
    mesh: PathBuf,
    /// The 4x4 modelview: 16 numbers row-major (eye = M p), 'identity',
    /// 'lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ' (gluLookAt), or a text file holding one of these.
    #[arg(long, allow_hyphen_values = true)]
    modelview: String,
    /// Read the 16 numbers in OpenGL memory order (column-major, as glGetFloatv returns them).
    #[arg(long)]
    column_major: bool,
    /// GL normal state: on = GL_NORMALIZE, off = neither (normal NOT normalized, as GL),
    /// rescale = GL_RESCALE_NORMAL.
    #[arg(long, default_value = "on", value_parser = NormalMode::NAMES)]
    normalize: String,
    /// Result where r = (0,0,-1): nan (current Mesa) or center (legacy Mesa, Blender Cycles).
    #[arg(long, default_value = "nan", value_parser = Singular::NAMES)]
    singular: String,
    /// Output: .csv (s,t per vertex), .npy (N,2 float32) or .obj (the mesh with vt = (s,t)).
    #[arg(short, long)]
    output: PathBuf,
    /// Allow the output to replace an input file.
    #[arg(long)]
    force: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let ext = a
        .output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if !matches!(ext.as_str(), "csv" | "npy" | "obj") {
        bail!(
            "{}: unknown output extension; use .csv, .npy or .obj",
            a.output.display()
        );
    }
    if !a.force && same_file(&a.mesh, &a.output) {
        bail!(
            "{}: the output would overwrite the input mesh (use --force to allow)",
            a.output.display()
        );
    }
    let spec = modelview_spec(&a.modelview)?;
    let m = parse::parse_matrix4(&spec, a.column_major, "--modelview")?;
    let mv = ModelviewState::new(m)?;
    let opts = TexgenOptions {
        normalize: NormalMode::parse(&a.normalize, "--normalize")?,
        singular: Singular::parse(&a.singular, "--singular")?,
    };
    let mesh = mesh::load_mesh(&a.mesh)?;
    let pos: Vec<f32> = mesh.positions.iter().flatten().copied().collect();
    let nrm: Vec<f32> = mesh.normals.iter().flatten().copied().collect();
    let mut st = vec![0.0f32; 2 * mesh.positions.len()];
    sphere_texgen(&pos, 3, &nrm, &mv, opts, &mut st)?;
    match ext.as_str() {
        "csv" => io::write_csv(&a.output, &["s", "t"], &st)?,
        "npy" => io::write_npy_f32(&a.output, &[mesh.positions.len(), 2], &st)?,
        _ => io::write_obj_with_uv(&a.output, &mesh, &st, None)?,
    }
    let nan = st
        .chunks_exact(2)
        .filter(|p| p[0].is_nan() || p[1].is_nan())
        .count();
    eprintln!(
        "spheremap texgen: {} vertices ({} normals), {} singular (NaN{}), modelview {}-> {}",
        mesh.positions.len(),
        if mesh.normals_from_file {
            "file"
        } else {
            "computed, angle-weighted"
        },
        nan,
        if ext == "obj" && nan > 0 {
            "; written as 0.5 0.5 in the OBJ"
        } else {
            ""
        },
        if mv.singular {
            "singular (identity inverse used, as GL) "
        } else {
            ""
        },
        a.output.display()
    );
    Ok(())
}

/// The spec itself, or the contents of the file it names.
fn modelview_spec(arg: &str) -> anyhow::Result<String> {
    let p = Path::new(arg);
    if !arg.starts_with("lookat:") && p.is_file() {
        return std::fs::read_to_string(p)
            .with_context(|| format!("{}: cannot read the modelview file", p.display()));
    }
    Ok(arg.to_string())
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}
