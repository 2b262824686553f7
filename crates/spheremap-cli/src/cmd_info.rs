use spheremap::images::codec::ReadOptions;
use spheremap::images::info::info;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Image file (OpenEXR, Radiance HDR, PFM, PNG, JPEG, WebP, KTX2, DDS; recognised by content).
    file: PathBuf,
    /// Read LDR files as linear values (no sRGB decoding) for the statistics.
    #[arg(long)]
    linear: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Exit 1 (after printing) when the file has NaN/Inf values or its extension disagrees with
    /// its content — for scripts that sweep folders.
    #[arg(long)]
    check: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    use std::fmt::Write;
    let r = info(
        &a.file,
        &ReadOptions {
            linear: a.linear,
            ..Default::default()
        },
    )?;
    let mut o = String::new();
    if a.json {
        let _ = writeln!(o, "{}", serde_json::to_string(&r)?);
    } else {
        let names: Vec<&str> = r.stats.iter().map(|s| s.channel.as_str()).collect();
        let _ = writeln!(
            o,
            "{}: {} {}x{}, {} channels ({})",
            r.file,
            r.format,
            r.width,
            r.height,
            r.channels,
            names.join(",")
        );
        if let Some(m) = r.extension_names {
            let _ = writeln!(
                o,
                "  note: the extension says {m}, the content is {}",
                r.format
            );
        }
        let num = |v: Option<f64>| v.map_or("none".to_string(), |v| format!("{v:.6}"));
        for s in &r.stats {
            let _ = writeln!(
                o,
                "  {}: min {}  max {}  mean {}",
                s.channel,
                num(s.min),
                num(s.max),
                num(s.mean)
            );
        }
        let _ = writeln!(
            o,
            "  non-finite: {} NaN, {} Inf{}",
            r.nan,
            r.inf,
            r.first_non_finite
                .map_or(String::new(), |(x, y)| format!(" (first at x={x}, y={y})"))
        );
        let _ = writeln!(o, "  negative values: {}", r.negative);
        if let Some(t) = &r.texture {
            let sizes: Vec<String> = t.levels.iter().map(|(w, h)| format!("{w}x{h}")).collect();
            let _ = writeln!(
                o,
                "  texture: {}, {} level{} ({}); the values above are level 0's",
                if t.cube {
                    "cube map (faces +X -X +Y -Y +Z -Z from the top)"
                } else {
                    "2D"
                },
                t.levels.len(),
                if t.levels.len() == 1 { "" } else { "s" },
                sizes.join(" ")
            );
        }
        match (&r.recorded, &r.note) {
            (Some(_), Some(text)) if r.format == "DDS" => {
                let _ = writeln!(
                    o,
                    "  mapping (DDS keeps no note; a cube texture's faces): {text}"
                );
            }
            (Some(_), Some(text)) => {
                let _ = writeln!(
                    o,
                    "  mapping (recorded in the file by spheremap when it wrote it): {text}"
                );
            }
            _ => {
                let _ = writeln!(
                    o,
                    "  mapping (a guess from the shape, not read from the file): {} — {}",
                    r.mapping_guess.name, r.mapping_guess.reason
                );
            }
        }
    }
    crate::out(&o);
    if a.check {
        let mut problems = Vec::new();
        if r.nan + r.inf > 0 {
            problems.push(format!("{} NaN/Inf values", r.nan + r.inf));
        }
        if let Some(m) = r.extension_names {
            problems.push(format!("named {m} but holds {}", r.format));
        }
        if !problems.is_empty() {
            return Err(crate::FoundProblem(format!(
                "{}: {}",
                a.file.display(),
                problems.join("; ")
            ))
            .into());
        }
    }
    Ok(())
}
