//! The tuning of one axis: the controller designed on the identified model (the slower
//! direction, the other checked), its robustness over the fitted intervals, the friction
//! compensation and its adaptation, the observer and the parameter estimation, the supply
//! schedule; each changed value with its origin, each value kept with the reason.

use std::fmt;
use std::path::Path;

use super::design::{analyse, command_response, goal_poles, place, Analysis, Controller};
use super::edit::{round_sig, Change, Editor, Kept};
use super::fitted::Fitted;
use super::keys::*;
use super::plant::{
    corners, design_parameters, drive_damping, flexible, flexible_with_contact, AxisModel,
    Direction,
};
use crate::daemon::config::{
    AdaptiveFrictionSection, AxisConfig, CommandKind, Config, ControllerSection,
    FrictionCompensationSection, ObserverSection, ParameterEstimationSection, ScheduleSection,
};
use crate::param_key;
use crate::physics::effects::Viscous;
use crate::physics::Family;

// The sections tune writes, named by the configuration's fields.
const CONTROLLER: &str = param_key!(AxisConfig, controller);
const FRICTION: &str = param_key!(AxisConfig, friction_compensation);
const ADAPTIVE: &str = param_key!(AxisConfig, adaptive_friction);
const OBSERVER: &str = param_key!(AxisConfig, observer);
const ESTIMATION: &str = param_key!(AxisConfig, parameter_estimation);
const SCHEDULE: &str = param_key!(AxisConfig, schedule);
/// The table of the axes, `[[axis]]`.
const AXIS: &str = param_key!(Config, axis);

/// `axis.<section>.<first>, <second>, ...`: keys of one section as the report names them; the
/// section alone without keys.
pub(super) fn keys(section: &str, names: &[&str]) -> String {
    match names.split_first() {
        None => format!("{AXIS}.{section}"),
        Some((first, rest)) => rest
            .iter()
            .fold(format!("{AXIS}.{section}.{first}"), |s, n| {
                format!("{s}, {n}")
            }),
    }
}

/// `[axis.<section>]`: one section as a table header, the way the messages name it.
pub(super) fn table(section: &str) -> String {
    format!("[{}]", keys(section, &[]))
}

/// The design goal: a dominant closed-loop pair of natural frequency `bandwidth` and damping
/// `damping`, the other poles `fast` times faster.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Goal {
    /// rad/s; `None`: the largest the drive and the sampling allow (see [`tune`]).
    pub bandwidth_rad_s: Option<f64>,
    pub damping: f64,
    pub fast: f64,
}

impl Default for Goal {
    fn default() -> Self {
        Goal {
            bandwidth_rad_s: None,
            damping: 1.0,
            fast: 3.0,
        }
    }
}

impl std::str::FromStr for Goal {
    type Err = String;

    /// `bandwidth=30,damping=0.9,fast=3` (any of them; rad/s for the bandwidth).
    fn from_str(s: &str) -> Result<Self, String> {
        let mut g = Goal::default();
        for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (k, v) = part
                .split_once('=')
                .ok_or_else(|| format!("--goal: expected key=value, got {part:?}"))?;
            let v: f64 = v
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && *v > 0.0)
                .ok_or_else(|| format!("--goal: {k} must be a positive number, got {v:?}"))?;
            match k.trim() {
                "bandwidth" | "bandwidth_rad_s" => g.bandwidth_rad_s = Some(v),
                "damping" => g.damping = v,
                "fast" => g.fast = v,
                other => {
                    return Err(format!(
                        "--goal: unknown key {other:?}, expected bandwidth, damping or fast"
                    ))
                }
            }
        }
        Ok(g)
    }
}

/// What `tune` is asked.
#[derive(Debug, Clone, PartialEq)]
pub struct TuneOptions {
    pub goal: Goal,
    /// Largest half-width of a design parameter's 95 % interval, relative to its value.
    pub max_spread: f64,
    /// Axis by name; the first one when `None`.
    pub axis: Option<String>,
}

impl Default for TuneOptions {
    fn default() -> Self {
        TuneOptions {
            goal: Goal::default(),
            max_spread: 0.25,
            axis: None,
        }
    }
}

/// The design on one direction's model.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionDesign {
    pub direction: Direction,
    pub analysis: Analysis,
}

/// The design over every corner of the fitted intervals.
#[derive(Debug, Clone, PartialEq)]
pub struct Robustness {
    /// Corners checked (both directions each).
    pub corners: usize,
    pub parameters: Vec<String>,
    pub spectral_radius_max: f64,
    pub gain_margin_min: Option<f64>,
    pub phase_margin_min_deg: Option<f64>,
    pub overshoot_max: f64,
}

/// The outcome: the tuned file's text and everything behind it.
#[derive(Debug, Clone, PartialEq)]
pub struct Tuning {
    pub text: String,
    pub family: Family,
    pub model: AxisModel,
    pub period_s: f64,
    pub goal: Goal,
    pub bandwidth_rad_s: f64,
    /// Why this bandwidth (the goal, or the limit that set it).
    pub bandwidth_reason: String,
    pub design_direction: Direction,
    pub controller: Controller,
    pub directions: Vec<DirectionDesign>,
    pub robustness: Robustness,
    /// The design on the flexible model of a geared drive (motor_gear), in contact.
    pub flexible: Option<Analysis>,
    /// The smallest share of the contact's stiffness (of [`CONTACT_SHARES`], from full contact
    /// down) at which the loop on the flexible model is still stable.
    pub contact_stable_down_to: Option<f64>,
    /// Start values of the friction compensation per direction, in command units.
    pub friction_start: Option<[f64; 2]>,
    pub changes: Vec<Change>,
    pub kept: Vec<Kept>,
}

fn largest_step(config: &Config, axis: usize) -> Option<f64> {
    let a = &config.axis[axis];
    let mut last = a.initial_setpoint_m;
    let mut largest: f64 = 0.0;
    for s in &a.setpoints {
        largest = largest.max((s.position_m - last).abs());
        last = s.position_m;
    }
    (largest > 0.0).then_some(largest)
}

