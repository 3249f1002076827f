//! The reference configurations and plant files, compiled into the binaries: `actuator demo`,
//! `actuator sim --family F` and the benches run from any directory and after `cargo install`,
//! where `config/` is not at hand. A file named on the command line always wins.

use crate::daemon::config::{Config, ConfigError};
use crate::physics::{Family, PhysicsError, Plant, PlantSpec};
use std::path::{Path, PathBuf};

/// One built-in file: the path it has in the sources (its name in messages) and its text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Builtin {
    pub path: &'static str,
    pub text: &'static str,
}

macro_rules! builtin {
    ($path:literal) => {
        Builtin {
            path: $path,
            text: include_str!(concat!("../", $path)),
        }
    };
}

/// The controller configuration shipped for a plant family.
pub fn config(family: Family) -> Builtin {
    match family {
        Family::Solenoid => builtin!("config/solenoid.toml"),
        Family::Pneumatic => builtin!("config/pneumatic.toml"),
        Family::LinearAxis => builtin!("config/linear_axis.toml"),
        Family::MotorGear => builtin!("config/motor_gear.toml"),
    }
}

/// The plant file shipped for a plant family.
pub fn plant(family: Family) -> Builtin {
    match family {
        Family::Solenoid => builtin!("config/plants/solenoid.toml"),
        Family::Pneumatic => builtin!("config/plants/pneumatic.toml"),
        Family::LinearAxis => builtin!("config/plants/linear_axis.toml"),
        Family::MotorGear => builtin!("config/plants/motor_gear.toml"),
    }
}

/// The plant a simulated CiA 402 drive runs when none is named: the linear axis commanded with
/// the force the drive applies (`config/plants/linear_axis_drive.toml`).
pub fn drive_plant() -> Builtin {
    builtin!("config/plants/linear_axis_drive.toml")
}

/// Where a configuration or plant comes from: a file the user named, or a built-in one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    File(PathBuf),
    Builtin(Builtin),
}

impl Source {
    /// The user's file when given, else the built-in one.
    pub fn or_builtin(path: Option<PathBuf>, builtin: Builtin) -> Self {
        match path {
            Some(p) => Source::File(p),
            None => Source::Builtin(builtin),
        }
    }

    /// The name used in messages: the file's path, or the source path with "(built in)".
    pub fn name(&self) -> String {
        match self {
            Source::File(p) => p.display().to_string(),
            Source::Builtin(b) => format!("{} (built in)", b.path),
        }
    }

    /// The path errors are reported against (relative paths inside a built-in configuration
    /// are taken from the source folder they have in the repository).
    pub fn path(&self) -> PathBuf {
        match self {
            Source::File(p) => p.clone(),
            Source::Builtin(b) => PathBuf::from(b.path),
        }
    }

    /// Read, parse and validate as a controller configuration.
    pub fn config(&self) -> Result<Config, ConfigError> {
        match self {
            Source::File(p) => Config::load(p),
            Source::Builtin(b) => Config::from_toml(b.text, Path::new(&self.name())),
        }
    }

    /// Read as a plant description.
    pub fn plant_spec(&self) -> Result<PlantSpec, PhysicsError> {
        match self {
            Source::File(p) => crate::physics::load_spec(p),
            Source::Builtin(b) => PlantSpec::from_toml(b.text, &self.name()),
        }
    }

    /// Read and build the plant.
    pub fn plant(&self) -> Result<Box<dyn Plant>, PhysicsError> {
        self.plant_spec()?.build_named(&self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_is_the_shipped_file_and_loads() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        for family in Family::ALL {
            for b in [config(family), plant(family)] {
                let on_disk = std::fs::read_to_string(root.join(b.path)).expect("shipped file");
                assert_eq!(on_disk, b.text, "{}", b.path);
            }
            let c = Source::Builtin(config(family)).config().expect("config");
            assert_eq!(c.axis.len(), 1, "{family}");
            let p = Source::Builtin(plant(family)).plant().expect("plant");
            assert_eq!(p.family(), family);
        }
        let drive = drive_plant();
        let on_disk = std::fs::read_to_string(root.join(drive.path)).expect("shipped file");
        assert_eq!(on_disk, drive.text, "{}", drive.path);
        let spec = Source::Builtin(drive).plant_spec().expect("drive plant");
        assert_eq!(spec.command, crate::physics::CommandUnit::Newton);
    }

    #[test]
    fn a_file_named_by_the_user_wins_and_errors_name_it() {
        let s = Source::or_builtin(
            Some(PathBuf::from("/nonexistent/x.toml")),
            config(Family::Solenoid),
        );
        let e = s.config().expect_err("no such file").to_string();
        assert!(e.contains("/nonexistent/x.toml"), "{e}");
        let b = Source::or_builtin(None, plant(Family::Pneumatic));
        assert_eq!(b.name(), "config/plants/pneumatic.toml (built in)");
    }
}
