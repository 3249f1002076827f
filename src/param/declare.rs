//! Declare once: a configuration section is one Rust type whose fields carry their name, unit,
//! range, documentation and access. The TOML schema (serde), the range checks with their
//! errors, the dictionary entries and their SDO writes all come from [`declare_section!`], so a
//! parameter's name is written once, as its field.

use super::ParamError;

/// When a declared parameter may change in a running node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Part of the structure (a model, the poles, a section as a whole): not in the dictionary,
    /// so never written over SDO. A reload (SIGHUP) changes it and rebuilds the axis, except
    /// what the node is built around (the bus, the node ids, an axis' command and profile, the
    /// cycle period: `ControllerNode::swap_in` refuses those), which only a restart changes.
    Restart,
    /// Over SDO while the node is pre-operational, or by a reload.
    PreOperational,
    /// By a reload; the dictionary shows it read-only (a table's points).
    ReadOnly,
}

/// The value type of a declared parameter, as the dictionary carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A real number (REAL64).
    Real,
    /// A count (UNSIGNED32, or UNSIGNED8: see [`ParamSpec::bits`]).
    Count,
    /// Several numbers (not in the dictionary).
    Array,
    /// Yes or no (not in the dictionary).
    Flag,
    /// A file (not in the dictionary); relative to the configuration file.
    Path,
    /// A table of its own, checked by its own type (not in the dictionary).
    Table,
    /// One of a few named values (not in the dictionary); see [`ParamSpec::choices`].
    Choice,
    /// Text (not in the dictionary).
    Text,
}

/// What is declared about one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// The configuration key, the dictionary entry's name and the field's name.
    pub name: &'static str,
    /// SI unit, empty for a number without one.
    pub unit: &'static str,
    pub kind: Kind,
    /// Width in bits of a count's dictionary entry (8 or 32); 0 for what is not a count.
    pub bits: u8,
    /// The key may be left out (an `Option`): absent means "not used", not a default value.
    pub optional: bool,
    /// Inclusive bounds; an infinite bound leaves that side open.
    pub min: f64,
    pub max: f64,
    /// One line for the dictionary, the EDS and the documentation (may be empty).
    pub doc: &'static str,
    /// The field's own documentation comment, one line of text per line of comment (may be
    /// empty): the longer story the configuration reference tells beside `doc`.
    pub details: &'static str,
    pub access: Access,
    /// For an optional key: the value the dictionary shows while it is left out (an infinite
    /// bound: "not watched"). A write of an infinite value leaves it out again, and a
    /// configured value must be finite.
    pub absent: Option<f64>,
    /// What the range asks for in the words of an error ("> 0", "a node id in 1..=127"), where
    /// a section keeps the wording its users know; empty: worded from the range.
    pub words: &'static str,
    /// An array shown in the dictionary one entry per point, with these names (`q0_per_m`,
    /// `supply_0`...); empty: an array is not in the dictionary.
    pub points: &'static [&'static str],
    /// Points a write of zero to the last one keeps: trailing zeros are dropped down to this
    /// length.
    pub kept: usize,
    /// The dictionary bounds the value by the axis' command range (±1 for a duty, ±1000
    /// otherwise) rather than by `min` and `max`.
    pub command_bound: bool,
    /// The values a [`Kind::Choice`] key takes, as written in the file; empty otherwise.
    pub choices: &'static [&'static str],
    /// Zero is refused although the range holds it: a scale whose sign carries a direction.
    pub nonzero: bool,
}

impl ParamSpec {
    /// What the declared range asks for, in words: "a number in [a, b]", "a finite number > 0",
    /// "a whole number >= 1"...
    pub fn range_text(&self) -> String {
        if !self.words.is_empty() {
            return self.words.to_string();
        }
        let whole = if self.kind == Kind::Count {
            "whole "
        } else {
            ""
        };
        let finite = if self.max == f64::MAX { "finite " } else { "" };
        let what = format!("a {finite}{whole}number");
        let high = self.max < f64::MAX;
        if self.min == f64::MIN_POSITIVE && !high {
            format!("{what} > 0")
        } else if self.min == f64::MIN_POSITIVE {
            format!("{what} in (0, {}]", self.max)
        } else if self.min > f64::MIN && high {
            format!("{what} in [{}, {}]", self.min, self.max)
        } else if self.min > f64::MIN {
            format!("{what} >= {}", self.min)
        } else if high {
            format!("{what} <= {}", self.max)
        } else {
            what
        }
    }

