use anyhow::{bail, Context};
use spheremap::base::{files, parse};
use spheremap::mappings::texgen::{sphere_texgen, ModelviewState, TexgenOptions};
use spheremap::mesh;
use spheremap::mesh::write::write_obj_with_uv;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Mesh file: OBJ, glTF (.gltf) or GLB.
    mesh: Option<PathBuf>,
    /// The 4x4 modelview: 16 numbers row-major (eye = M p), as 16 separate arguments
    /// (--modelview 1 0 0 0 0 1 0 0 ...) or in one ('1,0,0,0,...'); 'identity';
    /// 'lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ' (gluLookAt); or a text file holding one of these.
    #[arg(long, required = true, num_args = 1..=16, value_name = "SPEC",
          allow_negative_numbers = true)]
    modelview: Vec<String>,
    /// Read the 16 numbers in OpenGL memory order (column-major, as glGetFloatv returns them).
    #[arg(long)]
    column_major: bool,
    /// GL normal state: on = GL_NORMALIZE, off = neither (normal NOT normalized, as GL),
    /// rescale = GL_RESCALE_NORMAL.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::mappings::texgen::NormalMode>())]
    normalize: spheremap::mappings::texgen::NormalMode,
    /// Result where r = (0,0,-1): nan (current Mesa) or center (legacy Mesa, Blender Cycles).
    #[arg(long, default_value_t, value_parser = crate::names::typed::<spheremap::frame::conventions::Singular>())]
    singular: spheremap::frame::conventions::Singular,
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
    let (spec, mesh_path) = modelview_args(&a.modelview, a.mesh.as_deref())?;
    if !a.force && same_file(&mesh_path, &a.output) {
        bail!(
            "{}: the output would overwrite the input mesh (use --force to allow)",
            a.output.display()
        );
    }
    let spec = modelview_spec(&spec)?;
    let m = parse::parse_matrix4(&spec, a.column_major, "--modelview")?;
    let mv = ModelviewState::new(m)?;
    let opts = TexgenOptions {
        normalize: a.normalize,
        singular: a.singular,
    };
    let mesh = mesh::load_mesh(&mesh_path)?;
    let pos: Vec<f32> = mesh.positions.iter().flatten().copied().collect();
    let nrm: Vec<f32> = mesh.normals.iter().flatten().copied().collect();
    let mut st = vec![0.0f32; 2 * mesh.positions.len()];
    sphere_texgen(&pos, 3, &nrm, &mv, opts, &mut st)?;
    match ext.as_str() {
        "csv" => files::write_csv(&a.output, &["s", "t"], &st)?,
        "npy" => files::write_npy_f32(&a.output, &[mesh.positions.len(), 2], &st)?,
        _ => write_obj_with_uv(&a.output, &mesh, &st, None)?,
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

/// The modelview spec and the mesh path from `--modelview`'s values and the positional MESH.
/// The flag takes 16 separate numbers or one argument (a spec, or a file); since it takes up to
/// 16 values, a MESH written after it (`--modelview identity teapot.obj`) arrives among them and
/// is taken back from there.
fn modelview_args(values: &[String], mesh: Option<&Path>) -> anyhow::Result<(String, PathBuf)> {
    let is_number = |v: &str| v.trim().parse::<f64>().is_ok();
    // Separate numbers: the leading run of them; one argument of any other form: itself.
    let taken = if is_number(&values[0]) {
        values.iter().take_while(|v| is_number(v)).count()
    } else {
        1
    };
    let spec = values[..taken].join(" ");
    let mut rest = values[taken..].iter();
    let mesh = match (mesh, rest.next()) {
        (Some(m), None) => m.to_path_buf(),
        (None, Some(m)) => PathBuf::from(m),
        (None, None) => bail!("MESH: the mesh file is missing"),
        (Some(_), Some(extra)) => bail!(
            "--modelview: {extra:?} is not a number; the flag takes 16 numbers, 'identity', \
             'lookat:...' or a file (got {taken} value{} before it)",
            if taken == 1 { "" } else { "s" }
        ),
    };
    if let Some(extra) = rest.next() {
        bail!("--modelview: unexpected value {extra:?} after the mesh file");
    }
    if taken > 1 && taken != 16 {
        bail!("--modelview: expected 16 numbers (a 4x4 matrix), got {taken}");
    }
    Ok((spec, mesh))
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
