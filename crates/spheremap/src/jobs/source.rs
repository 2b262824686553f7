//! The environment a job reads, as users name it: one [`Source`] (mapping, preset, cube layout
//! and view; with the NaN/Inf rule, an [`EnvRequest`]), flattened into every request that reads
//! a map — [`crate::jobs::convert::ConvertJob`], the MatCap, prefilter and irradiance requests
//! — and spelled the same in recipes, JSON and Python: `src`, `src_preset`, `src_layout`,
//! `src_look`, `src_up`.  The CLI's `--from`, `--from-preset`, … set the same fields.  The older
//! spellings stay accepted ([`ALIASES`]): `from`, `from_preset`, … (conversions),
//! `env_format`, `env_preset`, … (lighting) and `environment_mapping`, `environment_preset`
//! (Python's scenes).
//!
//! The rules, in one place ([`Source::resolve`]):
//!
//! * **Mapping**: `src` (with `src_preset`), else what the file's note records, else the job's
//!   default (a conversion has none: a file without a note must name it).  A `src` that differs
//!   from the note is read as given, with a notice.
//! * **Cube layout**: `src_layout` (only for a cube map), else the note's when the note is of
//!   the mapping read, else from the image's shape.
//! * **View**: `src_look`/`src_up`, else the view the note records when the note is what the
//!   input is read as; none: the world's.

use crate::base::error::{Error, Result};
use crate::frame::view::{self, Mat3};
use crate::images::codec::{NonFinite, ReadOptions};
use crate::images::cube_layout::Layout;
use crate::images::envmap::{check_nonfinite_env, layout_for, mapping_for, EnvFiles, EnvReader};
use crate::images::note::MapNote;
use crate::images::Image;
use crate::mappings::mapping::{name_fields, Mapping};
use serde::{Deserialize, Serialize};

/// The environment a job reads.  `Default`: everything from the file's note.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Source {
    /// Its mapping (sphere, latlong, cube, angular, paraboloid, octahedral); `None`: what the
    /// file records.
    #[serde(alias = "from", alias = "env_format", alias = "environment_mapping")]
    pub src: Option<String>,
    /// The mapping's preset (`spheremap conventions`); `None`: the mapping's own, or the note's.
    #[serde(
        alias = "from_preset",
        alias = "env_preset",
        alias = "environment_preset"
    )]
    pub src_preset: Option<String>,
    /// The cube layout of a cube map in one image; `None`: the note's, else from its shape.
    #[serde(alias = "from_layout", alias = "env_layout")]
    pub src_layout: Option<String>,
    /// The view it was made for, when it is not the world's (a sphere map of a turned camera):
    /// world directions of its eye's −Z and +Y (up defaults to +Y).
    #[serde(alias = "from_look", alias = "env_look")]
    pub src_look: Option<[f64; 3]>,
    /// The world direction of that view's +Y (with `src_look`).
    #[serde(alias = "from_up", alias = "env_up")]
    pub src_up: Option<[f64; 3]>,
}

/// The other spellings each field takes, (alias, field): serde reads them (a test holds the
/// two together), Python's functions take them as keywords.
pub const ALIASES: [(&str, &str); 12] = [
    ("from", "src"),
    ("from_preset", "src_preset"),
    ("from_layout", "src_layout"),
    ("from_look", "src_look"),
    ("from_up", "src_up"),
    ("env_format", "src"),
    ("env_preset", "src_preset"),
    ("env_layout", "src_layout"),
    ("env_look", "src_look"),
    ("env_up", "src_up"),
    ("environment_mapping", "src"),
    ("environment_preset", "src_preset"),
];

/// A [`Source`] checked against its file's note.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedSource {
    pub mapping: Mapping,
    /// The cube layout given or noted (`None`: from the image's shape).
    pub layout: Option<Layout>,
    /// The view given or noted (`None`: the world's), and the rotation it makes: world
    /// directions → the map's frame.
    pub look: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    pub world_to_src: Mat3,
    /// What the user should hear: a mapping given that differs from the note's.
    pub notice: Option<String>,
}

impl Source {
    /// The fields resolved for a map that records `note` (`None`: an array, or a file without
    /// one), `default` the mapping of a map with neither (`None`: an error); `input` names the
    /// map in errors, which name the field.
    pub fn resolve(
        &self,
        note: Option<&MapNote>,
        input: &str,
        default: Option<&str>,
    ) -> Result<ResolvedSource> {
        let mapping = mapping_for(
            self.src.as_deref(),
            self.src_preset.as_deref(),
            note,
            default,
        )
        .map_err(|e| name_fields(e, "src", "src_preset"))?
        .ok_or_else(|| {
            Error::param(
                "src",
                format!(
                    "{input} records no mapping (spheremap records one in the EXR, PNG, JPEG \
                     and HDR maps it writes); name it with --from"
                ),
            )
        })?;
        let same_as_note = |t: &&MapNote| {
            (t.mapping.name(), t.mapping.preset_name()) == (mapping.name(), mapping.preset_name())
        };
        let notice = note.filter(|t| !same_as_note(t)).map(|t| {
            format!(
                "{input} records mapping {} (preset {}); reading it as {} (preset {})",
                t.mapping.name(),
                t.mapping.preset_name(),
                mapping.name(),
                mapping.preset_name()
            )
        });
        let layout = layout_for(self.src_layout.as_deref(), note, mapping)
            .map_err(|e| e.named("src_layout"))?;
        if self.src_layout.is_some() && mapping.name() != "cube" {
            return Err(Error::param(
                "src_layout",
                format!("only for src='cube', not {:?}", mapping.name()),
            ));
        }
        let noted_view = note.filter(same_as_note).and_then(|t| t.view);
        if self.src_look.is_none() && self.src_up.is_some() {
            return Err(Error::param(
                "src_up",
                "needs src_look (the direction of the view)",
            ));
        }
        let (look, up) = match (self.src_look, noted_view) {
            (None, Some((l, u))) => (Some(l), Some(u)),
            _ => (self.src_look, self.src_up),
        };
        let world_to_src = view::conversion_rotation(None, None, None, look, up).map_err(|e| {
            let field = match &e {
                Error::InvalidParameter { name, .. } if name == "up" => "src_up",
                _ => "src_look",
            };
            e.named(field)
        })?;
        Ok(ResolvedSource {
            mapping,
            layout,
            look,
            up,
            world_to_src,
            notice,
        })
    }
}

