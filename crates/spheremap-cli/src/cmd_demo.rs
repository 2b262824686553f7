use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory (created if missing).
    #[arg(default_value = "spheremap-demo")]
    outdir: PathBuf,
    /// Size of the direction chart and of the HDRI's sphere map, in texels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(spheremap::base::limits::DEMO_MIN_SIZE as i64..=spheremap::base::limits::DEMO_SIZE as i64))]
    size: u32,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    use std::fmt::Write;
    let mut o = String::new();
    let report = spheremap::demo::run(&a.outdir, a.size as usize)?;
    let _ = writeln!(
        o,
        "spheremap demo: GL_SPHERE_MAP direction chart, texgen of the bundled teapot, the bundled HDRI as a sphere map, and a ray-traced scene"
    );
    let _ = writeln!(
        o,
        "  teapot: {} vertices, {} singular (NaN) texcoords",
        report.vertices, report.nan_texcoords
    );
    for f in &report.files {
        let _ = writeln!(o, "  wrote {}", f.display());
    }
    let _ = writeln!(o, "  open teapot_spheremap.obj in any OBJ viewer: it is textured with the chart through its (s,t)");
    crate::out(&o);
    Ok(())
}