    /// The declaration with the field's own documentation comment, where it has one.
    pub const fn described(self, details: &'static str) -> Self {
        if details.is_empty() {
            self
        } else {
            ParamSpec { details, ..self }
        }
    }

    /// The declaration of key `name` among `params`: a key one section lends another
    /// (`from:` in [`declare_section!`](crate::declare_section)). Evaluated when the borrowing
    /// section is built, so a key the lender does not declare fails the build.
    pub const fn lent(params: &'static [ParamSpec], name: &str) -> Self {
        let mut i = 0;
        while i < params.len() {
            if same(params[i].name, name) {
                return params[i];
            }
            i += 1;
        }
        panic!("a section lends only the keys it declares");
    }

    /// Which point of the array `name` is, if it is one of this key's points.
    pub fn point(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| *p == name)
    }

    /// The values of a choice, as a documentation or an error lists them: "`a`, `b` or `c`".
    pub fn choices_text(&self) -> String {
        let quoted: Vec<String> = self.choices.iter().map(|c| format!("`{c}`")).collect();
        match quoted.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            Some((last, _)) => last.clone(),
            None => String::new(),
        }
    }

    /// `value` is within the declared range (each element of an array).
    pub fn check(&self, value: f64) -> Result<(), ParamError> {
        let integral = self.kind != Kind::Count || value.fract() == 0.0;
        if value.is_infinite() && self.absent.is_some() {
            return Err(ParamError::new(
                self.name,
                format!("must be finite, got {value} (leave the key out instead)"),
            ));
        }
        let zero = self.nonzero && value == 0.0;
        if value.is_nan() || value < self.min || value > self.max || !integral || zero {
            return Err(ParamError::new(
                self.name,
                format!("must be {}, got {value}", self.range_text()),
            ));
        }
        Ok(())
    }
}

/// `a == b`, in a constant (a `const fn` may not compare `str`s otherwise).
pub const fn same(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// The value types a declared section may hold.
pub trait ParamValue: Sized {
    const KIND: Kind;
    /// Width of a count's dictionary entry in bits; 0 for what is not a count.
    const BITS: u8 = 0;
    /// The key may be left out.
    const OPTIONAL: bool = false;
    /// The value of a key left out, where the type has one (`None` of an `Option`).
    fn absent() -> Option<Self> {
        None
    }
    /// False only for an optional value left out.
    fn given(&self) -> bool {
        true
    }
    /// The values, to check against the range.
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError>;
    /// The value as one number; `None` (the default) for what is not one number: an array,
    /// a table, a path.
    fn scalar(&self) -> Option<f64> {
        None
    }
    /// Take `value` (already checked); false (the default) for what is not one number.
    fn assign(&mut self, _value: f64) -> bool {
        false
    }
    /// A value made from one number (already checked); `None` (the default) for what is not
    /// one number.
    fn from_value(_value: f64) -> Option<Self> {
        None
    }
    /// The values a choice takes, as written in the file; empty (the default) for the rest.
    const CHOICES: &'static [&'static str] = &[];
    /// The value as the file writes it (`0.0025`, `"safe_state"`, `[1.0, 2.0]`), for the
    /// configuration reference; `None` (the default) for what has no one-line form (a table).
    fn text(&self) -> Option<String> {
        None
    }
    /// Point `k` of an array, `None` past its end (and, the default, for what is not an array).
    fn point(&self, _k: usize) -> Option<f64> {
        None
    }
    /// Set point `k` of an array to `value` (already checked), growing it with zeros; trailing
    /// zeros are then dropped down to `kept` points. False (the default) for what is not an
    /// array that can grow.
    fn set_point(&mut self, _k: usize, _value: f64, _kept: usize) -> bool {
        false
    }
}

impl ParamValue for f64 {
    const KIND: Kind = Kind::Real;
    fn text(&self) -> Option<String> {
        Some(real_text(*self))
    }
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
    fn from_value(value: f64) -> Option<Self> {
        Some(value)
    }
}

