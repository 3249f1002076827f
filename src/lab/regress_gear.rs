//! The inverse-dynamics form of `motor_gear`: the balance of torques on the load,
//! `J_l θ_l'' + τ_f + T_load - τ_c = 0`, with `τ_c` the torque the gear transmits to the load.
//!
//! Only the load angle (and the armature current, when recorded) is measured, so `τ_c` comes from
//! the drive side run on the measured signals: motor and gear as one body referred to the gear
//! output (the motor shaft's torsion mode lies far above the filter corner), driven by the motor
//! torque and tied to the measured load angle by the contact, a stiff spring-damper with the
//! backlash dead zone (Bao et al. eq. 1-3). The contact pulls the drive side onto the measured
//! load, so it does not drift as a free run in closed loop does; what it transmits is what the
//! load balance needs. The drive-side constants are taken as given (but the armature's inductance
//! where the data determine it: `regress::drive_grid`); the load side (inertia,
//! friction, spring, payload, offset) is linear in its parameters, and the backlash play and the
//! ratio limit of `varying_ratio` are searched on a grid.
//!
//! On the moving samples the balance is taken at each sample and masked to where the load slides
//! before it is filtered ([`in_motion`], [`super::motion`]): a load with stiction moves in hops shorter than the
//! filter's reach, and a held load's friction is whatever holds it.
//!
//! Backlash shows where the transmitted torque reverses: the load is free while the gear crosses
//! the play, which a rigid contact cannot produce.

use super::data::Dataset;
use super::effects::{self, Gear, SupplyFactor};
use super::regress::{fixed_term, p, param_term, shaped_command, supply_ratio, Term};
use super::signals::{zero_phase, Prepared};
use crate::physics::{CommandUnit, PlantSpec};

/// Sub-steps of the drive side per sample: 0.1 ms at 1 kHz, against the contact mode of about
/// 20 Hz and the armature's `L_a / R_a` of 0.3 ms (integrated exactly).
const SUBSTEPS: usize = 10;

/// Inertia and transmitted-torque terms of the load balance.
pub fn drive_terms(
    spec: &PlantSpec,
    raw: &Dataset,
    d: &Prepared,
    terms: &mut Vec<Term>,
) -> anyhow::Result<()> {
    terms.push(param_term(
        spec,
        "motor_gear.load_inertia_kg_m2",
        d.a.clone(),
    )?);
    let tau = transmitted_torque(spec, raw, d.dt)?;
    let filtered = zero_phase(&tau, d.cutoff_hz, d.dt);
    terms.push(fixed_term(
        "transmitted torque",
        filtered.into_iter().map(|t| -t).collect(),
    ));
    Ok(())
}

