//! Physical effects, one file each. An effect is a small `Copy` struct with its equation, its
//! parameters (base name, quantity, bounds, default) and the function the plant families call.
//!
//! To add an effect: write `effects/<name>.rs` with a struct implementing [`EffectDef`] and add
//! one line to the `catalogue!` below. An effect that is a force on the moving body says so in
//! [`EffectDef::load_force`] and every family adds it; one that acts elsewhere (the power stage,
//! the drive, the gear) is used by name in the families where it acts.

use super::family::Family;
use super::params::ParamDef;

pub mod backlash;
pub mod coulomb;
pub mod dead_time;
pub mod deadzone;
pub mod direction_asymmetry;
pub mod hysteresis;
pub mod offset;
pub mod payload;
pub mod position_stiffness;
pub mod saturation;
pub mod spring;
pub mod stiction;
pub mod stribeck;
pub mod supply_friction;
pub mod supply_gain;
pub mod varying_ratio;
pub mod viscous;

pub use backlash::Backlash;
pub use coulomb::Coulomb;
pub use dead_time::{DeadTime, DelayLine};
pub use deadzone::Deadzone;
pub use direction_asymmetry::DirectionAsymmetry;
pub use hysteresis::Hysteresis;
pub use offset::Offset;
pub use payload::Payload;
pub use position_stiffness::PositionStiffness;
pub use saturation::Saturation;
pub use spring::Spring;
pub use stiction::Stiction;
pub use stribeck::Stribeck;
pub use supply_friction::SupplyFriction;
pub use supply_gain::SupplyGain;
pub use varying_ratio::VaryingRatio;
pub use viscous::Viscous;

/// What every effect declares.
pub trait EffectDef: Sized + Copy {
    /// Name used in plant files, the lab and the docs.
    const NAME: &'static str;
    /// The equation, one line.
    const EQUATION: &'static str;
    /// Parameters, in the order `from_values` reads them.
    const PARAMS: &'static [ParamDef];
    /// Build from values in `PARAMS` order (already checked against their bounds).
    fn from_values(values: &[f64]) -> Self;
    /// Rules across parameters: `Err((index, rule))` names the offending one.
    fn check(_values: &[f64]) -> Result<(), (usize, String)> {
        Ok(())
    }
    /// For an effect that is a force on the moving body (the load of `motor_gear`): that force
    /// at position `y` and velocity `v`. The families add these forces, in catalogue order,
    /// after the drive's ([`Effects::add_load_forces`]); `None` for an effect that acts
    /// elsewhere.
    #[inline(always)]
    fn load_force(&self, _y: f64, _v: f64) -> Option<f64> {
        None
    }
}

macro_rules! registry {
    ($( $variant:ident => $field:ident : $ty:ty ),* $(,)?) => {
        /// The effects known by name.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum EffectKind { $( $variant ),* }

        impl EffectKind {
            /// All effects, in the order plant files list them.
            pub const ALL: &'static [EffectKind] = &[ $( EffectKind::$variant ),* ];

            /// The effect's name, e.g. `coulomb`.
            pub fn name(self) -> &'static str {
                match self { $( EffectKind::$variant => <$ty as EffectDef>::NAME ),* }
            }

            /// The effect's equation.
            pub fn equation(self) -> &'static str {
                match self { $( EffectKind::$variant => <$ty as EffectDef>::EQUATION ),* }
            }

            /// Parameter definitions.
            pub fn params(self) -> &'static [ParamDef] {
                match self { $( EffectKind::$variant => <$ty as EffectDef>::PARAMS ),* }
            }

            /// Cross-parameter rules.
            pub fn check(self, values: &[f64]) -> Result<(), (usize, String)> {
                match self { $( EffectKind::$variant => <$ty as EffectDef>::check(values) ),* }
            }
        }

        /// The effects of one plant, each present or not. Plain `Copy` data, so that the
        /// integrator reads them without indirection.
        #[derive(Debug, Clone, Copy, Default, PartialEq)]
        pub struct Effects { $( pub $field: Option<$ty> ),* }

        impl Effects {
            /// Switch on `kind` with `values` in its parameter order.
            pub fn set(&mut self, kind: EffectKind, values: &[f64]) {
                match kind { $( EffectKind::$variant => self.$field = Some(<$ty>::from_values(values)) ),* }
            }

            /// True when `kind` is present.
            pub fn has(&self, kind: EffectKind) -> bool {
                match kind { $( EffectKind::$variant => self.$field.is_some() ),* }
            }

            /// Add to `f` the force of every present effect that is a force on the moving body
            /// (position `y`, velocity `v`), in catalogue order.
            #[inline(always)]
            pub fn add_load_forces(&self, y: f64, v: f64, f: &mut f64) {
                $(
                    if let Some(force) = self.$field.as_ref().and_then(|e| e.load_force(y, v)) {
                        *f += force;
                    }
                )*
            }
        }
    };
}

