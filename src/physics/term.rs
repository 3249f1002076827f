//! Forces a model declares itself: a named term whose force on the moving body (the load of
//! `motor_gear`) is an expression over the motion, the command, the supply and the time, with
//! parameters of its own (a model file's `[[lab.term]]`). The plant adds it where the catalogue's
//! load forces act; the lab fits it as it fits an effect: the parameters the force is linear in by
//! regression, the others by a search over their range.
//!
//! The expression is parsed by `exmex`; this file resolves its names, tells which parameters
//! enter linearly and evaluates it without allocating.

use std::sync::Arc;

use exmex::{Express, FlatEx};

use super::params::{Param, ParamDef, Quantity};
use super::PhysicsError;

/// The signals a term's force may use, in the order of [`Signals::get`]: position (m or rad),
/// velocity (m/s or rad/s), command (the family's unit), supply (V or Pa) and time (s).
pub const SIGNALS: [&str; 5] = ["y", "v", "u", "supply", "t"];

/// Most names (signals, parameters and `pi`) one expression may use.
const MAX_NAMES: usize = 16;

/// The values of [`SIGNALS`] at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Signals {
    /// Position (m or rad).
    pub y: f64,
    /// Velocity (m/s or rad/s).
    pub v: f64,
    /// Command (the family's unit).
    pub u: f64,
    /// Supply (V or Pa).
    pub supply: f64,
    /// Time (s).
    pub t: f64,
}

impl Signals {
    fn get(&self, i: usize) -> f64 {
        match i {
            0 => self.y,
            1 => self.v,
            2 => self.u,
            3 => self.supply,
            _ => self.t,
        }
    }
}

/// Where one of the expression's names takes its value.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    Signal(usize),
    Pi,
    Param(usize),
}

/// The parsed expression and where each of its names comes from.
#[derive(Debug)]
struct Compiled {
    expr: FlatEx<f64>,
    slots: Vec<Slot>,
}

impl Compiled {
    /// The force at `s` with the term's parameters at `values`; NaN where the expression is
    /// undefined.
    fn eval(&self, s: &Signals, values: &[f64]) -> f64 {
        let mut buf = [0.0; MAX_NAMES];
        for (b, slot) in buf.iter_mut().zip(&self.slots) {
            *b = match *slot {
                Slot::Signal(i) => s.get(i),
                Slot::Pi => std::f64::consts::PI,
                Slot::Param(j) => values.get(j).copied().unwrap_or(f64::NAN),
            };
        }
        self.expr.eval(&buf[..self.slots.len()]).unwrap_or(f64::NAN)
    }
}

/// One declared term: its name, its force and its parameters.
#[derive(Debug, Clone)]
pub struct TermSpec {
    /// Name, also the table of its parameters' qualified names (`cogging.amp`).
    pub name: String,
    /// The force on the moving body as written (N, or N·m on a rotary axis), positive along `y`.
    pub force: String,
    /// Its parameters, each with the bounds it was declared with.
    pub params: Vec<Param>,
    /// True when the term is not part of the model but a candidate the lab tries beside the
    /// catalogue's effects (`diagnose`, `discover`).
    pub candidate: bool,
    /// Per parameter: true when the force is linear in it (jointly with the others so marked).
    pub linear: Vec<bool>,
    compiled: Arc<Compiled>,
}

impl PartialEq for TermSpec {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.force == other.force
            && self.params == other.params
            && self.candidate == other.candidate
    }
}

/// A parameter as declared: name, bounds and starting value.
#[derive(Debug, Clone, PartialEq)]
pub struct TermParam {
    /// Name inside the expression.
    pub name: String,
    /// Lower bound.
    pub min: f64,
    /// Upper bound.
    pub max: f64,
    /// Starting value (inside the bounds).
    pub value: f64,
}

/// True for a name made of letters, digits and `_`, not starting with a digit.
fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// True where a number starts at `i`: a digit, or a point before one.
fn number_starts(chars: &[char], i: usize) -> bool {
    chars[i].is_ascii_digit()
        || (chars[i] == '.' && chars.get(i + 1).is_some_and(char::is_ascii_digit))
}

/// The end of the number that starts at `i`, with its exponent when it has one (`1e-3`), so that
/// the `e` of an exponent is no name.
fn number_end(chars: &[char], mut i: usize) -> usize {
    while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
        i += 1;
    }
    if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
        let mut j = i + 1;
        if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
            j += 1;
        }
        if j < chars.len() && chars[j].is_ascii_digit() {
            while j < chars.len() && chars[j].is_ascii_digit() {
                j += 1;
            }
            return j;
        }
    }
    i
}