/// A count as the dictionary carries it: `$bits` wide, saturating when shown.
macro_rules! count_value {
    ($t:ty, $bits:expr) => {
        impl ParamValue for $t {
            const KIND: Kind = Kind::Count;
            const BITS: u8 = $bits;
            fn text(&self) -> Option<String> {
                Some(self.to_string())
            }
            fn each(
                &self,
                f: &mut dyn FnMut(f64) -> Result<(), ParamError>,
            ) -> Result<(), ParamError> {
                f(*self as f64)
            }
            fn scalar(&self) -> Option<f64> {
                Some(*self as f64)
            }
            fn assign(&mut self, value: f64) -> bool {
                // Checked whole and within the declared range before; the range keeps it
                // within the type.
                *self = value as $t;
                true
            }
            fn from_value(value: f64) -> Option<Self> {
                Some(value as $t)
            }
        }
    };
}

count_value!(u8, 8);
count_value!(u32, 32);
count_value!(u64, 32);
count_value!(usize, 32);
count_value!(i32, 32);

impl ParamValue for bool {
    const KIND: Kind = Kind::Flag;
    fn text(&self) -> Option<String> {
        Some(self.to_string())
    }
    fn each(&self, _f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        Ok(())
    }
    fn scalar(&self) -> Option<f64> {
        Some(f64::from(u8::from(*self)))
    }
    fn assign(&mut self, value: f64) -> bool {
        *self = value != 0.0;
        true
    }
    fn from_value(value: f64) -> Option<Self> {
        Some(value != 0.0)
    }
}

impl ParamValue for Vec<f64> {
    const KIND: Kind = Kind::Array;
    fn text(&self) -> Option<String> {
        Some(array_text(self))
    }
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        self.iter().try_for_each(|v| f(*v))
    }
    fn point(&self, k: usize) -> Option<f64> {
        self.get(k).copied()
    }
    fn set_point(&mut self, k: usize, value: f64, kept: usize) -> bool {
        if self.len() <= k {
            self.resize(k + 1, 0.0);
        }
        self[k] = value;
        while self.len() > kept && self.last() == Some(&0.0) {
            self.pop();
        }
        true
    }
}

impl ParamValue for String {
    const KIND: Kind = Kind::Text;
    fn text(&self) -> Option<String> {
        Some(format!("{self:?}"))
    }
    fn each(&self, _f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        Ok(())
    }
}

impl ParamValue for std::path::PathBuf {
    const KIND: Kind = Kind::Path;
    fn text(&self) -> Option<String> {
        Some(format!("{:?}", self.display().to_string()))
    }
    fn each(&self, _f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        Ok(())
    }
}

/// An optional key: its value's kind, checked when given, `None` when left out.
impl<T: ParamValue> ParamValue for Option<T> {
    const KIND: Kind = T::KIND;
    const BITS: u8 = T::BITS;
    const OPTIONAL: bool = true;
    const CHOICES: &'static [&'static str] = T::CHOICES;
    fn text(&self) -> Option<String> {
        self.as_ref().and_then(T::text)
    }
    fn point(&self, k: usize) -> Option<f64> {
        self.as_ref().and_then(|v| v.point(k))
    }
    fn absent() -> Option<Self> {
        Some(None)
    }
    fn given(&self) -> bool {
        self.is_some()
    }
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        match self {
            Some(v) => v.each(f),
            None => Ok(()),
        }
    }
    fn scalar(&self) -> Option<f64> {
        self.as_ref().and_then(T::scalar)
    }
    fn from_value(value: f64) -> Option<Self> {
        T::from_value(value).map(Some)
    }
    fn assign(&mut self, value: f64) -> bool {
        match T::from_value(value) {
            Some(v) => {
                *self = Some(v);
                true
            }
            None => false,
        }
    }
}

impl<const N: usize> ParamValue for [f64; N] {
    const KIND: Kind = Kind::Array;
    fn text(&self) -> Option<String> {
        Some(array_text(self))
    }
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        self.iter().try_for_each(|v| f(*v))
    }
}

/// A real as TOML writes it: `Debug` keeps a decimal point or an exponent, so that it reads
/// back as a float (`30.0`, where `Display` writes `30`), and writes `inf` for an infinite bound.
fn real_text(x: f64) -> String {
    format!("{x:?}")
}

/// An array as TOML writes it.
fn array_text(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|v| real_text(*v)).collect();
    format!("[{}]", items.join(", "))
}

/// A section made by [`declare_section!`].
pub trait Declared {
    /// Every parameter, in declaration order.
    const PARAMS: &'static [ParamSpec];

    /// The section's own documentation comment, one line of text per line of comment.
    const DOC: &'static str;

