//! The objects of an axis' intelligent sections: the parameters of the adaptive friction
//! compensation, the disturbance observer, the parameter-estimation diagnosis and the supply
//! schedule (each present only when the axis has it), and what the supervision has estimated
//! and learned (always present; published as `NaN` while nothing is known, 0 before the first
//! status period).
//!
//! | offset | object | access |
//! |---|---|---|
//! | 06h | adaptive friction compensation | rw in pre-operational |
//! | 07h | disturbance observer (supervision thresholds) | rw in pre-operational |
//! | 08h | parameter estimation (windows, confirmation, symptoms) | rw in pre-operational |
//! | 09h | supply schedule (points) | ro: a schedule is edited in the file (SIGHUP) |
//! | 11h | diagnosis: estimates, nominal values, symptoms, observer bands, learned cells | ro |
//!
//! Entry names are the config keys (and, for results, the names of the state file and the
//! recording), unique within an axis.

use super::daemon_objects::CommandKind;
use crate::canopen::od::EntrySpec;
use crate::canopen::od::{ObjectDictionaryBuilder, Value};
use crate::control::{AdaptiveFrictionSection, ScheduleSection};
use crate::param::{
    Access as ParamAccess, Declared, Kind, ParamSpec, COMMAND_PER_M_UNIT, COMMAND_UNIT,
    FORCE_PER_COMMAND_UNIT,
};
use crate::supervise::{ObserverSection, ParameterEstimationSection};

/// Offsets inside an axis block (see `daemon_objects::index`).
pub const ADAPTIVE_FRICTION: u16 = 0x06;
pub const OBSERVER: u16 = 0x07;
pub const PARAMETER_ESTIMATION: u16 = 0x08;
pub const SCHEDULE: u16 = 0x09;
pub const DIAGNOSIS: u16 = 0x11;

/// What an axis has of the intelligent sections.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IntelligenceParameters {
    /// `[axis.adaptive_friction]`: its entries, as declared.
    pub adaptive_friction: Option<AdaptiveFrictionSection>,
    /// `[axis.observer]`: its writable thresholds become entries, as declared.
    pub observer: Option<ObserverSection>,
    /// `[axis.parameter_estimation]`: its windows and symptom settings, as declared.
    pub estimation: Option<ParameterEstimationSection>,
    /// `[axis.schedule]`: its points, read-only, as declared.
    pub schedule: Option<ScheduleSection>,
}

/// Names of the physical parameters, as estimate and nominal entries.
pub const ESTIMATE_NAMES: [&str; 6] = [
    "estimate_current_time_constant_s",
    "estimate_damping_ratio",
    "estimate_natural_frequency_rad_per_s",
    "estimate_static_gain_m_per_v",
    "estimate_coulomb_friction_n",
    "estimate_pretension_n",
];
pub const NOMINAL_NAMES: [&str; 6] = [
    "nominal_current_time_constant_s",
    "nominal_damping_ratio",
    "nominal_natural_frequency_rad_per_s",
    "nominal_static_gain_m_per_v",
    "nominal_coulomb_friction_n",
    "nominal_pretension_n",
];
const UNITS: [&str; 6] = ["s", "", "rad/s", "m/V", "N", "N"];

/// The observer's learned bands, in the order of the diagnosis record.
pub const BAND_NAMES: [&str; 4] = [
    "observer_x4_pos_low_m",
    "observer_x4_pos_high_m",
    "observer_x4_neg_low_m",
    "observer_x4_neg_high_m",
];

/// The entries of a declared section: its parameters writable in pre-operational, with the
/// declared unit (the axis' command unit, or force per command unit, where declared so), range
/// and line of documentation, in declaration order. An array declared with points gives one
/// entry per point: every slot when writable (0 where the array is shorter), the values it has
/// when read-only. Read-only entries carry no range.
pub(super) fn declared_entries<S: Declared>(section: &S, command: CommandKind) -> Vec<EntrySpec> {
    let unit = |unit: &'static str| match unit {
        COMMAND_UNIT => command.unit(),
        COMMAND_PER_M_UNIT => command.per_m(),
        FORCE_PER_COMMAND_UNIT => command.force_per_command(),
        unit => unit,
    };
    let mut entries = Vec::new();
    for p in S::PARAMS {
        let writable = match p.access {
            ParamAccess::PreOperational => true,
            ParamAccess::ReadOnly => false,
            ParamAccess::Restart => continue,
        };
        if !p.points.is_empty() {
            for (k, name) in p.points.iter().enumerate() {
                let e = match (section.point(p.name, k), writable) {
                    (v, true) => EntrySpec::rw_preop(name, v.unwrap_or(0.0)).between(p.min, p.max),
                    (Some(v), false) => EntrySpec::ro(name, v),
                    (None, false) => break,
                };
                entries.push(e.unit(unit(p.unit)).doc(p.doc));
            }
            continue;
        }
        if let Some(e) = declared_entry(section, p, command) {
            entries.push(e.unit(unit(p.unit)).doc(p.doc));
        }
    }
    entries
}

