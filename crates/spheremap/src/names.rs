//! Every list of names a user can pass, by kind, in one table, with the core's parser for each:
//! the Python package's name lists and its argument checks are these, and so are the CLI's.

use crate::base::error::{Error, Result};
use crate::base::named::Named;

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

/// One kind of name: its enum's canonical names, whether a text is one of them or an alias,
/// and the error text for any other.
struct Kind {
    names: &'static [&'static str],
    known: fn(&str) -> bool,
    unknown: fn(&str) -> String,
}

fn of<T: Named>() -> Kind {
    fn known<T: Named>(v: &str) -> bool {
        T::lookup(v).is_some()
    }
    Kind {
        names: T::names(),
        known: known::<T>,
        unknown: T::unknown,
    }
}

/// The enum of each kind in [`KINDS`] (the payload enums' by their names: a mapping's without
/// its preset, a lens model's without its coefficients, a render mode's without its MatCap
/// variant, a material's without its roughness).
fn kind(kind: &str) -> Option<Kind> {
    use crate::{images, jobs, lighting, mappings, resample};
    Some(match kind {
        "mapping" => of::<mappings::mapping::MappingName>(),
        "filter" => of::<resample::Filter>(),
        "taps" => of::<resample::Taps>(),
        "outside" => of::<resample::Outside>(),
        "precision" => of::<resample::Precision>(),
        "layout" => of::<images::cube_layout::Layout>(),
        #[cfg(feature = "photo")]
        "fill" => of::<jobs::photo::Fill>(),
        "lens" => of::<mappings::fisheye::LensName>(),
        "render" => of::<jobs::render::ModeName>(),
        "normalize" => of::<mappings::texgen::NormalMode>(),
        "singular" => of::<crate::frame::conventions::Singular>(),
        "matcap" => of::<mappings::matcap::MatcapVariant>(),
        "nonfinite" => of::<images::codec::NonFinite>(),
        "tonemap" => of::<images::tonemap::ToneMap>(),
        "material" => of::<lighting::brdf::MaterialName>(),
        "roughness_map" => of::<lighting::prefilter::RoughnessMap>(),
        "prefilter_method" => of::<lighting::prefilter::PrefilterMethod>(),
        "encode" => of::<images::compress::Encoding>(),
        "wrap" => of::<jobs::render::Wrap>(),
        #[cfg(feature = "scene")]
        "scene" => of::<crate::trace::scene::Builtin>(),
        #[cfg(feature = "scene")]
        "shading" => of::<crate::trace::scene::Shading>(),
        _ => return None,
    })
}

/// The names of `kind` (the canonical spellings; parsers also take a few aliases), or `None`
/// for a kind not in [`KINDS`].
pub fn list(kind: &str) -> Option<&'static [&'static str]> {
    self::kind(kind).map(|k| k.names)
}

/// Checks `value` as a name of `kind` with the core's own parser (aliases included); the error
/// names the argument `arg`.
pub fn check(kind: &str, value: &str, arg: &str) -> Result<()> {
    let k = self::kind(kind).ok_or_else(|| {
        Error::param(
            "kind",
            format!(
                "unknown kind of name {kind:?}; expected one of: {}",
                KINDS.join(", ")
            ),
        )
    })?;
    if (k.known)(value) {
        Ok(())
    } else {
        Err(Error::param(arg, (k.unknown)(value)))
    }
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
