//! The tuning of a pneumatic axis: the drive gains `K_I1` (down), `K_I2` (up) per supply point of
//! `[axis.schedule]` from the fitted drive gains and supply law. The daemon designs the direction P
//! gains from them by the quadratic cost with the configured effort weight (Isermann & Raab:
//! `[q01, q02] = f(K_I1(P_L), K_I2(P_L))`); `tune` prints the gains and poles that design gives.

use std::fmt;
use std::path::Path;

use super::axis::{chosen_axis, keys, table};
use super::edit::{round_sig, Change, Editor, Kept};
use super::fitted::Fitted;
use super::keys::{
    PlantKey, PNEUMATIC_ATMOSPHERE, PNEUMATIC_GAIN_DOWN, PNEUMATIC_GAIN_UP, PNEUMATIC_SUPPLY,
    SUPPLY_EXPONENT, SUPPLY_EXPONENT_POS_SHIFT,
};
use super::TuneOptions;
use crate::control::{effort_weight_for_pole, integrator_lq_gain};
use crate::daemon::config::{AxisConfig, CommandKind, Config, ScheduleSection};
use crate::param_key;
use crate::physics::Family;

/// The section tune writes and its drive-gain columns (down, up), named by the declarations.
const SCHEDULE: &str = param_key!(AxisConfig, schedule);
const COLUMNS: [&str; 2] = [
    param_key!(ScheduleSection, drive_gain_down_m_per_s),
    param_key!(ScheduleSection, drive_gain_up_m_per_s),
];

/// The fitted drive gains, down then up.
pub const DRIVE_GAINS: [PlantKey; 2] = [PNEUMATIC_GAIN_DOWN, PNEUMATIC_GAIN_UP];

/// Why a record of the closed loop leaves the drive gains open, and what record determines them.
pub const CLOSED_LOOP: &str = "The record does not determine the drive gain well enough: \
    in a closed loop the P controller sets the duty from the position error, so a record with \
    little motion at large duty leaves a weaker drive with more duty and a stronger one with less \
    nearly alike, and the short small-duty pulses are mostly stiction. Record motion at large duty \
    in both directions (duty steps, or set-point steps over the stroke with the valves saturated) \
    and fit again";

/// One supply point of the schedule as the daemon will run it.
#[derive(Debug, Clone, PartialEq)]
pub struct SupplyPoint {
    pub supply_pa: f64,
    /// `[K_I1, K_I2]`, m/s.
    pub drive_gain: [f64; 2],
    /// `[q01, q02]` of the quadratic-cost design, duty per m.
    pub q_per_m: [f64; 2],
    /// Closed-loop pole `1 - q K_I T0` per direction with the drive the schedule gives.
    pub pole: [f64; 2],
}

/// What `tune` did for a pneumatic axis.
#[derive(Debug, Clone, PartialEq)]
pub struct PneumaticTuning {
    pub text: String,
    /// The fitted `[K_I1, K_I2]` at the model's supply and the supply pressure, Pa.
    pub fitted_gain: [f64; 2],
    pub fitted_supply_pa: f64,
    /// How the gains move with the supply.
    pub supply_law: String,
    /// The design goal (the closed-loop pole kept) and the effort weight it gives.
    pub goal: String,
    pub effort_weight_m2: f64,
    pub points: Vec<SupplyPoint>,
    /// Range of the closed-loop pole per direction at the fitted supply when the true drive gain
    /// lies anywhere in its interval (`None` for a gain without one).
    pub pole_over_interval: [Option<(f64, f64)>; 2],
    pub changes: Vec<Change>,
    pub kept: Vec<Kept>,
}

/// `K_I` of direction `i` (0 down, 1 up) at the supply pressure `P_L`, Pa.
type SupplyLaw = Box<dyn Fn(usize, f64) -> Option<f64>>;

/// Linear between the table's points, held beyond its ends (as the daemon's schedule reads it).
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> Option<f64> {
    let (first, last) = (xs.first()?, xs.last()?);
    if x <= *first {
        return ys.first().copied();
    }
    if x >= *last {
        return ys.last().copied();
    }
    let i = xs.windows(2).position(|w| x >= w[0] && x <= w[1])?;
    let t = (x - xs[i]) / (xs[i + 1] - xs[i]);
    Some(ys[i] + t * (ys[i + 1] - ys[i]))
}

