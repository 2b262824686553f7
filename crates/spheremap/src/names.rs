//! Every list of names a user can pass, by kind, in one table, with the core's parser for each:
//! the Python package's name lists and its argument checks are these, and so are the CLI's.

use crate::base::error::{Error, Result};
use crate::frame::conventions::Singular;
use crate::images::codec::NonFinite;
use crate::images::cube_layout::Layout;
use crate::images::tonemap::ToneMap;
#[cfg(feature = "photo")]
use crate::jobs::photo;
use crate::jobs::render;
use crate::mappings::fisheye::LensModel;
use crate::mappings::mapping::MAPPING_NAMES;
use crate::mappings::matcap::MatcapVariant;
use crate::mappings::texgen::NormalMode;
use crate::resample::{Filter, Outside, Precision, Taps};

/// The kinds of name, as [`list`] and [`check`] take them (`fill` with the `photo` feature,
/// `scene` (the built-in scenes) and `shading` with the `scene` feature).
pub const KINDS: [&str; 21] = [
    "mapping",
    "filter",
    "taps",
    "outside",
    "precision",
    "layout",
    "fill",
    "lens",
    "render",
    "normalize",
    "singular",
    "matcap",
    "nonfinite",
    "tonemap",
    "material",
    "roughness_map",
    "prefilter_method",
    "encode",
    "wrap",
    "scene",
    "shading",
];

/// The names of `kind` (the canonical spellings; parsers also take a few aliases), or `None`
/// for a kind not in [`KINDS`].
pub fn list(kind: &str) -> Option<&'static [&'static str]> {
    Some(match kind {
        "mapping" => &MAPPING_NAMES,
        "filter" => &Filter::NAMES,
        "taps" => &Taps::NAMES,
        "outside" => &Outside::NAMES,
        "precision" => &Precision::NAMES,
        "layout" => &Layout::NAMES,
        #[cfg(feature = "photo")]
        "fill" => &photo::Fill::NAMES,
        "lens" => &LensModel::NAMES,
        "render" => &render::Mode::NAMES,
        "normalize" => &NormalMode::NAMES,
        "singular" => &Singular::NAMES,
        "matcap" => &MatcapVariant::NAMES,
        "nonfinite" => &NonFinite::NAMES,
        "tonemap" => &ToneMap::NAMES,
        "material" => &crate::lighting::brdf::Material::NAMES,
        "roughness_map" => &crate::lighting::prefilter::RoughnessMap::NAMES,
        "prefilter_method" => &crate::lighting::prefilter::PrefilterMethod::NAMES,
        "encode" => &crate::images::compress::Encoding::NAMES,
        "wrap" => &render::Wrap::NAMES,
        #[cfg(feature = "scene")]
        "scene" => &crate::trace::scene::Builtin::NAMES,
        #[cfg(feature = "scene")]
        "shading" => &crate::trace::scene::Shading::NAMES,
        _ => return None,
    })
}

/// Checks `value` as a name of `kind` with the core's own parser (aliases included); the error
/// names the argument `arg`.
pub fn check(kind: &str, value: &str, arg: &str) -> Result<()> {
    let named = |r: Result<()>| r.map_err(|e| e.named(arg));
    named(match kind {
        "mapping" => crate::mappings::mapping::Mapping::parse(value, None).map(drop),
        "filter" => Filter::parse_as(value, arg).map(drop),
        "taps" => Taps::parse_as(value, arg).map(drop),
        "outside" => Outside::parse_as(value, arg).map(drop),
        "precision" => Precision::parse_as(value, arg).map(drop),
        "layout" => Layout::parse_as(value, arg).map(drop),
        #[cfg(feature = "photo")]
        "fill" => photo::Fill::parse_as(value, arg).map(drop),
        "lens" => LensModel::parse(value, [0.0; 4]).map(drop),
        "render" => render::Mode::parse(value, MatcapVariant::default()).map(drop),
        "normalize" => NormalMode::parse_as(value, arg).map(drop),
        "singular" => Singular::parse_as(value, arg).map(drop),
        "matcap" => MatcapVariant::parse_as(value, arg).map(drop),
        "nonfinite" => NonFinite::parse_as(value, arg).map(drop),
        "tonemap" => ToneMap::parse_as(value, arg).map(drop),
        "material" => crate::lighting::brdf::Material::parse(value, 0.5).map(drop),
        "roughness_map" => crate::lighting::prefilter::RoughnessMap::parse_as(value, arg).map(drop),
        "prefilter_method" => {
            crate::lighting::prefilter::PrefilterMethod::parse_as(value, arg).map(drop)
        }
        "encode" => crate::images::compress::Encoding::parse_as(value, arg).map(drop),
        "wrap" => render::Wrap::parse_as(value, arg).map(drop),
        #[cfg(feature = "scene")]
        "scene" => crate::trace::scene::Builtin::parse_as(value, arg).map(drop),
        #[cfg(feature = "scene")]
        "shading" => crate::trace::scene::Shading::parse_as(value, arg).map(drop),
        _ => Err(Error::param(
            "kind",
            format!(
                "unknown kind of name {kind:?}; expected one of: {}",
                KINDS.join(", ")
            ),
        )),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_name_parses_and_others_are_refused() {
        for kind in KINDS {
            if (cfg!(not(feature = "photo")) && kind == "fill")
                || (cfg!(not(feature = "scene")) && matches!(kind, "scene" | "shading"))
            {
                continue;
            }
            let names = list(kind).unwrap_or_else(|| panic!("{kind} has no list"));
            assert!(!names.is_empty(), "{kind}");
            for n in names {
                check(kind, n, "x").unwrap_or_else(|e| panic!("{kind} {n}: {e}"));
            }
            let e = check(kind, "no-such-name", "the_arg")
                .unwrap_err()
                .to_string();
            assert!(e.contains("the_arg"), "{kind}: {e}");
        }
        assert!(list("colour").is_none());
        assert!(check("colour", "red", "x").is_err());
    }
}
