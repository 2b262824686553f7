//! Enums of names a user types (`--filter tent`, `filter = "tent"` in a recipe, `filter="tent"`
//! in Python): each written once with [`named_enum!`], its canonical names, the aliases it also
//! takes and what it is called in messages.  The macro gives the enum its `NAMES`, `ALL`,
//! `ALIASES`, `name`, `parse` (one error text for every enum: "unknown filter "x"; expected one
//! of: box, tent, gaussian"), `Display`, `FromStr` and serde (a string; aliases accepted), so
//! clap's value parsers, recipes, JSON reports and the Python glue read and write the same
//! names.

/// What every [`named_enum!`] is, for code generic over them (the CLI's value parser).
pub trait Named: Copy + Send + Sync + 'static {
    /// The canonical names.
    fn names() -> &'static [&'static str];
    /// The value of a name or alias.
    fn lookup(name: &str) -> Option<Self>;
    /// The canonical name.
    fn name(self) -> &'static str;
    /// The text of the error for an unknown `name`.
    fn unknown(name: &str) -> String;
}

/// Defines a C-like enum of user-facing names:
///
/// ```ignore
/// named_enum! {
///     /// Reconstruction filter.
///     #[derive(Default)]
///     pub enum Filter: "filter" as "filter" {
///         /// The box.
///         #[default]
///         Box = "box",
///         Tent = "tent" | "triangle",
///     }
/// }
/// ```
///
/// After the enum's name: the noun its messages use (`unknown filter "x"`), then, after `as`,
/// the argument `parse` and serde's errors name (`parse_as` names another); an optional
/// `hint = "…"` after the variants is appended to the error's list.  Each variant: its
/// canonical name, then its aliases.  The enum derives `Clone, Copy, Debug, PartialEq, Eq,
/// Hash`.
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident : $noun:literal as $param:literal {
            $(
                $(#[$vmeta:meta])*
                $variant:ident = $canon:literal $(| $alias:literal)*
            ),+ $(,)?
        }
        $(hint = $hint:literal)?
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        $vis enum $name {
            $(
                $(#[$vmeta])*
                $variant,
            )+
        }

        impl $name {
            /// Every value, in the order of [`Self::NAMES`].
            pub const ALL: [$name; [$($canon),+].len()] = [$($name::$variant),+];
            /// The canonical names.
            pub const NAMES: [&'static str; [$($canon),+].len()] = [$($canon),+];
            /// The other spellings accepted: (alias, canonical name).
            pub const ALIASES: &'static [(&'static str, &'static str)] =
                &[$($(($alias, $canon),)*)+];

            /// The canonical name.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $canon,)+
                }
            }

            /// The value of a name or alias; `None` for any other text.
            pub fn lookup(name: &str) -> Option<$name> {
                match name {
                    $($canon $(| $alias)* => Some($name::$variant),)+
                    _ => None,
                }
            }

            /// The value of a name or alias; the error names the enum's argument (after `as`).
            pub fn parse(name: &str) -> $crate::base::error::Result<$name> {
                Self::parse_as(name, $param)
            }

            /// The value of a name or alias; the error names `param`.
            pub fn parse_as(name: &str, param: &str) -> $crate::base::error::Result<$name> {
                Self::lookup(name).ok_or_else(|| {
                    $crate::base::error::Error::param(param, Self::unknown(name))
                })
            }

            /// The text of the error for an unknown `name`.
            pub fn unknown(name: &str) -> String {
                let hint: &str = $crate::base::named::named_enum!(@hint $($hint)?);
                format!(
                    "unknown {} {name:?}; expected one of: {}{hint}",
                    $noun,
                    Self::NAMES.join(", ")
                )
            }
        }

        impl $crate::base::named::Named for $name {
            fn names() -> &'static [&'static str] {
                &$name::NAMES
            }
            fn lookup(name: &str) -> Option<$name> {
                $name::lookup(name)
            }
            fn name(self) -> &'static str {
                $name::name(self)
            }
            fn unknown(name: &str) -> String {
                $name::unknown(name)
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $name {
            type Err = $crate::base::error::Error;
            fn from_str(s: &str) -> $crate::base::error::Result<$name> {
                Self::parse(s)
            }
        }

        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                let name = <String as serde::Deserialize>::deserialize(d)?;
                Self::lookup(&name).ok_or_else(|| {
                    serde::de::Error::custom(format!("{}: {}", $param, Self::unknown(&name)))
                })
            }
        }
    };
    (@hint $hint:literal) => { $hint };
    (@hint) => { "" };
}
pub(crate) use named_enum;

#[cfg(test)]
mod tests {
    crate::base::named::named_enum! {
        /// A test enum.
        #[derive(Default)]
        pub enum Fruit: "fruit" as "fruit" {
            #[default]
            Apple = "apple" | "pomme",
            Pear = "pear",
        }
        hint = ", or a basket"
    }

    #[test]
    fn names_aliases_and_errors_come_from_one_list() {
        assert_eq!(Fruit::NAMES, ["apple", "pear"]);
        assert_eq!(Fruit::ALL, [Fruit::Apple, Fruit::Pear]);
        assert_eq!(Fruit::ALIASES, &[("pomme", "apple")]);
        assert_eq!(Fruit::default(), Fruit::Apple);
        for f in Fruit::ALL {
            assert_eq!(Fruit::parse(f.name()).unwrap(), f);
            assert_eq!(f.to_string(), f.name());
            assert_eq!(f.name().parse::<Fruit>().unwrap(), f);
        }
        assert_eq!(Fruit::parse("pomme").unwrap(), Fruit::Apple);
        let e = Fruit::parse("kiwi").unwrap_err().to_string();
        assert!(
            e.contains("fruit")
                && e.contains("unknown fruit \"kiwi\"; expected one of: apple, pear, or a basket"),
            "{e}"
        );
        let e = Fruit::parse_as("Pear", "--fruit").unwrap_err().to_string();
        assert!(e.contains("--fruit"), "{e}");
    }

    #[test]
    fn serde_writes_the_name_and_reads_aliases() {
        #[derive(serde::Serialize, serde::Deserialize)]
        struct R {
            fruit: Fruit,
        }
        let r: R = serde_json::from_str(r#"{"fruit": "pomme"}"#).unwrap();
        assert_eq!(r.fruit, Fruit::Apple);
        assert_eq!(
            serde_json::to_string(&R { fruit: Fruit::Pear }).unwrap(),
            r#"{"fruit":"pear"}"#
        );
        let e = serde_json::from_str::<R>(r#"{"fruit": "kiwi"}"#)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.starts_with("fruit: unknown fruit \"kiwi\"; expected one of: apple, pear"),
            "{e}"
        );
        let t: R = toml::from_str("fruit = \"pear\"").unwrap();
        assert_eq!(t.fruit, Fruit::Pear);
    }
}