/// Tune the pneumatic axis `options.axis` of `config_text` on the fitted model, keeping the
/// closed-loop pole the configuration gives its slower direction.
pub fn tune_pneumatic(
    fitted: &Fitted,
    config_text: &str,
    config_path: &Path,
    options: &TuneOptions,
) -> anyhow::Result<PneumaticTuning> {
    tune_pneumatic_at(fitted, config_text, config_path, options, None)
}

/// [`tune_pneumatic`] with the slower direction's closed-loop pole at the nominal supply given
/// (`Some(z)`, `0 <= z < 1`) instead of the configuration's.
pub fn tune_pneumatic_at(
    fitted: &Fitted,
    config_text: &str,
    config_path: &Path,
    options: &TuneOptions,
    pole: Option<f64>,
) -> anyhow::Result<PneumaticTuning> {
    if let Some(z) = pole {
        anyhow::ensure!(
            (0.0..1.0).contains(&z),
            "a closed-loop pole of a pneumatic direction is in [0, 1), got {z}"
        );
    }
    let origin = &fitted.origin;
    let cfg_name = config_path.display().to_string();
    let config = Config::from_toml(config_text, config_path)?;
    let (axis, a) = chosen_axis(&config, options, &cfg_name)?;
    anyhow::ensure!(
        a.command == CommandKind::Duty,
        "{cfg_name}: axis {:?} is commanded by {:?}; a pneumatic model is designed for a valve duty",
        a.name,
        a.command
    );
    let schedule = a
        .schedule
        .as_ref()
        .filter(|s| s.schedules_drive_gains())
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{cfg_name}: axis {:?} has no {} with {} / {}: tune writes the drive gains the \
                 daemon designs its direction P gains from",
                a.name,
                table(SCHEDULE),
                COLUMNS[0],
                COLUMNS[1]
            )
        })?;
    let pressures = schedule.supply_pressure_pa.clone().ok_or_else(|| {
        anyhow::anyhow!(
            "{cfg_name}: {} of a pneumatic axis needs {}",
            table(SCHEDULE),
            param_key!(ScheduleSection, supply_pressure_pa)
        )
    })?;

    // The drive gains must be determined by the fit.
    let mut gain = [0.0; 2];
    let name = |k: PlantKey| k.name(Family::Pneumatic);
    let drive_gains = DRIVE_GAINS.map(name);
    for (i, name) in drive_gains.iter().enumerate() {
        let v = fitted
            .get(name)
            .ok_or_else(|| anyhow::anyhow!("{origin}: the model has no {name}"))?;
        let Some(spread) = fitted.relative_spread(name) else {
            anyhow::bail!(
                "{origin}: {name} = {v:.4e} m/s has no 95 % interval: the fit did not estimate it \
                 (fixed or at a bound), so the model does not determine the drive to design from. \
                 {CLOSED_LOOP}"
            );
        };
        if spread > options.max_spread || v <= 0.0 {
            let (lo, hi) = fitted.intervals[name];
            anyhow::bail!(
                "{origin}: {name} = {v:.4e} m/s with the 95 % interval [{lo:.4e}, {hi:.4e}], \
                 ±{:.0} % of its value: too wide to design from (at most ±{:.0} %). {CLOSED_LOOP}",
                100.0 * spread,
                100.0 * options.max_spread
            );
        }
        gain[i] = v;
    }
    let supply = name(PNEUMATIC_SUPPLY);
    let p_model = fitted
        .get(&supply)
        .ok_or_else(|| anyhow::anyhow!("{origin}: the model has no {supply}"))?;
    let p_atm = fitted.get(&name(PNEUMATIC_ATMOSPHERE)).unwrap_or(101_325.0);
    anyhow::ensure!(
        p_model < p_atm,
        "{origin}: supply pressure {p_model} Pa is not below the atmosphere {p_atm} Pa"
    );

    // K_I(P_L) per direction at each supply point.
    let configured = [
        schedule.drive_gain_down_m_per_s.clone(),
        schedule.drive_gain_up_m_per_s.clone(),
    ];
    let exponent = name(SUPPLY_EXPONENT);
    let kappa = fitted.get(&exponent);
    // The up valve's law, `κ + Δκ` (Isermann & Raab's K_I2(P_L)); 0 for one law for both.
    let shift_key = name(SUPPLY_EXPONENT_POS_SHIFT);
    let shift = fitted.get(&shift_key).unwrap_or(0.0);
    let (law, supply_law): (SupplyLaw, String) = match kappa {
        // K_I ∝ (P_atm - P_L)^κ per valve, the model's supply law through the fitted gain at its
        // supply.
        Some(k) => (
            Box::new(move |i, p: f64| {
                let exponent = if i == 1 { k + shift } else { k };
                Some(gain[i] * ((p_atm - p) / (p_atm - p_model)).powf(exponent))
            }),
            format!(
                "K_I = K_I(fit) ((P_atm - P_L) / (P_atm - {p_model:.0} Pa))^κ, the model's \
                 {exponent} ({}){}",
                if fitted.intervals.contains_key(&exponent) {
                    "fitted"
                } else {
                    "declared in the model, not fitted"
                },
                if shift == 0.0 {
                    format!(", κ = {k:.3} for both valves")
                } else {
                    format!(
                        ", κ = {k:.3} for the down valve (K_I1) and {:.3} for the up valve \
                         (K_I2, {shift_key} {shift:+.3})",
                        k + shift
                    )
                }
            ),
        ),
        // Without a supply law: the configured table's shape, through the fitted gain.
        None => {
            let table = configured.clone();
            let xs = pressures.clone();
            (
                Box::new(move |i, p: f64| {
                    let t = table[i].as_ref()?;
                    let at_model = interpolate(&xs, t, p_model)?;
                    let at_p = interpolate(&xs, t, p)?;
                    (at_model > 0.0).then(|| gain[i] * at_p / at_model)
                }),
                format!(
                    "the configured table's shape over the supply (the model has no supply_gain), \
                     scaled to the fitted gain at {p_model:.0} Pa"
                ),
            )
        }
    };
    let mut columns = [Vec::new(), Vec::new()];
    for (i, col) in columns.iter_mut().enumerate() {
        for &p in &pressures {
            let k = law(i, p).ok_or_else(|| {
                anyhow::anyhow!(
                    "{cfg_name}: {} has no {} column to take the shape from",
                    table(SCHEDULE),
                    COLUMNS[i]
                )
            })?;
            col.push(round_sig(k, 4));
        }
    }

    // The goal: the closed-loop pole the configuration gives its slower direction at the nominal
    // supply, kept for the fitted drive by the effort weight r = b² z / (1 - z)².
    let period_s = config.cycle.period_s;
    let r_configured = schedule.effort_weight_m2.unwrap_or(0.0);
    let p_goal = schedule.nominal_supply_pa.unwrap_or(p_model);
    let at_goal = |col: &[f64]| interpolate(&pressures, col, p_goal);
    let tuned_at_goal = [0, 1].map(|i| at_goal(&columns[i]).unwrap_or(f64::NAN));
    let slow = if tuned_at_goal[1] < tuned_at_goal[0] {
        1
    } else {
        0
    };
    let configured_k = configured[slow]
        .as_deref()
        .and_then(at_goal)
        .unwrap_or(tuned_at_goal[slow]);
    let configured_pole = integrator_lq_gain(configured_k, period_s, r_configured)
        .map(|q| 1.0 - q * configured_k * period_s)
        .filter(|z| (0.0..1.0).contains(z));
    let goal_pole = pole.or(configured_pole);
    let r = goal_pole
        .and_then(|z| effort_weight_for_pole(tuned_at_goal[slow], period_s, z))
        .unwrap_or(r_configured);
    let goal = match goal_pole {
        Some(z) if pole.is_some() => format!(
            "the search's closed-loop pole {z:.3} of the slower direction ({}) at {:.0} Pa: r = \
             (K_I T0)^2 z / (1 - z)^2",
            ["down", "up"][slow],
            p_goal
        ),
        Some(z) => format!(
            "the configuration's closed-loop pole {z:.3} of the slower direction ({}) at {:.0} \
             Pa, kept for the fitted drive: r = (K_I T0)^2 z / (1 - z)^2",
            ["down", "up"][slow],
            p_goal
        ),
        None => "the configured effort weight (its pole is not in [0, 1))".to_string(),
    };

    // The daemon's design on them: K_I,design = min(K_I(P), K_I(P_nominal)).
    let nominal = schedule
        .nominal_supply_pa
        .map(|pn| [0, 1].map(|i| interpolate(&pressures, &columns[i], pn)));
    let q_of = |k: f64| integrator_lq_gain(k, period_s, r).unwrap_or(f64::NAN);
    let mut points = Vec::new();
    for (j, &p) in pressures.iter().enumerate() {
        let k = [columns[0][j], columns[1][j]];
        let design = [0, 1].map(|i| match nominal {
            Some(n) => k[i].min(n[i].unwrap_or(f64::INFINITY)),
            None => k[i],
        });
        let q = design.map(q_of);
        points.push(SupplyPoint {
            supply_pa: p,
            drive_gain: k,
            q_per_m: q,
            pole: [0, 1].map(|i| 1.0 - q[i] * k[i] * period_s),
        });
    }
    // Robustness: the gain designed on the fitted K_I, the drive anywhere in its interval.
    let pole_over_interval = [0, 1].map(|i| {
        let (lo, hi) = *fitted.intervals.get(&drive_gains[i])?;
        let q = q_of(gain[i]);
        let z = |k: f64| 1.0 - q * k * period_s;
        Some((z(hi), z(lo)))
    });

    // Write the configuration.
    let doc: toml_edit::DocumentMut = config_text
        .parse()
        .map_err(|e| anyhow::anyhow!("{cfg_name}: {e}"))?;
    let mut ed = Editor::new(doc, axis);
    for (i, key) in COLUMNS.iter().enumerate() {
        let (lo, hi) = fitted.intervals[&drive_gains[i]];
        ed.set_list(
            SCHEDULE,
            key,
            &columns[i],
            4,
            format!(
                "{} = {:.4e} m/s (95 % interval [{lo:.4e}, {hi:.4e}]) of {origin} at \
                 {p_model:.0} Pa; over the supply: {supply_law}",
                drive_gains[i], gain[i]
            ),
        );
    }
    ed.set(
        SCHEDULE,
        param_key!(ScheduleSection, effort_weight_m2),
        toml_edit::Value::from(round_sig(r, 4)),
        goal.clone(),
    );
    ed.keep(
        keys(SCHEDULE, &[param_key!(ScheduleSection, nominal_supply_pa)]),
        "the supply the gains are tuned at: the installation's choice",
    );
    if let Some(pa) = &a.pneumatic_adaptive {
        let band = pa.drive_gain_min_m_per_s..=pa.drive_gain_max_m_per_s;
        let outside: Vec<f64> = columns
            .iter()
            .flatten()
            .copied()
            .filter(|k| !band.contains(k))
            .collect();
        ed.keep(
            keys(param_key!(AxisConfig, pneumatic_adaptive), &[]),
            if outside.is_empty() {
                "its estimation starts from the tuned schedule; its plausible band holds every \
                 tuned gain"
                    .to_string()
            } else {
                format!(
                    "its estimation starts from the tuned schedule; tuned gains {outside:?} m/s lie \
                     outside its plausible band [{}, {}] m/s: widen it if the plant is this one",
                    pa.drive_gain_min_m_per_s, pa.drive_gain_max_m_per_s
                )
            },
        );
    }
    let controller = param_key!(AxisConfig, controller);
    ed.keep(
        format!(
            "{}, {}, {}, [{}], [{}], [{}]",
            keys(controller, &[]),
            keys(param_key!(AxisConfig, limits), &[]),
            keys(param_key!(AxisConfig, setpoints), &[]),
            param_key!(Config, bus),
            param_key!(Config, node),
            param_key!(Config, cycle)
        ),
        format!(
            "{}'s gains are unused under a drive-gain schedule (its output limits are the \
             valves'); the rest is the installation's, not the model's",
            table(controller)
        ),
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
    Ok(PneumaticTuning {
        text,
        fitted_gain: gain,
        fitted_supply_pa: p_model,
        supply_law,
        goal,
        effort_weight_m2: r,
        points,
        pole_over_interval,
        changes: ed.changes,
        kept: ed.kept,
    })
}

