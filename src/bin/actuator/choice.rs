//! Choices on the command line among the library's enums. The library keeps its types free of
//! command-line traits; here each gets clap's possible values (the names the library prints, with
//! a line of help each) and a parser with clap's own errors.

use actuatord::bench::rt::Load;
use actuatord::lab::{Command, FitMethod, Mode};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use std::marker::PhantomData;

/// A library enum the command line can choose from.
pub trait Named: Copy + Send + Sync + 'static {
    /// Every value, in the order the help lists them.
    fn all() -> &'static [Self];
    /// The name on the command line.
    fn name(self) -> &'static str;
    /// One line for `--help`, if the value needs one.
    fn help(self) -> Option<&'static str>;
}

/// The value parser of a [`Named`] enum.
#[derive(Clone)]
pub struct Choice<T>(PhantomData<T>);

impl<T: Named> Choice<T> {
    pub fn parser() -> Self {
        Self(PhantomData)
    }

    fn names() -> PossibleValuesParser {
        PossibleValuesParser::new(T::all().iter().map(|v| possible(*v)))
    }
}

fn possible<T: Named>(v: T) -> PossibleValue {
    let p = PossibleValue::new(v.name());
    match v.help() {
        Some(h) => p.help(h),
        None => p,
    }
}

impl<T: Named> TypedValueParser for Choice<T> {
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<T, clap::Error> {
        // clap checks the name and words the error; the match below then cannot miss.
        let name = Self::names().parse_ref(cmd, arg, value)?;
        T::all()
            .iter()
            .copied()
            .find(|v| v.name() == name)
            .ok_or_else(|| clap::Error::new(clap::error::ErrorKind::InvalidValue).with_cmd(cmd))
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(T::all().iter().map(|v| possible(*v))))
    }
}

impl Named for Mode {
    fn all() -> &'static [Self] {
        &Mode::ALL
    }
    fn name(self) -> &'static str {
        Mode::name(self)
    }
    fn help(self) -> Option<&'static str> {
        Some(match self {
            Mode::FreeRun => "Simulate the physics plant on the measured command",
            Mode::KStep => "Predict `k` samples ahead from the measured state",
            Mode::InverseDynamics => "Equation error of the balance of forces",
        })
    }
}

impl Named for FitMethod {
    fn all() -> &'static [Self] {
        &FitMethod::ALL
    }
    fn name(self) -> &'static str {
        FitMethod::name(self)
    }
    fn help(self) -> Option<&'static str> {
        Some(match self {
            FitMethod::LeastSquares => {
                "Batch least squares on the balance of forces (inverse dynamics)"
            }
            FitMethod::Recursive => {
                "Recursive least squares on the balance of forces, in time order, with forgetting"
            }
            FitMethod::OutputError => {
                "Output error: the predicted position (k-step or free run) fitted by Levenberg–Marquardt"
            }
        })
    }
}

impl Named for Load {
    fn all() -> &'static [Self] {
        &Load::ALL
    }
    fn name(self) -> &'static str {
        Load::name(self)
    }
    fn help(self) -> Option<&'static str> {
        match self {
            Load::None => None,
            Load::Cpu => Some("A busy thread per core"),
            Load::CanFlood => Some("Unrelated frames sent as fast as one thread can"),
        }
    }
}

impl Named for Command {
    fn all() -> &'static [Self] {
        &Command::ALL
    }
    fn name(self) -> &'static str {
        Command::name(self)
    }
    fn help(self) -> Option<&'static str> {
        Some(match self {
            Command::Force => "A force in N (linear_axis)",
            Command::Torque => "A motor torque in N·m: a servo drive in torque mode (motor_gear)",
            Command::Voltage => {
                "A terminal voltage in V, limited by the supply; a solenoid's only pulls (linear_axis, solenoid, motor_gear)"
            }
            Command::Duty => "A signed valve duty in [-1, 1] (pneumatic)",
            Command::Current => {
                "The current of a current-mode amplifier in A (linear_axis, solenoid, motor_gear)"
            }
        })
    }
}
