use spheremap::frame::conventions::{RowOrder, Singular, PRESETS};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Image size used for the pixel coordinates printed.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=1<<20))]
    size: u32,
    /// Show only this preset.
    #[arg(long)]
    preset: Option<String>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    use std::fmt::Write;
    let mut o = String::new();
    let n = a.size as usize;
    if let Some(name) = &a.preset {
        spheremap::SpherePreset::by_name(name)?;
    }
    let _ = writeln!(o, "Eye space: right-handed, +X right, +Y up, looking down -Z. Disc centre = +Z (back at the viewer), rim = -Z.");
    let _ = writeln!(o, "Pixel coordinates: (0,0) = top-left corner of row 0; pixel centres at i + 0.5; texel centres (i + 0.5)/N.");
    for p in PRESETS
        .iter()
        .filter(|p| a.preset.as_deref().is_none_or(|n| n == p.name))
    {
        let rows = match p.rows {
            RowOrder::TopIsT1 => "row 0 = t = 1 (file order)",
            RowOrder::TopIsT0 => "row 0 = t = 0 (GL upload order)",
        };
        let _ = writeln!(
            o,
            "\n{}: {}\n  {}{}",
            p.name,
            p.doc,
            rows,
            if p.v_down { ", texcoord v = 1 - t" } else { "" }
        );
        for (d, name) in [
            ([1.0, 0.0, 0.0], "+X"),
            ([-1.0, 0.0, 0.0], "-X"),
            ([0.0, 1.0, 0.0], "+Y"),
            ([0.0, -1.0, 0.0], "-Y"),
            ([0.0, 0.0, 1.0], "+Z"),
            ([0.0, 0.0, -1.0], "-Z"),
        ] {
            let (x, y) = p.dir_to_pixel(d, n, Singular::Nan);
            if x.is_nan() {
                let _ = writeln!(o, "    {name} -> the whole rim (no single pixel)");
            } else {
                let _ = writeln!(o, "    {name} -> pixel ({x:.3}, {y:.3}) in a {n}x{n} image");
            }
        }
    }
    crate::out(&o);
    Ok(())
}
