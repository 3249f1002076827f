//! The linear model per direction that the design needs, read from a fitted model, and the
//! corners of its parameters' intervals.

use super::design::ContinuousPlant;
use super::fitted::Fitted;
use super::keys::*;
use crate::physics::Family;

/// Direction of motion: positive (pulling in, extending) or negative.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Positive,
    Negative,
}

impl Direction {
    pub fn name(self) -> &'static str {
        match self {
            Direction::Positive => "positive",
            Direction::Negative => "negative",
        }
    }
}

/// One identified parameter the design uses: where it comes from and its value.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Qualified parameter name of the model file, or a product of them.
    pub names: Vec<&'static str>,
    pub value: f64,
}

/// The axis as the design sees it: `m y'' + d± y' + c y = K± u` behind an optional lag, with the
/// dry friction and the pretension beside it. Forces in N, or per command unit where the lab's
/// balance takes the command as the force (`linear_axis`).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisModel {
    pub family: Family,
    pub mass: f64,
    pub damping: [f64; 2],
    pub stiffness: f64,
    /// Force per command unit, per direction.
    pub gain: [f64; 2],
    /// Drive lag (the solenoid's coil), s.
    pub lag_s: Option<f64>,
    pub coulomb: Option<[f64; 2]>,
    pub pretension: f64,
    /// Exponent of the supply's effect on the drive, when the model has it.
    pub supply_exponent: Option<f64>,
    /// Nominal supply of the model (V).
    pub supply_nominal: Option<f64>,
    /// Total backlash play between the drive and the load (rad), when the model has it.
    pub backlash_gap: Option<f64>,
}

/// Parameters whose intervals move the linear design, per family.
pub fn design_parameters(family: Family) -> &'static [PlantKey] {
    match family {
        Family::Solenoid => &[
            SOLENOID_MASS,
            SOLENOID_LAG,
            SOLENOID_CURRENT_GAIN,
            SOLENOID_FORCE_CONSTANT,
            VISCOUS_POS,
            VISCOUS_NEG,
            SPRING_STIFFNESS,
            ASYMMETRY_POS,
            ASYMMETRY_NEG,
        ],
        Family::LinearAxis => &[
            LINEAR_AXIS_MASS,
            VISCOUS_POS,
            VISCOUS_NEG,
            SPRING_STIFFNESS,
            ASYMMETRY_POS,
            ASYMMETRY_NEG,
        ],
        // The drive's constants (armature, motor, gear) are declared, not fitted: the load side
        // is what the fit determines.
        Family::MotorGear => &[
            MOTOR_GEAR_LOAD_INERTIA,
            VISCOUS_POS,
            VISCOUS_NEG,
            PAYLOAD_MAX,
        ],
        _ => &[],
    }
}

/// The part of the model's damping that the drive itself gives (a motor's back-EMF through
/// the armature resistance, `h² K_T K_e / R_a`), beside which a fitted viscous slope's interval
/// is judged: for a geared motor it is most of the damping the design sees.
pub fn drive_damping(family: Family, value: &dyn Fn(&str) -> Option<f64>) -> f64 {
    match family {
        Family::MotorGear => (|| {
            let value = |k: PlantKey| value(&k.name(family));
            let h = value(MOTOR_GEAR_RATIO)?;
            Some(
                h * h * value(MOTOR_GEAR_TORQUE_CONSTANT)? * value(MOTOR_GEAR_BACK_EMF)?
                    / value(MOTOR_GEAR_RESISTANCE)?,
            )
        })()
        .unwrap_or(0.0),
        _ => 0.0,
    }
}

