//! The irradiance of a map as one request: [`IrradianceRequest`] holds what `spheremap
//! irradiance`, Python's `irradiance_sh` and a recipe's `irradiance` output take — the map's
//! [`Source`], the NaN/Inf rule, Filament's deringing window, and the irradiance map's mapping,
//! layout, size and samples — and runs on files ([`IrradianceRequest::run_files`]) or on a map
//! in memory ([`ResolvedIrradiance::report`]), returning one
//! [`crate::lighting::sh::IrradianceReport`].
//!
//! Outputs by their extension: `.json`, the report (without its timing and file list, so that
//! the same map makes the same bytes); `.txt`, Filament's `sh.txt`; an image (or a `{face}`
//! pattern), the irradiance map itself (the full cosine integral, no SH truncation:
//! [`crate::lighting::irradiance_map`]).

use crate::base::error::{Error, Result};
use crate::base::limits::{check_map_size, check_samples};
use crate::images::codec::{NonFinite, WriteOptions};
use crate::images::cube_layout::Layout;
use crate::images::envmap::{
    read_env_layout, read_note, refuse_overwrite, write_env_files, EnvFiles, EnvReader,
};
use crate::images::note::MapNote;
use crate::jobs::source::{EnvRequest, ResolvedEnv, Source};
use crate::lighting::sh::{IrradianceReport, Window};
use crate::mappings::mapping::Mapping;
use crate::resample::{EnvMap, IDENTITY};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The irradiance of a map, as users ask for it.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IrradianceRequest {
    /// The map (`src`, `src_preset`, …; also read as `env_format`, `env_preset`, …).
    #[serde(flatten)]
    pub source: Source,
    /// NaN/Inf in the map: error, zero or keep.
    pub nonfinite: NonFinite,
    /// Filament's deringing window: none, `"auto"` or a size in bands.
    pub window: Window,
    /// The irradiance map, for an image output: its mapping (default cube), cube layout, size
    /// N (cube faces N×N, lat-long 2N×N; default 32) and samples per texel (default 1).
    pub to: String,
    pub layout: Option<String>,
    pub size: usize,
    pub samples: u32,
}

impl Default for IrradianceRequest {
    fn default() -> Self {
        IrradianceRequest {
            source: Source::default(),
            nonfinite: NonFinite::default(),
            window: Window::None,
            to: "cube".into(),
            layout: None,
            size: 32,
            samples: 1,
        }
    }
}

/// An [`IrradianceRequest`] checked against its map.
#[derive(Clone, Debug)]
pub struct ResolvedIrradiance {
    pub env: ResolvedEnv,
    pub window: Window,
    pub to: Mapping,
    pub layout: Option<Layout>,
    pub size: usize,
    pub samples: u32,
}

/// What an output file holds, by its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Output {
    Report,
    ShTxt,
    Map,
}

fn output_kind(path: &str) -> Output {
    let ext = Path::new(path)
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("json") => Output::Report,
        Some("txt") => Output::ShTxt,
        _ => Output::Map,
    }
}

impl IrradianceRequest {
    /// Checks every field for a map that records `note` (`None`: an array, or a file without
    /// one); errors name the field.
    pub fn resolve(&self, note: Option<&MapNote>, input: &str) -> Result<ResolvedIrradiance> {
        let env = EnvRequest {
            source: self.source.clone(),
            nonfinite: self.nonfinite,
        }
        .resolve(note, input)?;
        let to = Mapping::parse(&self.to, None).map_err(|e| e.named("to"))?;
        let layout = self
            .layout
            .as_deref()
            .map(Layout::parse)
            .transpose()
            .map_err(|e| e.named("layout"))?;
        if layout.is_some() && !matches!(to, Mapping::Cube(_)) {
            return Err(Error::param(
                "layout",
                format!("a cube layout, but the irradiance map is {}", to.name()),
            ));
        }
        check_map_size("size", self.size)?;
        check_samples(self.samples, self.samples)?;
        Ok(ResolvedIrradiance {
            env,
            window: self.window,
            to,
            layout,
            size: self.size,
            samples: self.samples,
        })
    }

