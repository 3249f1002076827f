//! The design model of Bao, Mao & Luo (2016) for the `motor_gear` family: the nominal linear
//! model in the contact regime and the perturbation structure, descriptor form (eq. 15)
//! `E ẋ = (A + Σ δ_i A_i) x + B U_a + H d`, `y = C x`, `δ_i ∈ [-1, 1]`,
//! with `x = [I_a, ω_m, ω_g, ω_l, θ_m, θ_g, θ_l]` (the paper's state order),
//! `d = [δ4, δ5]` (friction offset and payload, the "hypothetical external disturbances").
//!
//! The rigid-body split is the one of `physics::families::motor_gear` (motor with pinion
//! `J_m`, gear/screw/nut at the output `J_g`, fork lever `J_l`); the paper's extra pinion body
//! `J_p` is lumped into `J_m`, so `E` is constant and the paper's `E_i` (eq. 24) vanish.

use nalgebra::DMatrix;

use super::lti::Ss;
use super::RobustError;
use crate::physics::{Family, PlantSpec};

/// The friction law of one direction replaced by two straight segments (Bao et al. eq. 5):
/// `τ = a1 + b1 |ω|` for `|ω| ≤ ω_sw`, `τ = a2 + b2 |ω|` above, magnitudes.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TwoSegmentFriction {
    /// `a_1 = f_s`, static level (N·m).
    pub a1: f64,
    /// `b_1 = f_v - (f_s - f_c)/q_s`, low-velocity slope (N·m·s/rad), the tangent at rest.
    pub b1: f64,
    /// `a_2 = f_c`, Coulomb level (N·m).
    pub a2: f64,
    /// `b_2 = f_v - (f_s - f_c) e^{-ω_max/q_s}/q_s`, high-velocity slope (N·m·s/rad).
    pub b2: f64,
    /// `ω_sw = (a_1 - a_2)/(b_2 - b_1)`, the switching speed (rad/s).
    pub w_switch: f64,
}

impl TwoSegmentFriction {
    /// Segments of `f_c + (f_s - f_c) e^{-|ω/q_s|} + f_v |ω|` (eq. 4) up to the speed `ω_max`.
    pub fn new(f_s: f64, f_c: f64, f_v: f64, q_s: f64, w_max: f64) -> Self {
        let ex = (f_s - f_c).max(0.0);
        let (b1, b2) = if q_s > 0.0 {
            (f_v - ex / q_s, f_v - ex * (-(w_max / q_s)).exp() / q_s)
        } else {
            (f_v, f_v)
        };
        let w_switch = if b2 > b1 {
            (f_s - f_c) / (b2 - b1)
        } else {
            0.0
        };
        Self {
            a1: f_s,
            b1,
            a2: f_c,
            b2,
            w_switch,
        }
    }

    /// `τ_linear(|ω|)` of eq. 5 (magnitude).
    pub fn eval(&self, speed: f64) -> f64 {
        let s = speed.abs();
        if s <= self.w_switch {
            self.a1 + self.b1 * s
        } else {
            self.a2 + self.b2 * s
        }
    }
}

/// Physical parameters of a `motor_gear` plant, SI units, as read from its [`PlantSpec`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MotorGearParams {
    pub resistance_ohm: f64,
    pub inductance_h: f64,
    pub back_emf_v_s_per_rad: f64,
    pub torque_constant_nm_per_a: f64,
    pub motor_inertia_kg_m2: f64,
    pub torsion_stiffness_nm_per_rad: f64,
    pub torsion_damping_nm_s_per_rad: f64,
    /// `h_0`.
    pub ratio: f64,
    pub gear_inertia_kg_m2: f64,
    pub contact_stiffness_nm_per_rad: f64,
    pub contact_damping_nm_s_per_rad: f64,
    pub load_inertia_kg_m2: f64,
    pub supply_voltage_v: f64,
    /// Total backlash gap `2b` (0 without the `backlash` effect).
    pub gap_rad: f64,
    /// Whether `h = h_0 / cos θ_l` (`varying_ratio` effect).
    pub varying_ratio: bool,
    /// Static (breakaway) friction `f_ps`, `f_ns` (N·m).
    pub static_pos_nm: f64,
    pub static_neg_nm: f64,
    /// Coulomb friction `f_pc`, `f_nc` (N·m).
    pub coulomb_pos_nm: f64,
    pub coulomb_neg_nm: f64,
    /// Viscous slopes `f_pv`, `f_nv` (N·m·s/rad).
    pub viscous_pos_nm_s_per_rad: f64,
    pub viscous_neg_nm_s_per_rad: f64,
    /// Stribeck velocities `q_ps`, `q_ns` (rad/s; 0 without the `stribeck` effect).
    pub stribeck_pos_rad_per_s: f64,
    pub stribeck_neg_rad_per_s: f64,
    /// `T_lmax` (N·m) and the angle of full payload (rad).
    pub payload_max_nm: f64,
    pub payload_full_scale_rad: f64,
    /// Command limits (V): the `saturation` effect or ± the supply.
    pub u_min_v: f64,
    pub u_max_v: f64,
}

