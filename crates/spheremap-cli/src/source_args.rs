//! The environment a command reads, the same five flags on every command that reads one
//! (`convert`, `bake-matcap`, `prefilter`, `irradiance`, `view`, `render`, `generate`,
//! `preview`): they set the core's `spheremap::jobs::source::Source`.  `--src…` and the
//! `--env-…` spellings of the lighting commands are the same flags.

use crate::job::vec3;
use spheremap::jobs::source::Source;

#[derive(clap::Args, Debug, Clone, Default)]
pub struct SourceArgs {
    /// Mapping of the input map: sphere, latlong, cube, angular, paraboloid, octahedral.
    /// Default: the mapping (and preset, cube layout and view) spheremap recorded in it when it
    /// wrote it, else latlong (sphere for render; convert asks for it).
    #[arg(long = "from", visible_aliases = ["src", "env-format"], value_name = "MAPPING", value_parser = crate::names::core("mapping"))]
    pub from: Option<String>,
    /// Preset of the input's mapping (see `spheremap conventions`); default: the mapping's
    /// own.
    #[arg(long, visible_aliases = ["src-preset", "env-preset"], value_name = "PRESET")]
    pub from_preset: Option<String>,
    /// Cube layout of an input cube map in one image (default: from its shape; a 6:1 strip
    /// must be named).
    #[arg(long, visible_aliases = ["src-layout", "env-layout"], value_name = "LAYOUT", value_parser = crate::names::core("layout"))]
    pub from_layout: Option<String>,
    /// The view the input was made for, when it is not the world's (a sphere map of a turned
    /// camera): the world direction of its eye's -Z.
    #[arg(long, visible_aliases = ["src-look", "env-look"], num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub from_look: Option<Vec<f64>>,
    /// The input view's up (with --from-look; default 0 1 0).
    #[arg(long, visible_aliases = ["src-up", "env-up"], num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    pub from_up: Option<Vec<f64>>,
}

impl SourceArgs {
    /// The core's source for these flags.
    pub fn source(&self) -> Source {
        Source {
            src: self.from.clone(),
            src_preset: self.from_preset.clone(),
            src_layout: self.from_layout.clone(),
            src_look: vec3(&self.from_look),
            src_up: vec3(&self.from_up),
        }
    }

    /// The core's environment request for these flags.
    pub fn env_request(
        &self,
        nonfinite: spheremap::images::codec::NonFinite,
    ) -> spheremap::jobs::source::EnvRequest {
        spheremap::jobs::source::EnvRequest {
            source: self.source(),
            nonfinite,
        }
    }

    /// The flag that sets a field of `Source` (`src_preset` → `--from-preset`); `None` for
    /// other names.
    pub fn flag(field: &str) -> Option<String> {
        field
            .strip_prefix("src")
            .filter(|rest| rest.is_empty() || rest.starts_with('_'))
            .map(|rest| format!("--from{}", rest.replace('_', "-")))
    }
}
