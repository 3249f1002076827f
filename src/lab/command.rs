//! What the `u` column of a record is (`--command force|torque|voltage|duty|current`), and
//! which families it means something for.
//!
//! | command | families | the drive the lab models |
//! |---|---|---|
//! | `force` | linear_axis | `F = u` (N) |
//! | `torque` | motor_gear | the motor torque `τ_m = u` (N·m) of a servo drive in torque mode |
//! | `voltage` | linear_axis, solenoid, motor_gear | the terminal voltage, limited by the supply; a solenoid's magnet only pulls (`0..U_s`) |
//! | `duty` | pneumatic | the signed valve duty in `[-1, 1]` |
//! | `current` | linear_axis, solenoid, motor_gear | a current-mode amplifier: the current the drive imposes (the force or torque follows it without the coil's lag) |
//!
//! A current command is the family's drive with the current imposed: on a solenoid `u` becomes
//! the measured current (`F = K_Mag u`), on a gear the motor torque `τ_m = K_T u` (the declared
//! torque constant); the stages before the current (coil lag, armature, power stage, dead zone,
//! supply) are not part of the model. On a linear axis a
//! current-mode amplifier gives a force `K_F u`: the balance takes the command as its scale, so the
//! fitted mass and friction come out per unit of `K_F` (multiply by `K_F` for newtons).

use std::fmt;

use super::data::Dataset;
use crate::physics::{CommandUnit, Family, PlantSpec};

/// What the `u` column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// A force, N.
    Force,
    /// A motor torque, N·m.
    Torque,
    /// A terminal voltage, V.
    Voltage,
    /// A signed valve duty, 1.
    Duty,
    /// The current a current-mode amplifier imposes, A.
    Current,
}

impl Command {
    /// Every command, as the command line lists them.
    pub const ALL: [Command; 5] = [
        Command::Force,
        Command::Torque,
        Command::Voltage,
        Command::Duty,
        Command::Current,
    ];