    /// The default declared for `name` as the file would write it; `None` for a key without
    /// one (required, or optional: left out means "not used"). A default with no one-line form
    /// (a table) is an empty text.
    fn default_text(name: &str) -> Option<String>;

    /// The value of the scalar parameter `name`.
    fn get(&self, name: &str) -> Option<f64>;

    /// Point `k` of the array `key` (`None` past its end, or when the key is left out).
    fn point(&self, key: &str, k: usize) -> Option<f64>;

    /// Set the scalar parameter `name`, or the point `name` of an array, to `value`, checked
    /// against its declaration.
    fn set(&mut self, name: &str, value: f64) -> Result<(), ParamError>;

    /// Every value within its declared range; the error names the first that is not.
    fn check(&self) -> Result<(), ParamError>;

    /// Whether the key `name` is given: false only for an optional key left out.
    fn present(&self, name: &str) -> bool;

    /// The declaration of `name`.
    fn spec(name: &str) -> Option<&'static ParamSpec> {
        Self::PARAMS.iter().find(|p| p.name == name)
    }
}

/// The unit a declared parameter gives as `COMMAND_UNIT` is the axis' command unit (V, duty, N,
/// ...), known only when the dictionary is built for an axis.
pub const COMMAND_UNIT: &str = "command";

/// The unit a declared parameter gives as `COMMAND_PER_M_UNIT` is the axis' command unit per m
/// (V/m, 1/m, ...), known only when the dictionary is built for an axis.
pub const COMMAND_PER_M_UNIT: &str = "command/m";

/// The unit a declared parameter gives as `FORCE_PER_COMMAND_UNIT` is the drive's force per
/// command unit (N/V, N per unit duty, ...), known only when the dictionary is built for an
/// axis.
pub const FORCE_PER_COMMAND_UNIT: &str = "N/command";

