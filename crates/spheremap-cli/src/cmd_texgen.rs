//! `spheremap texgen`: its flags as the core's `jobs::texgen::TexgenRequest`, run and reported.

use anyhow::bail;
use spheremap::jobs::texgen::TexgenRequest;
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
    /// Print the report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let (spec, mesh_path) = modelview_args(&a.modelview, a.mesh.as_deref())?;
    let request = TexgenRequest {
        modelview: spec,
        column_major: a.column_major,
        normalize: a.normalize,
        singular: a.singular,
    };
    let report = request
        .run_files(&mesh_path, &a.output, a.force)
        .map_err(crate::flag_error)?;
    crate::print_report(&report, a.json, crate::Words::Stderr { quiet: false });
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
