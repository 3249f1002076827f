//! The figures of a closed-loop run over a set-point tour, from the controller's own records:
//! what `actuator tune` predicts on a fitted model and `actuator sim --record` achieves on a
//! plant, computed the same way so that the two can be held side by side.

use std::fmt;

use crate::daemon::config::{AxisConfig, CommandKind};
use crate::daemon::record::CycleRecord;
use crate::supervise::FaultState;

/// Share of a step's size the position must stay within to count as settled.
pub const SETTLING_BAND: f64 = 0.05;

/// Share of each dwell, at its end, over which the steady error is taken.
pub const STEADY_SHARE: f64 = 0.1;

/// Share of the output range at either limit within which the command counts as saturated.
pub const SATURATION_SHARE: f64 = 1e-3;

/// The figures of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TourFigures {
    /// RMS of the following error (the rate-limited reference less the position) from the first
    /// set-point change on, m (rad on a rotary axis).
    pub rms_error: f64,
    /// The slowest settled step's settling time to within [`SETTLING_BAND`] of its size, s.
    pub worst_settling_s: Option<f64>,
    /// Steps whose position was still outside the band at the end of their dwell.
    pub unsettled_steps: usize,
    /// The largest overshoot past a step's target, as a share of the step.
    pub worst_overshoot: f64,
    /// Mean over the steps of `|setpoint - position|` over the last [`STEADY_SHARE`] of each dwell.
    pub steady_error: f64,
    /// Time the command spent at an output limit, s.
    pub saturation_s: f64,
    /// Faults the axis latched during the run (a fail-safe or a maintenance request).
    pub faults: usize,
    /// Set-point changes of the tour the run covered.
    pub steps: usize,
}

/// The command of a record in the axis' own command unit.
pub fn command_of(r: &CycleRecord, command: CommandKind) -> f64 {
    match command {
        CommandKind::Voltage => r.command_voltage,
        CommandKind::Duty => r.command_duty,
        CommandKind::Torque => r.command_torque,
        CommandKind::Velocity => r.command_velocity,
        // The target position sent: the reference plus the controller's correction.
        CommandKind::Position => r.reference_position,
    }
}

impl TourFigures {
    /// The figures of `records` (one axis, in cycle order) run by `axis`: its set-point changes
    /// and output limits. `None` when the run holds no record after the first change.
    pub fn of(records: &[CycleRecord], axis: &AxisConfig) -> Option<TourFigures> {
        let start = axis.setpoints.first().map_or(0.0, |s| s.at_s);
        let period = match records {
            [a, b, ..] => b.t_s - a.t_s,
            _ => return None,
        };
        // RMS over every record from the first change on.
        let (mut sum, mut n) = (0.0, 0usize);
        for r in records.iter().filter(|r| r.t_s >= start) {
            sum += r.following_error * r.following_error;
            n += 1;
        }
        if n == 0 {
            return None;
        }
        let rms_error = (sum / n as f64).sqrt();

        let (lo, hi) = (axis.controller.output_min, axis.controller.output_max);
        let edge = SATURATION_SHARE * (hi - lo).abs();
        let saturated = records
            .iter()
            .filter(|r| r.t_s >= start)
            .filter(|r| {
                let u = command_of(r, axis.command);
                u >= hi - edge || u <= lo + edge
            })
            .count();

        // A warning (a limit exceeded for less than its persistence) is not a fault.
        let latched = |r: &CycleRecord| {
            matches!(
                FaultState::from_code(r.fault_state),
                Some(FaultState::Fault | FaultState::MaintenanceRequested)
            )
        };
        let faults = records
            .windows(2)
            .filter(|w| !latched(&w[0]) && latched(&w[1]))
            .count()
            + usize::from(records.first().is_some_and(latched));

        // Each change's dwell: from its time to the next change or the end of the run.
        let end = records.last().map_or(start, |r| r.t_s + period);
        let mut from = axis.initial_setpoint_m;
        let mut worst_settling_s: Option<f64> = None;
        let mut unsettled_steps = 0;
        let mut worst_overshoot: f64 = 0.0;
        let (mut steady_sum, mut steady_n) = (0.0, 0usize);
        let mut steps = 0;
        for (i, s) in axis.setpoints.iter().enumerate() {
            let to = s.position_m;
            let size = (to - from).abs();
            let dwell_end = axis.setpoints.get(i + 1).map_or(end, |n| n.at_s).min(end);
            let dwell: Vec<&CycleRecord> = records
                .iter()
                .filter(|r| r.t_s >= s.at_s && r.t_s < dwell_end)
                .collect();
            let previous = from;
            from = to;
            if size == 0.0 || dwell.is_empty() {
                continue;
            }
            steps += 1;
            let direction = (to - previous).signum();
            let band = SETTLING_BAND * size;
            // Settled from the first record after the last one outside the band.
            match dwell.iter().rposition(|r| (to - r.position).abs() > band) {
                Some(last) if last + 1 == dwell.len() => unsettled_steps += 1,
                last => {
                    let t = last.map_or(dwell[0].t_s, |k| dwell[k + 1].t_s) - s.at_s;
                    worst_settling_s = Some(worst_settling_s.map_or(t, |w| w.max(t)));
                }
            }
            let past = dwell
                .iter()
                .map(|r| (r.position - to) * direction)
                .fold(0.0, f64::max);
            worst_overshoot = worst_overshoot.max(past / size);
            let tail = ((dwell.len() as f64 * STEADY_SHARE).ceil() as usize).max(1);
            let e: f64 = dwell[dwell.len() - tail..]
                .iter()
                .map(|r| (to - r.position).abs())
                .sum::<f64>()
                / tail as f64;
            steady_sum += e;
            steady_n += 1;
        }
        Some(TourFigures {
            rms_error,
            worst_settling_s,
            unsettled_steps,
            worst_overshoot,
            steady_error: if steady_n > 0 {
                steady_sum / steady_n as f64
            } else {
                0.0
            },
            saturation_s: saturated as f64 * period,
            faults,
            steps,
        })
    }

