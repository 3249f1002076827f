//! A key that takes one of a few named values (a reaction, a policy): declared once as an enum
//! whose variants carry the names the file uses. The names are the values TOML accepts, the list
//! an error offers for a misspelled one, and [`ParamSpec::choices`](super::ParamSpec::choices)
//! of a declared section's key.

/// Declare the values of a choice key: an enum whose variants each carry the name the file
/// writes, deserialised from exactly those names (an unknown one is refused with the list of
/// the others), with `name()`, `ALL` and the [`ParamValue`](crate::param::ParamValue) a
/// [`declare_section!`](crate::declare_section) field needs.
///
/// ```
/// actuatord::declare_choice! {
///     /// What to do.
///     pub enum Action {
///         Stop = stop,
///         KeepGoing = keep_going,
///     }
/// }
/// assert_eq!(Action::KeepGoing.name(), "keep_going");
/// let e = toml::from_str::<std::collections::BTreeMap<String, Action>>("a = \"go\"")
///     .expect_err("not a value");
/// assert!(e.to_string().contains("expected `stop` or `keep_going`"), "{e}");
/// ```
#[macro_export]
macro_rules! declare_choice {
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $value:ident ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[doc = ""]
        #[doc = concat!("Written in the file as ", $("`", stringify!($value), "` "),*, ".")]
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum $name {
            $( $(#[$vmeta])* $variant, )*
        }

        impl $name {
            /// Every value, in declaration order.
            #[allow(dead_code)]
            pub const ALL: &'static [$name] = &[$($name::$variant),*];

            /// The name the file writes.
            #[allow(dead_code)]
            pub fn name(self) -> &'static str {
                match self {
                    $( $name::$variant => stringify!($value), )*
                }
            }
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                const NAMES: &[&str] = &[$(stringify!($value)),*];
                struct Visit;
                impl<'de> serde::de::Visitor<'de> for Visit {
                    type Value = $name;
                    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                        write!(f, "one of {}", NAMES.join(", "))
                    }
                    fn visit_enum<A: serde::de::EnumAccess<'de>>(
                        self,
                        data: A,
                    ) -> Result<$name, A::Error> {
                        let (name, variant): (String, A::Variant) = data.variant()?;
                        serde::de::VariantAccess::unit_variant(variant)?;
                        match name.as_str() {
                            $( stringify!($value) => Ok($name::$variant), )*
                            other => Err(serde::de::Error::unknown_variant(other, NAMES)),
                        }
                    }
                }
                d.deserialize_enum(stringify!($name), NAMES, Visit)
            }
        }

        impl $crate::param::ParamValue for $name {
            const KIND: $crate::param::Kind = $crate::param::Kind::Choice;
            const CHOICES: &'static [&'static str] = &[$(stringify!($value)),*];
            fn text(&self) -> Option<String> {
                Some(format!("\"{}\"", self.name()))
            }
            fn each(
                &self,
                _f: &mut dyn FnMut(f64) -> Result<(), $crate::param::ParamError>,
            ) -> Result<(), $crate::param::ParamError> {
                Ok(())
            }
        }
    };
}