/// The names an expression uses as variables, with their character positions (1-based): runs of
/// letters, digits and `_` that are not numbers and not followed by `(` (a function).
fn names_in(text: &str) -> Vec<(String, usize)> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if number_starts(&chars, i) {
            i = number_end(&chars, i);
        } else if c.is_ascii_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let mut j = i;
            while j < chars.len() && chars[j] == ' ' {
                j += 1;
            }
            if chars.get(j) != Some(&'(') {
                out.push((chars[start..i].iter().collect(), start + 1));
            }
        } else {
            i += 1;
        }
    }
    out
}

/// The text with every number written with an exponent (`1e-3`, `2.5E+2`) written out
/// (`0.001`, `250`): the expression parser reads plain decimals only.
fn plain_numbers(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let mut in_name = false;
    while i < chars.len() {
        let c = chars[i];
        if in_name || !number_starts(&chars, i) {
            in_name = c.is_ascii_alphanumeric() || c == '_';
            out.push(c);
            i += 1;
            continue;
        }
        let end = number_end(&chars, i);
        let number: String = chars[i..end].iter().collect();
        let exponent = number.contains(['e', 'E']);
        match number.parse::<f64>() {
            Ok(v) if exponent => out.push_str(&format!("{v}")),
            _ => out.push_str(&number),
        }
        i = end;
    }
    out
}

/// The position (1-based) of the first parenthesis that has no partner, if any.
fn unbalanced(text: &str) -> Option<usize> {
    let mut open = Vec::new();
    for (i, c) in text.chars().enumerate() {
        match c {
            '(' => open.push(i + 1),
            ')' if open.pop().is_none() => return Some(i + 1),
            _ => {}
        }
    }
    open.first().copied()
}

impl TermSpec {
    /// A term from its declaration; `origin` (the model file) and the term's name prefix errors,
    /// which give the position in the expression where one is known.
    pub fn new(
        name: &str,
        force: &str,
        params: &[TermParam],
        candidate: bool,
        origin: &str,
    ) -> Result<TermSpec, PhysicsError> {
        let table = format!("lab.term '{name}'");
        let bad = |key: &str, rule: String| PhysicsError::invalid(origin, &table, key, rule);
        if !is_identifier(name) {
            return Err(bad(
                "name",
                "must be a name of letters, digits and _ (not starting with a digit)".into(),
            ));
        }
        for p in params {
            if !is_identifier(&p.name) {
                return Err(bad(
                    "params",
                    format!("'{}' is not a name of letters, digits and _", p.name),
                ));
            }
            if SIGNALS.contains(&p.name.as_str()) || p.name == "pi" {
                return Err(bad(
                    "params",
                    format!(
                        "'{}' is a signal of every term ({}, pi); name the parameter otherwise",
                        p.name,
                        SIGNALS.join(", ")
                    ),
                ));
            }
            if !(p.min.is_finite() && p.max.is_finite() && p.min < p.max) {
                return Err(bad(
                    "params",
                    format!(
                        "'{}': the range must be [min, max] with finite min < max, got [{}, {}]",
                        p.name, p.min, p.max
                    ),
                ));
            }
            if !(p.value >= p.min && p.value <= p.max) {
                return Err(bad(
                    "params",
                    format!(
                        "'{}': value {} lies outside [{}, {}]",
                        p.name, p.value, p.min, p.max
                    ),
                ));
            }
        }
        let known = || {
            let mut k: Vec<&str> = SIGNALS.to_vec();
            k.push("pi");
            k.extend(params.iter().map(|p| p.name.as_str()));
            k.join(", ")
        };
        if force.trim().is_empty() {
            return Err(bad("force", "is empty".into()));
        }
        for (n, at) in names_in(force) {
            if !SIGNALS.contains(&n.as_str()) && n != "pi" && !params.iter().any(|p| p.name == n) {
                return Err(bad(
                    "force",
                    format!(
                        "unknown name '{n}' at character {at} of \"{force}\"; known: {}",
                        known()
                    ),
                ));
            }
        }
        if let Some(at) = unbalanced(force) {
            return Err(bad(
                "force",
                format!("unbalanced parenthesis at character {at} of \"{force}\""),
            ));
        }
        let expr = exmex::parse::<f64>(&plain_numbers(force))
            .map_err(|e| bad("force", format!("cannot parse \"{force}\": {}", e.msg())))?;
        if expr.var_names().len() > MAX_NAMES {
            return Err(bad(
                "force",
                format!("uses {} names, at most {MAX_NAMES}", expr.var_names().len()),
            ));
        }
        let mut slots = Vec::new();
        for n in expr.var_names() {
            let slot = if let Some(i) = SIGNALS.iter().position(|s| s == n) {
                Slot::Signal(i)
            } else if n == "pi" {
                Slot::Pi
            } else if let Some(j) = params.iter().position(|p| &p.name == n) {
                Slot::Param(j)
            } else {
                return Err(bad(
                    "force",
                    format!("unknown name '{n}' in \"{force}\"; known: {}", known()),
                ));
            };
            slots.push(slot);
        }
        for p in params {
            if !slots
                .iter()
                .any(|s| matches!(s, Slot::Param(j) if params[*j].name == p.name))
            {
                return Err(bad(
                    "params",
                    format!("'{}' does not appear in \"{force}\"", p.name),
                ));
            }
        }
        let compiled = Arc::new(Compiled { expr, slots });
        let linear = linear_params(&compiled, params);
        Ok(TermSpec {
            name: name.to_string(),
            force: force.to_string(),
            params: params
                .iter()
                .map(|p| Param {
                    key: p.name.clone(),
                    unit: "",
                    def: ParamDef {
                        base: "",
                        quantity: Quantity::Named(""),
                        min: p.min,
                        min_strict: false,
                        max: p.max,
                        default: p.value,
                        doc: "a parameter of a term the model declares",
                    },
                    value: p.value,
                    free: true,
                })
                .collect(),
            candidate,
            linear,
            compiled,
        })
    }