    /// The figures in a line, lengths in `unit` (µm or µrad) per metre (radian) `scale`.
    pub fn line(&self, scale: f64, unit: &str) -> String {
        format!(
            "RMS following error {:.1} {unit}; worst settling {}; worst overshoot {:.1} %; \
             steady error {:.1} {unit}; saturated {:.3} s; faults {}",
            self.rms_error * scale,
            self.settling_text(),
            100.0 * self.worst_overshoot,
            self.steady_error * scale,
            self.saturation_s,
            self.faults
        )
    }

    fn settling_text(&self) -> String {
        let worst = self
            .worst_settling_s
            .map_or("-".to_string(), |t| format!("{:.0} ms", t * 1e3));
        if self.unsettled_steps > 0 {
            format!(
                "{worst}, {} of {} steps unsettled",
                self.unsettled_steps, self.steps
            )
        } else {
            worst
        }
    }
}

/// Named runs side by side, one row per figure: `tune` prints the given and the tuned
/// configuration so.
pub struct SideBySide<'a> {
    pub runs: Vec<(&'a str, &'a TourFigures)>,
    /// Length per metre (radian) and its unit, e.g. `1e6, "µm"`.
    pub scale: f64,
    pub unit: &'a str,
}

/// One row of [`SideBySide`]: a figure as text.
type Row = Box<dyn Fn(&TourFigures) -> String>;