/// Least gain margin, and phase margin in degrees, the design keeps on a geared drive's flexible
/// model (the classical 6 dB and 30°): the rigid model it is placed on leaves out the shaft's
/// and the contact's modes.
pub const FLEXIBLE_GAIN_MARGIN: f64 = 2.0;
pub const FLEXIBLE_PHASE_MARGIN_DEG: f64 = 30.0;

/// Shares of the gear contact's stiffness the design is checked at, from full contact down:
/// the describing function of the play's dead zone (see `plant::flexible_with_contact`).
pub const CONTACT_SHARES: [f64; 8] = [1.0, 0.8, 0.6, 0.4, 0.2, 0.1, 0.05, 0.02];

/// Safety factor `α` of a friction compensation `tune` adds (the value of every configuration
/// of the project: a fifth of the friction is left to the integral part).
pub const NEW_COMPENSATION_ALPHA: f64 = 0.8;

/// Share of the output range kept free at either limit when the bandwidth is chosen.
pub const DRIVE_RESERVE: f64 = 0.1;

/// The largest bandwidth whose design keeps the command inside the drive's limits on the
/// configured tour, and at most `0.1 / T0`.
fn drive_limited_bandwidth(
    model: &AxisModel,
    config: &Config,
    axis: usize,
    goal: Goal,
    period_s: f64,
) -> Result<(f64, String), String> {
    let a = &config.axis[axis];
    let (u_min, u_max) = (a.controller.output_min, a.controller.output_max);
    let k = model.gain[0].min(model.gain[1]);
    // The command that holds the axis at a position against its spring.
    let hold = |y: f64| (model.stiffness * y + model.pretension) / k;
    let positions: Vec<f64> = std::iter::once(a.initial_setpoint_m)
        .chain(a.setpoints.iter().map(|s| s.position_m))
        .collect();
    if let Some(y) = positions
        .iter()
        .find(|y| !(u_min..=u_max).contains(&hold(**y)))
    {
        return Err(format!(
            "the drive cannot hold the tour's position {y} m within [{u_min}, {u_max}] (the \
             fitted spring needs {:.3}): give the bandwidth (--goal bandwidth=...)",
            hold(*y)
        ));
    }
    // Each set-point change of the tour as the axis applies it (ramped where limited).
    let per_cycle = a
        .setpoint_rate_max_m_per_s
        .map_or(f64::INFINITY, |r| r * period_s);
    let cycles = (0.5 / period_s).ceil() as usize;
    let changes: Vec<(f64, f64)> = positions
        .windows(2)
        .map(|w| (w[0], w[1] - w[0]))
        .filter(|(_, d)| *d != 0.0)
        .collect();
    let step = largest_step(config, axis).unwrap_or(0.0);
    // The predicted command from the hold at the start of each change stays within the limits,
    // less a reserve for what the linear model does not know (friction, the fit's error).
    let reserve = DRIVE_RESERVE * (u_max - u_min);
    let (lo_u, hi_u) = (u_min + reserve, u_max - reserve);
    let fits = |w: f64| -> bool {
        changes.iter().all(|&(from, delta)| {
            let d = if delta > 0.0 {
                Direction::Positive
            } else {
                Direction::Negative
            };
            let Ok((ad, bd)) = model.linear(d).discretise(period_s) else {
                return false;
            };
            let poles = goal_poles(ad.len() - 1, w, goal.damping, goal.fast, period_s);
            let reference: Vec<f64> = (0..cycles)
                .map(|j| ((j + 1) as f64 * per_cycle).min(delta.abs()) * delta.signum())
                .collect();
            place(&ad, &bd, &poles).is_ok_and(|c| {
                command_response(&ad, &bd, &c, &reference)
                    .iter()
                    .all(|u| (lo_u..=hi_u).contains(&(hold(from) + u)))
            })
        })
    };
    let w_sample = 0.1 / period_s;
    // A rotary axis' positions are angles (config/motor_gear.toml).
    let (milli, unit) = match model.family {
        Family::MotorGear => ("mrad", "rad"),
        _ => ("mm", "m"),
    };
    let why = format!(
        "every set-point change of the tour (the largest {:.2} {milli}{}) keeps the predicted \
         command within [{lo_u:.4}, {hi_u:.4}] (the output range less {:.0} % at either end) from \
         the command that held the position before",
        step * 1e3,
        a.setpoint_rate_max_m_per_s
            .map_or(String::new(), |r| format!(" ramped at {r} {unit}/s")),
        100.0 * DRIVE_RESERVE
    );
    if fits(w_sample) {
        return Ok((
            w_sample,
            format!(
                "the largest the cycle samples ten times per time constant (w T0 = 0.1); {why}"
            ),
        ));
    }
    // Down from the sampling's limit in steps of 15 %, then bisect the last step (very low
    // bandwidths put every pole near 1, where the placement is ill-conditioned).
    let mut hi = w_sample;
    let mut lo = None;
    for _ in 0..40 {
        let w = hi * 0.85;
        if fits(w) {
            lo = Some(w);
            break;
        }
        hi = w;
    }
    let Some(mut lo) = lo else {
        return Err(format!(
            "no bandwidth down to {hi:.3} rad/s keeps the command within the drive's limits on \
             the tour: give the bandwidth (--goal bandwidth=...)"
        ));
    };
    for _ in 0..20 {
        let mid = (lo * hi).sqrt();
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok((lo, format!("the largest at which {why}")))
}

/// The axis `options.axis` names (the first without a name), with its index.
pub(super) fn chosen_axis<'c>(
    config: &'c Config,
    options: &TuneOptions,
    cfg_name: &str,
) -> anyhow::Result<(usize, &'c AxisConfig)> {
    let axis = match &options.axis {
        None => 0,
        Some(name) => config
            .axis
            .iter()
            .position(|a| &a.name == name)
            .ok_or_else(|| anyhow::anyhow!("{cfg_name}: no [[{AXIS}]] named {name:?}"))?,
    };
    let a = config
        .axis
        .get(axis)
        .ok_or_else(|| anyhow::anyhow!("{cfg_name}: no [[axis]]"))?;
    Ok((axis, a))
}

