//! The core's lists of names as clap value parsers: `--filter`, `--layout`, `--to`, ... take
//! exactly what the core's parsers take (aliases included), their help, the man pages and the
//! completion scripts list the core's names, and a bad name is the core's one-line error.

use clap::builder::{PossibleValue, TypedValueParser};
use clap::error::ErrorKind;
use spheremap::base::named::Named;

/// The flag as users type it (`--filter`), where the argument has a long name.
fn flag(arg: Option<&clap::Arg>) -> Option<String> {
    arg.and_then(|a| a.get_long()).map(|l| format!("--{l}"))
}

/// A bad value: the one-line message, as clap prints a validation error.
fn invalid(message: String) -> clap::Error {
    clap::Error::raw(ErrorKind::ValueValidation, format!("{message}\n"))
}

/// The names the help, the man pages and the completions list.
fn possible(names: &'static [&'static str]) -> Box<dyn Iterator<Item = PossibleValue>> {
    Box::new(names.iter().map(|n| PossibleValue::new(*n)))
}

/// A value checked by `spheremap::names::check(kind, …)`.
#[derive(Clone, Copy, Debug)]
pub struct CoreName(pub &'static str);

/// The value parser of a flag taking a name of `kind` (see `spheremap::names::KINDS`).
pub fn core(kind: &'static str) -> CoreName {
    debug_assert!(spheremap::names::list(kind).is_some(), "{kind}");
    CoreName(kind)
}

impl TypedValueParser for CoreName {
    type Value = String;

    fn parse_ref(
        &self,
        _cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<String, clap::Error> {
        let flag = flag(arg).unwrap_or_else(|| self.0.to_string());
        let v = value
            .to_str()
            .ok_or_else(|| invalid(format!("{flag}: not valid UTF-8")))?;
        spheremap::names::check(self.0, v, &flag)
            .map(|()| v.to_string())
            .map_err(|e| invalid(e.to_string()))
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(possible(spheremap::names::list(self.0).unwrap_or(&[])))
    }
}

/// The value parser of a flag taking a [`Named`] enum: the enum itself, its names in the help,
/// the core's error for any other text.
#[derive(Clone, Copy, Debug)]
pub struct Typed<T>(std::marker::PhantomData<T>);

/// The value parser of a flag taking a `T` (`value_parser = names::typed::<Filter>()`).
pub fn typed<T: Named>() -> Typed<T> {
    Typed(std::marker::PhantomData)
}

impl<T: Named> TypedValueParser for Typed<T> {
    type Value = T;

    fn parse_ref(
        &self,
        _cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<T, clap::Error> {
        let flag = flag(arg).unwrap_or_default();
        let v = value.to_str().unwrap_or("\u{fffd}");
        T::lookup(v).ok_or_else(|| invalid(format!("{flag}: {}", T::unknown(v))))
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(possible(T::names()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser, Debug)]
    struct T {
        #[arg(long, value_parser = core("filter"), default_value = "box")]
        filter: String,
    }

    #[derive(Parser, Debug)]
    struct U {
        #[arg(long, value_parser = typed::<Filter>(), default_value_t)]
        filter: Filter,
    }

    use spheremap::resample::Filter;

    #[test]
    fn typed_names_give_the_enum_its_default_and_the_cores_error() {
        assert_eq!(U::try_parse_from(["u"]).unwrap().filter, Filter::default());
        assert_eq!(
            U::try_parse_from(["u", "--filter", "triangle"])
                .unwrap()
                .filter,
            Filter::Tent
        );
        let e = U::try_parse_from(["u", "--filter", "lanczos"]).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::ValueValidation);
        let text = e.to_string();
        assert!(
            text.contains(
                "--filter: unknown filter \"lanczos\"; expected one of: box, tent, gaussian"
            ),
            "{text}"
        );
        let help = <U as clap::CommandFactory>::command()
            .render_long_help()
            .to_string();
        assert!(
            help.contains("gaussian") && help.contains("[default: box]"),
            "{help}"
        );
    }

    #[test]
    fn core_names_and_aliases_parse_and_others_are_the_cores_error() {
        assert_eq!(
            T::try_parse_from(["t", "--filter", "tent"]).unwrap().filter,
            "tent"
        );
        // An alias the core's parser takes.
        assert_eq!(
            T::try_parse_from(["t", "--filter", "triangle"])
                .unwrap()
                .filter,
            "triangle"
        );
        let e = T::try_parse_from(["t", "--filter", "lanczos"]).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::ValueValidation);
        assert!(e.to_string().contains("--filter: "), "{e}");
        let help = <T as clap::CommandFactory>::command()
            .render_long_help()
            .to_string();
        assert!(help.contains("gaussian"), "{help}");
    }
}
