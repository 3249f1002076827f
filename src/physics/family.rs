//! The four plant families and the units their parameters are expressed in.

use std::fmt;
use std::str::FromStr;

use super::params::Quantity;
use super::PhysicsError;

/// A plant family: the minimal physics of one kind of device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Family {
    /// One rigid body driven by a force (or a voltage times a gain).
    LinearAxis,
    /// Current loop, magnet force, mass and end stops (Isermann & Raab, solenoid drive).
    Solenoid,
    /// Membrane drive with two on/off valves and per-direction speed gains.
    Pneumatic,
    /// DC motor, torsion spring, gear, contact to the load (Bao et al.).
    MotorGear,
}

impl Family {
    /// All families, in a stable order.
    pub const ALL: [Family; 4] = [
        Family::LinearAxis,
        Family::Solenoid,
        Family::Pneumatic,
        Family::MotorGear,
    ];

    /// The name used in plant files and on command lines.
    pub fn name(self) -> &'static str {
        match self {
            Family::LinearAxis => "linear_axis",
            Family::Solenoid => "solenoid",
            Family::Pneumatic => "pneumatic",
            Family::MotorGear => "motor_gear",
        }
    }

    /// True for the rotary family: positions in rad, forces in N·m.
    pub fn is_rotary(self) -> bool {
        matches!(self, Family::MotorGear)
    }

    /// Key suffix and unit of a quantity in this family, e.g. `("_n", "N")` for a force on
    /// a linear family and `("_nm", "N·m")` on the rotary one.
    pub fn suffix_and_unit(
        self,
        q: Quantity,
        command: CommandUnit,
    ) -> (&'static str, &'static str) {
        let rot = self.is_rotary();
        match q {
            Quantity::Force => pick(rot, ("_n", "N"), ("_nm", "N·m")),
            Quantity::Damping => pick(rot, ("_n_s_per_m", "N·s/m"), ("_nm_s_per_rad", "N·m·s/rad")),
            Quantity::Stiffness => pick(rot, ("_n_per_m", "N/m"), ("_nm_per_rad", "N·m/rad")),
            Quantity::Position => pick(rot, ("_m", "m"), ("_rad", "rad")),
            Quantity::Velocity => pick(rot, ("_m_per_s", "m/s"), ("_rad_per_s", "rad/s")),
            Quantity::PerPosition => pick(rot, ("_per_m", "1/m"), ("_per_rad", "1/rad")),
            Quantity::PerPosition2 => pick(rot, ("_per_m2", "1/m²"), ("_per_rad2", "1/rad²")),
            Quantity::Time => ("_s", "s"),
            Quantity::Ratio => ("", "1"),
            Quantity::Command => command.suffix_and_unit(),
            Quantity::Supply => match self {
                Family::Pneumatic => ("_pa", "Pa"),
                _ => ("_v", "V"),
            },
            Quantity::Named(unit) => ("", unit),
        }
    }
}

fn pick<T>(rotary: bool, linear: T, rot: T) -> T {
    if rotary {
        rot
    } else {
        linear
    }
}

/// The unit of the command a plant takes in [`super::Plant::step`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandUnit {
    /// Force in N (linear axis).
    Newton,
    /// Voltage in V (solenoid, motor, linear axis with a force gain).
    Volt,
    /// Signed valve duty in [-1, 1] (pneumatic).
    Duty,
    /// Torque in N·m (motor with a torque input).
    NewtonMetre,
}

impl CommandUnit {
    /// Key suffix and unit.
    pub fn suffix_and_unit(self) -> (&'static str, &'static str) {
        match self {
            CommandUnit::Newton => ("_n", "N"),
            CommandUnit::Volt => ("_v", "V"),
            CommandUnit::Duty => ("_duty", "1"),
            CommandUnit::NewtonMetre => ("_nm", "N·m"),
        }
    }
}

impl fmt::Display for Family {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Family {
    type Err = PhysicsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Family::ALL
            .iter()
            .copied()
            .find(|f| f.name() == s)
            .ok_or_else(|| PhysicsError::Unknown {
                origin: "family".to_string(),
                what: "family",
                name: s.to_string(),
                hint: ", expected one of linear_axis, solenoid, pneumatic, motor_gear".to_string(),
            })
    }
}