impl AxisModel {
    /// The model with the parameters `values(name)` gives (the fitted values, or a corner of
    /// their intervals).
    pub fn with_values(
        family: Family,
        values: &dyn Fn(&str) -> Option<f64>,
    ) -> Result<AxisModel, String> {
        // The key's suffix (N or N·m, m or rad) follows the family.
        let value = |k: PlantKey| values(&k.name(family));
        let need = |k: PlantKey| {
            value(k).ok_or_else(|| {
                format!(
                    "the model has no {}, which the design needs",
                    k.name(family)
                )
            })
        };
        let or_zero = |k: PlantKey| value(k).unwrap_or(0.0);
        let damping = [or_zero(VISCOUS_POS), or_zero(VISCOUS_NEG)];
        let asym = [
            value(ASYMMETRY_POS).unwrap_or(1.0),
            value(ASYMMETRY_NEG).unwrap_or(1.0),
        ];
        let coulomb = value(COULOMB_POS)
            .zip(value(COULOMB_NEG))
            .map(|(p, n)| [p, n]);
        let backlash_gap = value(BACKLASH_GAP);
        match family {
            Family::Solenoid => {
                let k = need(SOLENOID_CURRENT_GAIN)? * need(SOLENOID_FORCE_CONSTANT)?;
                Ok(AxisModel {
                    family,
                    mass: need(SOLENOID_MASS)?,
                    damping,
                    stiffness: or_zero(SPRING_STIFFNESS),
                    gain: [k * asym[0], k * asym[1]],
                    lag_s: Some(need(SOLENOID_LAG)?),
                    coulomb,
                    pretension: or_zero(SPRING_PRETENSION),
                    supply_exponent: value(SUPPLY_EXPONENT),
                    supply_nominal: value(SOLENOID_SUPPLY),
                    backlash_gap,
                })
            }
            // The lab's balance of a linear axis takes the command as the force (docs/lab.md):
            // its fitted forces are per command unit, the drive's gain is 1.
            Family::LinearAxis => Ok(AxisModel {
                family,
                mass: need(LINEAR_AXIS_MASS)?,
                damping,
                stiffness: or_zero(SPRING_STIFFNESS),
                gain: asym,
                lag_s: None,
                coulomb,
                pretension: or_zero(SPRING_PRETENSION),
                supply_exponent: value(SUPPLY_EXPONENT),
                supply_nominal: value(LINEAR_AXIS_SUPPLY),
                backlash_gap,
            }),
            // Bao et al.'s transmission as one rigid body at the load angle (the shaft and the
            // contact are stiff against the loop's bandwidth; `tune` checks the design on the
            // flexible model too): inertia `J_l + J_g + h² J_m`, damping `b± + h² K_T K_e / R_a`
            // (viscous and back-EMF), torque `h K_T / R_a` per volt, the payload
            // `T_l = T_lmax θ / θ_full` as a spring.
            Family::MotorGear => {
                let h = need(MOTOR_GEAR_RATIO)?;
                let r = need(MOTOR_GEAR_RESISTANCE)?;
                let kt = need(MOTOR_GEAR_TORQUE_CONSTANT)?;
                let emf = drive_damping(family, values);
                let payload = match value(PAYLOAD_MAX) {
                    Some(t) => t.abs() / need(PAYLOAD_FULL_SCALE)?,
                    None => 0.0,
                };
                Ok(AxisModel {
                    family,
                    mass: need(MOTOR_GEAR_LOAD_INERTIA)?
                        + need(MOTOR_GEAR_GEAR_INERTIA)?
                        + h * h * need(MOTOR_GEAR_MOTOR_INERTIA)?,
                    damping: [damping[0] + emf, damping[1] + emf],
                    stiffness: payload + or_zero(SPRING_STIFFNESS),
                    gain: [h * kt / r; 2],
                    // The armature's `L_a / R_a` (a third of a millisecond for the project's
                    // motor) settles within a cycle: left out of the design model, whose other
                    // poles it would only drag (the flexible model has it).
                    lag_s: None,
                    coulomb,
                    pretension: or_zero(SPRING_PRETENSION),
                    supply_exponent: value(SUPPLY_EXPONENT),
                    supply_nominal: value(MOTOR_GEAR_SUPPLY),
                    backlash_gap,
                })
            }
            other => Err(format!(
                "tune designs the controller of solenoid, linear_axis and motor_gear models; \
                 {other} is not one"
            )),
        }
    }

    pub fn from_fitted(f: &Fitted) -> Result<AxisModel, String> {
        AxisModel::with_values(f.model.spec.family, &|n| f.get(n))
    }

    fn index(dir: Direction) -> usize {
        match dir {
            Direction::Positive => 0,
            Direction::Negative => 1,
        }
    }

    /// The linear plant of one direction.
    pub fn linear(&self, dir: Direction) -> ContinuousPlant {
        let i = Self::index(dir);
        ContinuousPlant::body(
            self.mass,
            self.damping[i],
            self.stiffness,
            self.gain[i],
            self.lag_s,
        )
    }

    /// True when the directions differ (damping or drive gain).
    pub fn has_two_directions(&self) -> bool {
        self.damping[0] != self.damping[1] || self.gain[0] != self.gain[1]
    }

    /// Undamped natural frequency `√(c/m)`, rad/s (0 without a spring).
    pub fn natural_frequency(&self) -> f64 {
        (self.stiffness / self.mass).sqrt()
    }
}

/// The flexible model of a `motor_gear` plant at the load angle: armature, motor, compliant
/// shaft, gear, the contact to the load (in contact, at the mean ratio), the load; Bao et al.
/// eqs. 6–7 as the robust design builds it. `None` for another family.
pub fn flexible(spec: &crate::physics::PlantSpec) -> Result<Option<ContinuousPlant>, String> {
    flexible_with_contact(spec, 1.0)
}

/// [`flexible`] with the contact's stiffness and damping at `share` of their values: the
/// describing function of the backlash's dead zone in the contact torque is a real gain between
/// 0 (inside the play) and 1 (deep in contact), so a loop stable for every share down to near 0
/// is predicted free of a limit cycle from the play (Bao et al.'s `δ1` between -1 and 0).
pub fn flexible_with_contact(
    spec: &crate::physics::PlantSpec,
    share: f64,
) -> Result<Option<ContinuousPlant>, String> {
    use crate::control::robust::{Envelope, MotorGearParams, UncertainModel};
    if spec.family != Family::MotorGear {
        return Ok(None);
    }
    let params = MotorGearParams::from_spec(spec).map_err(|e| e.to_string())?;
    let model = UncertainModel::new(params, Envelope::default()).map_err(|e| e.to_string())?;
    let mut a = model.nominal.a;
    if let Some(p) = model
        .perturbations
        .iter()
        .find(|p| p.name.starts_with("backlash"))
    {
        a += &p.a * (share - 1.0);
    }
    // The payload, a disturbance to the robust design, is the spring `T_l = T_lmax θ_l / θ_full`
    // on the load (rows and columns as `STATE_NAMES`: ω_l is 3, θ_l is 6).
    if params.payload_max_nm > 0.0 {
        a[(3, 6)] -=
            params.payload_max_nm / params.payload_full_scale_rad / params.load_inertia_kg_m2;
    }
    Ok(Some(ContinuousPlant {
        a,
        b: model.nominal.b,
        c: model.nominal.c,
    }))
}

