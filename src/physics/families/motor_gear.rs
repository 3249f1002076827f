//! `motor_gear`: DC motor, torsion spring, gear and load (Bao et al.).

use crate::physics::params::{ParamDef, Quantity};

/// Base parameters of the `[motor_gear]` table.
pub const PARAMS: &[ParamDef] = &[
    ParamDef::positive(
        "resistance_ohm",
        Quantity::Named("Ω"),
        1.55,
        "R_a, armature resistance",
    ),
    ParamDef::positive(
        "inductance_h",
        Quantity::Named("H"),
        0.0005,
        "L_a, armature inductance",
    ),
    ParamDef::non_negative(
        "back_emf_v_s_per_rad",
        Quantity::Named("V·s/rad"),
        0.03,
        "K_e",
    ),
    ParamDef::positive(
        "torque_constant_nm_per_a",
        Quantity::Named("N·m/A"),
        0.03,
        "K_T",
    ),
    ParamDef::positive("motor_inertia_kg_m2", Quantity::Named("kg·m²"), 1e-5, "J_m"),
    ParamDef::positive(
        "torsion_stiffness_nm_per_rad",
        Quantity::Named("N·m/rad"),
        50.0,
        "K_p",
    ),
    ParamDef::non_negative(
        "torsion_damping_nm_s_per_rad",
        Quantity::Named("N·m·s/rad"),
        0.005,
        "C_p",
    ),
    ParamDef::positive(
        "ratio",
        Quantity::Named("1"),
        100.0,
        "h_0, motor angle per gear output angle",
    ),
    ParamDef::positive(
        "gear_inertia_kg_m2",
        Quantity::Named("kg·m²"),
        1e-3,
        "J_g, at the gear output",
    ),
    ParamDef::positive(
        "contact_stiffness_nm_per_rad",
        Quantity::Named("N·m/rad"),
        500.0,
        "K_g",
    ),
    ParamDef::non_negative(
        "contact_damping_nm_s_per_rad",
        Quantity::Named("N·m·s/rad"),
        0.5,
        "C_g",
    ),
    ParamDef::positive("load_inertia_kg_m2", Quantity::Named("kg·m²"), 0.01, "J_l"),
    ParamDef::positive(
        "supply_voltage_v",
        Quantity::Named("V"),
        24.0,
        "H-bridge supply",
    ),
    ParamDef::any(
        "angle_min_rad",
        Quantity::Named("rad"),
        -1.2,
        "lower end stop of the load",
    ),
    ParamDef::any(
        "angle_max_rad",
        Quantity::Named("rad"),
        1.2,
        "upper end stop of the load",
    ),
];
