//! The configuration reference (`docs/configuration.md`, printed by `actuator config-doc`):
//! every key of every declared section with its kind, unit, range, default, access, values and
//! documentation, and the dictionary entry it gets, read from the declarations and from the
//! dictionary built for a configuration. Nothing in it is written by hand, so it cannot say
//! other than the code; a test compares the committed file with what this renders.

use std::fmt::Write;

use super::config::{
    AdaptiveFrictionSection, AxisConfig, BusConfig, CommandKind, Config, ControllerSection,
    CorrectionSection, CycleConfig, DitherSection, FaultReactionsSection,
    FrictionCompensationSection, LearnedTableSection, LimitsSection, NodeConfig, ObserverSection,
    ParameterEstimationSection, PneumaticAdaptiveSection, RecordConfig, ScheduleSection,
    SetpointStep, StateConfig,
};
use super::dictionary;
use super::profile_config::{Cia401Section, Cia402Section, HomingSection};
use crate::canopen::od::{markdown_table, BuildError, Entry, ObjectDictionary};
use crate::device::objects::MAX_AXES;
use crate::param::{
    Access, Declared, Kind, ParamSpec, COMMAND_PER_M_UNIT, COMMAND_UNIT, FORCE_PER_COMMAND_UNIT,
};
use crate::param_key;
use crate::supervise::SetpointTimeoutSection;

/// Whether key `name` of a section is given in a configuration: `None` when the section is not
/// there at all.
type Presence = Box<dyn Fn(&Config, &str) -> Option<bool>>;

/// Where a section's entries are in the dictionary.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Place {
    /// In no axis' block: a node-wide section.
    Node,
    /// In the axis' block, in the objects of the axis itself (`axis<N>`, `axis<N>_setpoint`):
    /// `[[axis]]`'s own keys.
    Axis,
    /// In the object named after the section's key in `[[axis]]` (`axis<N>_limits`).
    AxisSection(&'static str),
}

/// One declared section as the reference shows it.
struct Section {
    /// The TOML header: `[bus]`, `[[axis]]`, `[axis.limits]`.
    header: String,
    place: Place,
    doc: &'static str,
    params: &'static [ParamSpec],
    default_text: fn(&str) -> Option<String>,
    present: Presence,
}

fn section<S: Declared>(header: String, place: Place, present: Presence) -> Section {
    Section {
        header,
        place,
        doc: S::DOC,
        params: S::PARAMS,
        default_text: S::default_text,
        present,
    }
}

/// A node-wide section, `[key]` of the file.
fn node<S: Declared>(key: &'static str) -> Section {
    section::<S>(format!("[{key}]"), Place::Node, Box::new(|_, _| None))
}

/// A section of the axis, `[axis.key]`, as the first axis of a configuration has it.
fn axis<S: Declared + 'static>(key: &'static str, get: fn(&AxisConfig) -> Option<&S>) -> Section {
    section::<S>(
        format!("[{}.{key}]", param_key!(Config, axis)),
        Place::AxisSection(key),
        Box::new(move |c, name| c.axis.first().and_then(get).map(|s| s.present(name))),
    )
}