/// Tune axis `options.axis` of the configuration `config_text` (from `config_path`) on the
/// fitted model. Refuses (with the reason) a model whose design parameters' intervals are
/// wider than `options.max_spread`, or on whose intervals the design is not stable.
///
/// Without a bandwidth in the goal, the bandwidth is the largest at which
/// - the predicted command for the tour's largest set-point change (ramped where the axis
///   limits its rate), started from the command that holds the axis at any position of the
///   tour, stays within the controller's output limits: the design keeps to the drive's limits;
/// - the cycle samples the loop's time constant at least ten times: `ω T_0 ≤ 0.1`.
pub fn tune(
    fitted: &Fitted,
    config_text: &str,
    config_path: &Path,
    options: &TuneOptions,
) -> anyhow::Result<Tuning> {
    let origin = &fitted.origin;
    let cfg_name = config_path.display().to_string();
    let config = Config::from_toml(config_text, config_path)?;
    let (axis, a) = chosen_axis(&config, options, &cfg_name)?;
    let family = fitted.model.spec.family;
    match family {
        Family::Solenoid | Family::LinearAxis | Family::MotorGear => {}
        Family::Pneumatic => anyhow::bail!(
            "{origin}: a pneumatic model is tuned by tune_pneumatic (drive gains per supply point)"
        ),
    }
    anyhow::ensure!(
        a.command == CommandKind::Voltage,
        "{cfg_name}: axis {:?} is commanded by {:?}; a {family} model is designed for a voltage command",
        a.name,
        a.command
    );
    anyhow::ensure!(
        a.controller.state_space_file.is_none(),
        "{cfg_name}: axis {:?} runs a state-space controller from a file; tune writes the transfer \
         function of {} and would leave it unused",
        a.name,
        table(CONTROLLER)
    );
    // Intervals too wide to design from.
    // A viscous slope is judged against the whole damping the design sees: beside a motor's
    // back-EMF a loosely determined slope moves the loop little.
    let drive_d = drive_damping(family, &|n| fitted.get(n));
    for key in design_parameters(family) {
        let name = &key.name(family);
        if let Some(spread) = fitted.relative_spread(name) {
            let v = fitted.get(name).unwrap_or(f64::NAN);
            let (spread, of) = if key.of_effect::<Viscous>() && drive_d > 0.0 {
                (
                    spread * v.abs() / (v.abs() + drive_d),
                    format!(
                        "of the damping {:.4e} it is part of (with the drive's back-EMF)",
                        v.abs() + drive_d
                    ),
                )
            } else {
                (spread, "of its value".to_string())
            };
            if spread > options.max_spread {
                let (lo, hi) = fitted.intervals[name];
                anyhow::bail!(
                    "{origin}: {name} = {v:.4e} with the 95 % interval [{lo:.4e}, {hi:.4e}], ±{:.0} % \
                     {of}: too wide to design from (at most ±{:.0} %). Record more motion \
                     (set-point steps over the stroke, both directions) and fit again",
                    100.0 * spread,
                    100.0 * options.max_spread
                );
            }
        }
    }
    let model = AxisModel::from_fitted(fitted).map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
    anyhow::ensure!(
        model.mass > 0.0 && model.gain.iter().all(|g| *g > 0.0),
        "{origin}: mass {} and drive gain {:?} must be positive to design from",
        model.mass,
        model.gain
    );
    let period_s = config.cycle.period_s;

    // The goal's bandwidth.
    let goal = options.goal;
    let (mut bandwidth, mut bandwidth_reason) = match goal.bandwidth_rad_s {
        Some(w) => (w, "as asked (--goal)".to_string()),
        None => drive_limited_bandwidth(&model, &config, axis, goal, period_s)
            .map_err(|e| anyhow::anyhow!("{origin} with {cfg_name}: {e}"))?,
    };
    // A geared drive: the rigid model holds well below the shaft's and the contact's modes; the
    // design must keep its margins on the flexible model too.
    let flexible_plant =
        flexible(&fitted.model.spec).map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
    let mut flexible_analysis = None;
    let mut contact_stable_down_to = None;
    if let Some(fp) = &flexible_plant {
        let (af, bf) = fp.discretise(period_s)?;
        let (ar, br) = model.linear(Direction::Positive).discretise(period_s)?;
        let order = ar.len() - 1;
        let check = |w: f64| -> Option<Analysis> {
            let c = place(
                &ar,
                &br,
                &goal_poles(order, w, goal.damping, goal.fast, period_s),
            )
            .ok()?;
            Some(analyse(&af, &bf, &c, period_s))
        };
        let fine = |an: &Analysis| {
            an.spectral_radius < 1.0
                && an.gain_margin.is_some_and(|g| g >= FLEXIBLE_GAIN_MARGIN)
                && an
                    .phase_margin_deg
                    .is_some_and(|p| p >= FLEXIBLE_PHASE_MARGIN_DEG)
        };
        let first = bandwidth;
        let mut found = None;
        for _ in 0..60 {
            match check(bandwidth) {
                Some(an) if fine(&an) => {
                    found = Some(an);
                    break;
                }
                _ if goal.bandwidth_rad_s.is_some() => break,
                _ => bandwidth *= 0.95,
            }
        }
        match found {
            Some(an) => {
                if bandwidth < first {
                    bandwidth_reason = format!(
                        "the largest below {first:.1} rad/s ({bandwidth_reason}) at which the \
                         design keeps a gain margin of {FLEXIBLE_GAIN_MARGIN} and a phase margin \
                         of {FLEXIBLE_PHASE_MARGIN_DEG}° on the flexible model (shaft, gear \
                         contact)"
                    );
                }
                flexible_analysis = Some(an);
                // The play: the contact's share the loop stays stable down to.
                let c = place(
                    &ar,
                    &br,
                    &goal_poles(order, bandwidth, goal.damping, goal.fast, period_s),
                )?;
                let mut lowest = None;
                for share in CONTACT_SHARES {
                    let Some(p) = flexible_with_contact(&fitted.model.spec, share)
                        .map_err(|e| anyhow::anyhow!("{origin}: {e}"))?
                    else {
                        break;
                    };
                    let (a_s, b_s) = p.discretise(period_s)?;
                    if analyse(&a_s, &b_s, &c, period_s).spectral_radius >= 1.0 {
                        break;
                    }
                    lowest = Some(share);
                }
                contact_stable_down_to = lowest;
            }
            None => anyhow::bail!(
                "{origin}: no design at or below {first:.1} rad/s keeps a gain margin of \
                 {FLEXIBLE_GAIN_MARGIN} and a phase margin of {FLEXIBLE_PHASE_MARGIN_DEG}° on the \
                 flexible model (shaft, gear contact): ask for a lower bandwidth \
                 (--goal bandwidth=...) or hand over to `actuator design robust`"
            ),
        }
    }

    // The slower direction: the less loop gain at the goal's bandwidth.
    let design_direction = if model.has_two_directions()
        && model.linear(Direction::Negative).response(bandwidth).norm()
            < model.linear(Direction::Positive).response(bandwidth).norm()
    {
        Direction::Negative
    } else {
        Direction::Positive
    };
    let (ad, bd) = model.linear(design_direction).discretise(period_s)?;
    let order = ad.len() - 1;
    let poles = goal_poles(order, bandwidth, goal.damping, goal.fast, period_s);
    let controller = place(&ad, &bd, &poles)?;
    let mut directions = Vec::new();
    for dir in [Direction::Positive, Direction::Negative] {
        let (a_d, b_d) = model.linear(dir).discretise(period_s)?;
        directions.push(DirectionDesign {
            direction: dir,
            analysis: analyse(&a_d, &b_d, &controller, period_s),
        });
    }
    for d in &directions {
        anyhow::ensure!(
            d.analysis.spectral_radius < 1.0,
            "{origin}: the design for the {} direction leaves the {} direction unstable \
             (closed-loop pole at |z| = {:.3}); ask for a lower bandwidth (--goal bandwidth=...)",
            design_direction.name(),
            d.direction.name(),
            d.analysis.spectral_radius
        );
    }

    // Robustness over the corners of the fitted intervals.
    let names: Vec<String> = design_parameters(family)
        .iter()
        .map(|k| k.name(family))
        .collect();
    let all = corners(fitted, &names);
    let mut robustness = Robustness {
        corners: all.len(),
        parameters: all
            .first()
            .map(|c| c.iter().map(|(n, _)| n.clone()).collect())
            .unwrap_or_default(),
        spectral_radius_max: 0.0,
        gain_margin_min: None,
        phase_margin_min_deg: None,
        overshoot_max: 0.0,
    };
    for corner in &all {
        let value = |n: &str| {
            corner
                .iter()
                .find(|(c, _)| c == n)
                .map(|(_, v)| *v)
                .or_else(|| fitted.get(n))
        };
        let m = AxisModel::with_values(family, &value).map_err(|e| anyhow::anyhow!("{e}"))?;
        for dir in [Direction::Positive, Direction::Negative] {
            let (a_d, b_d) = m.linear(dir).discretise(period_s)?;
            let an = analyse(&a_d, &b_d, &controller, period_s);
            if an.spectral_radius >= 1.0 {
                anyhow::bail!(
                    "{origin}: the design is unstable within the fitted intervals ({} direction at {}: \
                     closed-loop pole at |z| = {:.3}): the intervals are too wide to design from at \
                     {bandwidth:.1} rad/s; ask for a lower bandwidth or fit on more data",
                    dir.name(),
                    corner
                        .iter()
                        .map(|(n, v)| format!("{n} = {v:.4e}"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    an.spectral_radius
                );
            }
            let r = &mut robustness;
            r.spectral_radius_max = r.spectral_radius_max.max(an.spectral_radius);
            r.overshoot_max = r.overshoot_max.max(an.overshoot());
            if let Some(g) = an.gain_margin {
                r.gain_margin_min = Some(r.gain_margin_min.map_or(g, |x: f64| x.min(g)));
            }
            if let Some(p) = an.phase_margin_deg {
                r.phase_margin_min_deg = Some(r.phase_margin_min_deg.map_or(p, |x: f64| x.min(p)));
            }
        }
    }

    // Write the configuration.
    let doc: toml_edit::DocumentMut = config_text
        .parse()
        .map_err(|e| anyhow::anyhow!("{cfg_name}: {e}"))?;
    let mut ed = Editor::new(doc, axis);
    let design_text = format!(
        "pole placement on the {} direction's model ({}), goal: {bandwidth:.1} rad/s, damping {}, other poles {}x faster, T0 = {} ms",
        design_direction.name(),
        if model.has_two_directions() {
            "the slower; the other checked"
        } else {
            "both directions alike"
        },
        goal.damping,
        goal.fast,
        period_s * 1e3
    );
    ed.set_list(
        CONTROLLER,
        param_key!(ControllerSection, q_per_m),
        &controller.q,
        10,
        &design_text,
    );
    ed.set_list(
        CONTROLLER,
        param_key!(ControllerSection, p),
        &controller.p,
        10,
        &design_text,
    );
    ed.keep(
        keys(
            CONTROLLER,
            &[
                param_key!(ControllerSection, output_min),
                param_key!(ControllerSection, output_max),
            ],
        ),
        "the drive's limits, not the model's",
    );

    // Friction compensation: levels from the identified dry friction.
    let step = &directions[design_direction as usize].analysis;
    let mut friction_start = None;
    let scale = match family {
        // The lab's linear_axis forces are per command unit: back to newtons with the
        // configured drive gain, which these data cannot determine.
        Family::LinearAxis => a
            .friction_compensation
            .as_ref()
            .map_or(1.0, |f| f.force_gain_n_per_command),
        _ => 1.0,
    };
    let k_mean = 0.5 * (model.gain[0] + model.gain[1]) * scale;
    // A Coulomb level the fit kept (collinear with the pretension or an offset on these data)
    // is not determined; the band F_C+ + F_C- is: split it evenly.
    let (pos_n, neg_n) = (&COULOMB_POS.name(family), &COULOMB_NEG.name(family));
    let split = fitted.intervals.contains_key(pos_n) != fitted.intervals.contains_key(neg_n);
    let coulomb = model
        .coulomb
        .map(|c| if split { [0.5 * (c[0] + c[1]); 2] } else { c });
    // An axis without friction compensation gets one where the fit determined the friction
    // (Isermann & Raab's `U_comp = α F_C± / K sign(e)`), with the configurations' safety factor
    // and, on a geared drive, a deadband of half the fitted play: inside it the error's sign
    // does not say on which flank of the play the gear is.
    let determined = fitted.intervals.contains_key(pos_n) || fitted.intervals.contains_key(neg_n);
    let added = match (&a.friction_compensation, coulomb) {
        (None, Some(_)) if determined => Some(FrictionCompensationSection {
            alpha: NEW_COMPENSATION_ALPHA,
            coulomb_pos_n: 0.0,
            coulomb_neg_n: 0.0,
            force_gain_n_per_command: 1.0,
            deadband_m: 0.5 * model.backlash_gap.unwrap_or(0.0),
            ..FrictionCompensationSection::neutral()
        }),
        _ => None,
    };
    if let Some(fc) = &added {
        ed.set_f64(
            FRICTION,
            param_key!(FrictionCompensationSection, alpha),
            fc.alpha,
            "the safety factor of the project's configurations (the axis had no friction \
             compensation; the fit determined its friction)",
        );
        match model.backlash_gap {
            Some(gap) => ed.set_f64(
                FRICTION,
                param_key!(FrictionCompensationSection, deadband_m),
                0.5 * gap,
                format!("half {} of {origin}", BACKLASH_GAP.name(family)),
            ),
            None => ed.keep(
                keys(
                    FRICTION,
                    &[param_key!(FrictionCompensationSection, deadband_m)],
                ),
                "0: the model has no play; raise it to the sensor's noise",
            ),
        }
    }
    match (added.as_ref().or(a.friction_compensation.as_ref()), coulomb) {
        (Some(fc), Some(c)) => {
            for (key, name, v) in [
                (
                    param_key!(FrictionCompensationSection, coulomb_pos_n),
                    pos_n,
                    c[0],
                ),
                (
                    param_key!(FrictionCompensationSection, coulomb_neg_n),
                    neg_n,
                    c[1],
                ),
            ] {
                let from = if split {
                    format!(
                        "half the friction band {pos_n} + {neg_n} of {origin} (the fit kept one \
                         level: the split between the directions is not determined){}",
                        scaled(family, scale)
                    )
                } else {
                    format!("{name} of {origin}{}", scaled(family, scale))
                };
                ed.set_f64(FRICTION, key, v * scale, from);
            }
            match family {
                Family::Solenoid => ed.set_f64(
                    FRICTION,
                    param_key!(FrictionCompensationSection, force_gain_n_per_command),
                    k_mean,
                    format!(
                        "{} x {} of {origin}",
                        SOLENOID_CURRENT_GAIN.name(family),
                        SOLENOID_FORCE_CONSTANT.name(family)
                    ),
                ),
                Family::MotorGear => ed.set_f64(
                    FRICTION,
                    param_key!(FrictionCompensationSection, force_gain_n_per_command),
                    k_mean,
                    format!(
                        "{} x {} / {} of {origin} (N·m per V at the load)",
                        MOTOR_GEAR_RATIO.name(family),
                        MOTOR_GEAR_TORQUE_CONSTANT.name(family),
                        MOTOR_GEAR_RESISTANCE.name(family)
                    ),
                ),
                _ => ed.keep(
                    keys(
                        FRICTION,
                        &[param_key!(
                            FrictionCompensationSection,
                            force_gain_n_per_command
                        )],
                    ),
                    "the lab's linear_axis balance takes the command as the force: the drive's \
                     newtons per volt are not in the data (the levels above are written with it)",
                ),
            }
            let start = [
                fc.alpha * c[0] * scale / k_mean,
                fc.alpha * c[1] * scale / k_mean,
            ];
            friction_start = Some(start);
            if added.is_none() {
                ed.keep(
                    keys(
                        FRICTION,
                        &[
                            param_key!(FrictionCompensationSection, alpha),
                            param_key!(FrictionCompensationSection, deadband_m),
                        ],
                    ),
                    "the share left to the integral part and the sensor's noise: not the model's",
                );
            }
            if a.adaptive_friction.is_some() {
                if let Some(tm) = step.time_constant_s() {
                    ed.set_f64(
                        ADAPTIVE,
                        param_key!(AdaptiveFrictionSection, model_time_constant_s),
                        tm,
                        "time to 63 % of the designed loop's predicted step (the reference model \
                         is the loop without friction)",
                    );
                }
                let most = 3.0 * start[0].max(start[1]) / fc.alpha.max(f64::MIN_POSITIVE);
                ed.set_f64(
                    ADAPTIVE,
                    param_key!(AdaptiveFrictionSection, compensation_max),
                    most,
                    "three times the identified friction in command units",
                );
                ed.keep(
                    format!("{} (start values)", keys(ADAPTIVE, &[])),
                    format!(
                        "the adaptation starts from the compensation above: {:.4} / {:.4} per \
                         direction (alpha F_C / K)",
                        start[0], start[1]
                    ),
                );
                ed.keep(
                    keys(
                        ADAPTIVE,
                        &[
                            param_key!(AdaptiveFrictionSection, adaptation_gain_per_m_s),
                            "deadbands",
                            param_key!(AdaptiveFrictionSection, settled_band_m),
                        ],
                    ),
                    "speed of learning and the sensor's noise: not the model's",
                );
            }
        }
        (Some(_), None) => ed.keep(
            keys(FRICTION, &[]),
            format!("{origin} has no coulomb friction: the levels are kept"),
        ),
        (None, Some(_)) => ed.keep(
            keys(FRICTION, &[]),
            "not configured: tune does not add sections",
        ),
        (None, None) => {}
    }

    // Observer and parameter estimation (the solenoid's model).
    if family == Family::Solenoid {
        let declared = |name: &str| -> String {
            if fitted.intervals.contains_key(name) {
                format!("{name} of {origin}")
            } else {
                format!("{name} of {origin} (declared in the model, not determined by the fit)")
            }
        };
        let name = |k: PlantKey| k.name(family);
        let declared = |k: PlantKey| declared(&name(k));
        let ki = fitted.get(&name(SOLENOID_CURRENT_GAIN)).unwrap_or(0.0);
        let kmag = fitted.get(&name(SOLENOID_FORCE_CONSTANT)).unwrap_or(0.0);
        let ti = model.lag_s.unwrap_or(0.0);
        if a.observer.is_some() {
            ed.set_f64(
                OBSERVER,
                param_key!(ObserverSection, mass_kg),
                model.mass,
                declared(SOLENOID_MASS),
            );
            ed.set_f64(
                OBSERVER,
                param_key!(ObserverSection, damping_n_s_per_m),
                0.5 * (model.damping[0] + model.damping[1]),
                format!(
                    "mean of {} and {} of {origin}",
                    name(VISCOUS_POS),
                    name(VISCOUS_NEG)
                ),
            );
            ed.set_f64(
                OBSERVER,
                param_key!(ObserverSection, spring_n_per_m),
                model.stiffness,
                declared(SPRING_STIFFNESS),
            );
            ed.set_f64(
                OBSERVER,
                param_key!(ObserverSection, force_constant_n_per_a),
                kmag,
                declared(SOLENOID_FORCE_CONSTANT),
            );
            ed.set_f64(
                OBSERVER,
                param_key!(ObserverSection, current_gain_a_per_v),
                ki,
                declared(SOLENOID_CURRENT_GAIN),
            );
            ed.set_f64(
                OBSERVER,
                param_key!(ObserverSection, current_time_constant_s),
                ti,
                declared(SOLENOID_LAG),
            );
            ed.keep(
                format!(
                    "{}, bands, warm-up",
                    keys(OBSERVER, &[param_key!(ObserverSection, poles)])
                ),
                "the observer's own design and the noise it learns its bands from",
            );
        }
        if let Some(pe) = &a.parameter_estimation {
            ed.set_f64(
                ESTIMATION,
                param_key!(ParameterEstimationSection, mass_kg),
                model.mass,
                declared(SOLENOID_MASS),
            );
            ed.set_f64(
                ESTIMATION,
                param_key!(ParameterEstimationSection, current_time_constant_s),
                ti,
                declared(SOLENOID_LAG),
            );
            // p = [T_I, D, ω0, K_P, F_C, F_0] of the model and its spread over the intervals.
            let nominal_of = |m: &AxisModel| -> [f64; 6] {
                let w0 = m.natural_frequency();
                [
                    m.lag_s.unwrap_or(0.0),
                    0.5 * (m.damping[0] + m.damping[1]) / (2.0 * m.mass * w0),
                    w0,
                    0.5 * (m.gain[0] + m.gain[1]) / m.stiffness,
                    m.coulomb.map_or(0.0, |c| 0.5 * (c[0] + c[1])),
                    m.pretension,
                ]
            };
            let p = nominal_of(&model);
            let needs: [&[PlantKey]; 6] = [
                &[SOLENOID_LAG],
                &[VISCOUS_POS, SPRING_STIFFNESS, SOLENOID_MASS],
                &[SPRING_STIFFNESS, SOLENOID_MASS],
                &[SPRING_STIFFNESS],
                &[COULOMB_POS, COULOMB_NEG],
                &[SPRING_PRETENSION],
            ];
            let undetermined: Vec<&str> = crate::supervise::PHYSICAL_NAMES
                .iter()
                .zip(needs)
                .filter(|(_, n)| n.iter().any(|k| !fitted.intervals.contains_key(&name(*k))))
                .map(|(name, _)| *name)
                .collect();
            // The spread of p over the corners of every interval the fit gave.
            let mut spread = [0.0_f64; 6];
            let every: Vec<String> = fitted.intervals.keys().cloned().collect();
            for corner in corners(fitted, &every) {
                let value = |n: &str| {
                    corner
                        .iter()
                        .find(|(c, _)| c == n)
                        .map(|(_, v)| *v)
                        .or_else(|| fitted.get(n))
                };
                if let Ok(m) = AxisModel::with_values(family, &value) {
                    for (s, (pc, pn)) in spread.iter_mut().zip(nominal_of(&m).iter().zip(p)) {
                        *s = s.max((pc - pn).abs() / pn.abs().max(f64::MIN_POSITIVE));
                    }
                }
            }
            if undetermined.is_empty() && p.iter().all(|v| v.is_finite() && *v > 0.0) {
                let mut t = toml_edit::InlineTable::new();
                for (k, v) in crate::supervise::PHYSICAL_NAMES.iter().zip(p) {
                    t.insert(*k, round_sig(v, 6).into());
                }
                ed.set(
                    ESTIMATION,
                    param_key!(ParameterEstimationSection, nominal),
                    toml_edit::Value::InlineTable(t),
                    format!("p = [T_I, D, w0, K_P, F_C, F_0] of {origin}"),
                );
                let floor: Vec<f64> = pe
                    .relative_floor
                    .iter()
                    .zip(spread)
                    .map(|(f, s)| f.max(s))
                    .collect();
                ed.set_list(
                    ESTIMATION,
                    param_key!(ParameterEstimationSection, relative_floor),
                    &floor,
                    3,
                    "the configured floor, widened to the fit's 95 % spread of each p",
                );
            } else {
                ed.keep(
                    keys(
                        ESTIMATION,
                        &[param_key!(ParameterEstimationSection, nominal)],
                    ),
                    format!(
                        "the fit did not determine {} (no interval): the nominal p is learned from \
                         the first windows in operation as configured; the fit's p would be \
                         [{}] with spreads [{}]",
                        undetermined.join(", "),
                        p.iter()
                            .map(|v| format!("{:.4e}", v))
                            .collect::<Vec<_>>()
                            .join(", "),
                        spread
                            .iter()
                            .map(|v| format!("{:.0} %", 100.0 * v))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                );
            }
            ed.keep(
                keys(
                    ESTIMATION,
                    &[param_key!(ParameterEstimationSection, fault_table)],
                ),
                "the fault-symptom table: `actuator bench fault-table` derives it for the \
                 reference solenoid (config/solenoid.toml with config/plants/solenoid.toml) only; \
                 it is not regenerated for this plant",
            );
        }
    } else {
        if a.observer.is_some() || a.parameter_estimation.is_some() {
            ed.keep(
                format!("{}, {}", keys(OBSERVER, &[]), keys(ESTIMATION, &[])),
                "models of the solenoid drive: kept",
            );
        }
    }

    // The supply schedule: gain factor (U_nom / U)^κ where the model has the supply's law.
    if let Some(s) = &a.schedule {
        match (
            s.supply_voltage_v.as_ref(),
            model.supply_exponent,
            model.supply_nominal,
            fitted.intervals.contains_key(&SUPPLY_EXPONENT.name(family)),
        ) {
            (Some(points), Some(kappa), Some(nominal), true) => {
                let factors: Vec<f64> = points.iter().map(|u| (nominal / u).powf(kappa)).collect();
                ed.set_list(
                    SCHEDULE,
                    param_key!(ScheduleSection, gain_factor),
                    &factors,
                    5,
                    format!("(U_nom / U)^kappa with supply_gain.exponent of {origin}"),
                );
            }
            _ => ed.keep(
                keys(SCHEDULE, &[]),
                format!(
                    "{origin} does not determine the supply's law (no fitted supply_gain: the \
                     record's supply did not vary, or the model lacks the effect)"
                ),
            ),
        }
    }
    ed.keep(
        format!(
            "{}, {}, [{}], [{}], [{}]",
            keys(param_key!(AxisConfig, limits), &[]),
            keys(param_key!(AxisConfig, setpoints), &[]),
            param_key!(Config, bus),
            param_key!(Config, node),
            param_key!(Config, cycle),
        ),
        "the installation's, not the model's",
    );

    let body = ed.doc.to_string();
    let header = format!(
        "# Tuned by `actuator tune` from the fitted model {origin} and {cfg_name}.\n\
         # Values marked `# tuned` are new (the comments above them describe the configuration \
         they replace);\n# `actuator tune` prints where each comes from.\n"
    );
    let text = format!("{header}{body}");
    Config::from_toml(&text, config_path).map_err(|e| {
        anyhow::anyhow!("the tuned configuration does not pass the daemon's validation: {e}")
    })?;
    Ok(Tuning {
        text,
        family,
        model,
        period_s,
        goal,
        bandwidth_rad_s: bandwidth,
        bandwidth_reason,
        design_direction,
        controller,
        directions,
        robustness,
        flexible: flexible_analysis,
        contact_stable_down_to,
        friction_start,
        changes: ed.changes,
        kept: ed.kept,
    })
}

fn scaled(family: Family, scale: f64) -> String {
    match family {
        Family::LinearAxis => format!(" (per command unit) x the configured {scale} N per command"),
        _ => String::new(),
    }
}

fn opt(v: Option<f64>, unit: &str) -> String {
    v.map_or("none".to_string(), |v| format!("{v:.3}{unit}"))
}

impl fmt::Display for Tuning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.model;
        writeln!(
            f,
            "model: {} m = {:.4e}, d = {:.4e} / {:.4e}, c = {:.4e}, K = {:.4e} / {:.4e}{}",
            self.family,
            m.mass,
            m.damping[0],
            m.damping[1],
            m.stiffness,
            m.gain[0],
            m.gain[1],
            m.lag_s
                .map_or(String::new(), |t| format!(", lag {:.3} ms", t * 1e3))
        )?;
        writeln!(
            f,
            "goal: closed-loop pair at {:.1} rad/s, damping {}, other poles {}x faster ({})",
            self.bandwidth_rad_s, self.goal.damping, self.goal.fast, self.bandwidth_reason
        )?;
        writeln!(
            f,
            "designed on the {} direction{}",
            self.design_direction.name(),
            if self.model.has_two_directions() {
                " (the slower), the other checked"
            } else {
                " (both alike)"
            }
        )?;
        writeln!(
            f,
            "{CONTROLLER}: {} = [{}], {} = [{}]",
            param_key!(ControllerSection, q_per_m),
            self.controller
                .q
                .iter()
                .map(|v| format!("{v:.6e}"))
                .collect::<Vec<_>>()
                .join(", "),
            param_key!(ControllerSection, p),
            self.controller
                .p
                .iter()
                .map(|v| format!("{v:.6}"))
                .collect::<Vec<_>>()
                .join(", ")
        )?;
        writeln!(
            f,
            "  direction  |z|max  overshoot  rise 90 %  settle 2 %  gain margin  phase margin  crossover    Ms"
        )?;
        for d in &self.directions {
            let a = &d.analysis;
            writeln!(
                f,
                "  {:<9}  {:>5.3}  {:>8.1} %  {:>9}  {:>10}  {:>11}  {:>12}  {:>9}  {:>4.2}",
                d.direction.name(),
                a.spectral_radius,
                100.0 * a.overshoot(),
                opt(a.rise_time_s().map(|t| t * 1e3), " ms"),
                opt(a.settling_time_s().map(|t| t * 1e3), " ms"),
                opt(a.gain_margin, ""),
                opt(a.phase_margin_deg, "°"),
                opt(a.crossover_rad_s, ""),
                a.sensitivity_peak
            )?;
        }
        let r = &self.robustness;
        writeln!(
            f,
            "robustness over {} corners of the fitted intervals of [{}], both directions: |z|max {:.3}, gain margin >= {}, phase margin >= {}, overshoot <= {:.1} %",
            r.corners,
            r.parameters.join(", "),
            r.spectral_radius_max,
            opt(r.gain_margin_min, ""),
            opt(r.phase_margin_min_deg, "°"),
            100.0 * r.overshoot_max
        )?;
        if let Some(a) = &self.flexible {
            writeln!(
                f,
                "on the flexible model (shaft, gear contact, in contact): |z|max {:.3}, overshoot {:.1} %, gain margin {}, phase margin {}, Ms {:.2}",
                a.spectral_radius,
                100.0 * a.overshoot(),
                opt(a.gain_margin, ""),
                opt(a.phase_margin_deg, "°"),
                a.sensitivity_peak
            )?;
        }
        if let Some(gap) = self.model.backlash_gap {
            let smallest = CONTACT_SHARES[CONTACT_SHARES.len() - 1];
            let verdict = match self.contact_stable_down_to {
                Some(s) if s <= smallest => format!(
                    "the loop on the flexible model stays stable with the contact's stiffness \
                     down to {:.0} % (the describing function of the play's dead zone): no limit \
                     cycle from the play is predicted",
                    100.0 * s
                ),
                Some(s) => format!(
                    "the loop on the flexible model is stable with the contact's stiffness down \
                     to {:.0} % only: a limit cycle across the play is possible (the describing \
                     function of its dead zone)",
                    100.0 * s
                ),
                None => "the loop is not stable on the flexible model in full contact".into(),
            };
            writeln!(
                f,
                "backlash: the fitted play of {:.3} mrad is not in the linear design; {verdict}; \
                 `--robust-plant FILE` writes the fitted plant for `actuator design robust`, \
                 which covers the play as a perturbation",
                gap * 1e3
            )?;
        }
        if let Some(s) = self.friction_start {
            writeln!(
                f,
                "friction compensation starts at {:.4} (positive) / {:.4} (negative) command units",
                s[0], s[1]
            )?;
        }
        super::edit::write_changes(f, &self.changes, &self.kept)
    }
}

/// The fitted model as a plant file (the model without its `[lab]` table, the fit's header
/// kept as comments) for `actuator design robust --plant`: the hand-over of a geared drive
/// to the H-infinity design, which covers the backlash, the ratio and the friction as
/// perturbations. Checked to load as a plant and to give the robust design's model.
pub fn robust_plant_file(fitted: &Fitted) -> anyhow::Result<String> {
    let origin = &fitted.origin;
    anyhow::ensure!(
        fitted.model.spec.family == Family::MotorGear,
        "{origin}: `actuator design robust` designs for motor_gear plants; this is {}",
        fitted.model.spec.family
    );
    let intervals: String = fitted
        .intervals
        .iter()
        .map(|(n, (lo, hi))| {
            format!(
                "# {n} = {:.6e}, 95 % interval [{lo:.6e}, {hi:.6e}]\n",
                fitted.get(n).unwrap_or(f64::NAN)
            )
        })
        .collect();
    let text = format!(
        "# The plant fitted in {origin}, written by `actuator tune --robust-plant` for\n\
         # `actuator design robust --plant`.\n{intervals}{}",
        fitted.model.spec.to_toml()
    );
    let spec = crate::physics::PlantSpec::from_toml(&text, origin)?;
    flexible(&spec).map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
    Ok(text)
}

/// Derive the fault-symptom table for the tuned axis on the fitted plant (the daemon of the
/// tuned configuration and the fitted model in lock-step, healthy and with each fault, as
/// `actuator bench fault-table` does for the reference solenoid), write it to `table`, and name
/// it in the tuned configuration (`table_key`: the path as the configuration gives it, relative
/// to the configuration's folder). Returns the derivation's summary.
pub fn regenerate_fault_table(
    tuning: &mut Tuning,
    fitted: &Fitted,
    config_path: &Path,
    table: &Path,
    table_key: &str,
) -> anyhow::Result<String> {
    use crate::bench::fault_table::{derive_with, FaultTableOptions, Simulation};
    anyhow::ensure!(
        tuning.family == Family::Solenoid,
        "the fault-symptom table is the solenoid's parameter diagnosis; {} has none",
        tuning.family
    );
    let config = Config::from_toml(&tuning.text, config_path)?;
    let options = FaultTableOptions::default();
    let sim = Simulation::with(&options, config, fitted.model.spec.clone())?;
    let derived = derive_with(&sim)?;
    let header = format!(
        "Fault-symptom table derived by `actuator tune --fault-table` for the plant fitted in\n\
         {}: the tuned daemon and the fitted model in lock-step, healthy and with each fault\n\
         (see `actuator bench fault-table` for how).",
        fitted.origin
    );
    std::fs::write(table, derived.file.to_toml(&header))
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", table.display()))?;
    let mut doc: toml_edit::DocumentMut = tuning.text.parse()?;
    let mut ed = Editor::new(std::mem::take(&mut doc), 0);
    ed.set(
        ESTIMATION,
        param_key!(ParameterEstimationSection, fault_table),
        toml_edit::Value::from(table_key),
        "derived for the fitted plant with the tuned configuration",
    );
    tuning.text = ed.doc.to_string();
    tuning.changes.extend(ed.changes);
    tuning.kept.retain(|k| {
        k.key
            != keys(
                ESTIMATION,
                &[param_key!(ParameterEstimationSection, fault_table)],
            )
    });
    Config::from_toml(&tuning.text, config_path).map_err(|e| {
        anyhow::anyhow!("the tuned configuration does not pass the daemon's validation: {e}")
    })?;
    Ok(derived.summary())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_spelled_as_the_configuration_file_writes_them() {
        // The report and the messages name keys the way a user finds them in the file.
        assert_eq!(keys(FRICTION, &[]), "axis.friction_compensation");
        assert_eq!(
            keys(ADAPTIVE, &["model_deadband_m", "settled_band_m"]),
            "axis.adaptive_friction.model_deadband_m, settled_band_m"
        );
        assert_eq!(table(SCHEDULE), "[axis.schedule]");
    }

    #[test]
    fn goal_parses_and_names_what_is_wrong() {
        let g: Goal = "bandwidth=30,damping=0.8".parse().expect("goal");
        assert_eq!(g.bandwidth_rad_s, Some(30.0));
        assert_eq!(g.damping, 0.8);
        assert!("speed=3".parse::<Goal>().unwrap_err().contains("speed"));
        assert!("damping=-1"
            .parse::<Goal>()
            .unwrap_err()
            .contains("damping"));
    }
}