/// Every corner of the intervals of `names` that the fit gave (at most 2¹⁰ of them): a value
/// function per corner.
pub fn corners(f: &Fitted, names: &[String]) -> Vec<Vec<(String, f64)>> {
    let with: Vec<(String, (f64, f64))> = names
        .iter()
        .filter_map(|n| f.intervals.get(n).map(|iv| (n.clone(), *iv)))
        .take(10)
        .collect();
    (0..1usize << with.len())
        .map(|mask| {
            with.iter()
                .enumerate()
                .map(|(j, (n, (lo, hi)))| (n.clone(), if mask >> j & 1 == 1 { *hi } else { *lo }))
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::PlantSpec;

    /// The project's geared drive at a fixed ratio (the rigid model has no varying ratio).
    fn motor_gear() -> PlantSpec {
        let text = include_str!("../../config/plants/motor_gear.toml")
            .replace("[varying_ratio]", "[unused]")
            .replace("max_angle_rad = 1.3", "");
        let text = text.replace("[unused]\n", "");
        PlantSpec::from_toml(&text, "motor_gear.toml").expect("plant")
    }

    #[test]
    fn the_rigid_gear_model_is_the_flexible_one_below_the_contact_mode() {
        let spec = motor_gear();
        assert!(spec.get("varying_ratio.max_angle_rad").is_none());
        let rigid = AxisModel::with_values(Family::MotorGear, &|n| spec.get(n)).expect("model");
        // J_l + J_g + h² J_m, b + h² K_T K_e / R_a, h K_T / R_a, T_lmax / θ_full.
        assert!((rigid.mass - (5e-4 + 3e-4 + 400.0 * 1e-6)).abs() < 1e-12);
        assert!((rigid.damping[0] - (0.05 + 400.0 * 0.03 * 0.03 / 1.55)).abs() < 1e-12);
        assert!((rigid.gain[0] - 20.0 * 0.03 / 1.55).abs() < 1e-12);
        assert!((rigid.stiffness - 1.0).abs() < 1e-12);
        let flex = flexible(&spec).expect("model").expect("motor_gear");
        let r = rigid.linear(Direction::Positive);
        for w in [0.3, 3.0, 30.0] {
            let (a, b) = (r.response(w), flex.response(w));
            assert!((a - b).norm() < 0.05 * b.norm(), "{w} rad/s: {a} vs {b}");
        }
        // At the contact mode (about 1300 rad/s here: sqrt(K_g (1/J_l + 1/(J_g + h² J_m)))) the
        // two part.
        let w = 1300.0;
        let (a, b) = (r.response(w), flex.response(w));
        assert!((a - b).norm() > 0.5 * a.norm(), "{a} vs {b}");
        // A quarter of the contact's stiffness halves the contact mode's frequency (the shaft's
        // mode, near 11000 rad/s, and the armature's real pole near 2600 rad/s stay). The light
        // fork lever's contact is well damped (damping ratio about 0.75, and overdamped at a
        // quarter of the stiffness), so the mode is read with a tenth of the contact damping:
        // what is checked is how the stiffness share enters the model.
        let mut light = spec.clone();
        let c = light
            .get("motor_gear.contact_damping_nm_s_per_rad")
            .expect("contact damping");
        light
            .set("motor_gear.contact_damping_nm_s_per_rad", 0.1 * c)
            .expect("contact damping");
        let contact_mode = |share: f64| -> f64 {
            let p = flexible_with_contact(&light, share)
                .expect("model")
                .expect("motor_gear");
            assert_eq!(
                share == 1.0,
                p == flexible(&light).expect("model").expect("motor_gear")
            );
            p.a.complex_eigenvalues()
                .iter()
                .filter(|e| e.im.abs() > 1e-6)
                .map(|e| e.norm())
                .filter(|w| (20.0..5000.0).contains(w))
                .fold(0.0, f64::max)
        };
        let (full, quarter) = (contact_mode(1.0), contact_mode(0.25));
        assert!((full - 1300.0).abs() < 150.0, "{full}");
        assert!((quarter / full - 0.5).abs() < 0.1, "{quarter} vs {full}");
        // No flexible model for another family.
        let solenoid = crate::physics::load_spec(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/config/plants/solenoid.toml"
        )))
        .expect("solenoid");
        assert!(flexible(&solenoid).expect("no error").is_none());
    }
}