/// Every declared section, in the order of the file: the node-wide ones, then `[[axis]]` and
/// the sections it is made of, in the order it declares them.
fn sections() -> Vec<Section> {
    let mut setpoints =
        axis::<SetpointStep>(param_key!(AxisConfig, setpoints), |a| a.setpoints.first());
    setpoints.header = format!(
        "[[{}.{}]]",
        param_key!(Config, axis),
        param_key!(AxisConfig, setpoints)
    );
    vec![
        node::<BusConfig>(param_key!(Config, bus)),
        node::<NodeConfig>(param_key!(Config, node)),
        node::<CycleConfig>(param_key!(Config, cycle)),
        node::<RecordConfig>(param_key!(Config, record)),
        node::<StateConfig>(param_key!(Config, state)),
        section::<AxisConfig>(
            format!("[[{}]]", param_key!(Config, axis)),
            Place::Axis,
            Box::new(|c, name| c.axis.first().map(|a| a.present(name))),
        ),
        axis::<ControllerSection>(param_key!(AxisConfig, controller), |a| Some(&a.controller)),
        axis::<FrictionCompensationSection>(param_key!(AxisConfig, friction_compensation), |a| {
            a.friction_compensation.as_ref()
        }),
        axis::<AdaptiveFrictionSection>(param_key!(AxisConfig, adaptive_friction), |a| {
            a.adaptive_friction.as_ref()
        }),
        axis::<DitherSection>(param_key!(AxisConfig, dither), |a| a.dither.as_ref()),
        axis::<CorrectionSection>(param_key!(AxisConfig, correction), |a| {
            a.correction.as_ref()
        }),
        axis::<ScheduleSection>(param_key!(AxisConfig, schedule), |a| a.schedule.as_ref()),
        axis::<PneumaticAdaptiveSection>(param_key!(AxisConfig, pneumatic_adaptive), |a| {
            a.pneumatic_adaptive.as_ref()
        }),
        axis::<ObserverSection>(param_key!(AxisConfig, observer), |a| a.observer.as_ref()),
        axis::<ParameterEstimationSection>(param_key!(AxisConfig, parameter_estimation), |a| {
            a.parameter_estimation.as_ref()
        }),
        axis::<FaultReactionsSection>(param_key!(AxisConfig, fault_reactions), |a| {
            a.fault_reactions.as_ref()
        }),
        axis::<LearnedTableSection>(param_key!(AxisConfig, learned_table), |a| {
            a.learned_table.as_ref()
        }),
        axis::<LimitsSection>(param_key!(AxisConfig, limits), |a| Some(&a.limits)),
        axis::<SetpointTimeoutSection>(param_key!(AxisConfig, setpoint_timeout), |a| {
            a.setpoint_timeout.as_ref()
        }),
        setpoints,
        axis::<Cia402Section>(param_key!(AxisConfig, cia402), |a| a.cia402.as_ref()),
        // Its keys are restart-only: no dictionary entries to look up under this key.
        axis::<HomingSection>("cia402.homing", |a| {
            a.cia402.as_ref().and_then(|c| c.homing.as_ref())
        }),
        axis::<Cia401Section>(param_key!(AxisConfig, cia401), |a| a.cia401.as_ref()),
    ]
}

/// The reference for every declared section, with the dictionary entries of the first axis of
/// `config` (named `source` in the text), and the whole dictionary of `config`.
pub fn render(config: &Config, source: &str) -> Result<String, BuildError> {
    let od = dictionary::build(config)?;
    let sections = sections();
    let mut out = String::new();
    let _ = write!(
        out,
        "# Configuration reference\n\n\
         <!-- Rendered by `actuator config-doc` from the declarations in the sources: do not \
         edit; `cargo run --bin actuator -- config-doc > docs/configuration.md` renders it \
         again. -->\n\n\
         Every key of the daemon's configuration file, as its section declares it in the \
         sources (`declare_section!`, see [architecture.md](architecture.md)): the TOML keys, \
         their defaults and range checks, the dictionary entries and the SDO writes all come \
         from those declarations, and so does this page. Dictionary entries are those of axis \
         0 of {source}; `actuator config-doc --config FILE` renders them for another \
         configuration. Rules between keys (a minimum below its maximum, the safe command \
         within the output limits, a section needing another) are checked when the file is \
         loaded and named in the error; they are not listed here.\n\n"
    );
    out.push_str(&legend());
    out.push_str("\n## Node-wide sections\n\n");
    for s in sections.iter().filter(|s| s.place == Place::Node) {
        render_section(&mut out, s, &sections, config, &od);
    }
    let _ = write!(
        out,
        "## The axes\n\nOne `[[{}]]` per axis, at most {MAX_AXES}.\n\n",
        param_key!(Config, axis)
    );
    for s in sections.iter().filter(|s| s.place != Place::Node) {
        render_section(&mut out, s, &sections, config, &od);
    }
    let _ = write!(
        out,
        "## The dictionary\n\nEvery entry of the dictionary of {source}, as `actuator eds` \
         describes it for CANopen tools. Besides the entries of the keys above: the CiA 301 \
         communication objects (1017h `producer_heartbeat_time` is `[{node}] {heartbeat}` in \
         ms, and writable in any state; 1016h shows each axis' `{limits}.{timeout}`, read-only), \
         the axis' name, actuator node id, command kind and live setpoint, whether its friction \
         compensation is enabled, and what the axes counted, learned and estimated.\n\n{}",
        markdown_table(&od),
        node = param_key!(Config, node),
        heartbeat = param_key!(NodeConfig, heartbeat_period_s),
        limits = param_key!(AxisConfig, limits),
        timeout = param_key!(LimitsSection, heartbeat_timeout_s),
    );
    Ok(out)
}

