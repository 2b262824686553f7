//! `spheremap shader`: prints a tested shader snippet.

use spheremap::jobs::shader::snippet;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// glsl (default), wgsl or hlsl.
    #[arg(long, default_value = "glsl")]
    lang: String,
    /// texgen (per-vertex GL_SPHERE_MAP), lookup (per-pixel sphere map), matcap.
    #[arg(long)]
    what: String,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    crate::out(snippet(&a.lang, &a.what)?);
    Ok(())
}