fn need(spec: &PlantSpec, key: &str) -> Result<f64, RobustError> {
    spec.get(key)
        .ok_or_else(|| RobustError::Model(format!("parameter {key} missing")))
}

impl MotorGearParams {
    /// Read a `motor_gear` plant description; absent effects count as zero.
    pub fn from_spec(spec: &PlantSpec) -> Result<Self, RobustError> {
        if spec.family != Family::MotorGear {
            return Err(RobustError::Model(format!(
                "family {} is not motor_gear",
                spec.family.name()
            )));
        }
        let opt = |k: &str| spec.get(k).unwrap_or(0.0);
        let supply = need(spec, "motor_gear.supply_voltage_v")?;
        let stribeck_pos = opt("stribeck.excess_pos_nm");
        let stribeck_neg = opt("stribeck.excess_neg_nm");
        let coulomb_pos = opt("coulomb.coulomb_pos_nm");
        let coulomb_neg = opt("coulomb.coulomb_neg_nm");
        let static_pos = (coulomb_pos + stribeck_pos).max(opt("stiction.breakaway_pos_nm"));
        let static_neg = (coulomb_neg + stribeck_neg).max(opt("stiction.breakaway_neg_nm"));
        let p = Self {
            resistance_ohm: need(spec, "motor_gear.resistance_ohm")?,
            inductance_h: need(spec, "motor_gear.inductance_h")?,
            back_emf_v_s_per_rad: need(spec, "motor_gear.back_emf_v_s_per_rad")?,
            torque_constant_nm_per_a: need(spec, "motor_gear.torque_constant_nm_per_a")?,
            motor_inertia_kg_m2: need(spec, "motor_gear.motor_inertia_kg_m2")?,
            torsion_stiffness_nm_per_rad: need(spec, "motor_gear.torsion_stiffness_nm_per_rad")?,
            torsion_damping_nm_s_per_rad: need(spec, "motor_gear.torsion_damping_nm_s_per_rad")?,
            ratio: need(spec, "motor_gear.ratio")?,
            gear_inertia_kg_m2: need(spec, "motor_gear.gear_inertia_kg_m2")?,
            contact_stiffness_nm_per_rad: need(spec, "motor_gear.contact_stiffness_nm_per_rad")?,
            contact_damping_nm_s_per_rad: need(spec, "motor_gear.contact_damping_nm_s_per_rad")?,
            load_inertia_kg_m2: need(spec, "motor_gear.load_inertia_kg_m2")?,
            supply_voltage_v: supply,
            gap_rad: opt("backlash.gap_rad"),
            varying_ratio: spec.get("varying_ratio.max_angle_rad").is_some(),
            static_pos_nm: static_pos,
            static_neg_nm: static_neg,
            coulomb_pos_nm: coulomb_pos,
            coulomb_neg_nm: coulomb_neg,
            viscous_pos_nm_s_per_rad: opt("viscous.damping_pos_nm_s_per_rad"),
            viscous_neg_nm_s_per_rad: opt("viscous.damping_neg_nm_s_per_rad"),
            stribeck_pos_rad_per_s: opt("stribeck.velocity_pos_rad_per_s"),
            stribeck_neg_rad_per_s: opt("stribeck.velocity_neg_rad_per_s"),
            payload_max_nm: opt("payload.max_load_nm").abs(),
            payload_full_scale_rad: spec.get("payload.full_scale_rad").unwrap_or(1.0),
            u_min_v: spec.get("saturation.min_v").unwrap_or(-supply).max(-supply),
            u_max_v: spec.get("saturation.max_v").unwrap_or(supply).min(supply),
        };
        if spec.command != crate::physics::CommandUnit::Volt {
            return Err(RobustError::Model(
                "the design model needs the voltage command (armature circuit)".into(),
            ));
        }
        Ok(p)
    }