    /// The name on the command line and in model files.
    pub fn name(self) -> &'static str {
        match self {
            Command::Force => "force",
            Command::Torque => "torque",
            Command::Voltage => "voltage",
            Command::Duty => "duty",
            Command::Current => "current",
        }
    }

    /// The families this command means something for.
    pub fn families(self) -> &'static [Family] {
        match self {
            Command::Force => &[Family::LinearAxis],
            Command::Torque => &[Family::MotorGear],
            Command::Voltage => &[Family::LinearAxis, Family::Solenoid, Family::MotorGear],
            Command::Duty => &[Family::Pneumatic],
            Command::Current => &[Family::LinearAxis, Family::Solenoid, Family::MotorGear],
        }
    }

    /// The commands a family accepts.
    pub fn accepted_by(family: Family) -> Vec<Command> {
        Command::ALL
            .into_iter()
            .filter(|c| c.families().contains(&family))
            .collect()
    }

    /// Make `spec` and `data` read `u` as this command. An error names the families that accept
    /// it and the commands the model's family accepts.
    pub fn apply(self, spec: &mut PlantSpec, data: &mut Dataset) -> anyhow::Result<()> {
        let family = spec.family;
        if !self.families().contains(&family) {
            let names = |list: Vec<&str>| list.join(", ");
            anyhow::bail!(
                "--command {}: not a command of {family}; {} accept it ({family} takes {})",
                self.name(),
                names(self.families().iter().map(|f| f.name()).collect()),
                names(
                    Command::accepted_by(family)
                        .into_iter()
                        .map(Command::name)
                        .collect()
                )
            );
        }
        let unit = match (self, family) {
            (Command::Force, _) => CommandUnit::Newton,
            (Command::Torque, _) => CommandUnit::NewtonMetre,
            (Command::Duty, _) => CommandUnit::Duty,
            (Command::Voltage, _) => CommandUnit::Volt,
            (Command::Current, Family::LinearAxis) => CommandUnit::Newton,
            (Command::Current, Family::MotorGear) => {
                // An imposed armature current is a motor torque `K_T u`, held over the sample
                // as the amplifier holds it.
                let kt = spec
                    .get("motor_gear.torque_constant_nm_per_a")
                    .unwrap_or(f64::NAN);
                for u in &mut data.input {
                    *u *= kt;
                }
                CommandUnit::NewtonMetre
            }
            (Command::Current, _) => {
                // The coil's current is imposed: it is the measured current of the balance.
                data.current = Some(data.input.clone());
                CommandUnit::Volt
            }
        };
        spec.set_command(unit)
            .map_err(|e| anyhow::anyhow!("--command {}: {e}", self.name()))
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> Dataset {
        Dataset {
            origin: "r.csv".into(),
            time: vec![0.0, 1e-3, 2e-3],
            input: vec![0.1, -0.2, 0.3],
            output: vec![0.0; 3],
            supply: None,
            current: Some(vec![9.0; 3]),
        }
    }

    #[test]
    fn each_command_sets_the_unit_its_families_take() {
        for family in Family::ALL {
            for c in Command::accepted_by(family) {
                let mut spec = PlantSpec::new(family);
                let mut d = record();
                c.apply(&mut spec, &mut d)
                    .unwrap_or_else(|e| panic!("{c} on {family}: {e}"));
                let want = match (c, family) {
                    (Command::Torque, _) | (Command::Current, Family::MotorGear) => {
                        CommandUnit::NewtonMetre
                    }
                    (Command::Duty, _) => CommandUnit::Duty,
                    (Command::Force, _) | (Command::Current, Family::LinearAxis) => {
                        CommandUnit::Newton
                    }
                    _ => CommandUnit::Volt,
                };
                assert_eq!(spec.command, want, "{c} on {family}");
                // A solenoid's current command is the current the balance uses, a gear's the
                // motor torque `K_T u`; others leave the record.
                let current = if c == Command::Current && family == Family::Solenoid {
                    d.input.clone()
                } else {
                    vec![9.0; 3]
                };
                assert_eq!(d.current, Some(current), "{c} on {family}");
                let kt = if c == Command::Current && family == Family::MotorGear {
                    spec.get("motor_gear.torque_constant_nm_per_a")
                        .expect("K_T")
                } else {
                    1.0
                };
                let want_u: Vec<f64> = record().input.iter().map(|u| u * kt).collect();
                assert_eq!(d.input, want_u, "{c} on {family}");
            }
        }
        // Every command has a family, every family a command.
        assert!(Command::ALL.iter().all(|c| !c.families().is_empty()));
        assert!(Family::ALL
            .iter()
            .all(|f| !Command::accepted_by(*f).is_empty()));
    }

    #[test]
    fn a_command_of_another_family_names_those_that_take_it() {
        let mut spec = PlantSpec::new(Family::Solenoid);
        let err = Command::Torque
            .apply(&mut spec, &mut record())
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "--command torque: not a command of solenoid; motor_gear accept it \
             (solenoid takes voltage, current)"
        );
        let err = Command::Duty
            .apply(&mut PlantSpec::new(Family::MotorGear), &mut record())
            .unwrap_err()
            .to_string();
        assert!(err.contains("pneumatic accept it"), "{err}");
        assert!(
            err.contains("(motor_gear takes torque, voltage, current)"),
            "{err}"
        );
    }

    #[test]
    fn a_torque_command_renames_the_command_valued_keys() {
        let mut spec = PlantSpec::new(Family::MotorGear);
        spec.add_effect(crate::physics::EffectKind::Deadzone)
            .expect("effect");
        Command::Torque
            .apply(&mut spec, &mut record())
            .expect("motor_gear takes a torque");
        assert!(spec.get("deadzone.threshold_nm").is_some());
        assert!(spec.get("deadzone.threshold_v").is_none());
    }
}
