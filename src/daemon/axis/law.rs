//! The axis' control law as one part: the linear controller (discrete or state-space) with the
//! static correction, or the pneumatic drive's scheduled (and adapted) direction P controller.
//! Built once from `[axis.controller]`, `[axis.correction]` and `[axis.schedule]`; it composes
//! the command with what the friction part adds, within the limits the supply allows. The
//! benchmarks compose theirs with the same type ([`ControlLaw::linear`],
//! [`ControlLaw::with_direction_p`]).

use super::super::config::AxisConfig;
use crate::control::robust::StateSpaceController;
use crate::control::{
    ControllerError, DiscreteController, LinearController, NonlinearCorrection, ParamError,
    PneumaticAdaptive, PneumaticStep,
};

pub struct ControlLaw {
    controller: LinearController,
    correction: Option<NonlinearCorrection>,
    pneumatic: Option<PneumaticAdaptive>,
    /// What the direction P controller did this cycle (gains, estimates, their health).
    pneumatic_step: PneumaticStep,
    /// `z` of this cycle's drive-gain estimation update (estimation stage), 1 for none.
    pneumatic_eigenvalue: f64,
}

impl ControlLaw {
    /// The law an axis configuration asks for, preset to hold `safe_command`.
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Self, ControllerError> {
        let unvalidated = |e: ParamError| ControllerError::NotFinite(e.name);
        let c = &cfg.controller;
        let mut controller = match &c.state_space_file {
            Some(file) => LinearController::StateSpace(Box::new(
                StateSpaceController::load(file)
                    .map_err(|e| ControllerError::File(e.to_string()))?,
            )),
            None => LinearController::Discrete(Box::new(DiscreteController::new(
                &c.p,
                &c.q_per_m,
                c.output_min,
                c.output_max,
            )?)),
        };
        controller.preset(cfg.safe_command);
        let correction = cfg
            .correction_config()
            .map(NonlinearCorrection::new)
            .transpose()
            .map_err(unvalidated)?;
        let pneumatic = match cfg.pneumatic_config(period_s) {
            Ok(Some(c)) => Some(PneumaticAdaptive::new(&c).map_err(unvalidated)?),
            Ok(None) => None,
            Err(_) => {
                return Err(ControllerError::NotFinite(crate::param_key!(
                    AxisConfig, schedule
                )))
            }
        };
        Ok(Self {
            controller,
            correction,
            pneumatic,
            pneumatic_step: PneumaticStep::default(),
            pneumatic_eigenvalue: 1.0,
        })
    }

    /// A linear controller alone (no correction, no direction P controller), as a benchmark
    /// runs the paper's controller.
    pub fn linear(controller: LinearController) -> Self {
        Self {
            controller,
            correction: None,
            pneumatic: None,
            pneumatic_step: PneumaticStep::default(),
            pneumatic_eigenvalue: 1.0,
        }
    }

    /// The same law with the pneumatic drive's direction P controller, which then makes the
    /// command in place of `self`'s linear controller (a benchmark's pneumatic loop, as an axis
    /// with `[axis.schedule]` drive gains runs it).
    pub fn with_direction_p(self, pneumatic: PneumaticAdaptive) -> Self {
        Self {
            pneumatic: Some(pneumatic),
            ..self
        }
    }

    /// Restart bumplessly from the command `u`.
    pub fn preset(&mut self, u: f64) {
        self.controller.preset(u);
    }

    /// Take `du` out of (or add it to) the controller's stored output: the arrival relief.
    pub fn shift_output(&mut self, du: f64) {
        if du != 0.0 {
            self.controller.shift_output(du);
        }
    }

    /// Estimation stage: the pneumatic drive's gain estimators take this cycle's position (not
    /// while the axis rests in its safe state: nothing to learn).
    pub fn estimate(&mut self, position: f64, fail_safe: bool) {
        self.pneumatic_eigenvalue = 1.0;
        if let Some(p) = self.pneumatic.as_mut() {
            if !fail_safe {
                self.pneumatic_eigenvalue = p.estimate(position);
            }
        }
    }

    /// The direction P controller's duty for reference `r`, position `y`, supply pressure `p`
    /// (scheduled, and adapted when configured); `None` without one.
    pub fn direction_p(&mut self, reference: f64, position: f64, supply_pa: f64) -> Option<f64> {
        let p = self.pneumatic.as_mut()?;
        self.pneumatic_step = p.control(reference, position, supply_pa, self.pneumatic_eigenvalue);
        Some(self.pneumatic_step.duty)
    }

    /// What the direction P controller did in its last cycle.
    pub fn pneumatic_step(&self) -> &PneumaticStep {
        &self.pneumatic_step
    }

    /// `u = f*(G_c(q) e_g) + U_comp + u_d` clamped to the output range times `limit_factor`:
    /// `e_g` is the error scaled by the schedule's gain factor (the same as scaling the
    /// controller's `q`), the correction `f*` linearises the static characteristic, and the
    /// compensation and dither are added after it because they are already in command units.
    pub fn command(
        &mut self,
        scaled_error: f64,
        position: f64,
        compensation: f64,
        dither: f64,
        limit_factor: f64,
    ) -> f64 {
        let u_c = self.controller.propose(scaled_error);
        let u_corr = self
            .correction
            .as_mut()
            .map_or(u_c, |c| c.step(u_c, position));
        // The limits the supply allows: u_max(V) = f_l(V) u_max (schedule).
        let (lo, hi) = self.controller.limits();
        let (lo, hi) = (lo * limit_factor, hi * limit_factor);
        let u = (u_corr + compensation + dither).clamp(lo, hi);
        // The controller's own share of what was applied, back through the correction's gain:
        // feeding it back is the anti-windup.
        let own = u - compensation - dither;
        let share = if self.correction.is_some() && u_corr.abs() > 1e-12 {
            u_c * own / u_corr
        } else {
            own
        };
        self.controller.commit(scaled_error, share);
        u
    }
}