/// Declare a configuration section: a struct that TOML deserialises (unknown keys refused)
/// and whose fields each carry unit, range, access, a line of documentation and, where one
/// makes sense, a default (a key without a default is required, unless its type is an
/// `Option`: left out, it is `None`). `min` and `max` may be left out where the type bounds
/// the value (a count's 0, a path); the side is then open. `words:` says in an error what the
/// range asks for, where the wording derived from it ("a finite number > 0") would differ from
/// the one a section's users already know ("> 0"). `nonzero: true` refuses zero within the
/// range (a scale whose sign says the direction). The section's and the fields' documentation
/// comments are kept as text too ([`Declared::DOC`](crate::param::Declared::DOC),
/// [`ParamSpec::details`](crate::param::ParamSpec::details)) for the
/// configuration reference; besides them the section takes only `#[derive(...)]` attributes.
///
/// A key may be lent by another declared section, `safe_command: f64 = { from: AxisKeys }`:
/// its whole declaration (unit, range, access, documentation, default) is `AxisKeys`'s, which
/// declares it in a lower layer that needs it (the device profile, for the key's dictionary
/// entry). The field's type must be the lender's, and the lender gives each of its keys a
/// default or makes it optional (a lent key left out takes `AxisKeys::defaults()`'s value).
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
        $(#[doc = $sdoc:literal])*
        $(#[derive($($derive:ident),* $(,)?)])*
        pub struct $name:ident {
            $(
                $(#[doc = $fdoc:literal])*
                $field:ident : $ty:ty = {
                    $(from: $from:ident $(,)?)?
                    $(
                        unit: $unit:expr,
                        $(min: $min:expr,)?
                        $(max: $max:expr,)?
                        access: $access:ident,
                        doc: $doc:literal
                        $(, words: $words:literal)?
                        $(, points: [$($point:ident),* $(,)?])?
                        $(, kept: $kept:expr)?
                        $(, command_bound: $command_bound:expr)?
                        $(, nonzero: $nonzero:expr)?
                        $(, absent: $absent:expr)?
                        $(, default: $default:expr)? $(,)?
                    )?
                }
            ),* $(,)?
        }
    ) => {
        $(#[doc = $sdoc])*
        #[derive(Debug, Clone, PartialEq)]
        $(#[derive($($derive),*)])*
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
                // A missing key is reported from within the table, as a derived struct's is,
                // so that the format places it at this table and not at an enclosing one (an
                // entry of an array of tables rather than the array's first).
                struct Section;
                impl<'de> serde::de::Visitor<'de> for Section {
                    type Value = $name;
                    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                        f.write_str("a table")
                    }
                    fn visit_map<A: serde::de::MapAccess<'de>>(
                        self,
                        map: A,
                    ) -> Result<$name, A::Error> {
                        let keys = <Keys as serde::Deserialize>::deserialize(
                            serde::de::value::MapAccessDeserializer::new(map),
                        )?;
                        Ok($name {
                            $(
                                $field: match keys.$field {
                                    Some(v) => v,
                                    None => $crate::__declared_pick!(
                                        [$( $crate::__declared_default!($field, $ty $(, $default)?) )?]
                                        [$( $crate::__declared_lent_default!($field, $from) )?]
                                    ),
                                },
                            )*
                        })
                    }
                }
                d.deserialize_struct(
                    stringify!($name),
                    &[$(stringify!($field)),*],
                    Section,
                )
            }
        }

        impl $name {
            /// The section with every key left out: its declared defaults, `None` for optional
            /// keys; `None` when a key has neither.
            #[allow(dead_code)]
            pub fn defaults() -> Option<Self> {
                Some($name {
                    $(
                        $field: $crate::__declared_pick!(
                            [$( $crate::__declared_fallback!($ty $(, $default)?) )?]
                            [$( $from::defaults().map(|lent| lent.$field) )?]
                        )?,
                    )*
                })
            }
        }

        impl $crate::param::Declared for $name {
            const DOC: &'static str = concat!("" $(, $sdoc, "\n")*);

            const PARAMS: &'static [$crate::param::ParamSpec] = &[
                $(
                    $crate::param::ParamSpec::described($crate::__declared_pick!(
                        [$(
                            $crate::param::ParamSpec {
                                name: stringify!($field),
                                unit: $unit,
                                kind: <$ty as $crate::param::ParamValue>::KIND,
                                bits: <$ty as $crate::param::ParamValue>::BITS,
                                optional: <$ty as $crate::param::ParamValue>::OPTIONAL,
                                min: $crate::__declared_or!(f64::NEG_INFINITY $(, $min)?),
                                max: $crate::__declared_or!(f64::INFINITY $(, $max)?),
                                doc: $doc,
                                details: "",
                                access: $crate::param::Access::$access,
                                absent: $crate::__declared_or!(None $(, Some($absent))?),
                                words: $crate::__declared_or!("" $(, $words)?),
                                points: $crate::__declared_or!(&[] $(, &[$(stringify!($point)),*])?),
                                kept: $crate::__declared_or!(0 $(, $kept)?),
                                command_bound: $crate::__declared_or!(false $(, $command_bound)?),
                                choices: <$ty as $crate::param::ParamValue>::CHOICES,
                                nonzero: $crate::__declared_or!(false $(, $nonzero)?),
                            }
                        )?]
                        [$(
                            $crate::param::ParamSpec::lent(
                                <$from as $crate::param::Declared>::PARAMS,
                                stringify!($field),
                            )
                        )?]
                    ), concat!("" $(, $fdoc, "\n")*)),
                )*
            ];

            fn default_text(name: &str) -> Option<String> {
                match name {
                    $(
                        stringify!($field) => $crate::__declared_pick!(
                            [$( $crate::__declared_default_text!($ty $(, $default)?) )?]
                            [$(
                                <$from as $crate::param::Declared>::default_text(
                                    stringify!($field),
                                )
                            )?]
                        ),
                    )*
                    _ => None,
                }
            }

            fn get(&self, name: &str) -> Option<f64> {
                let value = match name {
                    $( stringify!($field) => $crate::param::ParamValue::scalar(&self.$field), )*
                    _ => None,
                };
                value.or_else(|| <Self as $crate::param::Declared>::spec(name)?.absent)
            }

            fn point(&self, key: &str, k: usize) -> Option<f64> {
                match key {
                    $( stringify!($field) => $crate::param::ParamValue::point(&self.$field, k), )*
                    _ => None,
                }
            }

            fn set(&mut self, name: &str, value: f64) -> Result<(), $crate::param::ParamError> {
                let Some(spec) = <Self as $crate::param::Declared>::spec(name) else {
                    // A point of an array: checked against the array's range.
                    let mut i = 0;
                    $(
                        let spec = &<Self as $crate::param::Declared>::PARAMS[i];
                        if let Some(k) = spec.point(name) {
                            spec.check(value)?;
                            return if $crate::param::ParamValue::set_point(
                                &mut self.$field, k, value, spec.kept,
                            ) {
                                Ok(())
                            } else {
                                Err($crate::param::ParamError::new(
                                    spec.name,
                                    format!("cannot take {name}"),
                                ))
                            };
                        }
                        i += 1;
                    )*
                    let _ = i;
                    return Err($crate::param::ParamError::new(
                        "parameter",
                        format!("no parameter {name}"),
                    ));
                };
                if spec.absent.is_some() && value.is_infinite() {
                    // An infinite bound: "not watched", the key left out.
                    let cleared = match name {
                        $( stringify!($field) => match <$ty as $crate::param::ParamValue>::absent() {
                            Some(absent) => {
                                self.$field = absent;
                                true
                            }
                            None => false,
                        }, )*
                        _ => false,
                    };
                    if cleared {
                        return Ok(());
                    }
                }
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

            fn present(&self, name: &str) -> bool {
                match name {
                    $( stringify!($field) => {
                        $crate::param::ParamValue::given(&self.$field)
                    } )*
                    _ => false,
                }
            }
        }
    };
}