impl fmt::Display for SideBySide<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (s, u) = (self.scale, self.unit);
        write!(f, "  {:<34}", "")?;
        for (name, _) in &self.runs {
            write!(f, "{name:>21}")?;
        }
        writeln!(f)?;
        let rows: [(String, Row); 7] = [
            (
                format!("RMS following error/{u}"),
                Box::new(move |x| format!("{:.1}", x.rms_error * s)),
            ),
            (
                format!("worst settling ({:.0} % band)/ms", 100.0 * SETTLING_BAND),
                Box::new(|x| {
                    x.worst_settling_s
                        .map_or("-".to_string(), |t| format!("{:.0}", t * 1e3))
                }),
            ),
            (
                "steps unsettled".to_string(),
                Box::new(|x| format!("{} of {}", x.unsettled_steps, x.steps)),
            ),
            (
                "worst overshoot/%".to_string(),
                Box::new(|x| format!("{:.1}", 100.0 * x.worst_overshoot)),
            ),
            (
                format!("steady error/{u}"),
                Box::new(move |x| format!("{:.1}", x.steady_error * s)),
            ),
            (
                "saturated/s".to_string(),
                Box::new(|x| format!("{:.3}", x.saturation_s)),
            ),
            ("faults".to_string(), Box::new(|x| x.faults.to_string())),
        ];
        for (label, value) in rows.iter() {
            write!(f, "  {label:<34}")?;
            for (_, x) in &self.runs {
                write!(f, "{:>21}", value(x))?;
            }
            writeln!(f)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::config::SetpointStep;

    fn axis(steps: &[(f64, f64)]) -> AxisConfig {
        let config = crate::daemon::Config::from_toml(
            crate::defaults::config(crate::physics::Family::Solenoid).text,
            std::path::Path::new("solenoid.toml"),
        )
        .expect("reference configuration");
        let mut a = config.axis[0].clone();
        a.initial_setpoint_m = 0.0;
        a.setpoints = steps
            .iter()
            .map(|&(at_s, position_m)| SetpointStep { at_s, position_m })
            .collect();
        a
    }

    /// Each set-point approached as `to - (to - from) shape((t - at) / tau)`, sampled every
    /// 10 ms; the command at the upper limit for the first 50 ms of each step.
    fn run(a: &AxisConfig, seconds: f64, tau: f64, shape: fn(f64) -> f64) -> Vec<CycleRecord> {
        let mut out = Vec::new();
        let dt = 0.01;
        for k in 0..(seconds / dt).round() as usize {
            let t = k as f64 * dt;
            let (mut from, mut to, mut at) = (a.initial_setpoint_m, a.initial_setpoint_m, 0.0);
            for s in a.setpoints.iter().filter(|s| s.at_s <= t) {
                from = to;
                to = s.position_m;
                at = s.at_s;
            }
            let y = to - (to - from) * shape((t - at) / tau);
            out.push(CycleRecord {
                t_s: t,
                position: y,
                setpoint_position: to,
                reference_position: to,
                following_error: to - y,
                command_voltage: if t - at < 0.05 - 1e-9 {
                    a.controller.output_max
                } else {
                    1.0
                },
                ..CycleRecord::default()
            });
        }
        out
    }

    fn first_order(x: f64) -> f64 {
        (-x).exp()
    }

    /// A ramp to 1.5 times the step at x = 1, then back to the target: an overshoot of half the step.
    fn half_overshoot(x: f64) -> f64 {
        if x < 1.0 {
            1.0 - 1.5 * x
        } else {
            -0.5 * (-5.0 * (x - 1.0)).exp()
        }
    }

    #[test]
    fn settling_overshoot_and_saturation_of_a_known_response() {
        let a = axis(&[(1.0, 0.01), (2.0, 0.0)]);
        let f = TourFigures::of(&run(&a, 3.0, 0.05, first_order), &a).expect("figures");
        assert_eq!(f.steps, 2);
        // exp(-t/τ) = 5 % at t = 3 τ = 150 ms, to the next 10 ms sample.
        let t = f.worst_settling_s.expect("settled");
        assert!((t - 0.15).abs() <= 0.0101, "settling {t}");
        assert_eq!(f.unsettled_steps, 0);
        assert!(f.worst_overshoot < 1e-12, "{}", f.worst_overshoot);
        // 5 samples of 10 ms per step at the limit.
        assert!((f.saturation_s - 0.1).abs() < 1e-9, "{}", f.saturation_s);
        // The error holds exp(-t/τ) of each step, sampled every 10 ms: over the 200 samples
        // from 1 s on its mean square is 2 d² Σ exp(-2 k dt / τ) / 200.
        let sum = 1.0 / (1.0 - (-2.0 * 0.01 / 0.05_f64).exp());
        let rms = 0.01 * (2.0 * sum / 200.0).sqrt();
        assert!(
            (f.rms_error - rms).abs() < 1e-3 * rms,
            "{} {rms}",
            f.rms_error
        );
        assert_eq!(f.faults, 0);
    }

    #[test]
    fn an_overshoot_and_a_step_that_never_settles_are_counted() {
        let a = axis(&[(1.0, 0.01), (2.0, 0.0)]);
        let f = TourFigures::of(&run(&a, 3.0, 0.05, half_overshoot), &a).expect("figures");
        assert!(
            (f.worst_overshoot - 0.5).abs() < 0.02,
            "{}",
            f.worst_overshoot
        );
        let slow = TourFigures::of(&run(&a, 3.0, 2.0, first_order), &a).expect("figures");
        assert_eq!(slow.unsettled_steps, 2);
        assert!(slow.worst_settling_s.is_none());
        assert!(slow.steady_error > 0.5 * 0.01 * (-0.9_f64 / 2.0).exp());
    }
}
