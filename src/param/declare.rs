//! Declare once: a configuration section is one Rust type whose fields carry their name, unit,
//! range, documentation and access. The TOML schema (serde), the range checks with their
//! errors, the dictionary entries and their SDO writes all come from [`declare_section!`], so a
//! parameter's name is written once, as its field.

use super::ParamError;

/// When a declared parameter may change in a running node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Part of the structure (a model, the poles): only by a restart; not in the dictionary.
    Restart,
    /// Over SDO while the node is pre-operational, or by a reload.
    PreOperational,
}

/// The value type of a declared parameter, as the dictionary carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A real number (REAL64).
    Real,
    /// A count (UNSIGNED32).
    Count,
    /// Several numbers (not in the dictionary).
    Array,
}

/// What is declared about one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// The configuration key, the dictionary entry's name and the field's name.
    pub name: &'static str,
    /// SI unit, empty for a number without one.
    pub unit: &'static str,
    pub kind: Kind,
    /// Inclusive bounds; an infinite bound leaves that side open.
    pub min: f64,
    pub max: f64,
    /// One line for the dictionary, the EDS and the documentation (may be empty).
    pub doc: &'static str,
    pub access: Access,
}

impl ParamSpec {
    /// `value` is within the declared range (each element of an array).
    pub fn check(&self, value: f64) -> Result<(), ParamError> {
        let integral = self.kind != Kind::Count || value.fract() == 0.0;
        if value.is_nan() || value < self.min || value > self.max || !integral {
            let what = if self.kind == Kind::Count {
                "a whole number"
            } else {
                "a number"
            };
            return Err(ParamError::new(
                self.name,
                format!(
                    "must be {what} in [{}, {}], got {value}",
                    self.min, self.max
                ),
            ));
        }
        Ok(())
    }
}

/// The value types a declared section may hold.
pub trait ParamValue {
    const KIND: Kind;
    /// The values, to check against the range.
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError>;
    /// The value as one number; `None` for an array.
    fn scalar(&self) -> Option<f64>;
    /// Take `value` (already checked); false for an array.
    fn assign(&mut self, value: f64) -> bool;
}

impl ParamValue for f64 {
    const KIND: Kind = Kind::Real;
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        f(*self)
    }
    fn scalar(&self) -> Option<f64> {
        Some(*self)
    }
    fn assign(&mut self, value: f64) -> bool {
        *self = value;
        true
    }
}

impl ParamValue for u32 {
    const KIND: Kind = Kind::Count;
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        f(f64::from(*self))
    }
    fn scalar(&self) -> Option<f64> {
        Some(f64::from(*self))
    }
    fn assign(&mut self, value: f64) -> bool {
        // Checked whole and within u32 by the declared range before.
        *self = value as u32;
        true
    }
}

impl<const N: usize> ParamValue for [f64; N] {
    const KIND: Kind = Kind::Array;
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        self.iter().try_for_each(|v| f(*v))
    }
    fn scalar(&self) -> Option<f64> {
        None
    }
    fn assign(&mut self, _value: f64) -> bool {
        false
    }
}

/// A section made by [`declare_section!`].
pub trait Declared {
    /// Every parameter, in declaration order.
    const PARAMS: &'static [ParamSpec];

    /// The value of the scalar parameter `name`.
    fn get(&self, name: &str) -> Option<f64>;

    /// Set the scalar parameter `name` to `value`, checked against its declaration.
    fn set(&mut self, name: &str, value: f64) -> Result<(), ParamError>;

    /// Every value within its declared range; the error names the first that is not.
    fn check(&self) -> Result<(), ParamError>;

    /// The declaration of `name`.
    fn spec(name: &str) -> Option<&'static ParamSpec> {
        Self::PARAMS.iter().find(|p| p.name == name)
    }
}

/// The unit a declared parameter gives as `COMMAND_UNIT` is the axis' command unit (V, duty, N,
/// ...), known only when the dictionary is built for an axis.
pub const COMMAND_UNIT: &str = "command";

/// Declare a configuration section: a struct that TOML deserialises (unknown keys refused)
/// and whose fields each carry unit, range, access, a line of documentation and, where one
/// makes sense, a default (a key without a default is required).
///
/// ```ignore
/// declare_section! {
///     /// `[axis.example]`.
///     pub struct ExampleSection {
///         /// Below this the residual counts as small.
///         residual_max_m: f64 = { unit: "m", min: 1e-12, max: 1e3,
///                                 access: PreOperational, doc: "a line for the dictionary",
///                                 default: 1e-4 },
///     }
/// }
/// ```
#[macro_export]
macro_rules! declare_section {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[doc = $fdoc:literal])*
                $field:ident : $ty:ty = {
                    unit: $unit:expr,
                    min: $min:expr,
                    max: $max:expr,
                    access: $access:ident,
                    doc: $doc:literal
                    $(, default: $default:expr)? $(,)?
                }
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            $( $(#[doc = $fdoc])* pub $field: $ty, )*
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                // Every key optional here, so that a declared default can stand in for a
                // missing one; a key without a default is then reported missing by name.
                #[derive(serde::Deserialize)]
                #[serde(deny_unknown_fields)]
                struct Keys {
                    $( $field: Option<$ty>, )*
                }
                let keys = Keys::deserialize(d)?;
                Ok($name {
                    $(
                        $field: match keys.$field {
                            Some(v) => v,
                            None => $crate::__declared_default!($field $(, $default)?),
                        },
                    )*
                })
            }
        }

        impl $crate::param::Declared for $name {
            const PARAMS: &'static [$crate::param::ParamSpec] = &[
                $(
                    $crate::param::ParamSpec {
                        name: stringify!($field),
                        unit: $unit,
                        kind: <$ty as $crate::param::ParamValue>::KIND,
                        min: $min,
                        max: $max,
                        doc: $doc,
                        access: $crate::param::Access::$access,
                    },
                )*
            ];

            fn get(&self, name: &str) -> Option<f64> {
                match name {
                    $( stringify!($field) => $crate::param::ParamValue::scalar(&self.$field), )*
                    _ => None,
                }
            }

            fn set(&mut self, name: &str, value: f64) -> Result<(), $crate::param::ParamError> {
                let spec = <Self as $crate::param::Declared>::spec(name).ok_or_else(|| {
                    $crate::param::ParamError::new("parameter", format!("no parameter {name}"))
                })?;
                spec.check(value)?;
                let assigned = match name {
                    $( stringify!($field) => $crate::param::ParamValue::assign(&mut self.$field, value), )*
                    _ => false,
                };
                if assigned {
                    Ok(())
                } else {
                    Err($crate::param::ParamError::new(spec.name, "is not a single number"))
                }
            }

            fn check(&self) -> Result<(), $crate::param::ParamError> {
                let mut i = 0;
                $(
                    let spec = &<Self as $crate::param::Declared>::PARAMS[i];
                    $crate::param::ParamValue::each(&self.$field, &mut |v| spec.check(v))?;
                    i += 1;
                )*
                let _ = i;
                Ok(())
            }
        }
    };
}

/// The value of a declared key the configuration leaves out: its default, or the error that
/// names it as missing. Used by [`declare_section!`] inside `Deserialize::deserialize`.
#[doc(hidden)]
#[macro_export]
macro_rules! __declared_default {
    ($field:ident) => {
        return Err(serde::de::Error::missing_field(stringify!($field)))
    };
    ($field:ident, $default:expr) => {
        $default
    };
}