    /// Reads the map `input` (one image, a face pattern), and writes each of `outputs` (by its
    /// extension: `.json` the report, `.txt` Filament's `sh.txt`, an image the irradiance map
    /// with `write`).  Refuses an output that is the input unless `force`.  Returns the report
    /// (its `output`: the files written) and the notice the source's rules gave.
    pub fn run_files(
        &self,
        input: &str,
        outputs: &[String],
        write: &WriteOptions,
        force: bool,
    ) -> Result<(IrradianceReport, Option<String>)> {
        self.run_files_with(input, outputs, write, force, &mut read_env_layout)
    }

    /// `run_files` with the map read by `read`.
    pub fn run_files_with(
        &self,
        input: &str,
        outputs: &[String],
        write: &WriteOptions,
        force: bool,
        read: &mut EnvReader<'_>,
    ) -> Result<(IrradianceReport, Option<String>)> {
        let t0 = std::time::Instant::now();
        let files = EnvFiles::parse(input);
        let note = read_note(files.first())?;
        let r = self.resolve(note.as_ref(), input)?;
        let outs: Vec<EnvFiles> = outputs.iter().map(|o| EnvFiles::parse(o)).collect();
        if !force {
            let paths: Vec<String> = outs.iter().flat_map(EnvFiles::paths).collect();
            refuse_overwrite(&files.paths(), &paths)?;
        }
        for (o, name) in outs.iter().zip(outputs) {
            match output_kind(name) {
                Output::Map => o.check_output(r.to)?,
                _ if matches!(o, EnvFiles::Faces { .. }) => {
                    return Err(Error::param(
                        "output",
                        format!("{name}: a report or sh.txt is one file, not a {{face}} pattern"),
                    ))
                }
                _ => {}
            }
        }
        let img = r.env.read(&files, read)?;
        let env = EnvMap::new(r.env.mapping, &img, files.first())?;
        let mut report = r.report(&env, &files.label())?;
        for (o, name) in outs.iter().zip(outputs) {
            match output_kind(name) {
                Output::Report => {
                    write_text(name, &report_file(&report, name)?)?;
                    report.output.push(name.clone());
                }
                Output::ShTxt => {
                    write_text(name, &report.filament.sh_txt)?;
                    report.output.push(name.clone());
                }
                Output::Map => {
                    let map = r.map(&env)?;
                    let written = write_env_files(o, r.to, &map, r.layout, &IDENTITY, write)?;
                    report.output.extend(written);
                }
            }
        }
        report.seconds = t0.elapsed().as_secs_f64();
        Ok((report, r.env.notice.clone()))
    }
}

impl ResolvedIrradiance {
    /// The SH9 report of `env` (read as resolved), which `input` names.
    pub fn report(&self, env: &EnvMap, input: &str) -> Result<IrradianceReport> {
        IrradianceReport::of(env, &self.env.world_to_env, self.window, input)
    }

    /// The irradiance map of `env`, in the world frame.
    pub fn map(&self, env: &EnvMap) -> Result<crate::images::Image> {
        let (w, h) = self.to.canvas(self.size);
        crate::lighting::irradiance_map(env, &self.env.world_to_env, self.to, w, h, self.samples)
    }
}

/// The report as a file holds it: what the map gives, not how long it took or where it was
/// written, so that the same input makes the same bytes (the batch manifest hashes files).
fn report_file(report: &IrradianceReport, name: &str) -> Result<String> {
    let mut v = serde_json::to_value(report).map_err(|e| Error::data(name, e.to_string()))?;
    if let Some(o) = v.as_object_mut() {
        o.remove("seconds");
        o.remove("output");
    }
    let mut s = serde_json::to_string_pretty(&v).map_err(|e| Error::data(name, e.to_string()))?;
    s.push('\n');
    Ok(s)
}

fn write_text(name: &str, text: &str) -> Result<()> {
    crate::base::files::write_text(Path::new(name), text)
}

impl crate::jobs::Report for crate::lighting::sh::IrradianceReport {
    fn lines(&self) -> Vec<String> {
        let r = self;
        let mut o = vec![format!(
            "{}: SH9 radiance coefficients (three.js SphericalHarmonics3):",
            r.input
        )];
        for (i, c) in r.coefficients.iter().enumerate() {
            o.push(format!("  {i}: {:12.6} {:12.6} {:12.6}", c[0], c[1], c[2]));
        }
        if let Some(w) = r.window {
            o.push(format!("  window: {w:.3} bands"));
        }
        for f in &r.output {
            o.push(format!("  wrote {f}"));
        }
        o
    }
}