impl fmt::Display for PneumaticTuning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "pneumatic drive: K_I1 (down) {:.2} mm/s, K_I2 (up) {:.2} mm/s at {:.0} mbar",
            self.fitted_gain[0] * 1e3,
            self.fitted_gain[1] * 1e3,
            self.fitted_supply_pa / 100.0
        )?;
        writeln!(f, "over the supply: {}", self.supply_law)?;
        writeln!(
            f,
            "goal: {}; effort weight {:.4e} m^2",
            self.goal, self.effort_weight_m2
        )?;
        writeln!(
            f,
            "direction P gains by the daemon's quadratic-cost design (closed-loop pole 1 - q K_I T0):"
        )?;
        for p in &self.points {
            writeln!(
                f,
                "  {:>6.0} mbar: K_I {:.2} / {:.2} mm/s, q {:.1} / {:.1} 1/m, pole {:.3} / {:.3}",
                p.supply_pa / 100.0,
                p.drive_gain[0] * 1e3,
                p.drive_gain[1] * 1e3,
                p.q_per_m[0],
                p.q_per_m[1],
                p.pole[0],
                p.pole[1]
            )?;
        }
        for (i, dir) in ["down", "up"].iter().enumerate() {
            if let Some((lo, hi)) = self.pole_over_interval[i] {
                writeln!(
                    f,
                    "robustness ({dir}): with the drive gain anywhere in its 95 % interval the \
                     pole at the fitted supply lies in [{lo:.3}, {hi:.3}]{}",
                    if lo > -1.0 && hi < 1.0 {
                        " (stable)"
                    } else {
                        " (NOT stable over the interval)"
                    }
                )?;
            }
        }
        super::edit::write_changes(f, &self.changes, &self.kept)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_is_linear_between_points_and_held_beyond() {
        let xs = [40e3, 60e3, 80e3];
        let ys = [3.0, 2.0, 0.0];
        assert_eq!(interpolate(&xs, &ys, 30e3), Some(3.0));
        assert_eq!(interpolate(&xs, &ys, 90e3), Some(0.0));
        assert!((interpolate(&xs, &ys, 70e3).expect("inside") - 1.0).abs() < 1e-12);
    }

    /// A model of the reference plant (config/plants/pneumatic.toml) gives back the schedule
    /// config/pneumatic.toml was written with by hand from the paper's supply law, and its
    /// effort weight.
    /// The schedule `tune` writes into config/pneumatic.toml for a model of the reference plant
    /// (config/plants/pneumatic.toml, edited by `edit`) with fitted valve speeds of 30 and
    /// 22 mm/s.
    fn tuned_schedule(edit: impl Fn(String) -> String) -> ScheduleSection {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let plant =
            std::fs::read_to_string(root.join("config/plants/pneumatic.toml")).expect("plant file");
        let plant = edit(plant);
        let model = format!(
            "# pneumatic.gain_down_m_per_s = 3.0e-2, 95 % interval [2.9e-2, 3.1e-2]\n\
             # pneumatic.gain_up_m_per_s = 2.2e-2, 95 % interval [2.1e-2, 2.3e-2]\n\
             command = \"duty\"\n{plant}"
        );
        let fitted = Fitted::from_text(&model, "reference.toml").expect("model");
        let path = root.join("config/pneumatic.toml");
        let text = std::fs::read_to_string(&path).expect("configuration");
        let t = tune_pneumatic(&fitted, &text, &path, &TuneOptions::default()).expect("tuned");
        let mut config = Config::from_toml(&t.text, &path).expect("valid");
        config.axis.remove(0).schedule.expect("schedule")
    }

    #[test]
    fn the_reference_plant_gives_back_the_hand_written_schedule() {
        let s = tuned_schedule(|plant| plant);
        // The hand-written table is rounded to 0.1 mm/s.
        let close = |got: &Option<Vec<f64>>, want: [f64; 3]| {
            let got = got.as_deref().expect("column");
            assert_eq!(got.len(), 3);
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() <= 0.5e-4, "{got:?} against {want:?}");
            }
        };
        close(&s.drive_gain_down_m_per_s, [0.0511, 0.03, 0.0123]);
        close(&s.drive_gain_up_m_per_s, [0.0375, 0.022, 0.009]);
        // The same drive keeps the same effort weight.
        assert_eq!(s.effort_weight_m2, Some(2.2e-7));
    }

    /// A model with a law per valve: the down valve's column follows κ, the up valve's κ + Δκ
    /// (here flat over the supply).
    #[test]
    fn each_valve_column_follows_its_own_law() {
        let s = tuned_schedule(|plant| {
            assert!(
                plant.contains("exponent = 1.35"),
                "the plant file names its exponent"
            );
            plant.replace(
                "exponent = 1.35",
                "exponent = 1.35\nexponent_pos_shift = -1.35",
            )
        });
        let down = s.drive_gain_down_m_per_s.as_deref().expect("column");
        let up = s.drive_gain_up_m_per_s.as_deref().expect("column");
        assert!((down[0] - 0.0511).abs() <= 0.5e-4, "{down:?}");
        assert!(up.iter().all(|k| (k - 0.022).abs() <= 0.5e-4), "{up:?}");
    }
}