/// The catalogue of effects, one line each (`Variant => file: Type`), in the order plant files
/// list them: the one list from which the physics' [`EffectKind`] and [`Effects`] and the lab's
/// registry of effects (`lab/effects/<file>.rs`, a unit struct named like the variant) are
/// made. `catalogue!(m)` calls the macro `m` with the list.
macro_rules! catalogue {
    ($m:path) => {
        $m! {
            Viscous => viscous: Viscous,
            Coulomb => coulomb: Coulomb,
            Stiction => stiction: Stiction,
            Stribeck => stribeck: Stribeck,
            Spring => spring: Spring,
            PositionStiffness => position_stiffness: PositionStiffness,
            Backlash => backlash: Backlash,
            Hysteresis => hysteresis: Hysteresis,
            DirectionAsymmetry => direction_asymmetry: DirectionAsymmetry,
            Deadzone => deadzone: Deadzone,
            SupplyGain => supply_gain: SupplyGain,
            SupplyFriction => supply_friction: SupplyFriction,
            DeadTime => dead_time: DeadTime,
            Saturation => saturation: Saturation,
            Payload => payload: Payload,
            Offset => offset: Offset,
            VaryingRatio => varying_ratio: VaryingRatio,
        }
    };
}
pub(crate) use catalogue;

catalogue!(registry);

impl EffectKind {
    /// Look an effect up by name.
    pub fn from_name(name: &str) -> Option<EffectKind> {
        EffectKind::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// Whether a family has a place for this effect.
    pub fn supported_by(self, family: Family) -> bool {
        match self {
            EffectKind::Backlash | EffectKind::VaryingRatio => family == Family::MotorGear,
            EffectKind::PositionStiffness => family != Family::MotorGear,
            // A seal pressed by its supply: a cylinder (a linear axis driven by a force) or the
            // pneumatic drive; a coil's or motor's voltage presses no seal.
            EffectKind::SupplyFriction => matches!(family, Family::LinearAxis | Family::Pneumatic),
            _ => true,
        }
    }

    /// Comma-separated names of the effects a family supports.
    pub fn names_for(family: Family) -> String {
        EffectKind::ALL
            .iter()
            .filter(|k| k.supported_by(family))
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

impl std::fmt::Display for EffectKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Dry friction of one body, merged from `coulomb`, `stribeck` and `stiction` (and a jam level).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DryFriction {
    /// Coulomb level, positive motion.
    pub coulomb_pos: f64,
    /// Coulomb level, negative motion.
    pub coulomb_neg: f64,
    /// Stribeck part, if any.
    pub stribeck: Option<Stribeck>,
    /// Net force needed to start moving positive: the largest of the breakaway force and the
    /// friction at zero speed.
    pub break_pos: f64,
    /// Same, negative.
    pub break_neg: f64,
    /// True when there is any dry friction: zero velocity becomes a state of its own.
    pub present: bool,
}

impl DryFriction {
    /// Merge the dry friction effects, every level scaled by `scale`, plus `extra` on both
    /// directions (jamming).
    pub fn from_effects(e: &Effects, scale: f64, extra: f64) -> Self {
        let (mut cp, mut cn) = e.coulomb.map_or((0.0, 0.0), |c| (c.level_pos, c.level_neg));
        cp = cp * scale + extra;
        cn = cn * scale + extra;
        let stribeck = e.stribeck.map(|s| Stribeck {
            excess_pos: s.excess_pos * scale,
            excess_neg: s.excess_neg * scale,
            ..s
        });
        let (sp, sn) = e.stiction.map_or((0.0, 0.0), |s| {
            (s.breakaway_pos * scale, s.breakaway_neg * scale)
        });
        let (ep, en) = stribeck.map_or((0.0, 0.0), |s| (s.excess_pos, s.excess_neg));
        let break_pos = (sp + extra).max(cp + ep);
        let break_neg = (sn + extra).max(cn + en);
        DryFriction {
            coulomb_pos: cp,
            coulomb_neg: cn,
            stribeck,
            break_pos,
            break_neg,
            present: break_pos > 0.0 || break_neg > 0.0,
        }
    }

    /// Magnitude of the dry friction while sliding in direction `dir` at velocity `v`.
    #[inline]
    pub fn sliding(&self, dir: f64, v: f64) -> f64 {
        let c = if dir > 0.0 {
            self.coulomb_pos
        } else {
            self.coulomb_neg
        };
        match self.stribeck {
            Some(s) => c + s.excess(dir, v),
            None => c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The forces on the body are those of the effects that are one (spring, payload, offset),
    /// and only those: friction, which the families add in their own place, stays out.
    #[test]
    fn load_forces_are_the_spring_payload_and_offset() {
        let mut e = Effects::default();
        e.set(EffectKind::Spring, &[1000.0, 2.0]);
        e.set(EffectKind::Payload, &[5.0, 0.1]);
        e.set(EffectKind::Offset, &[0.5]);
        e.set(EffectKind::Viscous, &[10.0, 10.0]);
        e.set(EffectKind::Coulomb, &[1.0, 1.0]);
        let (y, v) = (0.02, 0.3);
        let mut f = 0.0;
        e.add_load_forces(y, v, &mut f);
        // -(F_0 + c y) - F_max y / y_full + F_b
        let expected = -(2.0 + 1000.0 * 0.02) - 5.0 * (0.02 / 0.1) + 0.5;
        assert!((f - expected).abs() < 1e-12, "{f} != {expected}");

        let mut untouched = 7.0;
        Effects::default().add_load_forces(y, v, &mut untouched);
        assert_eq!(untouched, 7.0);
    }
}