    /// Two-segment friction laws `(positive, negative)` up to the load speed `ω_max`.
    pub fn friction_segments(&self, w_max: f64) -> (TwoSegmentFriction, TwoSegmentFriction) {
        (
            TwoSegmentFriction::new(
                self.static_pos_nm,
                self.coulomb_pos_nm,
                self.viscous_pos_nm_s_per_rad,
                self.stribeck_pos_rad_per_s,
                w_max,
            ),
            TwoSegmentFriction::new(
                self.static_neg_nm,
                self.coulomb_neg_nm,
                self.viscous_neg_nm_s_per_rad,
                self.stribeck_neg_rad_per_s,
                w_max,
            ),
        )
    }
}

/// The operating envelope the perturbation ranges are taken over.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Envelope {
    /// Largest load angle |θ_l| of the task (rad): the ratio ranges over `[h_0, h_0 / cos θ]`.
    pub max_angle_rad: f64,
    /// Largest load speed |ω_l| (rad/s): end of the high-velocity friction segment.
    pub max_speed_rad_per_s: f64,
    /// Nominal friction slope at the midpoint `b̄ = (b_fmax + b_fmin)/2` as in the paper
    /// (`Δb = (b_fmax - b_fmin)/2`); otherwise at the sliding slope `b̄ = b_fmax` with
    /// `Δb = b_fmax - b_fmin` (`δ3 = -1` is the Stribeck tangent at rest).
    #[serde(default)]
    pub friction_nominal_midpoint: bool,
}

impl Default for Envelope {
    /// ±20° and 25 rad/s: the paper's tests (10° at up to 20 Hz, peak speed 22 rad/s).
    fn default() -> Self {
        Self {
            max_angle_rad: 0.35,
            max_speed_rad_per_s: 25.0,
            friction_nominal_midpoint: false,
        }
    }
}

/// One real parametric perturbation `δ_i A_i`, factored `E⁻¹A_i = L_i R_i` (rank `r_i`) so that
/// it is the feedback `w_i = δ_i z_i`, `z_i = R_i x`, entering as `L_i w_i` (the LFT of Fig. 5).
#[derive(Debug, Clone, PartialEq)]
pub struct Perturbation {
    pub name: &'static str,
    /// `E⁻¹ A_i`, n×n.
    pub a: DMatrix<f64>,
    /// n×r_i.
    pub l: DMatrix<f64>,
    /// r_i×n.
    pub r: DMatrix<f64>,
}

/// An additive bounded disturbance `E⁻¹ H_j δ_j`.
#[derive(Debug, Clone, PartialEq)]
pub struct Disturbance {
    pub name: &'static str,
    /// `E⁻¹ H_j`, n×1, for `|δ_j| ≤ 1`.
    pub h: DMatrix<f64>,
}