/// The moving samples' columns of the gear's balance, rebuilt where the load sticks and slips
/// ([`super::motion`]): the load's inertia, the torque the drive side transmits when run on the
/// lightly filtered load angle, and the load side's terms from `load`.
pub fn in_motion(
    spec: &PlantSpec,
    raw: &Dataset,
    d: &Prepared,
    terms: &mut [Term],
    load: &dyn Fn(&Prepared, &mut Vec<Term>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    super::motion::in_motion(raw, d, terms, &|light, cols| {
        cols.push(param_term(
            spec,
            "motor_gear.load_inertia_kg_m2",
            light.a.clone(),
        )?);
        // The drive side on the lightly filtered load angle: the contact spring-damper turns
        // the position's noise into torque (K_g and C_g / T_0 times it), which the light filter
        // takes out above the contact mode.
        let smooth = Dataset {
            output: light.y.clone(),
            ..raw.clone()
        };
        let tau = transmitted_torque(spec, &smooth, d.dt)?;
        cols.push(fixed_term(
            "transmitted torque",
            tau.into_iter().map(|t| -t).collect(),
        ));
        load(light, cols)
    })
}

/// Drive-side constants, referred to the gear output, and the gear as the model's effects make it.
struct Drive {
    r: f64,
    l: f64,
    ke: f64,
    kt: f64,
    jm: f64,
    h0: f64,
    jg: f64,
    supply_v: f64,
    /// The ratio and the contact between gear and load.
    gear: Gear,
    /// Factor of the drive at the supply ratio; `None`: the supply only limits the drive.
    supply: Option<SupplyFactor>,
}

impl Drive {
    fn of(spec: &PlantSpec) -> anyhow::Result<Drive> {
        let g = |n: &str| p(spec, &format!("motor_gear.{n}"));
        let (h0, kg, cg) = (
            g("ratio")?,
            g("contact_stiffness_nm_per_rad")?,
            g("contact_damping_nm_s_per_rad")?,
        );
        let mut gear = Gear::rigid(h0, kg, cg);
        let mut supply = None;
        for e in effects::present(spec) {
            e.gear(spec, &mut gear)?;
            if supply.is_none() {
                supply = e.supply_factor(spec)?;
            }
        }
        Ok(Drive {
            r: g("resistance_ohm")?,
            l: g("inductance_h")?,
            ke: g("back_emf_v_s_per_rad")?,
            kt: g("torque_constant_nm_per_a")?,
            jm: g("motor_inertia_kg_m2")?,
            h0,
            jg: g("gear_inertia_kg_m2")?,
            supply_v: g("supply_voltage_v")?,
            gear,
            supply,
        })
    }

    /// Ratio `h` and its rate `ḣ` at load angle and speed.
    #[inline]
    fn ratio(&self, th: f64, w: f64) -> (f64, f64) {
        (self.gear.ratio)(th, w)
    }

    /// Contact torque from gear to load for twist `Δ = θ_g - θ_l` and its rate (Bao et al.
    /// eq. 1-2).
    #[inline]
    fn contact(&self, twist: f64, rate: f64) -> f64 {
        (self.gear.contact)(twist, rate)
    }
}

/// The torque the gear transmits to the load at each sample, from the drive side run on the
/// measured load angle (linear between samples) and the drive signal: the measured current, or
/// the armature voltage after the power stage, or the commanded torque.
pub fn transmitted_torque(spec: &PlantSpec, raw: &Dataset, dt: f64) -> anyhow::Result<Vec<f64>> {
    let c = Drive::of(spec)?;
    if !(c.r > 0.0 && c.l > 0.0 && c.jg > 0.0 && c.h0 > 0.0) {
        anyhow::bail!("motor_gear: resistance, inductance, gear inertia and ratio must be > 0");
    }
    let n = raw.len();
    let torque_input = spec.command == CommandUnit::NewtonMetre;
    let u = shaped_command(spec, raw, dt)?;
    let supply = supply_ratio(spec, raw)?;
    let current = if torque_input {
        None
    } else {
        raw.current.as_ref()
    };
    let hs = dt / SUBSTEPS as f64;
    let decay = (-hs * c.r / c.l).exp();
    let y = &raw.output;
    let mut th_g = y.first().copied().unwrap_or(0.0);
    let mut w_g = 0.0;
    let mut i = current.and_then(|c| c.first().copied()).unwrap_or(0.0);
    let mut out = vec![0.0; n];
    for k in 0..n {
        let next = (k + 1).min(n - 1);
        let (y0, y1) = (y[k], y[next]);
        let w_l = (y1 - y0) / dt;
        // Power stage as in the plant: the H-bridge limits the voltage to the supply.
        let drive = if torque_input {
            u[k]
        } else {
            let r = supply[k];
            match &c.supply {
                Some(f) => u[k].clamp(-c.supply_v, c.supply_v) * f(r, u[k] > 0.0),
                None => u[k].clamp(-c.supply_v * r, c.supply_v * r),
            }
        };
        for s in 0..SUBSTEPS {
            let frac = s as f64 / SUBSTEPS as f64;
            let th_l = y0 + frac * (y1 - y0);
            let (h, h_rate) = c.ratio(th_l, w_l);
            let tc = c.contact(th_g - th_l, w_g - w_l);
            if s == 0 {
                out[k] = tc;
            }
            if s == 0 {
                if let Some(cur) = current {
                    // The measured current anchors each sample; between samples it follows the
                    // armature's own law below, not a straight line: after a voltage step it
                    // settles within L_a / R_a, far inside the sample.
                    i = cur[k];
                }
            }
            let tm = if torque_input { drive } else { c.kt * i };
            // (J_g + h² J_m) ω_g' = h τ_m - h J_m ḣ ω_g - τ_c (rigid motor shaft, ω_m = h ω_g)
            let acc = (h * tm - h * c.jm * h_rate * w_g - tc) / (c.jg + h * h * c.jm);
            w_g += hs * acc;
            th_g += hs * w_g;
            if !torque_input {
                // L_a I' = U - R_a I - K_e h ω_g, exact for the sub-step with ω_g held.
                let i_ss = (drive - c.ke * h * w_g) / c.r;
                i = i_ss + (i - i_ss) * decay;
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{EffectKind, Family};

    fn gear(torque: bool, backlash: Option<f64>) -> PlantSpec {
        let mut s = PlantSpec::new(Family::MotorGear);
        if torque {
            s.command = CommandUnit::NewtonMetre;
        }
        if let Some(gap) = backlash {
            s.add_effect(EffectKind::Backlash).expect("backlash");
            s.set("backlash.gap_rad", gap).expect("gap");
        }
        s
    }

    fn held(u: f64, n: usize) -> Dataset {
        Dataset {
            origin: "held".into(),
            time: (0..n).map(|k| k as f64 * 1e-3).collect(),
            input: vec![u; n],
            output: vec![0.0; n],
            supply: None,
            current: None,
        }
    }

    #[test]
    fn contact_is_free_inside_the_gap_and_a_spring_damper_outside() {
        let d = Drive::of(&gear(false, Some(0.01))).expect("drive");
        let (kg, cg) = (d.gear.stiffness, d.gear.damping);
        assert_eq!(d.contact(0.004, 1.0), 0.0);
        assert_eq!(d.contact(-0.004, -1.0), 0.0);
        assert!((d.contact(0.007, 0.0) - kg * 0.002).abs() < 1e-12);
        assert!((d.contact(-0.007, 0.0) + kg * 0.002).abs() < 1e-12);
        // One-sided: a contact separating fast pulls nothing.
        assert_eq!(d.contact(0.0051, -1e3), 0.0);
        let rigid = Drive::of(&gear(false, None)).expect("drive");
        assert!((rigid.contact(0.001, 0.1) - (kg * 0.001 + cg * 0.1)).abs() < 1e-12);
    }

    #[test]
    fn a_held_load_takes_the_commanded_torque_times_the_ratio() {
        // Torque command on a load held at zero: once the gear has settled on the contact,
        // the transmitted torque is h τ_m, with or without play.
        for gap in [None, Some(0.01)] {
            let spec = gear(true, gap);
            let tau = transmitted_torque(&spec, &held(0.05, 20_000), 1e-3).expect("torque");
            let h = p(&spec, "motor_gear.ratio").expect("motor_gear.ratio");
            let last = tau[tau.len() - 1];
            assert!(
                (last - h * 0.05).abs() < 1e-3 * h * 0.05,
                "gap {gap:?}: {last} against {}",
                h * 0.05
            );
        }
    }

    #[test]
    fn a_held_load_under_a_voltage_takes_the_stall_torque() {
        // Stalled motor: I = U / R_a, τ_c = h K_T U / R_a.
        let spec = gear(false, None);
        let tau = transmitted_torque(&spec, &held(2.0, 20_000), 1e-3).expect("torque");
        let want = p(&spec, "motor_gear.ratio").expect("motor_gear.ratio")
            * p(&spec, "motor_gear.torque_constant_nm_per_a")
                .expect("motor_gear.torque_constant_nm_per_a")
            * 2.0
            / p(&spec, "motor_gear.resistance_ohm").expect("motor_gear.resistance_ohm");
        let last = tau[tau.len() - 1];
        assert!((last - want).abs() < 1e-3 * want, "{last} against {want}");
    }

    #[test]
    fn with_a_measured_current_the_transmitted_torque_is_the_plants_across_the_play() {
        // The physics plant (RK4, the motor shaft's torsion, contact events) driven open loop by
        // a voltage; its true contact torque against what the lab computes from the recorded
        // load angle and current. The current settles within L_a / R_a = 0.3 ms after each
        // voltage step: drawn as a straight line between samples it lagged the drive by a
        // fraction of a sample, which the play's free flight turned into a late contact.
        // The drive is the heavier reading of Bao et al.'s Table 1
        // (tests/data/motor_gear_heavy_reading.toml), whose contact mode (about 260 rad/s) the
        // 1 ms record resolves; on the family's light gear (contact mode near 1300 rad/s,
        // ω T ≈ 1.3) the load's path bends within a sample, and the lab's drive side, tied to
        // the load angle drawn as a straight line between samples, is 2.5 % off.
        let mut spec = gear(false, Some(0.005));
        for (key, v) in [
            ("motor_gear.motor_inertia_kg_m2", 1e-5),
            ("motor_gear.ratio", 30.0),
            ("motor_gear.gear_inertia_kg_m2", 0.02),
            ("motor_gear.load_inertia_kg_m2", 0.01),
        ] {
            spec.set(key, v).expect(key);
        }
        for e in [EffectKind::Viscous, EffectKind::Coulomb] {
            spec.add_effect(e).expect("effect");
        }
        for key in [
            "sensor.position_quantum_rad",
            "sensor.position_noise_rad",
            "sensor.current_quantum_a",
            "sensor.current_noise_a",
        ] {
            spec.set(key, 0.0).expect("sensor key");
        }
        let mut plant = spec.build().expect("plant");
        let (dt, n) = (1e-3, 3000);
        let mut d = held(0.0, n);
        let mut current = vec![0.0; n];
        let (mut gear_angle, mut load_angle) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..n {
            let t = k as f64 * dt;
            let m = plant.measure();
            d.output[k] = m.position;
            current[k] = m.current_a;
            gear_angle[k] = plant.drive_position();
            load_angle[k] = plant.truth().position;
            // Pulses with pauses (the load stops, the gear crosses the play from rest) and a
            // voltage that changes every sample, as a controller's does.
            let wave = (std::f64::consts::TAU * 1.5 * t).sin();
            let pulse = if wave.abs() > 0.3 {
                5.0 * wave.signum()
            } else {
                0.0
            };
            let jitter = ((k * 7919) % 13) as f64 / 6.0 - 1.0;
            d.input[k] = pulse + 1.5 * jitter;
            plant.step(d.input[k], dt);
        }
        d.current = Some(current);
        let c = Drive::of(&spec).expect("drive");
        let half = 0.5 * 0.005;
        let lab = transmitted_torque(&spec, &d, dt).expect("torque");
        let (mut err, mut total) = (0.0, 0.0);
        for k in 100..n - 1 {
            let twist = gear_angle[k] - load_angle[k];
            let rate = ((gear_angle[k + 1] - load_angle[k + 1])
                - (gear_angle[k - 1] - load_angle[k - 1]))
                / (2.0 * dt);
            let truth = c.contact(twist, rate);
            assert!(twist.abs() < 5.0 * half, "the load follows: twist {twist}");
            err += (lab[k] - truth).powi(2);
            total += truth * truth;
        }
        let relative = (err / total).sqrt();
        assert!(
            relative < 0.01,
            "lab against plant: {:.1} %",
            100.0 * relative
        );
    }

    #[test]
    fn the_ratio_grows_with_one_over_cos_of_the_load_angle() {
        let mut s = gear(false, None);
        s.add_effect(EffectKind::VaryingRatio).expect("effect");
        s.set("varying_ratio.max_angle_rad", 1.0).expect("limit");
        let d = Drive::of(&s).expect("drive");
        let (h, _) = d.ratio(0.5, 0.0);
        assert!((h - d.h0 / 0.5f64.cos()).abs() < 1e-12);
        let (h, rate) = d.ratio(1.2, 3.0);
        assert!((h - d.h0 / 1.0f64.cos()).abs() < 1e-12 && rate == 0.0);
    }
}