/// The value of a declared key the configuration leaves out: its default, or the error that
/// names it as missing. Used by [`declare_section!`] inside `Deserialize::deserialize`.
#[doc(hidden)]
#[macro_export]
macro_rules! __declared_default {
    ($field:ident, $ty:ty) => {
        match <$ty as $crate::param::ParamValue>::absent() {
            Some(v) => v,
            None => return Err(serde::de::Error::missing_field(stringify!($field))),
        }
    };
    ($field:ident, $ty:ty, $default:expr) => {
        $default
    };
}

/// The value of a key left out, if it has one: its declared default, or `None` of an optional
/// key. Used by [`declare_section!`] for `defaults()`.
#[doc(hidden)]
#[macro_export]
macro_rules! __declared_fallback {
    ($ty:ty) => {
        <$ty as $crate::param::ParamValue>::absent()
    };
    ($ty:ty, $default:expr) => {
        Some($default)
    };
}

/// The text of a key's declared default, `None` without one. Used by [`declare_section!`] for
/// `default_text()`.
#[doc(hidden)]
#[macro_export]
macro_rules! __declared_default_text {
    ($ty:ty) => {
        None
    };
    ($ty:ty, $default:expr) => {{
        let value: $ty = $default;
        Some($crate::param::ParamValue::text(&value).unwrap_or_default())
    }};
}

/// The value of a lent key the configuration leaves out: the lending section's default for it,
/// or the error that names it as missing. Used by [`declare_section!`] inside
/// `Deserialize::deserialize`.
#[doc(hidden)]
#[macro_export]
macro_rules! __declared_lent_default {
    ($field:ident, $from:ident) => {
        match $from::defaults() {
            Some(lent) => lent.$field,
            None => return Err(serde::de::Error::missing_field(stringify!($field))),
        }
    };
}

/// The tokens of whichever of a key's two forms was given: declared here, or lent (`from:`).
/// Used by [`declare_section!`].
#[doc(hidden)]
#[macro_export]
macro_rules! __declared_pick {
    ([$($declared:tt)+] []) => {
        $($declared)+
    };
    ([] [$($lent:tt)+]) => {
        $($lent)+
    };
}

/// The given expression, or the fallback. Used by [`declare_section!`] for open bounds.
#[doc(hidden)]
#[macro_export]
macro_rules! __declared_or {
    ($fallback:expr) => {
        $fallback
    };
    ($fallback:expr, $given:expr) => {
        $given
    };
}

/// The configuration key of field `$field` of section type `$section`, as text, checked by the
/// compiler: a parameter renamed in its declaration (or misspelled here) is a build error, so
/// code that names a key (an editor writing a configuration, an error, a rule between keys)
/// cannot drift from the declaration. The key is the field's name: a declared section and the
/// configuration's structs take their TOML keys from their fields without renaming.
///
/// ```
/// use actuatord::supervise::ObserverSection;
/// assert_eq!(actuatord::param_key!(ObserverSection, mass_kg), "mass_kg");
/// ```
///
/// A key the section does not declare does not build:
///
/// ```compile_fail,E0609
/// use actuatord::supervise::ObserverSection;
/// let _ = actuatord::param_key!(ObserverSection, mass);
/// ```
#[macro_export]
macro_rules! param_key {
    ($section:ty, $field:ident) => {{
        #[allow(dead_code)]
        fn declared(section: &$section) {
            let _ = &section.$field;
        }
        stringify!($field)
    }};
}