/// The environment a lighting job or the viewer reads, as users name it: its [`Source`]
/// (mapping, preset and cube layout, default its note, else lat-long; its view when it is not
/// the world's, default its note's) and what to do with NaN/Inf.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EnvRequest {
    #[serde(flatten)]
    pub source: Source,
    pub nonfinite: NonFinite,
}

/// An [`EnvRequest`] checked against its file.
#[derive(Clone, Debug)]
pub struct ResolvedEnv {
    pub mapping: Mapping,
    pub layout: Option<Layout>,
    /// World → the map's frame.
    pub world_to_env: Mat3,
    pub nonfinite: NonFinite,
    pub notice: Option<String>,
}

impl EnvRequest {
    /// Resolves the fields for a map that records `note` (`None`: an array, or a file without
    /// one; read as lat-long unless `src` names its mapping); errors name the field.
    pub fn resolve(&self, note: Option<&MapNote>, input: &str) -> Result<ResolvedEnv> {
        let r = self.source.resolve(note, input, Some("latlong"))?;
        Ok(ResolvedEnv {
            mapping: r.mapping,
            layout: r.layout,
            world_to_env: r.world_to_src,
            nonfinite: self.nonfinite,
            notice: r.notice,
        })
    }
}

impl ResolvedEnv {
    /// Reads the environment's `files` (`read` decodes them:
    /// [`crate::images::envmap::read_env_layout`] or a caller's cache) in the resolved mapping
    /// and layout, and applies the NaN/Inf rule.
    pub fn read(&self, files: &EnvFiles, read: &mut EnvReader<'_>) -> Result<Image> {
        let (mut img, _) = read(files, self.mapping, self.layout, &ReadOptions::default())?;
        check_nonfinite_env(&mut img, files, self.nonfinite)?;
        Ok(img)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_alias_reads_as_its_field_and_the_field_is_written_by_its_name() {
        let fields = ["src", "src_preset", "src_layout", "src_look", "src_up"];
        let value = |f: &str| match f {
            "src_look" | "src_up" => serde_json::json!([0.0, 1.0, 0.0]),
            _ => serde_json::json!("x"),
        };
        for name in fields.iter().copied().chain(ALIASES.iter().map(|a| a.0)) {
            let field = ALIASES.iter().find(|a| a.0 == name).map_or(name, |a| a.1);
            let s: Source =
                serde_json::from_value(serde_json::json!({ name: value(field) })).unwrap();
            let back = serde_json::to_value(&s).unwrap();
            assert_eq!(back[field], value(field), "{name}");
            let set = back.as_object().unwrap().values().filter(|v| !v.is_null());
            assert_eq!(set.count(), 1, "{name}");
        }
        let mut written: Vec<String> = serde_json::to_value(Source::default())
            .unwrap()
            .as_object()
            .unwrap()
            .keys()
            .cloned()
            .collect();
        written.sort();
        let mut fields = fields.to_vec();
        fields.sort();
        assert_eq!(written, fields);
    }

    #[test]
    fn a_cube_layout_is_taken_for_a_cube_map_only() {
        let src = |mapping: &str| Source {
            src: Some(mapping.into()),
            src_layout: Some("hcross".into()),
            ..Default::default()
        };
        let r = src("cube").resolve(None, "in", None).unwrap();
        assert_eq!(r.layout, Some(Layout::HCross));
        let e = src("latlong").resolve(None, "in", None).unwrap_err();
        assert_eq!(
            e.to_string(),
            r#"src_layout: only for src='cube', not "latlong""#
        );
    }

    #[test]
    fn a_field_given_twice_under_two_spellings_is_refused() {
        let e = serde_json::from_str::<Source>(r#"{"src": "sphere", "from": "latlong"}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("duplicate field `src`"), "{e}");
    }

    #[test]
    fn a_view_turns_the_world_into_the_maps_eye_and_is_checked_under_its_fields() {
        let src = |look, up| Source {
            src: Some("latlong".into()),
            src_look: look,
            src_up: up,
            ..Default::default()
        };
        let r = src(Some([1.0, 0.0, 0.0]), None)
            .resolve(None, "in", None)
            .unwrap();
        let m = r.world_to_src;
        let eye = [0, 1, 2].map(|i| m[i][0]);
        assert!(
            (eye[0]).abs() < 1e-12 && (eye[1]).abs() < 1e-12 && (eye[2] + 1.0).abs() < 1e-12,
            "{eye:?}"
        );
        let e = |s: Source| s.resolve(None, "in", None).unwrap_err().to_string();
        assert!(e(src(None, Some([0.0, 1.0, 0.0]))).starts_with("src_up: needs src_look"));
        assert!(e(src(Some([0.0; 3]), None)).starts_with("src_look: "));
        assert!(e(src(Some([0.0, 1.0, 0.0]), Some([0.0, 2.0, 0.0]))).starts_with("src_up: "));
        let no_mapping = Source::default().resolve(None, "in.exr", None);
        assert!(no_mapping
            .unwrap_err()
            .to_string()
            .starts_with("src: in.exr records no mapping"));
    }
}
