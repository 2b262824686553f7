//! `spheremap info` and Python's `info` as one request: [`InfoRequest`] reads a file's header
//! and texels ([`crate::images::info`]) and reports them, in JSON or in words, with the
//! problems `--check` fails on.

use crate::base::error::Result;
use crate::images::codec::ReadOptions;
use crate::images::info::{info, InfoReport};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What to read of an image file.  `Default` gives every documented default.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InfoRequest {
    /// Read LDR files as linear values (no sRGB decoding) for the statistics.
    pub linear: bool,
}

impl InfoRequest {
    /// The report of the file at `path`.
    pub fn run_files(&self, path: &Path) -> Result<InfoReport> {
        info(
            path,
            &ReadOptions {
                linear: self.linear,
                ..Default::default()
            },
        )
    }
}

impl super::Report for InfoReport {
    fn lines(&self) -> Vec<String> {
        let r = self;
        let names: Vec<&str> = r.stats.iter().map(|s| s.channel.as_str()).collect();
        let mut o = vec![format!(
            "{}: {} {}x{}, {} channels ({})",
            r.file,
            r.format,
            r.width,
            r.height,
            r.channels,
            names.join(",")
        )];
        if let Some(m) = r.extension_names {
            o.push(format!(
                "  note: the extension says {m}, the content is {}",
                r.format
            ));
        }
        let num = |v: Option<f64>| v.map_or("none".to_string(), |v| format!("{v:.6}"));
        for s in &r.stats {
            o.push(format!(
                "  {}: min {}  max {}  mean {}",
                s.channel,
                num(s.min),
                num(s.max),
                num(s.mean)
            ));
        }
        o.push(format!(
            "  non-finite: {} NaN, {} Inf{}",
            r.nan,
            r.inf,
            r.first_non_finite
                .map_or(String::new(), |(x, y)| format!(" (first at x={x}, y={y})"))
        ));
        o.push(format!("  negative values: {}", r.negative));
        if let Some(t) = &r.texture {
            let sizes: Vec<String> = t.levels.iter().map(|(w, h)| format!("{w}x{h}")).collect();
            o.push(format!(
                "  texture: {}, {} level{} ({}); the values above are level 0's",
                if t.cube {
                    "cube map (faces +X -X +Y -Y +Z -Z from the top)"
                } else {
                    "2D"
                },
                t.levels.len(),
                if t.levels.len() == 1 { "" } else { "s" },
                sizes.join(" ")
            ));
        }
        o.push(match (&r.recorded, &r.note) {
            (Some(_), Some(text)) if r.format == "DDS" => {
                format!("  mapping (DDS keeps no note; a cube texture's faces): {text}")
            }
            (Some(_), Some(text)) => {
                format!("  mapping (recorded in the file by spheremap when it wrote it): {text}")
            }
            _ => format!(
                "  mapping (a guess from the shape, not read from the file): {} — {}",
                r.mapping_guess.name, r.mapping_guess.reason
            ),
        });
        o
    }
}

/// What `info --check` fails on: NaN/Inf values, an extension that names another format than
/// the content; empty when the file is sound.
pub fn problems(r: &InfoReport) -> Vec<String> {
    let mut p = Vec::new();
    if r.nan + r.inf > 0 {
        p.push(format!("{} NaN/Inf values", r.nan + r.inf));
    }
    if let Some(m) = r.extension_names {
        p.push(format!("named {m} but holds {}", r.format));
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::Report;

    #[test]
    fn a_file_is_reported_in_words_and_its_problems_listed() {
        let dir = std::env::temp_dir().join(format!("spheremap-info-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("nan.pfm");
        let mut img = crate::images::Image::new(4, 2, 3);
        img.data[5] = f32::NAN;
        crate::images::codec::write_image(&path, &img, &Default::default()).unwrap();
        let r = InfoRequest::default().run_files(&path).unwrap();
        let lines = r.lines();
        assert!(
            lines[0].ends_with("nan.pfm: PFM 4x2, 3 channels (R,G,B)"),
            "{lines:?}"
        );
        assert!(
            lines
                .iter()
                .any(|l| l.starts_with("  non-finite: 1 NaN, 0 Inf (first at x=1, y=0)")),
            "{lines:?}"
        );
        assert_eq!(problems(&r), vec!["1 NaN/Inf values".to_string()]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