/// Nominal model plus perturbation structure (Bao et al. eqs. 8, 9, 15–25).
#[derive(Debug, Clone)]
pub struct UncertainModel {
    pub params: MotorGearParams,
    pub envelope: Envelope,
    /// Descriptor matrix `E = diag(L_a, J_m, J_g, J_l, 1, 1, 1)` (eq. 23).
    pub e: DMatrix<f64>,
    /// Nominal system `ẋ = E⁻¹A x + E⁻¹B U_a`, `y = θ_l` (contact regime, `h = h̄`, slope `b̄`).
    /// `δ1 = 0` is contact: the range `δ1 ∈ [-1, 1]` covers the gap (`-1`) and over-covers the
    /// stiffer side.
    pub nominal: Ss,
    /// `δ1` backlash, `δ2` ratio, `δ3` friction slope (only those present in the plant).
    pub perturbations: Vec<Perturbation>,
    /// `δ4` friction offset, `δ5` payload.
    pub disturbances: Vec<Disturbance>,
    /// `h̄ = (h_1 + h_2)/2` and `Δh = (h_2 - h_1)/2`.
    pub ratio_mid: f64,
    pub ratio_half_range: f64,
    /// `b̄ = (b_fmax + b_fmin)/2` and `Δb = (b_fmax - b_fmin)/2` (N·m·s/rad).
    pub slope_mid: f64,
    pub slope_half_range: f64,
    /// `a_f`, the friction offset bound (N·m).
    pub friction_offset_nm: f64,
}

/// Names of the states, in order.
pub const STATE_NAMES: [&str; 7] = [
    "I_a (A)",
    "ω_m (rad/s)",
    "ω_g (rad/s)",
    "ω_l (rad/s)",
    "θ_m (rad)",
    "θ_g (rad)",
    "θ_l (rad)",
];

/// Factor `M = L R` with `L = U_r Σ_r^{1/2}`, `R = Σ_r^{1/2} V_rᵀ` (rank by SVD).
fn low_rank(m: &DMatrix<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = m.nrows();
    let svd = m.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return (DMatrix::zeros(n, 0), DMatrix::zeros(0, n));
    };
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&i| svd.singular_values[i] > 1e-12 * smax && smax > 0.0)
        .collect();
    let mut l = DMatrix::zeros(n, keep.len());
    let mut r = DMatrix::zeros(keep.len(), m.ncols());
    for (k, &i) in keep.iter().enumerate() {
        let s = svd.singular_values[i].sqrt();
        l.set_column(k, &(u.column(i) * s));
        r.set_row(k, &(vt.row(i) * s));
    }
    (l, r)
}