    /// The parameters as declared, at their present values.
    pub fn declared(&self) -> Vec<TermParam> {
        self.params
            .iter()
            .map(|p| TermParam {
                name: p.key.clone(),
                min: p.def.min,
                max: p.def.max,
                value: p.value,
            })
            .collect()
    }

    /// True when the force uses the signal `name` (one of [`SIGNALS`]).
    pub fn uses(&self, name: &str) -> bool {
        SIGNALS
            .iter()
            .position(|s| *s == name)
            .is_some_and(|i| self.compiled.slots.contains(&Slot::Signal(i)))
    }

    /// The force at `s` with the parameters at `values` (in declaration order).
    pub fn force_with(&self, s: &Signals, values: &[f64]) -> f64 {
        self.compiled.eval(s, values)
    }

    /// The force at `s` with the parameters at their present values.
    pub fn force_at(&self, s: &Signals) -> f64 {
        self.load().force(s)
    }

    /// The term as a plant applies it: its force with the present parameter values.
    pub fn load(&self) -> LoadTerm {
        let mut values = [0.0; MAX_NAMES];
        for (v, p) in values.iter_mut().zip(&self.params) {
            *v = p.value;
        }
        LoadTerm {
            compiled: Arc::clone(&self.compiled),
            values,
        }
    }

    /// Model-file text of the term (`[[lab.term]]`), read back by the lab's model reader.
    pub fn to_toml(&self) -> String {
        let params: Vec<String> = self
            .params
            .iter()
            .map(|p| {
                format!(
                    "{} = {{ min = {:?}, max = {:?}, value = {:?} }}",
                    p.key, p.def.min, p.def.max, p.value
                )
            })
            .collect();
        format!(
            "\n[[lab.term]]\nname = \"{}\"\nforce = \"{}\"\nparams = {{ {} }}\ncandidate = {}\n",
            self.name,
            self.force.replace('\\', "\\\\").replace('"', "\\\""),
            params.join(", "),
            self.candidate
        )
    }
}

/// A declared term as the plant applies it: allocation-free to evaluate.
#[derive(Debug, Clone)]
pub struct LoadTerm {
    compiled: Arc<Compiled>,
    values: [f64; MAX_NAMES],
}

impl LoadTerm {
    /// The force on the moving body at `s` (N or N·m, positive along `y`).
    #[inline]
    pub fn force(&self, s: &Signals) -> f64 {
        self.compiled.eval(s, &self.values)
    }
}

