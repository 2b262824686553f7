use spheremap::image_io::{inspect, ReadOptions};
use spheremap::tag::MapTag;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Image file (OpenEXR, Radiance HDR, PFM, PNG, JPEG, WebP; recognised by content).
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
    let i = inspect(
        &a.file,
        &ReadOptions {
            linear: a.linear,
            ..Default::default()
        },
    )?;
    let recorded = i.tag.as_deref().and_then(MapTag::parse);
    let mut o = String::new();
    let mismatch = i.extension_mismatch.map(|f| f.name());
    if a.json {
        let stats: Vec<_> = i
            .channel_names
            .iter()
            .zip(&i.stats)
            .map(|(n, s)| serde_json::json!({"channel": n, "min": finite(s.0 as f64), "max": finite(s.1 as f64), "mean": finite(s.2)}))
            .collect();
        let v = serde_json::json!({
            "file": a.file.display().to_string(),
            "format": i.format.name(),
            "extension_names": mismatch,
            "width": i.width,
            "height": i.height,
            "channels": i.channels,
            "stats": stats,
            "nan": i.nan_count,
            "inf": i.inf_count,
            "negative": i.negative_count,
            "first_non_finite": i.first_non_finite,
            "mapping_guess": {"name": i.mapping_guess.0, "reason": i.mapping_guess.1, "is_a_guess": true},
            "recorded": recorded.map(|t| serde_json::json!({
                "mapping": t.mapping.name(), "preset": t.mapping.preset_name(),
                "layout": t.layout.map(|l| l.name()),
                "face": t.face.map(|f| spheremap::cube::FACE_NAMES[f]),
                "look": t.view.map(|v| v.0), "up": t.view.map(|v| v.1),
            })),
        });
        let _ = writeln!(o, "{v}");
    } else {
        let _ = writeln!(
            o,
            "{}: {} {}x{}, {} channels ({})",
            a.file.display(),
            i.format.name(),
            i.width,
            i.height,
            i.channels,
            i.channel_names.join(",")
        );
        if let Some(m) = mismatch {
            let _ = writeln!(
                o,
                "  note: the extension says {m}, the content is {}",
                i.format.name()
            );
        }
        for (n, s) in i.channel_names.iter().zip(&i.stats) {
            let _ = writeln!(o, "  {n}: min {:.6}  max {:.6}  mean {:.6}", s.0, s.1, s.2);
        }
        let _ = writeln!(
            o,
            "  non-finite: {} NaN, {} Inf{}",
            i.nan_count,
            i.inf_count,
            i.first_non_finite
                .map_or(String::new(), |(x, y)| format!(" (first at x={x}, y={y})"))
        );
        let _ = writeln!(o, "  negative values: {}", i.negative_count);
        match recorded {
            Some(t) => {
                let _ = writeln!(
                    o,
                    "  mapping (recorded in the file by spheremap when it wrote it): {}",
                    t.text()
                );
            }
            None => {
                let _ = writeln!(
                    o,
                    "  mapping (a guess from the shape, not read from the file): {} — {}",
                    i.mapping_guess.0, i.mapping_guess.1
                );
            }
        }
    }
    crate::out(&o);
    if a.check {
        let mut problems = Vec::new();
        if i.nan_count + i.inf_count > 0 {
            problems.push(format!("{} NaN/Inf values", i.nan_count + i.inf_count));
        }
        if let Some(m) = mismatch {
            problems.push(format!("named {m} but holds {}", i.format.name()));
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

/// JSON has no NaN/Inf: those become null.
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}
