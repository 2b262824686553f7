//! `spheremap info`: its flags as the core's `jobs::info::InfoRequest`, run and reported.

use spheremap::jobs::info::{problems, InfoRequest};
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
    let request = InfoRequest { linear: a.linear };
    let r = request.run_files(&a.file)?;
    crate::print_report(&r, a.json, crate::Words::Stdout);
    let problems = problems(&r);
    if a.check && !problems.is_empty() {
        return Err(
            crate::FoundProblem(format!("{}: {}", a.file.display(), problems.join("; "))).into(),
        );
    }
    Ok(())
}
