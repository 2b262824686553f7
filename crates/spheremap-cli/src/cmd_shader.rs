//! `spheremap shader`: prints a tested shader snippet.

use spheremap::jobs::shader::{source, Language, Snippet};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// glsl (default), wgsl or hlsl.
    #[arg(long, default_value_t, value_parser = crate::names::typed::<Language>())]
    lang: Language,
    /// texgen (per-vertex GL_SPHERE_MAP), lookup (per-pixel sphere map), matcap.
    #[arg(long, value_parser = crate::names::typed::<Snippet>())]
    what: Snippet,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    crate::out(source(a.lang, a.what));
    Ok(())
}
