//! The plant parameters `tune` reads from a fitted model, named through their declarations in
//! the physics (a family's or an effect's `PARAMS`): the table is the family's or the effect's
//! own name, the base name is checked against the table's declared parameters when the crate
//! builds, and the unit suffix follows the model's family (`_n` on a linear family, `_nm` on
//! `motor_gear`). A parameter renamed in the physics fails the build here rather than going
//! missing from a fitted model.

use crate::physics::effects::{
    Backlash, Coulomb, DirectionAsymmetry, Payload, Spring, SupplyGain, Viscous,
};
use crate::physics::families::{linear_axis, motor_gear, pneumatic, solenoid};
use crate::physics::{CommandUnit, EffectDef, Family, ParamDef, Quantity};

/// The table of a plant file a parameter sits in.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Table {
    Family(Family),
    Effect(&'static str),
}

/// One declared parameter of a plant file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantKey {
    table: Table,
    def: ParamDef,
}

impl PlantKey {
    const fn new(table: Table, def: ParamDef) -> Self {
        // A parameter in the command's unit takes its suffix from the model's command, which a
        // key named by the family alone cannot know.
        assert!(
            !matches!(def.quantity, Quantity::Command),
            "a command-unit parameter has no key without the model's command"
        );
        PlantKey { table, def }
    }

    /// Parameter `base` of `family`'s own table.
    const fn family(family: Family, defs: &'static [ParamDef], base: &str) -> Self {
        Self::new(Table::Family(family), ParamDef::declared(defs, base))
    }

    /// Parameter `base` of effect `E`'s table.
    const fn effect<E: EffectDef>(base: &str) -> Self {
        Self::new(Table::Effect(E::NAME), ParamDef::declared(E::PARAMS, base))
    }

    /// The qualified name, `table.key`, in a model of `family` (a family's own parameter is
    /// named by its family whatever `family` is).
    pub fn name(self, family: Family) -> String {
        let (table, family) = match self.table {
            Table::Family(own) => (own.name(), own),
            Table::Effect(effect) => (effect, family),
        };
        // Command-unit parameters are refused in `new`: the command does not reach the key.
        format!("{table}.{}", self.def.key(family, CommandUnit::Volt))
    }

    /// The parameter belongs to effect `E`.
    pub fn of_effect<E: EffectDef>(self) -> bool {
        self.table == Table::Effect(E::NAME)
    }
}

pub const SOLENOID_MASS: PlantKey = PlantKey::family(Family::Solenoid, solenoid::PARAMS, "mass_kg");
pub const SOLENOID_LAG: PlantKey = PlantKey::family(
    Family::Solenoid,
    solenoid::PARAMS,
    "current_time_constant_s",
);
pub const SOLENOID_CURRENT_GAIN: PlantKey =
    PlantKey::family(Family::Solenoid, solenoid::PARAMS, "current_gain_a_per_v");
pub const SOLENOID_FORCE_CONSTANT: PlantKey =
    PlantKey::family(Family::Solenoid, solenoid::PARAMS, "force_constant_n_per_a");
pub const SOLENOID_SUPPLY: PlantKey =
    PlantKey::family(Family::Solenoid, solenoid::PARAMS, "supply_voltage_v");

pub const LINEAR_AXIS_MASS: PlantKey =
    PlantKey::family(Family::LinearAxis, linear_axis::PARAMS, "mass_kg");
pub const LINEAR_AXIS_SUPPLY: PlantKey =
    PlantKey::family(Family::LinearAxis, linear_axis::PARAMS, "supply_voltage_v");

pub const MOTOR_GEAR_LOAD_INERTIA: PlantKey =
    PlantKey::family(Family::MotorGear, motor_gear::PARAMS, "load_inertia_kg_m2");
pub const MOTOR_GEAR_GEAR_INERTIA: PlantKey =
    PlantKey::family(Family::MotorGear, motor_gear::PARAMS, "gear_inertia_kg_m2");
pub const MOTOR_GEAR_MOTOR_INERTIA: PlantKey =
    PlantKey::family(Family::MotorGear, motor_gear::PARAMS, "motor_inertia_kg_m2");