/// What each column says.
fn legend() -> String {
    let units: Vec<String> = CommandKind::ALL
        .iter()
        .map(|c| {
            let unit = if c.unit().is_empty() {
                "none"
            } else {
                c.unit()
            };
            format!("{unit} for `{}`", c.name())
        })
        .collect();
    format!(
        "Columns:\n\n\
         - **kind**: a real, a count (a whole number), a flag (`true` or `false`), an array of \
         reals, a path (relative to the configuration file), text, one of a few named values \
         (a choice), or a table of its own (a section below).\n\
         - **unit**: SI. `{COMMAND_UNIT}` is the axis' command unit, set by its `command` key \
         ({}); `{COMMAND_PER_M_UNIT}` is that unit per metre of error, \
         `{FORCE_PER_COMMAND_UNIT}` the drive's force per command unit.\n\
         - **range**: what the value must be, as an error words it; the values of a choice.\n\
         - **default**: the value a key left out takes; *required* keys have none; an \
         *optional* key left out is not used (a limit left out is not watched).\n\
         - **access**: every key changes with a reload (SIGHUP), except what the node is \
         built around (the bus, the node ids, an axis' `command` and `profile`, the cycle \
         period), which only a restart changes. *SDO* keys can also be written over SDO while \
         the node is pre-operational; *read-only* keys are shown in the dictionary but not \
         written there.\n\
         - **entry (axis 0)**: `index:subindex` and name of the key's dictionary entry (an \
         array shown point by point has one entry per point).\n",
        units.join(", ")
    )
}

fn render_section(
    out: &mut String,
    s: &Section,
    sections: &[Section],
    config: &Config,
    od: &ObjectDictionary,
) {
    let _ = writeln!(out, "### `{}`\n", s.header);
    // A section's comment opens with its header, which the heading already shows.
    let doc = text(s.doc);
    let doc = match doc.strip_prefix(&format!("`{}`: ", s.header)) {
        Some(rest) => capitalised(rest),
        None => doc,
    };
    if !doc.is_empty() {
        let _ = writeln!(out, "{doc}\n");
    }
    out.push_str(
        "| key | kind | unit | range | default | access | entry (axis 0) | documentation |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for p in s.params {
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | {} | {} | {} | {} | {} |",
            p.name,
            kind(p, s, sections),
            cell(p.unit),
            cell(&range(p)),
            default(p, s),
            access(p.access),
            entries(p, s, config, od),
            cell(&documentation(p)),
        );
    }
    out.push('\n');
}

fn kind(p: &ParamSpec, s: &Section, sections: &[Section]) -> String {
    let kind = match p.kind {
        Kind::Real => "real".to_string(),
        Kind::Count => "count".to_string(),
        Kind::Array if p.points.is_empty() => "array".to_string(),
        Kind::Array => format!("array, at most {} points", p.points.len()),
        Kind::Flag => "flag".to_string(),
        Kind::Path => "path".to_string(),
        Kind::Text => "text".to_string(),
        Kind::Choice => "choice".to_string(),
        Kind::Table => {
            let own = (s.place == Place::Axis)
                .then(|| {
                    sections
                        .iter()
                        .find(|t| t.place == Place::AxisSection(p.name))
                })
                .flatten();
            match own {
                Some(t) => format!("table: [`{}`](#{})", t.header, anchor(&t.header)),
                None => "table".to_string(),
            }
        }
    };
    if p.optional {
        format!("{kind}, optional")
    } else {
        kind
    }
}

/// The anchor a Markdown renderer gives the heading `` `header` ``: lower case, punctuation
/// other than `-` and `_` dropped.
fn anchor(header: &str) -> String {
    header
        .chars()
        .filter(|c| c.is_alphanumeric() || *c == '-' || *c == '_')
        .flat_map(char::to_lowercase)
        .collect()
}