/// Which parameters the force is linear in, jointly: a parameter joins the linear set when the
/// force stays affine along random lines through the set's values, at random signals and other
/// parameters (`f(α θ₁ + (1-α) θ₂) = α f(θ₁) + (1-α) f(θ₂)`).
fn linear_params(c: &Compiled, params: &[TermParam]) -> Vec<bool> {
    let mut rng = super::rng::SplitMix64::new(0x5eed_7e57);
    let mut linear = vec![false; params.len()];
    let draw =
        |rng: &mut super::rng::SplitMix64, p: &TermParam| p.min + (p.max - p.min) * rng.uniform();
    for j in 0..params.len() {
        let mut set = linear.clone();
        set[j] = true;
        let affine = (0..16).all(|_| {
            let s = Signals {
                y: 2.0 * rng.uniform() - 1.0,
                v: 2.0 * rng.uniform() - 1.0,
                u: 2.0 * rng.uniform() - 1.0,
                supply: rng.uniform(),
                t: 10.0 * rng.uniform(),
            };
            let base: Vec<f64> = params.iter().map(|p| draw(&mut rng, p)).collect();
            let mut a = base.clone();
            let mut b = base.clone();
            for (i, p) in params.iter().enumerate() {
                if set[i] {
                    a[i] = draw(&mut rng, p);
                    b[i] = draw(&mut rng, p);
                }
            }
            let (fa, fb) = (c.eval(&s, &a), c.eval(&s, &b));
            [-0.7, 0.4, 1.9].iter().all(|&alpha: &f64| {
                let mid: Vec<f64> = a
                    .iter()
                    .zip(&b)
                    .map(|(x, y)| alpha * x + (1.0 - alpha) * y)
                    .collect();
                let f = c.eval(&s, &mid);
                let want = alpha * fa + (1.0 - alpha) * fb;
                f.is_finite()
                    && want.is_finite()
                    && (f - want).abs() <= 1e-9 * (fa.abs() + fb.abs() + f.abs()) + 1e-300
            })
        });
        linear[j] = affine;
    }
    linear
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(name: &str, min: f64, max: f64) -> TermParam {
        TermParam {
            name: name.into(),
            min,
            max,
            value: 0.5 * (min + max),
        }
    }

    #[test]
    fn a_cogging_term_evaluates_and_knows_its_linear_parameters() {
        let t = TermSpec::new(
            "cogging",
            "a*sin(2*pi*y/pitch) + b*cos(2*pi*y/pitch) + c0*v*v",
            &[
                p("a", -50.0, 50.0),
                p("b", -50.0, 50.0),
                p("pitch", 0.001, 0.05),
                p("c0", 0.0, 2.0),
            ],
            false,
            "m.toml",
        )
        .expect("parses");
        assert_eq!(t.linear, vec![true, true, false, true]);
        let s = Signals {
            y: 0.003,
            v: 0.2,
            ..Signals::default()
        };
        let f = t.force_with(&s, &[10.0, -4.0, 0.012, 1.5]);
        let phase = 2.0 * std::f64::consts::PI * 0.003 / 0.012;
        let want = 10.0 * phase.sin() - 4.0 * phase.cos() + 1.5 * 0.04;
        assert!((f - want).abs() < 1e-12, "{f} vs {want}");
        assert!(t.uses("y") && t.uses("v") && !t.uses("t"));
        assert_eq!(t.load().force(&s), t.force_at(&s));
    }

    #[test]
    fn a_product_of_two_parameters_keeps_one_linear() {
        let t = TermSpec::new(
            "x",
            "a*b*y + c*exp(-y/d)",
            &[
                p("a", 0.0, 1.0),
                p("b", 0.0, 1.0),
                p("c", 0.0, 1.0),
                p("d", 0.1, 1.0),
            ],
            false,
            "m.toml",
        )
        .expect("parses");
        assert_eq!(t.linear, vec![true, false, true, false]);
    }

    #[test]
    fn errors_name_the_file_the_term_and_the_position() {
        let err = TermSpec::new(
            "cog",
            "amp * sin(2*pi*y/pich)",
            &[p("amp", 0.0, 1.0)],
            false,
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("m.toml") && err.contains("cog"), "{err}");
        assert!(
            err.contains("'pich'") && err.contains("character 18"),
            "{err}"
        );
        let err = TermSpec::new(
            "cog",
            "amp * sin(2*y",
            &[p("amp", 0.0, 1.0)],
            false,
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("character 10"), "{err}");
        let err = TermSpec::new("cog", "amp * y", &[p("amp", 1.0, 0.0)], false, "m.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("amp") && err.contains("min < max"), "{err}");
        let err = TermSpec::new(
            "cog",
            "amp * y",
            &[p("amp", 0.0, 1.0), p("k", 0.0, 1.0)],
            false,
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("'k' does not appear"), "{err}");
        let err = TermSpec::new(
            "cog",
            "amp * y ** 2 +",
            &[p("amp", 0.0, 1.0)],
            false,
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("cannot parse"), "{err}");
        // An exponent is part of its number, not a name.
        let t = TermSpec::new(
            "cog",
            "amp * 1e-3 * y + 2.5E+2*amp + x2e1*0",
            &[p("amp", 0.0, 1.0), p("x2e1", 0.0, 1.0)],
            false,
            "m.toml",
        )
        .expect("numbers with exponents");
        let s = Signals {
            y: 2.0,
            ..Signals::default()
        };
        assert!((t.force_with(&s, &[1.0, 0.5]) - 250.002).abs() < 1e-12);
    }

    #[test]
    fn a_term_written_and_read_keeps_its_values() {
        let t = TermSpec::new(
            "cog",
            "amp * sin(y/w)",
            &[p("amp", 0.0, 1.0), p("w", 0.1, 2.0)],
            true,
            "m.toml",
        )
        .expect("parses");
        let text = t.to_toml();
        assert!(
            text.contains("[[lab.term]]") && text.contains("candidate = true"),
            "{text}"
        );
        assert!(
            text.contains("w = { min = 0.1, max = 2.0, value = 1.05 }"),
            "{text}"
        );
    }
}