pub const MOTOR_GEAR_RATIO: PlantKey =
    PlantKey::family(Family::MotorGear, motor_gear::PARAMS, "ratio");
pub const MOTOR_GEAR_TORQUE_CONSTANT: PlantKey = PlantKey::family(
    Family::MotorGear,
    motor_gear::PARAMS,
    "torque_constant_nm_per_a",
);
pub const MOTOR_GEAR_BACK_EMF: PlantKey = PlantKey::family(
    Family::MotorGear,
    motor_gear::PARAMS,
    "back_emf_v_s_per_rad",
);
pub const MOTOR_GEAR_RESISTANCE: PlantKey =
    PlantKey::family(Family::MotorGear, motor_gear::PARAMS, "resistance_ohm");
pub const MOTOR_GEAR_SUPPLY: PlantKey =
    PlantKey::family(Family::MotorGear, motor_gear::PARAMS, "supply_voltage_v");

pub const PNEUMATIC_GAIN_DOWN: PlantKey =
    PlantKey::family(Family::Pneumatic, pneumatic::PARAMS, "gain_down_m_per_s");
pub const PNEUMATIC_GAIN_UP: PlantKey =
    PlantKey::family(Family::Pneumatic, pneumatic::PARAMS, "gain_up_m_per_s");
pub const PNEUMATIC_SUPPLY: PlantKey =
    PlantKey::family(Family::Pneumatic, pneumatic::PARAMS, "supply_pressure_pa");
pub const PNEUMATIC_ATMOSPHERE: PlantKey =
    PlantKey::family(Family::Pneumatic, pneumatic::PARAMS, "atmosphere_pa");

pub const VISCOUS_POS: PlantKey = PlantKey::effect::<Viscous>("damping_pos");
pub const VISCOUS_NEG: PlantKey = PlantKey::effect::<Viscous>("damping_neg");
pub const SPRING_STIFFNESS: PlantKey = PlantKey::effect::<Spring>("stiffness");
pub const SPRING_PRETENSION: PlantKey = PlantKey::effect::<Spring>("pretension");
pub const ASYMMETRY_POS: PlantKey = PlantKey::effect::<DirectionAsymmetry>("gain_pos");
pub const ASYMMETRY_NEG: PlantKey = PlantKey::effect::<DirectionAsymmetry>("gain_neg");
pub const COULOMB_POS: PlantKey = PlantKey::effect::<Coulomb>("coulomb_pos");
pub const COULOMB_NEG: PlantKey = PlantKey::effect::<Coulomb>("coulomb_neg");
pub const SUPPLY_EXPONENT: PlantKey = PlantKey::effect::<SupplyGain>("exponent");
pub const SUPPLY_EXPONENT_POS_SHIFT: PlantKey =
    PlantKey::effect::<SupplyGain>("exponent_pos_shift");
pub const PAYLOAD_MAX: PlantKey = PlantKey::effect::<Payload>("max_load");
pub const PAYLOAD_FULL_SCALE: PlantKey = PlantKey::effect::<Payload>("full_scale");
pub const BACKLASH_GAP: PlantKey = PlantKey::effect::<Backlash>("gap");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_model_files_with_the_family_suffix() {
        assert_eq!(SOLENOID_MASS.name(Family::Solenoid), "solenoid.mass_kg");
        assert_eq!(COULOMB_POS.name(Family::Solenoid), "coulomb.coulomb_pos_n");
        assert_eq!(
            COULOMB_POS.name(Family::MotorGear),
            "coulomb.coulomb_pos_nm"
        );
        assert_eq!(
            VISCOUS_NEG.name(Family::MotorGear),
            "viscous.damping_neg_nm_s_per_rad"
        );
        assert_eq!(BACKLASH_GAP.name(Family::MotorGear), "backlash.gap_rad");
        assert!(VISCOUS_POS.of_effect::<Viscous>() && !SPRING_STIFFNESS.of_effect::<Viscous>());
    }
}