/// The entry of one declared scalar, writable in pre-operational, within its declared range
/// (or the command's, where declared so); `None` for what the dictionary does not carry.
fn declared_entry<S: Declared>(
    section: &S,
    p: &ParamSpec,
    command: CommandKind,
) -> Option<EntrySpec> {
    let v = section.get(p.name)?;
    let side = |x: f64, f: fn(f64) -> Value| x.is_finite().then(|| f(x));
    Some(match (p.kind, p.bits) {
        (Kind::Real, _) if p.command_bound => {
            EntrySpec::rw_preop(p.name, v).between(-command.bound(), command.bound())
        }
        (Kind::Real, _) => EntrySpec::rw_preop(p.name, v).between(p.min, p.max),
        // The declared range keeps a count within its entry; a larger value shows saturated.
        (Kind::Count, 8) => EntrySpec::rw_preop(p.name, v as u8).range(
            side(p.min, |x| Value::Unsigned8(x as u8)),
            side(p.max, |x| Value::Unsigned8(x as u8)),
        ),
        (Kind::Count, _) => EntrySpec::rw_preop(p.name, v as u32).range(
            side(p.min, |x| Value::Unsigned32(x as u32)),
            side(p.max, |x| Value::Unsigned32(x as u32)),
        ),
        (Kind::Array | Kind::Flag | Kind::Path | Kind::Table | Kind::Choice | Kind::Text, _) => {
            return None
        }
    })
}

/// Add the intelligent-section objects of axis `i` (indices from `at(offset)`).
pub fn intelligence_objects(
    mut b: ObjectDictionaryBuilder,
    i: usize,
    at: impl Fn(u16) -> u16,
    p: &IntelligenceParameters,
    command: CommandKind,
) -> ObjectDictionaryBuilder {
    let axis = Some(i);
    if let Some(a) = &p.adaptive_friction {
        b = b.record(
            at(ADAPTIVE_FRICTION),
            format!("axis{i}_adaptive_friction"),
            axis,
            declared_entries(a, command),
        );
    }
    if let Some(o) = &p.observer {
        b = b.record(
            at(OBSERVER),
            format!("axis{i}_observer"),
            axis,
            declared_entries(o, command),
        );
    }
    if let Some(e) = &p.estimation {
        b = b.record(
            at(PARAMETER_ESTIMATION),
            format!("axis{i}_parameter_estimation"),
            axis,
            declared_entries(e, command),
        );
    }
    if let Some(s) = &p.schedule {
        let (_, supply) = s.variable();
        let shown = ScheduleSection::PARAMS.iter().map(|p| p.points.len()).max();
        let n = supply.len().min(shown.unwrap_or(0));
        let mut entries = vec![EntrySpec::ro("points", n as u8)];
        entries.extend(declared_entries(s, command));
        b = b.record(at(SCHEDULE), format!("axis{i}_schedule"), axis, entries);
    }
    let mut diagnosis: Vec<EntrySpec> = ESTIMATE_NAMES
        .iter()
        .zip(UNITS)
        .map(|(n, u)| {
            EntrySpec::ro(n, 0.0f64)
                .unit(u)
                .doc("from the last usable estimation window; NaN before one")
        })
        .collect();
    diagnosis.extend(NOMINAL_NAMES.iter().zip(UNITS).map(|(n, u)| {
        EntrySpec::ro(n, 0.0f64)
            .unit(u)
            .doc("configured, learned from the first windows, or restored from the state file")
    }));
    diagnosis.push(
        EntrySpec::ro("symptoms", 0u16)
            .doc("2 bits per [T_I, D, omega0, K_P, F_C, F_0], bit 0 first: 01 +, 10 -, 00 0"),
    );
    diagnosis.push(
        EntrySpec::ro("diagnosed_fault", 0u8)
            .doc("latest latched supervised fault, codes of the DBC value table; 0 none"),
    );
    diagnosis.push(EntrySpec::ro("diagnosis_confidence", 1.0f64));
    diagnosis.push(EntrySpec::ro("nominal_learned", false));
    diagnosis.extend(BAND_NAMES.iter().map(|n| {
        EntrySpec::ro(n, 0.0f64)
            .unit("m")
            .doc("learned nominal band of the observer's x4; NaN before it is learned")
    }));
    diagnosis.push(
        EntrySpec::ro("learned_table_cells", 0u32)
            .doc("operating-point cells of the learned table holding values"),
    );
    b.record(at(DIAGNOSIS), format!("axis{i}_diagnosis"), axis, diagnosis)
}

/// Symptoms as the `symptoms` entry encodes them: `+1` → 01, `-1` → 10, per parameter.
pub fn symptom_bits(symptoms: &[i8; 6]) -> u16 {
    symptoms
        .iter()
        .enumerate()
        .map(|(k, s)| match s.signum() {
            1 => 1u16 << (2 * k),
            -1 => 2u16 << (2 * k),
            _ => 0,
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symptoms_take_two_bits_each() {
        assert_eq!(symptom_bits(&[0; 6]), 0);
        assert_eq!(symptom_bits(&[1, 0, 0, 0, 0, 0]), 0b01);
        assert_eq!(symptom_bits(&[0, 1, -1, 1, 0, 0]), 0b01_10_01_00);
        assert_eq!(symptom_bits(&[0, 0, 0, 0, 0, -1]), 0b10 << 10);
    }
}