impl UncertainModel {
    /// Build the model of eqs. 6–8 and 15–25 for the given envelope.
    ///
    /// Equations (rows of `E ẋ = A x + …`):
    /// - `L_a İ_a = U_a - R_a I_a - K_e ω_m` (eq. 3)
    /// - `J_m ω̇_m = K_T I_a - K_p(θ_m - hθ_g) - C_p(ω_m - hω_g)`
    /// - `J_g ω̇_g = h[K_p(θ_m - hθ_g) + C_p(ω_m - hω_g)] - k_c(θ_g - θ_l) - c_c(ω_g - ω_l)`
    /// - `J_l ω̇_l = k_c(θ_g - θ_l) + c_c(ω_g - ω_l) - τ_linear - T_l` (eq. 7)
    ///
    /// Perturbations (eq. 8):
    /// - backlash `k_c = K_g(1 + δ1)`, `c_c = C_g(1 + δ1)`: nominal in contact, `δ1 = -1` is the
    ///   gap (no torque through the contact); the dead-zone offset `K_g b sign(θ_g - θ_l)` is a
    ///   constant shift of `θ_g` against `θ_l`, left to the integral action;
    /// - ratio `h = h̄ + Δh δ2` with `h_1 = h_0`, `h_2 = h_0 / cos θ_max` (eq. 14), and
    ///   `h² ≈ h̄² + 2h̄Δh δ2` (first order in `δ2`, as the paper's `ΔK_d`, `ΔC_d`). The
    ///   dropped `Δh² δ2²` makes the stiffness matrix slightly inconsistent: at `δ2 = ±1` the
    ///   rigid-body pole moves into the right half plane (about +28 rad/s for the project's
    ///   plant file), an artefact of the linearisation; the exact model at any fixed ratio
    ///   (`MotorGearParams::ratio` set, `varying_ratio` off) keeps it at 0;
    /// - friction `τ_linear = a_f δ4 + b̄ ω_l + Δb ω_l δ3` with `b_fmin = min(b_p1, b_n1)`,
    ///   `b_fmax = max(b_p2, b_n2)`, `a_f = max(f_ps, f_ns)`; `b̄`, `Δb` at the midpoint (paper)
    ///   or from the sliding slope (see [`Envelope::friction_nominal_midpoint`]);
    /// - payload `T_l = T_lmax δ5`.
    pub fn new(params: MotorGearParams, envelope: Envelope) -> Result<Self, RobustError> {
        let p = &params;
        let angle_ok = (0.0..1.5).contains(&envelope.max_angle_rad);
        let speed_ok = envelope.max_speed_rad_per_s > 0.0;
        if !angle_ok || !speed_ok {
            return Err(RobustError::Model(format!(
                "envelope: angle {} rad must be in [0, 1.5), speed {} rad/s > 0",
                envelope.max_angle_rad, envelope.max_speed_rad_per_s
            )));
        }
        let h1 = p.ratio;
        let h2 = if p.varying_ratio {
            p.ratio / envelope.max_angle_rad.cos()
        } else {
            p.ratio
        };
        let hm = 0.5 * (h1 + h2);
        let dh = 0.5 * (h2 - h1);
        let (fp, fnn) = p.friction_segments(envelope.max_speed_rad_per_s);
        let b_min = fp.b1.min(fnn.b1);
        let b_max = fp.b2.max(fnn.b2);
        let (bm, db) = if envelope.friction_nominal_midpoint {
            (0.5 * (b_max + b_min), 0.5 * (b_max - b_min))
        } else {
            (b_max, b_max - b_min)
        };
        let a_f = p.static_pos_nm.max(p.static_neg_nm);
        let (kp, cp, kg, cg) = (
            p.torsion_stiffness_nm_per_rad,
            p.torsion_damping_nm_s_per_rad,
            p.contact_stiffness_nm_per_rad,
            p.contact_damping_nm_s_per_rad,
        );
        // Indices into x = [I, ωm, ωg, ωl, θm, θg, θl].
        const I: usize = 0;
        const WM: usize = 1;
        const WG: usize = 2;
        const WL: usize = 3;
        const TM: usize = 4;
        const TG: usize = 5;
        const TL: usize = 6;
        let n = 7;
        let mut a = DMatrix::zeros(n, n);
        a[(I, I)] = -p.resistance_ohm;
        a[(I, WM)] = -p.back_emf_v_s_per_rad;
        a[(WM, I)] = p.torque_constant_nm_per_a;
        a[(WM, WM)] = -cp;
        a[(WM, WG)] = cp * hm;
        a[(WM, TM)] = -kp;
        a[(WM, TG)] = kp * hm;
        a[(WG, WM)] = hm * cp;
        a[(WG, WG)] = -hm * hm * cp - cg;
        a[(WG, WL)] = cg;
        a[(WG, TM)] = hm * kp;
        a[(WG, TG)] = -hm * hm * kp - kg;
        a[(WG, TL)] = kg;
        a[(WL, WG)] = cg;
        a[(WL, WL)] = -cg - bm;
        a[(WL, TG)] = kg;
        a[(WL, TL)] = -kg;
        a[(TM, WM)] = 1.0;
        a[(TG, WG)] = 1.0;
        a[(TL, WL)] = 1.0;
        let ediag = [
            p.inductance_h,
            p.motor_inertia_kg_m2,
            p.gear_inertia_kg_m2,
            p.load_inertia_kg_m2,
            1.0,
            1.0,
            1.0,
        ];
        let e = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&ediag));
        let einv = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            n,
            ediag.iter().map(|v| 1.0 / v),
        ));
        let mut b = DMatrix::zeros(n, 1);
        b[(I, 0)] = 1.0;
        let mut c = DMatrix::zeros(1, n);
        c[(0, TL)] = 1.0;
        let nominal = Ss::new(&einv * &a, &einv * &b, c, DMatrix::zeros(1, 1))?;

        let mut perturbations = Vec::new();
        let mut push = |name: &'static str, ai: DMatrix<f64>| {
            let a = &einv * ai;
            if a.amax() > 0.0 {
                let (l, r) = low_rank(&a);
                perturbations.push(Perturbation { name, a, l, r });
            }
        };
        if p.gap_rad > 0.0 {
            // δ1: A_1 (eq. 17), the contact spring and damper switched on and off.
            let mut a1 = DMatrix::zeros(n, n);
            a1[(WG, WG)] = -cg;
            a1[(WG, WL)] = cg;
            a1[(WG, TG)] = -kg;
            a1[(WG, TL)] = kg;
            a1[(WL, WG)] = cg;
            a1[(WL, WL)] = -cg;
            a1[(WL, TG)] = kg;
            a1[(WL, TL)] = -kg;
            push("backlash (δ1)", a1);
        }
        if dh > 0.0 {
            // δ2: A_2 (eq. 18), first order in Δh.
            let mut a2 = DMatrix::zeros(n, n);
            a2[(WM, WG)] = cp * dh;
            a2[(WM, TG)] = kp * dh;
            a2[(WG, WM)] = dh * cp;
            a2[(WG, WG)] = -2.0 * hm * dh * cp;
            a2[(WG, TM)] = dh * kp;
            a2[(WG, TG)] = -2.0 * hm * dh * kp;
            push("transmission ratio (δ2)", a2);
        }
        if db > 0.0 {
            // δ3: A_3 (eq. 21), the friction slope between its two segments.
            let mut a3 = DMatrix::zeros(n, n);
            a3[(WL, WL)] = -db;
            push("friction slope (δ3)", a3);
        }
        let mut disturbances = Vec::new();
        if a_f > 0.0 {
            let mut h = DMatrix::zeros(n, 1);
            h[(WL, 0)] = -a_f / p.load_inertia_kg_m2;
            disturbances.push(Disturbance {
                name: "friction offset (δ4)",
                h,
            });
        }
        if p.payload_max_nm > 0.0 {
            let mut h = DMatrix::zeros(n, 1);
            h[(WL, 0)] = -p.payload_max_nm / p.load_inertia_kg_m2;
            disturbances.push(Disturbance {
                name: "payload (δ5)",
                h,
            });
        }
        Ok(Self {
            params,
            envelope,
            e,
            nominal,
            perturbations,
            disturbances,
            ratio_mid: hm,
            ratio_half_range: dh,
            slope_mid: bm,
            slope_half_range: db,
            friction_offset_nm: a_f,
        })
    }

    /// The linear model at given perturbation values (one per entry of `perturbations`),
    /// `ẋ = (E⁻¹A + Σ δ_i E⁻¹A_i) x + E⁻¹B U_a`.
    pub fn perturbed(&self, deltas: &[f64]) -> Result<Ss, RobustError> {
        if deltas.len() != self.perturbations.len() {
            return Err(RobustError::Dimension(format!(
                "{} deltas for {} perturbations",
                deltas.len(),
                self.perturbations.len()
            )));
        }
        let mut a = self.nominal.a.clone();
        for (d, p) in deltas.iter().zip(&self.perturbations) {
            a += &p.a * *d;
        }
        Ss::new(
            a,
            self.nominal.b.clone(),
            self.nominal.c.clone(),
            self.nominal.d.clone(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_segments_touch_the_stribeck_curve_at_rest_and_at_speed() {
        let (fs, fc, fv, q) = (0.6, 0.4, 0.05, 0.1);
        let seg = TwoSegmentFriction::new(fs, fc, fv, q, 20.0);
        let stribeck = |w: f64| fc + (fs - fc) * (-(w / q)).exp() + fv * w;
        assert!((seg.eval(0.0) - stribeck(0.0)).abs() < 1e-12);
        assert!((seg.eval(20.0) - stribeck(20.0)).abs() < 1e-9);
        // Segments meet at the switching speed.
        let w = seg.w_switch;
        assert!((seg.a1 + seg.b1 * w - (seg.a2 + seg.b2 * w)).abs() < 1e-12);
    }

    #[test]
    fn low_rank_factors_reproduce_the_matrix() {
        let m = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, 2.0, 4.0, 0.0, 0.0, 0.0, 0.0]);
        let (l, r) = low_rank(&m);
        assert_eq!(l.ncols(), 1);
        assert!((&l * &r - m).norm() < 1e-12);
    }
}