fn range(p: &ParamSpec) -> String {
    let mut range = match p.kind {
        Kind::Real | Kind::Count => p.range_text(),
        Kind::Array => format!("each {}", p.range_text()),
        Kind::Choice => p.choices_text(),
        Kind::Flag | Kind::Path | Kind::Text | Kind::Table => String::new(),
    };
    if p.command_bound {
        range.push_str("; its entry within ±1 for a duty, ±1000 otherwise");
    }
    if let Some(absent) = p.absent {
        let _ = write!(range, "; left out, its entry shows `{absent:?}`");
    }
    range
}

fn default(p: &ParamSpec, s: &Section) -> String {
    match (s.default_text)(p.name) {
        Some(text) if text.is_empty() => "empty".to_string(),
        Some(text) => format!("`{}`", cell(&text)),
        None if p.optional => "*optional*".to_string(),
        None => "*required*".to_string(),
    }
}

fn access(access: Access) -> &'static str {
    match access {
        Access::Restart => "reload",
        Access::PreOperational => "reload; SDO",
        Access::ReadOnly => "reload; read-only",
    }
}

/// The entries key `p` has for axis 0: one, one per point, or none for a key the dictionary
/// does not carry, a section the configuration leaves out or points it does not give.
fn entries(p: &ParamSpec, s: &Section, config: &Config, od: &ObjectDictionary) -> String {
    if p.access == Access::Restart {
        return String::new();
    }
    let given = (s.present)(config, p.name);
    let object = match s.place {
        Place::Node => None,
        Place::Axis => Some(None),
        Place::AxisSection(key) => Some(Some(format!("axis0_{key}"))),
    };
    let Some(object) = object else {
        return String::new();
    };
    let names: Vec<&str> = if p.points.is_empty() {
        vec![p.name]
    } else {
        p.points.to_vec()
    };
    let found: Vec<&Entry> = od
        .objects()
        .iter()
        .filter(|o| o.axis == Some(0) && object.as_ref().is_none_or(|name| o.name == *name))
        .flat_map(|o| od.object_entries(o))
        .filter(|e| names.contains(&e.name))
        .collect();
    // A key left out has an entry only where it declares what the entry shows meanwhile (an
    // infinite limit); a read-only array has entries for the points it has.
    match (given, found.is_empty()) {
        (None, _) => "section not configured".to_string(),
        (Some(false), _) if p.absent.is_none() => "not given".to_string(),
        (Some(_), true) => String::new(),
        (Some(_), false) => found
            .iter()
            .map(|e| format!("`{}` `{}`", e.id, e.name))
            .collect::<Vec<_>>()
            .join("<br>"),
    }
}

/// The field's own comment where it has one, else the dictionary's line.
fn documentation(p: &ParamSpec) -> String {
    let details = text(p.details);
    if details.is_empty() {
        p.doc.to_string()
    } else {
        details
    }
}

/// A documentation comment as one paragraph: its lines trimmed and joined, an intra-doc link's
/// brackets dropped.
fn text(comment: &str) -> String {
    let words: Vec<&str> = comment
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    words.join(" ").replace("[`", "`").replace("`]", "`")
}

fn capitalised(text: &str) -> String {
    let mut chars = text.chars();
    match chars.next() {
        Some(first) => first.to_uppercase().chain(chars).collect(),
        None => String::new(),
    }
}

/// A table cell: a `|` would end it.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_section_of_the_axis_is_in_the_reference() {
        let sections = sections();
        for p in AxisConfig::PARAMS.iter().filter(|p| p.kind == Kind::Table) {
            assert!(
                sections
                    .iter()
                    .any(|s| s.place == Place::AxisSection(p.name)),
                "[axis.{}] has no section in the reference",
                p.name
            );
        }
    }

    #[test]
    fn anchors_are_the_headings_without_punctuation() {
        assert_eq!(
            anchor("[axis.friction_compensation]"),
            "axisfriction_compensation"
        );
        assert_eq!(anchor("[[axis.setpoints]]"), "axissetpoints");
    }
}
